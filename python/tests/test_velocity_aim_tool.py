"""tools/analysis/velocity_aim.py: the velocity aim, decided per task from an arms.txt file, by the screen's
rule for the best Lagrangian; its three conditions checked on made-up arms either side of each
bound, and end to end on committed velocity runs (known figures)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

from conftest import ROOT

TOOL = ROOT / "tools" / "analysis" / "velocity_aim.py"
spec = importlib.util.spec_from_file_location("velocity_aim", TOOL)
aim = importlib.util.module_from_spec(spec)
sys.path.insert(0, str(TOOL.parent))
sys.modules["velocity_aim"] = aim  # dataclasses look their module up there
spec.loader.exec_module(aim)


def arm(name, ret, cost, rate):
    return aim.Arm(name, 3, ret, cost, rate)


def test_the_best_lagrangian_is_the_highest_return_within_the_limit_else_the_lowest_cost():
    within_low, within_high, over = arm("a", 900, 20, 0.2), arm("b", 1000, 25, 0.2), arm("c", 3000, 26, 0.2)
    assert aim.best_lagrangian([within_low, over, within_high], 25).name == "b"
    assert aim.best_lagrangian([arm("d", 3000, 40, 0.2), arm("e", 100, 30, 0.2)], 25).name == "e"


@pytest.mark.parametrize(
    "candidate, met",
    [
        (arm("x", 1001, 25.0, 0.05), True),  # each condition met, at its bound
        (arm("x", 1001, 25.1, 0.05), False),  # over the limit
        (arm("x", 1000, 10.0, 0.05), False),  # a return equal to the Lagrangian's is not higher
        (arm("x", 1001, 10.0, 0.0501), False),  # over half its training cost rate
    ],
)
def test_the_aim_needs_all_three_conditions(candidate, met):
    best = arm("lag", 1000, 20.0, 0.1)
    assert aim.verdict(candidate, best, 25.0)[0] is met


def dirs(arm_dir):
    return " ".join(f"results/velocity/SafetyHopperVelocity-v1/{arm_dir}-s{s}" for s in range(3))


def test_committed_runs_decide_the_aim(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    arms.write_text(f"SafetyHopperVelocity-v1 defender {dirs('sac-auto-default')}\n"
                    f"SafetyHopperVelocity-v1 lagrangian-v1 {dirs('sac-bare-lagrangian')}\n"
                    "SafetyHopperVelocity-v1 pid\n")
    done = subprocess.run([sys.executable, str(TOOL), str(arms), "--candidate", "defender", "--lagrangians",
                           "lagrangian-v1", "pid", "--defender", str(binary)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    # The default's 3 Hopper runs: 880 / 66.5, cost rate 0.109; the first Lagrangian
    # (lagrangian-v1): 971 / 48.2, 0.187.
    assert "best Lagrangian: lagrangian-v1" in out, out
    assert "evaluation cost 66.5 > the limit 25" in out, out
    assert "return 880 <= lagrangian-v1's 971" in out, out
    assert "training cost rate 0.109 > half lagrangian-v1's (0.187 / 2 = 0.093)" in out, out
    # Over the limit, the verdict does not wait for PID.
    assert "**aim not met**, on 3 seeds (whatever pid gives: over the limit)" in out, out


def test_a_verdict_waits_for_the_lagrangians_still_to_run_only_within_the_limit():
    assert aim.pending(arm("x", 1001, 25.0, 0.05), ["pid"], 25.0, 3) == " (provisional: pid not yet run)"
    assert aim.pending(arm("x", 1001, 25.1, 0.05), ["pid"], 25.0, 3) == " (whatever pid gives: over the limit)"
    assert aim.pending(arm("x", 1001, 30, 0.05), ["pid", "omnisafe-saclag"], 25.0, 3) == (
        " (whatever pid, omnisafe-saclag give: over the limit)")
    assert aim.pending(arm("x", 1001, 30, 0.05), [], 25.0, 3) == ""


def test_a_verdict_waits_for_the_candidates_own_seeds_even_over_the_limit():
    # Two seeds at 25.4 can still come under 25 with a third.
    two = aim.Arm("x", 2, 1001, 25.4, 0.05)
    assert aim.pending(two, ["pid"], 25.0, 3) == " (provisional: x has 2 of 3 seeds; pid not yet run)"
    assert aim.pending(two, [], 25.0, 3) == " (provisional: x has 2 of 3 seeds)"


def test_a_file_without_the_candidate_is_refused(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    arms.write_text(f"SafetyHopperVelocity-v1 defender {dirs('sac-auto-default')}\n")
    done = subprocess.run([sys.executable, str(TOOL), str(arms), "--defender", str(binary)],
                          capture_output=True, text=True)
    assert done.returncode != 0 and "no arm named 'defender-limit'" in done.stderr, done.stderr
