//! defender-nn: see the crate README (being built).
