"""A single-file, CleanRL-style SAC (continuous actions) trained on a Gymnasium task under
DEFENDER. The only DEFENDER-specific lines are marked `# DEFENDER`: the agent below is plain SAC
and learns, from filtered steps (terminated, reward R_task), to avoid what looks unsafe.

    pip install ".[mujoco]" torch                  # or: make python && pip install -r python/requirements-sb3.txt
    python examples/cleanrl_sac_defender.py --env-id Hopper-v5 --total-timesteps 20000
    python examples/cleanrl_sac_defender.py --env-id InvertedDoublePendulum-v5 --no-defender
"""

from __future__ import annotations

import argparse
import pathlib
import random
import time

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from defender_rl import DefenderWrapper  # DEFENDER

ROOT = pathlib.Path(__file__).resolve().parents[1]


def parse_args():
    p = argparse.ArgumentParser()
    p.add_argument("--env-id", default="Hopper-v5")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--total-timesteps", type=int, default=20_000)
    p.add_argument("--buffer-size", type=int, default=1_000_000)
    p.add_argument("--gamma", type=float, default=0.99)
    p.add_argument("--tau", type=float, default=0.005)
    p.add_argument("--batch-size", type=int, default=256)
    p.add_argument("--learning-starts", type=int, default=5_000)
    p.add_argument("--policy-lr", type=float, default=3e-4)
    p.add_argument("--q-lr", type=float, default=1e-3)
    p.add_argument("--policy-frequency", type=int, default=2)
    p.add_argument("--target-network-frequency", type=int, default=1)
    p.add_argument("--alpha", type=float, default=0.2)
    p.add_argument("--autotune", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--defender", action=argparse.BooleanOptionalAction, default=True)  # DEFENDER
    p.add_argument("--strategy", default="MeanDemoW5/MeanDemoW10")  # DEFENDER
    p.add_argument("--demos", default=None, help="default: data/demos/<ENV>.npz")  # DEFENDER
    return p.parse_args()


class ReplayBuffer:
    def __init__(self, obs_dim, act_dim, size):
        self.obs = np.zeros((size, obs_dim), np.float32)
        self.next_obs = np.zeros((size, obs_dim), np.float32)
        self.act = np.zeros((size, act_dim), np.float32)
        self.rew = np.zeros(size, np.float32)
        self.done = np.zeros(size, np.float32)
        self.size, self.n, self.i = size, 0, 0

    def add(self, o, o2, a, r, d):
        self.obs[self.i], self.next_obs[self.i], self.act[self.i], self.rew[self.i], self.done[self.i] = o, o2, a, r, d
        self.i = (self.i + 1) % self.size
        self.n = min(self.n + 1, self.size)

    def sample(self, batch, device):
        idx = np.random.randint(0, self.n, size=batch)
        t = lambda x: torch.as_tensor(x[idx], device=device)  # noqa: E731
        return t(self.obs), t(self.act), t(self.next_obs), t(self.rew), t(self.done)


class SoftQNetwork(nn.Module):
    def __init__(self, obs_dim, act_dim):
        super().__init__()
        self.fc1, self.fc2, self.fc3 = nn.Linear(obs_dim + act_dim, 256), nn.Linear(256, 256), nn.Linear(256, 1)

    def forward(self, x, a):
        x = F.relu(self.fc1(torch.cat([x, a], 1)))
        return self.fc3(F.relu(self.fc2(x)))


LOG_STD_MAX, LOG_STD_MIN = 2, -5


class Actor(nn.Module):
    def __init__(self, env):
        super().__init__()
        obs_dim, act_dim = env.observation_space.shape[0], env.action_space.shape[0]
        self.fc1, self.fc2 = nn.Linear(obs_dim, 256), nn.Linear(256, 256)
        self.fc_mean, self.fc_logstd = nn.Linear(256, act_dim), nn.Linear(256, act_dim)
        high, low = env.action_space.high, env.action_space.low
        self.register_buffer("action_scale", torch.tensor((high - low) / 2.0, dtype=torch.float32))
        self.register_buffer("action_bias", torch.tensor((high + low) / 2.0, dtype=torch.float32))

    def forward(self, x):
        x = F.relu(self.fc2(F.relu(self.fc1(x))))
        log_std = torch.tanh(self.fc_logstd(x))
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (log_std + 1)
        return self.fc_mean(x), log_std

    def get_action(self, x):
        mean, log_std = self(x)
        normal = torch.distributions.Normal(mean, log_std.exp())
        x_t = normal.rsample()
        y_t = torch.tanh(x_t)
        action = y_t * self.action_scale + self.action_bias
        log_prob = normal.log_prob(x_t) - torch.log(self.action_scale * (1 - y_t.pow(2)) + 1e-6)
        return action, log_prob.sum(1, keepdim=True), torch.tanh(mean) * self.action_scale + self.action_bias


def main():
    args = parse_args()
    random.seed(args.seed)
    np.random.seed(args.seed)
    torch.manual_seed(args.seed)
    device = torch.device("cpu")

    env = gym.make(args.env_id)
    if args.defender:  # DEFENDER: the whole integration is this wrapper
        demos = args.demos or ROOT / "data" / "demos" / f"{args.env_id}.npz"
        env = DefenderWrapper(env, demos, args.strategy, seed=args.seed)
    obs_dim, act_dim = env.observation_space.shape[0], env.action_space.shape[0]
    env.action_space.seed(args.seed)

    actor = Actor(env).to(device)
    qf1, qf2 = SoftQNetwork(obs_dim, act_dim).to(device), SoftQNetwork(obs_dim, act_dim).to(device)
    qf1_target, qf2_target = SoftQNetwork(obs_dim, act_dim).to(device), SoftQNetwork(obs_dim, act_dim).to(device)
    qf1_target.load_state_dict(qf1.state_dict())
    qf2_target.load_state_dict(qf2.state_dict())
    q_optimizer = torch.optim.Adam(list(qf1.parameters()) + list(qf2.parameters()), lr=args.q_lr)
    actor_optimizer = torch.optim.Adam(actor.parameters(), lr=args.policy_lr)
    if args.autotune:
        target_entropy = -float(act_dim)
        log_alpha = torch.zeros(1, requires_grad=True, device=device)
        alpha = log_alpha.exp().item()
        a_optimizer = torch.optim.Adam([log_alpha], lr=args.q_lr)
    else:
        alpha = args.alpha

    rb = ReplayBuffer(obs_dim, act_dim, min(args.buffer_size, args.total_timesteps))
    start = time.time()
    obs, _ = env.reset(seed=args.seed)
    episodes, crashes, filtered, ep_return = 0, 0, 0, 0.0
    for global_step in range(args.total_timesteps):
        if global_step < args.learning_starts:
            action = env.action_space.sample()
        else:
            with torch.no_grad():
                action, _, _ = actor.get_action(torch.as_tensor(obs, dtype=torch.float32, device=device)[None])
            action = action[0].numpy()

        next_obs, reward, terminated, truncated, info = env.step(action)
        ep_return += float(reward)
        # A filtered step is terminated with the dynamics model's prediction as next_obs: stored
        # as any terminal transition, so the agent learns the unsafe region has no future.
        rb.add(obs, next_obs, action, reward, float(terminated))
        if terminated or truncated:
            episodes += 1
            outcome = info.get("defender_outcome", "crashed" if terminated else "truncated")  # DEFENDER
            crashes += outcome == "crashed"
            filtered += outcome == "filtered"
            if episodes % 50 == 0:
                print(f"step {global_step + 1}: {episodes} episodes, crash {100 * crashes / episodes:.1f}%, "
                      f"filtered {100 * filtered / episodes:.1f}%, last return {ep_return:.1f}, "
                      f"{int((global_step + 1) / (time.time() - start))} steps/s")
            ep_return = 0.0
            obs, _ = env.reset()
        else:
            obs = next_obs

        if global_step >= args.learning_starts:
            b_obs, b_act, b_next, b_rew, b_done = rb.sample(args.batch_size, device)
            with torch.no_grad():
                next_a, next_logp, _ = actor.get_action(b_next)
                q_next = torch.min(qf1_target(b_next, next_a), qf2_target(b_next, next_a)) - alpha * next_logp
                target = b_rew + (1 - b_done) * args.gamma * q_next.view(-1)
            q1, q2 = qf1(b_obs, b_act).view(-1), qf2(b_obs, b_act).view(-1)
            qf_loss = F.mse_loss(q1, target) + F.mse_loss(q2, target)
            q_optimizer.zero_grad()
            qf_loss.backward()
            q_optimizer.step()

            if global_step % args.policy_frequency == 0:
                for _ in range(args.policy_frequency):
                    pi, log_pi, _ = actor.get_action(b_obs)
                    actor_loss = ((alpha * log_pi) - torch.min(qf1(b_obs, pi), qf2(b_obs, pi))).mean()
                    actor_optimizer.zero_grad()
                    actor_loss.backward()
                    actor_optimizer.step()
                    if args.autotune:
                        with torch.no_grad():
                            _, log_pi, _ = actor.get_action(b_obs)
                        alpha_loss = (-log_alpha.exp() * (log_pi + target_entropy)).mean()
                        a_optimizer.zero_grad()
                        alpha_loss.backward()
                        a_optimizer.step()
                        alpha = log_alpha.exp().item()

            if global_step % args.target_network_frequency == 0:
                for net, tgt in ((qf1, qf1_target), (qf2, qf2_target)):
                    for p, tp in zip(net.parameters(), tgt.parameters()):
                        tp.data.copy_(args.tau * p.data + (1 - args.tau) * tp.data)

    print(f"{args.env_id} SAC{' + DEFENDER ' + args.strategy if args.defender else ''}: {args.total_timesteps} steps, "
          f"{episodes} episodes, crash {100 * crashes / max(episodes, 1):.1f}%, "
          f"filtered {100 * filtered / max(episodes, 1):.1f}%, {time.time() - start:.0f}s")
    if args.defender:
        print("DEFENDER counters:", env.defender_stats)  # DEFENDER
    env.close()


if __name__ == "__main__":
    main()
