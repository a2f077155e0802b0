//! Folding supersampled dumps: each k×k pixel block becomes k² ordered-grid samples of one pixel.
