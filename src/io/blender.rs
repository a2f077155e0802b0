//! Blender Cycles multilayer EXR reader (channels `<ViewLayer>.<Pass>.<Chan>`).
