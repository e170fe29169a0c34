"""strategy="auto": the wrapper chooses the strategy `defender select` / `defender
train --strategy auto` choose (the Rust `defender::selection`), on the shipped demonstrations,
and exposes the choice and its scores; `defender_rl.select` ranks as `defender select`.

The comparison runs the `defender` binary itself. Full sets take about 26 s per task and side on
two idle cores, so the default run uses the first 10 demonstrations of each group (`num_demos`,
`--num-demos`); DEFENDER_FULL_SELECTION=1 compares the full shipped sets too."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess

import gymnasium as gym
import pytest

import defender_rl
from defender_rl import DefenderError, DefenderWrapper

from conftest import ROOT, DriftEnv, drift_demos

TASKS = ["InvertedDoublePendulum-v5", "Hopper-v5", "Walker2d-v5"]
FULL = os.environ.get("DEFENDER_FULL_SELECTION") == "1"
SIZES = [10, pytest.param(None, marks=pytest.mark.skipif(not FULL, reason="DEFENDER_FULL_SELECTION=1"))]
SCORES = ["false_alarm_rate", "crash_prevention_rate", "safe_allowed", "unsafe_allowed", "mean_lead", "score"]


def rust_select(demos, num_demos, tmp_path, *extra):
    """`defender select --no-equal` (with `--scaling auto`, what `--strategy auto` runs): its
    selection.csv rows."""
    cargo = shutil.which("cargo")
    assert cargo, "cargo is needed to build the defender binary the test compares with"
    subprocess.run([cargo, "build", "--release", "--quiet", "-p", "defender-cli"], cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    out = tmp_path / "selection.csv"
    cmd = [os.path.join(target, "release", "defender"), "select", "--demos", str(demos), "--no-equal", "--out", str(out)]
    if num_demos is not None:
        cmd += ["--num-demos", str(num_demos)]
    cmd += list(extra)
    subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True)
    with open(out, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("num_demos", SIZES)
@pytest.mark.parametrize("task", TASKS)
def test_auto_picks_the_strategy_of_the_rust_selection(task, num_demos, tmp_path):
    demos = ROOT / "data" / "demos" / f"{task}.npz"
    rows = rust_select(demos, num_demos, tmp_path, "--scaling", "auto")
    best = rows[0]
    assert best["eligible"] == "true", f"{task}: no eligible strategy in defender select's ranking"

    # No scaling given: auto compares plain and z-scored DTW.
    env = DefenderWrapper(gym.make(task), demos, "auto", num_demos=num_demos, seed=0)
    chosen = env.strategy_selection
    assert env.strategy == best["strategy"] == chosen["strategy"]
    assert chosen["scaling"] == best["scaling"] and chosen["scalings"] == ["none", "zscore"]
    for key in SCORES:  # selection.csv writes Rust's shortest round-trip form: exact
        assert chosen[key] == float(best[key]), key
    assert chosen["candidates"] == len(rows) // 2 == 441  # all strategies without Equal, per scaling
    assert chosen["equal"] is False and chosen["chosen_by"] == "auto"
    assert chosen["min_lead"] == 1 and chosen["max_false_alarm"] == 0.1
    assert chosen["seconds"] > 0
    if num_demos is not None:
        assert (chosen["safe_demos"], chosen["unsafe_demos"]) == (num_demos, num_demos)

    # The wrapper then runs with it, as with the strategy given by name.
    env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert "defender_filtered" in info
    env.close()

    # defender_rl.select ranks as `defender select` does, row for row.
    ranked = defender_rl.select(demos, num_demos=num_demos, equal=False, scaling="auto")
    assert [(r["strategy"], r["scaling"]) for r in ranked] == [(r["strategy"], r["scaling"]) for r in rows]
    assert [r["eligible"] for r in ranked] == [r["eligible"] == "true" for r in rows]
    assert all(r["score"] == float(c["score"]) for r, c in zip(ranked, rows))


def test_zscore_scaling_is_the_command_lines(tmp_path):
    """scaling="zscore" (select and the wrapper's auto) is `defender select --scaling zscore`, and
    it is another cost than plain DTW: another ranking."""
    demos = ROOT / "data" / "demos" / "Hopper-v5.npz"
    rows = rust_select(demos, 10, tmp_path, "--scaling", "zscore")
    ranked = defender_rl.select(demos, num_demos=10, equal=False, scaling="zscore")
    assert [(r["strategy"], r["score"]) for r in ranked] == [(c["strategy"], float(c["score"])) for c in rows]
    plain = defender_rl.select(demos, num_demos=10, equal=False)
    assert [r["score"] for r in plain] != [r["score"] for r in ranked]
    assert {r["scaling"] for r in ranked} == {"zscore"} and {r["scaling"] for r in plain} == {"none"}
    env = DefenderWrapper(gym.make("Hopper-v5"), demos, "auto", num_demos=10, seed=0, scaling="zscore")
    assert env.strategy == rows[0]["strategy"]
    # A given scaling is used as given: nothing else compared.
    assert env.strategy_selection["scaling"] == "zscore" and env.strategy_selection["scalings"] == []
    env.close()


def test_select_options_and_numpy_output():
    demos = drift_demos(4)
    rows = defender_rl.select(demos, strategies=["MinBoth/MinBoth", "MeanDemoW5/MeanDemoW10"])
    assert [r["rank"] for r in rows] == [1, 2]
    assert {r["strategy"] for r in rows} == {"MinBoth/MinBoth", "MeanDemoW5/MeanDemoW10"}
    assert all(r["ablation_score"] is None for r in rows)
    arrays = defender_rl.select(demos, strategies=["MinBoth/MinBoth", "MaxBoth/MaxBoth"], as_numpy=True)
    assert list(arrays["rank"]) == [1, 2] and arrays["eligible"].dtype == bool
    # With recorded episodes the ablation score multiplies the demonstrations' score.
    with_episodes = defender_rl.select(demos, drift_demos(3, seed=1), strategies=["MinBoth/MinBoth"])
    r = with_episodes[0]
    assert r["ablation_score"] is not None and r["score"] == pytest.approx(r["demo_score"] * r["ablation_score"])
    assert len(defender_rl.select(demos, equal=False)) == 441


def test_a_given_strategy_has_no_selection():
    env = DefenderWrapper(DriftEnv(), drift_demos(), "MinBoth/MinBoth", seed=0)
    assert env.strategy == "MinBoth/MinBoth" and env.strategy_selection is None


def test_auto_and_select_refuse_what_leave_one_out_cannot_use():
    one_each = drift_demos(1)
    with pytest.raises(DefenderError, match="at least 2 per group"):
        DefenderWrapper(DriftEnv(), one_each, "auto", seed=0)
    with pytest.raises(DefenderError, match="at least 2 per group"):
        defender_rl.select(one_each)
    with pytest.raises(DefenderError, match="strategy: .*auto, or"):
        DefenderWrapper(DriftEnv(), drift_demos(), "Auto", seed=0)
    with pytest.raises(DefenderError, match="strategies"):
        defender_rl.select(drift_demos(), strategies=["MinBoth/Nope"])
    with pytest.raises(DefenderError, match="strategies: an empty list"):
        defender_rl.select(drift_demos(), strategies=[])
    with pytest.raises(DefenderError, match="max_false_alarm"):
        defender_rl.select(drift_demos(), max_false_alarm=1.5)
    with pytest.raises(DefenderError, match="min_lead"):
        defender_rl.select(drift_demos(), min_lead=0)
