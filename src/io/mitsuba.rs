//! Mitsuba 3 `aov` integrator EXR reader.
