//! defender-dtw: see the crate README (being built).
