//! Render-target formats, bit packing, built-in layouts and material-ID indirection: whole G-buffers packed into real words.
