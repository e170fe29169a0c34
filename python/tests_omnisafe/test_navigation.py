"""The navigation tasks' learner and demonstrations (tools/navigation/navigation_train.py,
tools/navigation/navigation_demos.py) in the peer venv: `make test-omnisafe`, outside `make test`.

Here: OmniSafe's PPOLag trains a few episodes on SafetyPointGoal1-v0; every training episode is
recorded as the task took it (the raw observation, not OmniSafe's normalised one; the same costs,
returns and lengths as OmniSafe's own episode log) and labelled by docs/SPEC.md section 13; the
policy snapshots give OmniSafe's own deterministic action; the demonstrations tool records and
labels episodes of every snapshot.
"""

from __future__ import annotations

import csv
import glob
import json
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import torch

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "navigation"))

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
    import safety_gymnasium
    from omnisafe.common.normalizer import Normalizer
    from safety_gymnasium.wrappers import SafetyGymnasium2Gymnasium

import navigation_demos  # noqa: E402

from defender_rl import EpisodeSet  # noqa: E402

TASK = "SafetyPointGoal1-v0"


def rows(path: pathlib.Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=600, cwd=ROOT)


def train(out: pathlib.Path, seed: int, steps: int) -> None:
    # Epochs of one 1,000-step episode each, one pass over each epoch's data: seconds.
    done = run("tools/navigation/navigation_train.py", "--env", TASK, "--seed", str(seed), "--steps", str(steps),
               "--steps-per-epoch", "1000", "--update-iters", "1", "--out", str(out))
    assert done.returncode == 0, done.stderr[-3000:]


def test_ppolag_episodes_are_recorded_raw_labelled_and_snapshotted(tmp_path):
    out = tmp_path / "s3"
    train(out, 3, 3000)
    theirs, ours = rows(out / "episodes.csv"), rows(out / "labels.csv")
    assert len(theirs) == len(ours) == 3
    for t, o in zip(theirs, ours):
        # OmniSafe sums in float32, the log in float64.
        assert int(t["length"]) == int(o["length"]) == 1000
        assert abs(float(t["cost"]) - float(o["cost"])) < 1e-3 and abs(float(t["return"]) - float(o["return"])) < 1e-3
        unsafe = float(o["cost"]) > 25
        assert o["label"] == ("unsafe" if unsafe else "safe")
        assert (int(o["recorded_steps"]) < 1000) == unsafe
        assert (int(o["first_cost_step"]) >= 0) == (float(o["cost"]) > 0)
    run_json = json.loads((out / "run.json").read_text())
    assert run_json["complete"] and run_json["env_steps"] == 3000
    recorded = EpisodeSet.load(str(out / "episodes.npz"))
    assert recorded.meta["episode_cost_limit"] == 25.0 and recorded.meta["obs_dim"] == 60 and len(recorded) == 3
    assert [len(recorded.episode(i)["rew"]) for i in range(3)] == [int(o["recorded_steps"]) for o in ours]
    # The recorded observations are the task's own: OmniSafe's first reset takes the seed, its
    # rollout then resets again (no seed) and the first episode starts there.
    task = safety_gymnasium.make(TASK)
    task.reset(seed=3)
    first, _ = task.reset()
    np.testing.assert_allclose(recorded.episode(0)["obs"][0], first, rtol=1e-6, atol=1e-6)
    assert np.abs(recorded.episode(0)["act"]).max() <= 1.0
    # The seed makes the same recording (docs/results-navigation.md regenerates its sets so).
    train(tmp_path / "again", 3, 3000)
    again = EpisodeSet.load(str(tmp_path / "again" / "episodes.npz"))
    for name in ("obs", "act", "rew", "ep_len", "crashed"):
        np.testing.assert_array_equal(again.to_arrays()[name], recorded.to_arrays()[name])

    # A snapshot per epoch and the initial one; its policy is OmniSafe's deterministic actor.
    folder, snaps = navigation_demos.snapshots(str(out))
    assert [e for e, _ in snaps] == [0, 1, 2, 3]
    cfgs = json.loads(pathlib.Path(folder, "config.json").read_text())
    env = SafetyGymnasium2Gymnasium(safety_gymnasium.make(TASK))
    policy = navigation_demos.SnapshotPolicy(cfgs, snaps[-1][1], env.observation_space, env.action_space)
    params = torch.load(snaps[-1][1])
    norm = Normalizer(shape=(60,), clip=5)
    norm.load_state_dict(params["obs_normalizer"])
    for obs in recorded.episode(1)["obs"][:50:10]:
        x = norm.normalize(torch.as_tensor(obs, dtype=torch.float32))  # OmniSafe's (it also updates)
        expected = np.clip(policy._actor.predict(x, deterministic=True).detach().numpy(), -1, 1)
        np.testing.assert_allclose(policy(obs), expected, atol=1e-3)


def test_demonstrations_from_the_snapshots(tmp_path):
    out = tmp_path / "s4"
    train(out, 4, 2000)
    demos, cands = tmp_path / "demos.npz", tmp_path / "candidates.csv"
    done = run("tools/navigation/navigation_demos.py", "--run", str(out), "--per-snapshot", "2", "--safe", "1",
               "--unsafe", "1", "--out", str(demos), "--candidates", str(cands))
    found = rows(cands)
    assert [int(r["snapshot_epoch"]) for r in found] == [0, 0, 1, 1, 2, 2]
    assert [int(r["episode"]) for r in found] == list(range(6))
    labels = [r["label"] for r in found]
    for r in found:
        assert (int(r["recorded_steps"]) == 1000) == (r["label"] == "safe")
    if "safe" in labels and "unsafe" in labels:
        assert done.returncode == 0, done.stderr[-3000:]
        made = EpisodeSet.load(str(demos))
        assert made.group_sizes == (1, 1) and made.meta["episode_cost_limit"] == 25.0
        assert "navigation_demos" in made.meta["provenance"]
    else:  # a group with no candidate: DemoRecorder.select says so, and no file is written
        assert done.returncode != 0 and "candidates" in done.stderr and not demos.exists()
    assert not glob.glob(str(tmp_path / "*.tmp"))
