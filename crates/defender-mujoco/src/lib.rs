//! defender-mujoco: see the crate README (being built).
