//! Sweeps: an experiment file expanded to ordinary runs ([`experiment`]) and scheduled on this
//! machine's cores ([`runner`]). On a cluster, Ray Tune schedules the same runs
//! (`python/defender_rl/tune.py`), from the same expansion (`defender sweep --list --json`).

pub mod complete;
pub mod runner;
