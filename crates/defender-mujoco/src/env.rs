//! [`MujocoEnv`]: one Gymnasium MuJoCo task on MuJoCo, implementing [`defender_rl::Env`].
//!
//! Each rule below follows Gymnasium 1.4.0's `hopper_v5.py`, `walker2d_v5.py`,
//! `inverted_double_pendulum_v5.py`, `hopper_v4.py`, `walker2d_v4.py`, `half_cheetah_v4.py` and
//! `mujoco_env.py`, and is checked against recordings of Gymnasium itself (`tests/parity.rs`,
//! data from `tools/golden/gym_record.py`). The velocity tasks add safety-gymnasium 1.0.0's cost
//! ([`Cost`](crate::Cost)) to their v4 base and change nothing else.

use defender_rl::{BoxSpace, Env, EnvError, Result, Step, StepInfo, TimeLimit, check_vector};
use mujoco_rs::prelude::{MjData, MjModel, MjtWarning};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::task::{Body, Task, Version};

/// Gymnasium clips the velocities (and IDP's constraint force) it observes to this range.
const OBS_CLIP: f64 = 10.0;

/// MuJoCo warnings that mean the simulation was reset or the controls were discarded: MuJoCo
/// resets `mjData` when qpos/qvel/qacc become NaN, Inf or larger than 1e10, and zeroes `ctrl`
/// when a control is. Any of them makes the step [`StepInfo::unstable`].
const INSTABILITY_WARNINGS: [MjtWarning; 4] = [
    MjtWarning::mjWARN_BADQPOS,
    MjtWarning::mjWARN_BADQVEL,
    MjtWarning::mjWARN_BADQACC,
    MjtWarning::mjWARN_BADCTRL,
];

/// A Gymnasium MuJoCo task of the registry ([`crate::registry`]) with Gymnasium's default
/// arguments, without a time limit (use [`make`] for the registered 1000-step horizon).
///
/// - Actions go to `ctrl` unchanged and MuJoCo steps `frame_skip` times, as in
///   `MujocoEnv.do_simulation`: Gymnasium does not clip actions, and neither do we. MuJoCo clamps
///   `ctrl` to the actuators' `ctrlrange` ([-1, 1]) inside the physics; the control cost uses the
///   raw action. Actions of the wrong length or with non-finite values are an error.
/// - `mj_rnePostConstraint`, which Gymnasium calls after stepping, is skipped: it only fills
///   `cacc`/`cfrc_int`/`cfrc_ext`, which no observation or reward of these tasks reads and the
///   next `mj_step` recomputes.
/// - `reset(seed)` draws the initial state from Gymnasium's distributions (uniform noise of
///   `reset_noise_scale` on qpos, and on qvel for Hopper/Walker2d; Gaussian qvel noise for
///   HalfCheetah and InvertedDoublePendulum) with this environment's own ChaCha8 generator (seeded with 0 at
///   construction); the draws are not numpy's, so a seed gives a different state than in Python.
/// - A step's cost follows the task's [`Cost`](crate::Cost) rule ([`Task::cost`]).
/// - After a terminated step, [`Env::step`] returns [`EnvError::NeedsReset`] until the next reset.
pub struct MujocoEnv {
    task: Task,
    data: MjData<Box<MjModel>>,
    observation_space: BoxSpace,
    action_space: BoxSpace,
    init_qpos: Vec<f64>,
    init_qvel: Vec<f64>,
    rng: ChaCha8Rng,
    frame_skip: usize,
    dt: f64,
    needs_reset: bool,
}

impl std::fmt::Debug for MujocoEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MujocoEnv")
            .field("id", &self.task.id())
            .field("qpos", &self.qpos())
            .field("qvel", &self.qvel())
            .field("needs_reset", &self.needs_reset)
            .finish_non_exhaustive()
    }
}

/// Builds the task with Gymnasium id `id`, wrapped in its registered time limit (1000 steps),
/// as `gymnasium.make(id)` does.
///
/// # Errors
/// [`EnvError::UnknownEnv`] (listing the known ids) or [`EnvError::Simulator`] if MuJoCo fails
/// to load the model.
pub fn make(id: &str) -> Result<TimeLimit<MujocoEnv>> {
    let env = MujocoEnv::from_id(id)?;
    let horizon = env.task.spec().max_episode_steps;
    Ok(TimeLimit::new(env, horizon))
}

impl MujocoEnv {
    /// Builds `task` (no time limit). The environment needs a [`Env::reset`] (or
    /// [`MujocoEnv::reset_to`]) before the first step.
    ///
    /// # Errors
    /// [`EnvError::Simulator`] if MuJoCo fails to load the model or allocate its data.
    pub fn new(task: Task) -> Result<Self> {
        crate::logging::route_mujoco_log_to_tracing();
        let spec = task.spec();
        let model = MjModel::from_xml_string(&task.xml()?)
            .map_err(|e| EnvError::Simulator(format!("{}: loading the MuJoCo model: {e}", spec.id)))?;
        let data = MjData::try_new(Box::new(model))
            .map_err(|e| EnvError::Simulator(format!("{}: allocating MuJoCo data: {e}", spec.id)))?;
        let model = data.model();
        let (low, high): (Vec<f64>, Vec<f64>) =
            model.actuator_ctrlrange().iter().map(|r| (r[0], r[1])).unzip();
        if low.len() != spec.act_dim {
            return Err(EnvError::Simulator(format!(
                "{}: the model has {} actuators, expected {}",
                spec.id,
                low.len(),
                spec.act_dim
            )));
        }
        let action_space = BoxSpace::new(low, high)?;
        let dt = model.opt().timestep * spec.frame_skip as f64;
        let init_qpos = data.qpos().to_vec();
        let init_qvel = data.qvel().to_vec();
        let env = Self {
            task,
            observation_space: BoxSpace::unbounded(spec.obs_dim),
            action_space,
            init_qpos,
            init_qvel,
            rng: ChaCha8Rng::seed_from_u64(0),
            frame_skip: spec.frame_skip,
            dt,
            needs_reset: true,
            data,
        };
        let obs_dim = env.observation().len();
        if obs_dim != spec.obs_dim {
            return Err(EnvError::Simulator(format!(
                "{}: the model gives {obs_dim} observations, expected {}",
                spec.id, spec.obs_dim
            )));
        }
        Ok(env)
    }

    /// Builds the task with Gymnasium id `id`, without a time limit.
    ///
    /// # Errors
    /// [`EnvError::UnknownEnv`] listing the known ids, or as [`MujocoEnv::new`].
    pub fn from_id(id: &str) -> Result<Self> {
        Self::new(Task::from_id(id)?)
    }

    /// The task.
    pub fn task(&self) -> Task {
        self.task
    }

    /// Seconds of simulated time per environment step (`timestep * frame_skip`).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Joint positions (MuJoCo `qpos`, `nq` values; Hopper's first is the x position that the
    /// observation leaves out).
    pub fn qpos(&self) -> &[f64] {
        self.data.qpos()
    }

    /// Joint velocities (MuJoCo `qvel`, `nv` values, not clipped).
    pub fn qvel(&self) -> &[f64] {
        self.data.qvel()
    }

    /// Sets the joint positions and velocities and recomputes the derived quantities
    /// (`mj_forward`), as Gymnasium's `MujocoEnv.set_state`: time, controls and the solver's warm
    /// start are kept. The episode continues from this state (a later step is allowed).
    ///
    /// # Errors
    /// [`EnvError::LengthMismatch`] if `qpos`/`qvel` do not have `nq`/`nv` values,
    /// [`EnvError::NonFinite`] if one is NaN or infinite. The state is unchanged on error.
    pub fn set_state(&mut self, qpos: &[f64], qvel: &[f64]) -> Result<()> {
        check_vector("qpos", qpos, self.init_qpos.len())?;
        check_vector("qvel", qvel, self.init_qvel.len())?;
        self.data.qpos_mut().copy_from_slice(qpos);
        self.data.qvel_mut().copy_from_slice(qvel);
        self.data.forward();
        self.needs_reset = false;
        Ok(())
    }

    /// Starts a new episode from the given state: resets all of MuJoCo's data (`mj_resetData`:
    /// time, controls, warm start, warnings), then [`MujocoEnv::set_state`]. Returns the first
    /// observation. This is how the parity recordings start (see `tools/golden/gym_record.py`).
    ///
    /// # Errors
    /// As [`MujocoEnv::set_state`]; on error the environment needs a reset.
    pub fn reset_to(&mut self, qpos: &[f64], qvel: &[f64]) -> Result<Vec<f64>> {
        check_vector("qpos", qpos, self.init_qpos.len())?;
        check_vector("qvel", qvel, self.init_qvel.len())?;
        self.data.reset();
        self.set_state(qpos, qvel)?;
        Ok(self.observation())
    }

    /// The observation of the current state.
    pub fn observation(&self) -> Vec<f64> {
        let mut obs = Vec::with_capacity(self.observation_space.dim());
        let qpos = self.data.qpos();
        let qvel = self.data.qvel();
        let clip = |v: f64| v.clamp(-OBS_CLIP, OBS_CLIP);
        match self.task.body() {
            // position[1:] (x excluded), clip(qvel, -10, 10)
            Body::Hopper | Body::Walker2d => {
                obs.extend_from_slice(&qpos[1..]);
                obs.extend(qvel.iter().copied().map(clip));
            }
            // position[1:], qvel unclipped (half_cheetah_v4.py does not clip)
            Body::HalfCheetah => {
                obs.extend_from_slice(&qpos[1..]);
                obs.extend_from_slice(qvel);
            }
            // qpos[:1], sin(qpos[1:]), cos(qpos[1:]), clip(qvel), clip(qfrc_constraint)[:1]
            Body::InvertedDoublePendulum => {
                obs.push(qpos[0]);
                obs.extend(qpos[1..].iter().map(|q| q.sin()));
                obs.extend(qpos[1..].iter().map(|q| q.cos()));
                obs.extend(qvel.iter().copied().map(clip));
                obs.push(clip(self.data.qfrc_constraint()[0]));
            }
        }
        obs
    }

    /// Gymnasium's `is_healthy` for Hopper and Walker2d (open intervals, as the Python `<`); the
    /// same ranges in v4 and v5. HalfCheetah and InvertedDoublePendulum have none.
    fn is_healthy(&self) -> bool {
        let qpos = self.data.qpos();
        let (z, angle) = (qpos[1], qpos[2]);
        match self.task.body() {
            Body::Hopper => {
                // state_vector()[2:]: qpos[2:] then the unclipped qvel.
                let state_ok = qpos[2..].iter().chain(self.data.qvel()).all(|&s| -100.0 < s && s < 100.0);
                state_ok && HOPPER_Z.0 < z && z < HOPPER_Z.1 && -HOPPER_ANGLE < angle && angle < HOPPER_ANGLE
            }
            Body::Walker2d => {
                WALKER_Z.0 < z && z < WALKER_Z.1 && -WALKER_ANGLE < angle && angle < WALKER_ANGLE
            }
            Body::HalfCheetah | Body::InvertedDoublePendulum => true,
        }
    }

    /// Sum of MuJoCo's counters of the warnings in [`INSTABILITY_WARNINGS`].
    fn instability_count(&self) -> i64 {
        let warnings = self.data.warning();
        INSTABILITY_WARNINGS.iter().map(|&w| i64::from(warnings[w as usize].number)).sum()
    }

    /// Ends the episode after MuJoCo reported an instability: an observation of the state MuJoCo
    /// reset to, reward 0, terminated, `unstable`.
    fn unstable_step(&mut self, what: &str) -> Step {
        let time = self.data.ffi().time;
        tracing::warn!(
            env = self.task.id(),
            time,
            "MuJoCo simulation unstable ({what}); ending the episode as terminated"
        );
        self.needs_reset = true;
        let obs = self.observation().into_iter().map(|v| if v.is_finite() { v } else { 0.0 }).collect();
        Step {
            obs,
            reward: 0.0,
            // An unstable simulation ends the episode as terminated: a crash (see `Cost`).
            cost: self.task.cost().of_unstable_step(),
            terminated: true,
            truncated: false,
            info: StepInfo { unstable: true, ..StepInfo::default() },
        }
    }
}

impl Clone for MujocoEnv {
    /// A copy of the simulator as it stands (`mj_copyData`: positions, velocities, warm starts,
    /// the time), so that stepping either gives the same trajectory as stepping the other would.
    fn clone(&self) -> Self {
        Self {
            task: self.task,
            data: self.data.clone(),
            observation_space: self.observation_space.clone(),
            action_space: self.action_space.clone(),
            init_qpos: self.init_qpos.clone(),
            init_qvel: self.init_qvel.clone(),
            rng: self.rng.clone(),
            frame_skip: self.frame_skip,
            dt: self.dt,
            needs_reset: self.needs_reset,
        }
    }
}

/// The healthy ranges of Hopper and Walker2d (Gymnasium's `healthy_z_range`,
/// `healthy_angle_range`) and the initial torso height both start from (`init_qpos[1]`).
const HOPPER_Z: (f64, f64) = (0.7, f64::INFINITY);
const HOPPER_ANGLE: f64 = 0.2;
const WALKER_Z: (f64, f64) = (0.8, 2.0);
const WALKER_ANGLE: f64 = 1.0;
const INIT_Z: f64 = 1.25;
/// InvertedDoublePendulum: the tip's height at rest (two poles of 0.6) and the height at or below
/// which the episode terminates.
const IDP_TIP_REST: f64 = 1.2;
const IDP_TIP_MIN: f64 = 1.0;

/// How far `v` has gone from `init` toward the boundaries `lo < init < hi`: 0 at `init`, 1 on a
/// boundary (an infinite boundary is never approached).
fn toward(v: f64, init: f64, (lo, hi): (f64, f64)) -> f64 {
    if v < init {
        (init - v) / (init - lo)
    } else if hi.is_finite() {
        (v - init) / (hi - init)
    } else {
        0.0
    }
}

/// [`Env::failure_proximity`] of an observation of `body` (columns as [`MujocoEnv::observation`]
/// writes them): Hopper and Walker2d read the torso height (column 0) and angle (column 1);
/// InvertedDoublePendulum the tip's height, `0.6 cos q1 + 0.6 cos(q1 + q2)`, from the sines
/// (columns 1, 2) and cosines (3, 4). Hopper's bound on `|state| < 100` is left out: the
/// observation clips the velocities it reads.
fn failure_proximity(body: Body, obs: &[f64]) -> Option<f64> {
    match body {
        Body::Hopper if obs.len() >= 2 => {
            Some(toward(obs[0], INIT_Z, HOPPER_Z).max(obs[1].abs() / HOPPER_ANGLE))
        }
        Body::Walker2d if obs.len() >= 2 => {
            Some(toward(obs[0], INIT_Z, WALKER_Z).max(obs[1].abs() / WALKER_ANGLE))
        }
        Body::InvertedDoublePendulum if obs.len() >= 5 => {
            let (s1, s2, c1, c2) = (obs[1], obs[2], obs[3], obs[4]);
            let tip = 0.6 * c1 + 0.6 * (c1 * c2 - s1 * s2);
            Some(((IDP_TIP_REST - tip) / (IDP_TIP_REST - IDP_TIP_MIN)).max(0.0))
        }
        _ => None,
    }
}

impl Env for MujocoEnv {
    fn id(&self) -> &str {
        self.task.id()
    }

    fn fork(&self) -> Option<Box<dyn Env>> {
        Some(Box::new(self.clone()))
    }

    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        failure_proximity(self.task.body(), obs)
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    fn reset(&mut self, seed: Option<u64>) -> Result<Vec<f64>> {
        if let Some(seed) = seed {
            self.rng = ChaCha8Rng::seed_from_u64(seed);
        }
        let scale = self.task.reset_noise_scale();
        let mut qpos = self.init_qpos.clone();
        let mut qvel = self.init_qvel.clone();
        // numpy's uniform(low, high) draws from [low, high), as does random_range.
        for q in &mut qpos {
            *q += self.rng.random_range(-scale..scale);
        }
        for v in &mut qvel {
            *v += match self.task.body() {
                Body::Hopper | Body::Walker2d => self.rng.random_range(-scale..scale),
                Body::HalfCheetah | Body::InvertedDoublePendulum => {
                    self.rng.sample::<f64, _>(StandardNormal) * scale
                }
            };
        }
        self.reset_to(&qpos, &qvel)
    }

    fn step(&mut self, action: &[f64]) -> Result<Step> {
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        self.action_space.check("action", action)?;
        let x_before = self.data.qpos()[0];
        self.data.ctrl_mut().copy_from_slice(action);
        // Zeroed per step, so that a warning is seen even after MuJoCo's own reset of the data
        // (which may leave the counter where it was) and after a `set_state` without reset.
        for w in INSTABILITY_WARNINGS {
            self.data.warning_mut()[w as usize].number = 0;
        }
        for _ in 0..self.frame_skip {
            self.data.step();
            if self.instability_count() != 0 {
                return Ok(self.unstable_step("MuJoCo warned of a bad qpos, qvel, qacc or ctrl"));
            }
        }
        // x_velocity as Gymnasium's `info["x_velocity"]`: the forward reward and the velocity cost.
        let x_velocity = (self.data.qpos()[0] - x_before) / self.dt;
        let squared_action = action.iter().fold(0.0, |acc, a| acc + a * a);
        let (reward, terminated) = match self.task.body() {
            Body::Hopper | Body::Walker2d => {
                let forward_reward = x_velocity; // forward_reward_weight = 1
                let healthy = self.is_healthy();
                // v4 pays the healthy reward on the falling step too (see `Version`).
                let healthy_reward = if healthy || self.task.version() == Version::V4 { 1.0 } else { 0.0 };
                let ctrl_cost = 1e-3 * squared_action;
                ((forward_reward + healthy_reward) - ctrl_cost, !healthy)
            }
            // forward_reward_weight 1, ctrl_cost_weight 0.1; never terminates.
            Body::HalfCheetah => (x_velocity - 0.1 * squared_action, false),
            Body::InvertedDoublePendulum => {
                // site_xpos as mj_step left it (computed before its last integration), as Gymnasium reads it.
                let [x, _, y] = self.data.site_xpos()[0];
                let terminated = y <= 1.0;
                let qvel = self.data.qvel();
                let (v1, v2) = (qvel[1], qvel[2]);
                let dist_penalty = 0.01 * x * x + (y - 2.0) * (y - 2.0);
                let vel_penalty = 1e-3 * v1 * v1 + 5e-3 * v2 * v2;
                let alive_bonus = if terminated { 0.0 } else { 10.0 };
                (alive_bonus - dist_penalty - vel_penalty, terminated)
            }
        };
        let obs = self.observation();
        if !reward.is_finite() || obs.iter().any(|v| !v.is_finite()) {
            return Ok(self.unstable_step("non-finite observation or reward"));
        }
        self.needs_reset = terminated;
        let cost = self.task.cost().of_step(terminated, x_velocity);
        Ok(Step { obs, reward, cost, terminated, truncated: false, info: StepInfo::default() })
    }
}
