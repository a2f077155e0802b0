//! Reader for the input files of the ISPC `examples/cpu/deferred` sample (`.bin`, little-endian).
