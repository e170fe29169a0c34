//! defender: see the crate README (being built).
