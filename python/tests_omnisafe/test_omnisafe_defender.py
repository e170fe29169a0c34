"""OmniSafe 0.5.0's agents on a DEFENDER-wrapped Safety-Gymnasium task (tools/peers/omnisafe_defender_env.py,
tools/peers/omnisafe_defender.py), in the peer venv of tools/peers/omnisafe-venv.sh with the wheel installed:
`make test-omnisafe` (scripts/test-omnisafe.sh), outside `make test` (the venv is about 6 GB).

Here: the CMDP passes the wrapper's step through OmniSafe's interface (tensors, a filtered step
terminal with R_task and cost 0, the final observation from OmniSafe's AutoReset), OmniSafe's
evaluation environment is the bare task, and OmniSafe's SACLag and PPOLag train on
`Defender-SafetyHopperVelocity-v1` through `omnisafe.Agent` (a few thousand steps each) with the
costs reaching OmniSafe's logger and episodes filtered.
"""

from __future__ import annotations

import csv
import glob
import json
import os
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest
import torch

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "peers"))

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
    import omnisafe_defender_env as defender_env  # noqa: E402
    from omnisafe.envs.core import make
    from omnisafe.envs.wrapper import AutoReset

from defender_rl import EpisodeSet  # noqa: E402

TASK = "SafetyHopperVelocity-v1"
ENV_ID = "Defender-" + TASK
DEMOS = ROOT / "data" / "demos" / f"{TASK}.npz"
# A fixed strategy (what `strategy="auto"` chose on this set in results/velocity): no selection
# at the start, which would take minutes here.
STRATEGY = "MinBothW5/MinBothW10"


@pytest.fixture(autouse=True)
def quiet(monkeypatch):
    monkeypatch.setenv("DEFENDER_PROGRESS_INTERVAL", "off")


def test_the_ids_are_registered_with_omnisafe():
    from omnisafe.envs.core import support_envs

    ids = set(support_envs())
    assert {ENV_ID, "Defender-SafetyWalker2dVelocity-v1", "Defender-SafetyPointGoal1-v0"} <= ids
    assert defender_env.task_of(ENV_ID) == TASK
    # The navigation tasks ship no demonstrations: configure says how to give them.
    with pytest.raises(FileNotFoundError, match="demos=PATH"):
        defender_env.configure("SafetyPointGoal1-v0")
    # OmniSafe's per-task section of SACLag.yaml, for the same agent under our id.
    assert defender_env.task_cfgs("SACLag", "SafetyPointGoal1-v0")["algo_cfgs"]["alpha"] > 0
    assert defender_env.task_cfgs("SACLag", TASK) == {}


def test_omnisafes_env_cfgs_configure_the_wrapper():
    # OmniSafe passes custom_cfgs["env_cfgs"] to the constructor: the wrapper's keys configure it
    # (here over configure's), the others would go to safety_gymnasium.make.
    defender_env.configure(TASK, str(DEMOS), strategy=STRATEGY)
    cmdp = make(ENV_ID, num_envs=1, strategy="MeanDemoW5/MeanDemoW10", seed=7)
    cmdp.reset()
    assert cmdp.defender.strategy == "MeanDemoW5/MeanDemoW10" and cmdp.max_episode_steps == 1000
    assert cmdp.summary()["demos"] == str(DEMOS) and cmdp.summary()["episode_cost_limit"] == 25.0
    cmdp.close()
    assert cmdp.summary()["defender_stats"]["steps"] == 0  # still answers once OmniSafe closed it
    with pytest.raises(ValueError, match="one environment"):
        make(ENV_ID, num_envs=2)


def test_a_filtered_step_reaches_omnisafe_as_the_wrappers_step():
    # The actions of the set's unsafe demonstrations, replayed through OmniSafe's AutoReset
    # around our CMDP: fast running, which the filter stops.
    defender_env.configure(TASK, str(DEMOS), strategy=STRATEGY)
    cmdp = make(ENV_ID, num_envs=1)
    env = AutoReset(cmdp, device=torch.device("cpu"))
    env.set_seed(3)
    obs, info = env.reset()
    assert obs.dtype == torch.float32 and obs.shape == (11,) and cmdp.defender is not None
    wrapper = cmdp.defender
    assert wrapper.strategy == STRATEGY and wrapper.dynamics_info is not None
    demos = EpisodeSet.load(str(DEMOS))
    unsafe = [demos.episode(i)["act"] for i in range(len(demos)) if demos.episode(i)["crashed"]]
    filtered = executed_cost = 0
    for actions in unsafe[:10]:
        for action in actions:
            obs, reward, cost, terminated, truncated, info = env.step(torch.as_tensor(action))
            assert all(t.dtype == torch.float32 for t in (obs, reward, cost, terminated, truncated))
            done = bool(terminated) or bool(truncated)
            step_info = info["final_info"] if done else info
            assert float(cost) == step_info["cost"]
            if step_info["defender_filtered"]:
                filtered += 1
                # SPEC section 5: R_task, terminated, cost 0; the prediction as the last observation.
                assert float(reward) == pytest.approx(wrapper.r_task) and float(cost) == 0.0
                assert bool(terminated) and step_info["defender_outcome"] == "filtered"
                assert info["final_observation"].shape == (11,) and obs.shape == (11,)
            else:
                executed_cost += float(cost)
            if done:
                break
        else:
            env.reset()
    stats = wrapper.defender_stats
    assert filtered > 0 and stats["filtered_episodes"] == filtered, stats
    assert executed_cost > 0, "no executed step of the replayed running cost anything"
    env.close()


def test_omnisafes_evaluation_environment_is_the_bare_task():
    from omnisafe.adapter.offpolicy_adapter import OffPolicyAdapter
    from omnisafe.envs.core import Wrapper
    from omnisafe.utils.config import get_default_kwargs_yaml

    defender_env.configure(TASK, str(DEMOS), strategy=STRATEGY)
    cfgs = get_default_kwargs_yaml("SACLag", ENV_ID, "off-policy")
    adapter = OffPolicyAdapter(ENV_ID, 1, 0, cfgs)

    def inner(env):
        while isinstance(env, Wrapper):
            env = env._env
        return env

    train, evaluation = inner(adapter._env), inner(adapter._eval_env)
    assert not train.is_evaluation and train.defender is not None
    assert evaluation.is_evaluation and evaluation.defender is None
    obs, info = adapter._eval_env.reset()
    for _ in range(20):
        obs, reward, cost, terminated, truncated, info = adapter._eval_env.step(torch.zeros(1, 3))
        assert "defender_filtered" not in info and "cost" in info.get("final_info", info)
    assert evaluation.defender is None


def train(tmp_path: pathlib.Path, algo: str, *extra: str) -> pathlib.Path:
    out = tmp_path / algo
    cmd = [
        sys.executable, str(ROOT / "tools" / "peers" / "omnisafe_defender.py"), "--algo", algo, "--env", TASK,
        "--seed", "0", "--out", str(out), "--strategy", STRATEGY, *extra,
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env={**os.environ, "DEFENDER_PROGRESS_INTERVAL": "off"})
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


def rows(path: pathlib.Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def check_run(out: pathlib.Path, algo: str, steps: int) -> tuple[list[dict], list[dict], dict]:
    run = json.loads((out / "run.json").read_text())
    assert run["complete"] and run["env_steps"] == steps and run["omnisafe_env"] == ENV_ID
    assert run["versions"]["defender-rl"] != "not installed"
    episodes, ours = rows(out / "episodes.csv"), rows(out / "defender_episodes.csv")
    summary = json.loads((out / "defender.json").read_text())
    stats = summary["defender_stats"]
    assert summary["strategy"] == STRATEGY and stats["steps"] == steps
    # The same episodes from both sides: OmniSafe's sums are the wrapper's step's.
    assert len(episodes) == len(ours) > 0
    for theirs, mine in zip(episodes, ours):
        assert int(theirs["length"]) == int(mine["length"])
        assert float(theirs["cost"]) == pytest.approx(float(mine["cost"]))
        assert int(theirs["total_steps"]) == int(mine["total_steps"])
    outcomes = [r["outcome"] for r in ours]
    assert set(outcomes) <= {"crashed", "filtered", "truncated"}
    # Episodes were filtered, and the wrapper's counters say the same as its per-episode rows.
    assert stats["filtered_episodes"] == outcomes.count("filtered") > 0, stats
    # PPOLag's rollout resets at each epoch's start, cutting the running episode: the wrapper
    # drops it, as OmniSafe's logger does.
    assert stats["episodes"] == len(ours), stats
    # Costs reached OmniSafe's logger (progress.csv's Metrics/EpCost, a mean over its episodes).
    (progress,) = glob.glob(str(out / f"{algo}-{{{ENV_ID}}}" / "seed-000-*" / "progress.csv"))
    logged = rows(pathlib.Path(progress))
    assert len(logged) == steps // 1000
    assert max(float(r["Metrics/EpCost"]) for r in logged) > 0
    # The agent learned: its losses moved from one epoch to the next.
    assert len({r["Loss/Loss_pi"] for r in logged}) == len(logged)
    # DEFENDER's outcomes reached it too (the CMDP's spec_log): shares of each epoch's episodes.
    shares = [float(r["Defender/Filtered"]) for r in logged]
    assert max(shares) > 0 and all(0 <= x <= 1 for x in shares if x == x), shares
    assert sum(float(r["cost"]) for r in episodes) > 0
    return episodes, ours, summary


def test_saclag_trains_on_the_wrapped_task(tmp_path):
    steps = 3000
    out = train(tmp_path, "SACLag", "--steps", str(steps), "--steps-per-epoch", "1000", "--start-learning-steps", "500")
    check_run(out, "SACLag", steps)
    # One deterministic evaluation episode an epoch, on the bare task.
    assert len(rows(out / "evals.csv")) == steps // 1000


def test_ppolag_trains_on_the_wrapped_task_and_a_seed_repeats(tmp_path):
    steps = 3000
    args = ("--steps", str(steps), "--steps-per-epoch", "1000", "--update-iters", "5")
    out = train(tmp_path, "PPOLag", *args)
    episodes, ours, _ = check_run(out, "PPOLag", steps)
    assert rows(out / "evals.csv") == []  # OmniSafe's on-policy agents do not evaluate
    assert np.isfinite(json.loads((out / "defender.json").read_text())["r_task"])
    # The same seed again: the same episodes, outcomes and costs (OmniSafe's seed seeds the
    # task's first reset, torch, and DEFENDER's dynamics model).
    again = train(tmp_path / "again", "PPOLag", *args)
    assert rows(again / "defender_episodes.csv") == ours
    assert [r["return"] for r in rows(again / "episodes.csv")] == [r["return"] for r in episodes]
