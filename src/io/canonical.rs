//! Our canonical G-buffer EXR (docs/FORMAT.md): lossless, every attribute, any sample count.
