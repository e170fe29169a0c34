"""tools/analysis/velocity_aim.py: the velocity aim, decided per task from an arms.txt file, by the screen's
rule for the best Lagrangian; its three conditions checked on made-up arms either side of each
bound, the aim by the share of episodes within the limit likewise, and end to end on committed velocity
runs (known figures)."""

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


def shared(within, ret=1001, cost=30.0, rate=0.05):
    return aim.Arm("x", 5, ret, cost, rate, (cost - 5, cost + 5), within, (within - 0.1, within + 0.1))


@pytest.mark.parametrize(
    "candidate, met",
    [
        (shared(0.6), True),  # the mean over the limit, but more episodes within than the Lagrangian's
        (shared(0.59), False),  # fewer episodes within than the Lagrangian's
        (shared(0.6, ret=1000), False),  # the return condition stands
        (shared(0.6, rate=0.0501), False),  # the cost-rate condition stands
    ],
)
def test_the_aim_by_the_share_reads_the_limit_per_episode(candidate, met):
    best = aim.Arm("lag", 5, 1000, 20.0, 0.1, (15, 25), 0.6, (0.5, 0.7))
    assert aim.share_verdict(candidate, best)[0] is met


def test_the_aim_by_the_share_needs_half_the_episodes_within_even_against_a_worse_lagrangian():
    best = aim.Arm("lag", 5, 1000, 50.0, 0.1, (45, 55), 0.3, (0.2, 0.4))
    assert aim.share_verdict(shared(0.49), best)[0] is False
    assert aim.share_verdict(shared(0.5), best)[0] is True


def test_an_interval_that_holds_the_limit_is_said():
    assert aim.straddles(shared(0.6, cost=22.0), 25.0)  # [17, 27]
    assert not aim.straddles(shared(0.6, cost=19.0), 25.0)  # [14, 24]


def test_runs_with_every_evaluation_episode_give_the_share_and_its_verdict(binary, tmp_path):
    screen = "results/velocity-power-screen/SafetyHopperVelocity-v1"
    arms = tmp_path / "arms.txt"
    arms.write_text(f"SafetyHopperVelocity-v1 dl-cont-d20 {screen}/sac-auto-dl-cont-d20-s0 {screen}/sac-auto-dl-cont-d20-s1\n"
                    f"SafetyHopperVelocity-v1 lag {screen}/sac-bare-lag-s0 {screen}/sac-bare-lag-s1\n")
    done = subprocess.run([sys.executable, str(TOOL), str(arms), "--candidate", "dl-cont-d20", "--lagrangians", "lag",
                           "--defender", str(binary)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    # The power screen's runs at 100k, read as the finals are (last 10 evaluations of 20 episodes).
    assert "evaluation cost 44.9 [32.0, 57.9], episodes within the limit 44% [31%, 57%]" in out, out
    assert "**aim not met**, on 2 seeds" in out, out
    assert ("by the share of episodes within the limit: **not met** (episodes within the limit 44% < lag's 46%, "
            "< one half)") in out, out
