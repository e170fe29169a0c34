//! Lagrangian SAC's multiplier `lambda`, as OmniSafe 0.5's `Lagrange` updates it: Adam on the
//! loss `-lambda (J_c - d)`, then `lambda` clamped at 0, where `J_c` is the mean episode cost of
//! the last `window` training episodes and `d` the cost limit.
//!
//! OmniSafe steps it at every gradient step with a rate of 1e-5, after 200,000 warm-up steps;
//! here it steps once per finished training episode with `lambda_lr` from SAC's first gradient
//! step (docs/decisions-baselines.md, "Lagrangian SAC": about 5-10 times faster than OmniSafe's
//! on Hopper, and without its warm-up, which would leave most of a 300k-step run unconstrained).

use serde::{Deserialize, Serialize};

use super::episode_costs::EpisodeCosts;
use crate::nets::ScalarAdam;
use crate::safety::LagrangianConfig;

/// The multiplier with its optimiser and the episode costs it is driven by. All of it is state a
/// checkpoint keeps: a resumed run steps it exactly as the run left alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Multiplier {
    /// `lambda >= 0`, in f32 as OmniSafe's `torch.nn.Parameter`.
    lambda: f32,
    opt: ScalarAdam,
    /// `d`.
    cost_limit: f64,
    /// `J_c`'s episodes (its fields flattened: the checkpoint's JSON is that of earlier runs).
    #[serde(flatten)]
    episodes: EpisodeCosts,
    /// Adam steps taken.
    updates: u64,
}

impl Multiplier {
    /// `lambda = lambda_init`, no episode seen.
    pub fn new(config: &LagrangianConfig) -> Self {
        Self {
            lambda: config.lambda_init as f32,
            opt: ScalarAdam::new(config.lambda_lr),
            cost_limit: config.cost_limit,
            episodes: EpisodeCosts::new(config.window),
            updates: 0,
        }
    }

    /// The current `lambda`.
    pub fn lambda(&self) -> f32 {
        self.lambda
    }

    /// `J_c`: the mean cost of the last `window` finished episodes (`None` before the first).
    pub fn mean_episode_cost(&self) -> Option<f64> {
        self.episodes.mean()
    }

    /// Adam steps taken so far.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Counts one training step's `cost`. At the end of an episode (`episode_end`: terminated or
    /// truncated) the episode's cost joins the window and, if `learning` (the agent's warm-up is
    /// over: OmniSafe skips its warm-up epochs), `lambda` takes one step.
    pub fn observe(&mut self, cost: f64, episode_end: bool, learning: bool) {
        if self.episodes.observe(cost, episode_end)
            && learning
            && let Some(j_c) = self.mean_episode_cost()
        {
            self.step(j_c);
        }
    }

    /// One Adam step on `-lambda (J_c - d)`, whose gradient in `lambda` is `-(J_c - d)`: `lambda`
    /// rises while the episodes cost more than `d`, falls while they cost less; then `lambda <- max(lambda, 0)`
    /// (OmniSafe's `clamp_(0, upper_bound)` without an upper bound).
    fn step(&mut self, j_c: f64) {
        let grad = -(j_c - self.cost_limit) as f32;
        self.opt.step(&mut self.lambda, grad);
        self.lambda = self.lambda.max(0.0);
        self.updates += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn multiplier(cost_limit: f64) -> Multiplier {
        Multiplier::new(&LagrangianConfig { cost_limit, window: 3, ..LagrangianConfig::default() })
    }

    /// Runs `n` episodes of 5 steps, each costing `cost` on its last step.
    fn episodes(m: &mut Multiplier, n: usize, cost: f64, learning: bool) -> Vec<f32> {
        (0..n)
            .map(|_| {
                for t in 0..5 {
                    m.observe(if t == 4 { cost } else { 0.0 }, t == 4, learning);
                }
                m.lambda()
            })
            .collect()
    }

    #[test]
    fn lambda_rises_while_episodes_cost_more_than_the_limit() {
        let mut m = multiplier(0.1);
        let lambdas = episodes(&mut m, 20, 1.0, true);
        assert!(lambdas.windows(2).all(|w| w[1] > w[0]), "{lambdas:?}");
        // Adam's first step is about lr whatever the gradient's size.
        assert!((lambdas[0] - 0.011).abs() < 1e-4, "{}", lambdas[0]);
        assert_eq!(m.mean_episode_cost(), Some(1.0));
        assert_eq!(m.updates(), 20);
    }

    #[test]
    fn lambda_falls_to_zero_and_stays_there_while_episodes_cost_less() {
        let mut m = multiplier(0.5);
        episodes(&mut m, 30, 1.0, true);
        let high = m.lambda();
        assert!(high > 0.2, "{high}");
        let lambdas = episodes(&mut m, 400, 0.0, true);
        // J_c stays above d for the window's first episodes and Adam's momentum carries lambda
        // up a little longer, then it falls...
        let peak = (0..lambdas.len()).max_by(|&i, &j| lambdas[i].total_cmp(&lambdas[j])).unwrap();
        assert!(peak < 20, "{lambdas:?}");
        assert!(lambdas[peak..].windows(2).all(|w| w[1] <= w[0]), "{lambdas:?}");
        assert!(lambdas[peak + 20] < high);
        // ...to 0, where the clamp holds it.
        let zero = lambdas.iter().position(|&l| l == 0.0).expect("lambda never reached 0");
        assert!(lambdas[zero..].iter().all(|&l| l == 0.0), "{:?}", &lambdas[zero..]);
    }

    #[test]
    fn lambda_does_not_move_during_the_warm_up_but_the_window_fills() {
        let mut m = multiplier(0.1);
        let lambdas = episodes(&mut m, 10, 1.0, false);
        assert!(lambdas.iter().all(|&l| l == 0.001), "{lambdas:?}");
        assert_eq!((m.updates(), m.mean_episode_cost()), (0, Some(1.0)));
        episodes(&mut m, 1, 1.0, true);
        assert!(m.lambda() > 0.001);
    }

    #[test]
    fn j_c_is_the_mean_over_the_window_and_the_running_cost_spans_steps() {
        let mut m = multiplier(0.1);
        for cost in [1.0, 0.0, 0.0, 2.0] {
            m.observe(cost, false, false);
            m.observe(0.5, true, false);
        }
        // Episodes cost 1.5, 0.5, 0.5, 2.5; the window keeps the last 3.
        assert_eq!(m.mean_episode_cost(), Some(3.5 / 3.0));
        m.observe(1.0, false, false);
        let back: Multiplier = serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(back, m, "the running cost and the window survive a checkpoint");
    }
}
