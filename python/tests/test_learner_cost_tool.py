"""tools/analysis/learner_cost.py: the episode cost a run's constraint learner was charged beside the task's
and the deployed policy's; the charge rule on a made-up run (a filtered episode under and over
L + 1), known figures of committed runs, and its refusals."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

from conftest import ROOT

TOOL = ROOT / "tools" / "analysis" / "learner_cost.py"
spec = importlib.util.spec_from_file_location("learner_cost", TOOL)
tool = importlib.util.module_from_spec(spec)
sys.modules["learner_cost"] = tool  # dataclasses look their module up there
spec.loader.exec_module(tool)

VELOCITY = ROOT / "results" / "velocity" / "SafetyHopperVelocity-v1"


def made_up(tmp_path, defender: str, episodes: list[tuple[str, float]]):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.toml").write_text(f'env = "SafetyHopperVelocity-v1"\n[defender]\n{defender}\n')
    rows = "".join(f"{i},{100 * (i + 1)},1.0,100,{o},0.1,{c}\n" for i, (o, c) in enumerate(episodes))
    (run / "metrics.csv").write_text("episode,total_steps,return,length,outcome,wall_seconds,cost\n" + rows)
    (run / "eval.csv").write_text("total_steps,mean_return,std_return,mean_length,episodes,mean_cost\n"
                                  "1000,5.0,0.0,100,5,30.0\n2000,5.0,0.0,100,5,40.0\n")
    return run


def test_a_filtered_episode_costs_the_learner_the_limit_plus_one_or_its_own_cost_if_higher(tmp_path):
    run = made_up(tmp_path, 'episode_cost_limit = 25.0\nfiltered_cost = "violation"',
                  [("filtered", 3.0), ("filtered", 30.0), ("truncated", 10.0), ("crashed", 1.0)])
    s = tool.seen(run, 50)
    assert s.task_cost == pytest.approx((3 + 30 + 10 + 1) / 4)
    assert s.learner_cost == pytest.approx((26 + 30 + 10 + 1) / 4)
    assert s.outcomes == {"crashed": 0.25, "filtered": 0.5, "truncated": 0.25}
    assert s.eval_cost == pytest.approx(35.0)
    # Only the last N episodes count.
    assert tool.seen(run, 2).learner_cost == pytest.approx((10 + 1) / 2)


def test_without_the_charge_the_learner_is_charged_the_tasks_cost(tmp_path):
    run = made_up(tmp_path, 'episode_cost_limit = 25.0', [("filtered", 3.0), ("truncated", 10.0)])
    assert tool.seen(run, 50).learner_cost == pytest.approx(6.5)


def test_committed_runs_give_their_known_figures():
    # defender-limit's seed 0: 30 of its last 50 episodes filtered, each charged up to 26.
    s = tool.seen(VELOCITY / "sac-auto-defender-limit-s0", 50)
    assert (round(s.task_cost, 1), round(s.learner_cost, 1), s.outcomes["filtered"]) == (18.9, 25.9, 0.6)
    assert round(s.eval_cost, 1) == 37.2
    lag = tool.seen(VELOCITY / "sac-bare-lag-s0", 50)
    assert lag.learner_cost == lag.task_cost and round(lag.task_cost, 1) == 23.0


def test_refusals_name_the_file_and_what_is_wrong(tmp_path):
    run = made_up(tmp_path, 'filtered_cost = "violation"', [("filtered", 3.0)])
    with pytest.raises(SystemExit, match="no episode_cost_limit"):
        tool.seen(run, 50)
    (run / "config.toml").write_text('[defender]\nepisode_cost_limit = 25.0\n')
    (run / "metrics.csv").write_text("episode,total_steps,return,length,outcome,wall_seconds\n0,1,1.0,1,crashed,0.1\n")
    with pytest.raises(SystemExit, match="no per-episode costs"):
        tool.seen(run, 50)
    done = subprocess.run([sys.executable, str(TOOL), str(tmp_path / "absent")], capture_output=True, text=True)
    assert done.returncode != 0 and "absent/config.toml: cannot read" in done.stderr, done.stderr
    assert done.stdout == ""
