//! A shield: what decides, step by step, whether a policy's action may run, kept at deployment
//! as it was while training. A DEFENDER training environment lends one (its filter as it stands,
//! [`crate::Env::shield`]) so that each evaluation also runs with the filter kept
//! (crate::evaluation; docs/SPEC.md, section 6).

use crate::error::Result;

/// Decides per step whether an action is executed, from the episode's trajectory so far.
///
/// A shield is the evaluation's own copy: nothing it does reaches the environment that lent it.
pub trait Shield {
    /// Starts a new episode (forgets the trajectory).
    fn reset(&mut self);

    /// Step `t`: the policy observed `obs` and proposes `action` (in the environment's bounds, as
    /// the environment would receive it). Appends the step to the trajectory and says whether
    /// the action may be executed; `false` stops the episode before it runs.
    ///
    /// # Errors
    /// Wrong lengths or non-finite values.
    fn allows(&mut self, obs: &[f64], action: &[f64]) -> Result<bool>;
}
