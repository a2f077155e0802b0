//! Recovering the camera from a world-space position pass by least squares (positions ↔ pixel rays).
