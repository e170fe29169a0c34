"""tools/analysis/screen_rule.py applies the written screen rules (docs/decisions-baselines.md and
docs/decisions-velocity.md) to run directories: here hand-made ones whose measures are
known, so that a wrong count, window or choice shows."""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT

TOOL = ROOT / "tools" / "analysis" / "screen_rule.py"


def make_run(path, steps, episodes, evals):
    """A run directory: `episodes` as (total_steps, length, outcome, cost), `evals` as
    (total_steps, mean_return, mean_cost[, shield_mean_cost])."""
    path.mkdir(parents=True)
    (path / "config.toml").write_text(f'env = "{path.parent.name}"\ntotal_steps = {steps}\n')
    lines = ["episode,total_steps,return,length,outcome,wall_seconds,cost"]
    lines += [f"{i},{t},1.0,{n},{o},0.1,{c}" for i, (t, n, o, c) in enumerate(episodes)]
    (path / "metrics.csv").write_text("\n".join(lines) + "\n")
    header = "total_steps,mean_return,std_return,mean_length,episodes,mean_cost"
    shielded = any(len(e) == 4 for e in evals)
    if shielded:
        header += ",shield_mean_return,shield_mean_cost,shield_filtered"
    rows = [header]
    for e in evals:
        row = f"{e[0]},{e[1]},0,10,5,{e[2]}"
        if shielded:
            row += f",1.0,{e[3]},0.2" if len(e) == 4 else ",,,"
        rows.append(row)
    (path / "eval.csv").write_text("\n".join(rows) + "\n")


def run_tool(*args):
    out = subprocess.run([sys.executable, str(TOOL), *args], check=True, capture_output=True, text=True)
    return out.stdout


def test_the_baselines_rule_counts_crashes_after_the_warm_up_and_reads_the_last_40_percent(tmp_path):
    steps = 100_000
    evals = lambda late: [(10_000, 9999.0, 0), (50_000, 9999.0, 0), (60_000, late, 0), (100_000, late, 0)]
    bare = tmp_path / "bare" / "Hopper-v5"
    # Bare SAC: 1000 late; crashes at 4,000 (warm-up: not counted) and 8,000.
    for seed in (0, 1):
        make_run(bare / f"sac-bare-s{seed}", steps, [(4000, 10, "crashed", 1), (8000, 10, "crashed", 1)], evals(1000.0))
    screen = tmp_path / "screen" / "Hopper-v5"
    # lag-a: 3 crashes after the warm-up, return 900 (above the bar of 800).
    # lag-b: 1 crash, return 700 (below the bar): not chosen though it crashes less.
    # pid-x: 5 crashes, return 500; pid-y: 2 crashes, 600: neither reaches the bar, pid-y's return is higher.
    settings = {
        "lag-a": (3, 900.0),
        "lag-b": (1, 700.0),
        "pid-x": (5, 500.0),
        "pid-y": (2, 600.0),
    }
    for name, (crashes, ret) in settings.items():
        # The PID settings in a second sweep directory, as Recovery RL's screen is: one table.
        root = screen if name.startswith("lag") else tmp_path / "screen2" / "Hopper-v5"
        for seed in (0, 1):
            eps = [(1000, 5, "crashed", 1)] + [(6000 + 1000 * k, 5, "crashed", 1) for k in range(crashes)]
            make_run(root / f"sac-bare-{name}-s{seed}", steps, eps, evals(ret))
    out = run_tool("baselines", str(tmp_path / "screen"), str(tmp_path / "screen2"), "--bare", str(tmp_path / "bare"))
    assert out.count("### Hopper-v5") == 1, out
    assert "bare SAC 1000 (bar 800), 1 crashes after the warm-up" in out, out
    assert "| sac-bare-lag-a | 2 | 3.0 | 900 | yes |" in out, out
    assert "- lag: **sac-bare-lag-a** (the fewest crashes above the bar" in out, out
    assert "- pid: **sac-bare-pid-y** (none reaches the bar: the highest return" in out, out


def test_the_interventions_columns_count_after_the_warm_up_and_pool_the_seeds_checks(tmp_path):
    steps = 100_000
    evals = [(60_000, 1000.0, 0), (100_000, 1000.0, 0)]
    for seed in (0, 1):
        make_run(tmp_path / "bare" / "Hopper-v5" / f"sac-bare-s{seed}", steps, [(8000, 10, "crashed", 1)], evals)
    header = ("total_steps,episode,intervention,episode_steps,episode_cost,checked,would_fail,"
              "steps_to_failure,continuation_steps,continuation_return,continuation_cost")
    # (total_steps, checked, would_fail, steps_to_failure): the first in the warm-up, not counted.
    rows = {
        0: [(3000, 1, 1, 9), (7000, 1, 1, 2), (8000, 1, 0, None), (9000, 0, None, None)],
        1: [(7000, 1, 1, 4), (9000, 1, 1, 6)],
    }
    for seed, interventions in rows.items():
        run = tmp_path / "screen" / "Hopper-v5" / f"sac-MeanDemoW5-MeanDemoW10-margin04-s{seed}"
        make_run(run, steps, [(6000, 5, "filtered", 0)], evals)
        lines = [header] + [
            f"{t},{i},{i},5,0,{c},{'' if f is None else f},{'' if n is None else n},5,1.0,0"
            for i, (t, c, f, n) in enumerate(interventions)
        ]
        (run / "interventions.csv").write_text("\n".join(lines) + "\n")
    out = run_tool("baselines", str(tmp_path / "screen"), "--bare", str(tmp_path / "bare"))
    # After the warm-up: 3 and 2 interventions (mean 2.5); checked 2 + 2, of which 3 would have
    # failed (precision 0.75), after 2, 4 and 6 steps (median 4).
    assert "| sac-MeanDemoW5-MeanDemoW10-margin04 | 2 | 0.0 | 1000 | yes | 2.5 | 0.75 | 4 |" in out, out
    assert "- margin: **sac-MeanDemoW5-MeanDemoW10-margin04**" in out, out


def test_the_velocity_rule_weighs_the_limit_and_half_the_best_lagrangians_cost_rate(tmp_path):
    steps = 100_000
    root = tmp_path / "vel" / "SafetyHopperVelocity-v1"

    def run(name, eval_cost, eval_return, cost, filtered=0):
        # Ten episodes of 100 steps, the last `filtered` of them ended by the filter.
        eps = [(100 * (k + 1), 100, "filtered" if k >= 10 - filtered else "truncated", cost / 10) for k in range(10)]
        late = [(t, eval_return, eval_cost, 1.0) for t in (60_000, 80_000, 100_000)]
        for seed in (0, 1):
            make_run(root / f"{name}-s{seed}", steps, eps, [(10_000, 0.0, 999.0, 1.0)] + late)

    run("sac-bare-lag", 20.0, 1000.0, 100.0)  # within the limit, return 1000, rate 0.1
    run("sac-bare-pid", 30.0, 2000.0, 50.0)  # over the limit: not the best Lagrangian
    run("sac-auto-def-a", 24.0, 1500.0, 40.0, filtered=2)  # rate 40 / 998 = 0.040: qualifies
    run("sac-auto-def-b", 10.0, 1200.0, 30.0)  # qualifies, lower return
    run("sac-auto-def-c", 5.0, 3000.0, 80.0)  # rate 0.08 > 0.05: out
    out = run_tool("velocity", str(tmp_path / "vel"))
    assert "| sac-auto-def-a | 2 | 24.0 | 1500 | 0.040 | 1.0 | - |" in out, out
    assert "best Lagrangian: sac-bare-lag (training cost rate 0.100, bound 0.050)" in out, out
    assert "- chosen: **sac-auto-def-a** (qualifies with the highest return)" in out, out


def test_the_velocity_rule_with_one_reference_gives_the_share_of_late_episodes_within_the_limit(tmp_path):
    steps = 100_000
    root = tmp_path / "vel" / "SafetyHopperVelocity-v1"
    late = [(60_000, 1000.0, 20.0), (100_000, 1000.0, 20.0)]

    def run(name, seed, episode_costs, cost):
        path = root / f"{name}-s{seed}"
        make_run(path, steps, [(100 * (k + 1), 100, "truncated", cost / 10) for k in range(10)],
                 [(10_000, 0.0, 999.0)] + late)
        # Each evaluation's episodes: the early one (10,000 steps) all over the limit and left
        # out of the share; the late ones as given (25 itself is within).
        lines = ["total_steps,episode,return,cost,shield_return,shield_cost,shield_stopped"]
        lines += [f"10000,{k},0,999,,," for k in range(2)]
        lines += [f"{t},{k},1000,{c},,," for t, _, _ in late for k, c in enumerate(episode_costs)]
        (path / "eval_episodes.csv").write_text("\n".join(lines) + "\n")

    for seed, costs in ((0, [10, 25]), (1, [26, 40])):
        run("sac-bare-lag", seed, costs, 100.0)  # the only reference: within 25 on 100% and 0%
    out = run_tool("velocity", str(tmp_path / "vel"))
    assert "(the rule waits for every setting" in out, out  # no variant yet: no choice
    for seed, costs in ((0, [5, 30]), (1, [5, 5])):
        run("sac-auto-dl", seed, costs, 40.0)
    (root / "sac-auto-dl2-s0").mkdir()
    (root / "sac-auto-dl2-s0" / "config.toml").write_text(f"total_steps = {steps}\n")
    (root / "sac-auto-dl2-s0" / "eval.csv").write_text("total_steps,mean_return,mean_cost\n")
    out = run_tool("velocity", str(tmp_path / "vel"))
    assert "| sac-bare-lag | 2 | 20.0 | 1000 | 0.100 | - | 50% |" in out, out
    assert "| sac-auto-dl | 2 | 20.0 | 1000 | 0.040 | - | 75% |" in out, out
    assert "(the rule waits for every setting" in out, out  # sac-auto-dl2 under way
    __import__("shutil").rmtree(root / "sac-auto-dl2-s0")
    out = run_tool("velocity", str(tmp_path / "vel"))
    assert "best Lagrangian: sac-bare-lag (training cost rate 0.100, bound 0.050)" in out, out
    assert "- chosen: **sac-auto-dl** (qualifies with the highest return)" in out, out


def test_a_reference_arm_is_read_to_the_screens_budget_beside_the_rule(tmp_path):
    steps = 100_000
    evals = [(60_000, 1000.0, 0), (100_000, 1000.0, 0), (200_000, 5000.0, 0)]
    bare = tmp_path / "bare" / "Hopper-v5"
    for seed in (0, 1):
        make_run(bare / f"sac-bare-s{seed}", steps, [(8000, 10, "crashed", 1)], evals)
    # The reference ran to 200k: what happened after 100k (a crash, a filtered episode, the
    # evaluation of 5000) must not count; nor the warm-up's crash and filtered episode.
    for seed, (crashes, filtered) in enumerate([(2, 3), (4, 1)]):
        eps = [(1000, 5, "crashed", 1), (2000, 5, "filtered", 0)]
        eps += [(6000 + 100 * k, 5, "crashed", 1) for k in range(crashes)]
        eps += [(9000 + 100 * k, 5, "filtered", 0) for k in range(filtered)]
        eps += [(150_000, 5, "crashed", 1), (160_000, 5, "filtered", 0)]
        make_run(bare / f"sac-auto-ref-s{seed}", 200_000, eps, [(60_000, 1100.0, 0), (100_000, 1300.0, 0), (200_000, 5000.0, 0)])
    for seed in (0, 1):
        make_run(tmp_path / "screen" / "Hopper-v5" / f"sac-bare-lag-a-s{seed}", steps, [], evals)
    out = run_tool("baselines", str(tmp_path / "screen"), "--bare", str(tmp_path / "bare"), "--reference", "sac-auto-ref")
    expected = ("- reference sac-auto-ref, read to 100000 steps: 3.0 crashes after the warm-up (2, 4), "
                "return 1200, 2.0 filtered episodes after the warm-up (3, 1)")
    assert expected in out, out
    # The reference is no setting of the screen: the rule's choice is made without it.
    assert "- lag: **sac-bare-lag-a**" in out, out
    assert "| sac-auto-ref" not in out, out


def test_a_reference_without_runs_on_the_screens_seeds_is_a_clear_error(tmp_path):
    evals = [(60_000, 1000.0, 0), (100_000, 1000.0, 0)]
    make_run(tmp_path / "bare" / "Hopper-v5" / "sac-bare-s0", 100_000, [], evals)
    make_run(tmp_path / "screen" / "Hopper-v5" / "sac-bare-lag-a-s0", 100_000, [], evals)
    tool = [sys.executable, str(TOOL), "baselines", str(tmp_path / "screen"), "--bare", str(tmp_path / "bare")]
    out = subprocess.run([*tool, "--reference", "sac-auto-none"], capture_output=True, text=True)
    assert out.returncode != 0
    assert "--reference sac-auto-none" in out.stderr and "sac-auto-none-s0" in out.stderr, out.stderr
