//! The network work of one SAC update on Hopper (obs 11, act 3, 256x256 networks, batch 256),
//! shared by the criterion bench and the `nn_profile` example.

use defender_nn::faer::Mat;
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand::SeedableRng;

pub const BATCH: usize = 256;
pub const OBS: usize = 11;
pub const ACT: usize = 3;

/// Multiply-adds of one forward pass of `widths` at batch `b`.
pub fn macs(widths: &[usize], b: usize) -> u64 {
    widths.windows(2).map(|w| (w[0] * w[1] * b) as u64).sum()
}

fn input(rows: usize, cols: usize) -> Mat<f32> {
    Mat::from_fn(rows, cols, |i, j| (((i * 31 + j * 17) % 29) as f32 - 14.0) / 14.0)
}

/// Two critics and their targets, an actor (mean and log-std heads), three Adams, inputs.
pub struct SacShape {
    q1: Mlp,
    q2: Mlp,
    q1_t: Mlp,
    q2_t: Mlp,
    pi: Mlp,
    o1: Adam,
    o2: Adam,
    op: Adam,
    s: Mat<f32>,
    sa: Mat<f32>,
    g_q: Mat<f32>,
    g_pi: Mat<f32>,
}

impl SacShape {
    pub fn new(par: Parallelism) -> Self {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut new =
            |w: &[usize]| Mlp::new(w, Activation::Relu, Activation::Identity, &mut rng).with_parallelism(par);
        let q1 = new(&Self::critic_widths());
        let q2 = new(&Self::critic_widths());
        let pi = new(&Self::actor_widths());
        let cfg = AdamConfig { lr: 3e-4, ..Default::default() };
        SacShape {
            q1_t: q1.clone(),
            q2_t: q2.clone(),
            o1: Adam::new(&q1, cfg),
            o2: Adam::new(&q2, cfg),
            op: Adam::new(&pi, cfg),
            q1,
            q2,
            pi,
            s: input(BATCH, OBS),
            sa: input(BATCH, OBS + ACT),
            g_q: input(BATCH, 1),
            g_pi: input(BATCH, 2 * ACT),
        }
    }

    pub fn critic_widths() -> [usize; 4] {
        [OBS + ACT, 256, 256, 1]
    }

    pub fn actor_widths() -> [usize; 4] {
        [OBS, 256, 256, 2 * ACT]
    }

    /// FLOPs of [`SacShape::update`] (2 per multiply-add).
    pub fn flops() -> u64 {
        let q = macs(&Self::critic_widths(), BATCH);
        let pi = macs(&Self::actor_widths(), BATCH);
        2 * (2 * q // target critics on (s', a')
            + pi // actor on s'
            + 2 * 3 * q // critics: forward, backward (params; the input GEMM of layer 0 is skipped)
            + 2 * 2 * q // critics: forward and input-only backward for the actor loss
            + 3 * pi) // actor: forward and backward
    }

    /// One update's network work (losses replaced by fixed gradients).
    pub fn update(&mut self) {
        let a_next = self.pi.forward(self.s.as_ref());
        for j in 0..ACT {
            for i in 0..BATCH {
                self.sa[(i, OBS + j)] = a_next[(i, j)].tanh();
            }
        }
        self.q1_t.forward(self.sa.as_ref());
        self.q2_t.forward(self.sa.as_ref());
        for (q, o) in [(&mut self.q1, &mut self.o1), (&mut self.q2, &mut self.o2)] {
            q.forward(self.sa.as_ref());
            q.zero_grad();
            q.backward_params(self.g_q.as_ref());
            o.step(q);
        }
        self.pi.forward(self.s.as_ref());
        for q in [&mut self.q1, &mut self.q2] {
            q.forward(self.sa.as_ref());
            q.backward_input(self.g_q.as_ref());
        }
        self.pi.zero_grad();
        self.pi.backward_params(self.g_pi.as_ref());
        self.op.step(&mut self.pi);
        self.q1_t.polyak_update(&self.q1, 0.005);
        self.q2_t.polyak_update(&self.q2, 0.005);
    }
}
