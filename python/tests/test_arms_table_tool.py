"""tools/analysis/arms_table.py: one row per arm of an arms.txt file, from `defender report` on the arm's
committed runs (results/keeps-learning and results/baselines: real runs, known figures)."""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT

TOOL = ROOT / "tools" / "analysis" / "arms_table.py"
BARE = " ".join(f"results/keeps-learning/InvertedDoublePendulum-v5/sac-bare-s{s}" for s in range(3))


def run_tool(binary, arms_file):
    return subprocess.run([sys.executable, str(TOOL), str(arms_file), "--defender", str(binary)],
                          capture_output=True, text=True)


def test_each_arm_is_the_reports_row_of_its_runs(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    arms.write_text(f"# a comment\nInvertedDoublePendulum-v5 bare {BARE}\nInvertedDoublePendulum-v5 later\n")
    done = run_tool(binary, arms)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("| task | arm | seeds | crashes | after warm-up |"), lines[0]
    # IDP's bare SAC, 3 seeds of 30k steps: 1107 ± 9.8 crashes, 310 ± 13.9 after the 5,000-step
    # warm-up (as `defender report` gives them), last-10 evaluation 6480 ± 259.0; no filter.
    assert lines[2] == ("| InvertedDoublePendulum-v5 | bare | 3 | 1107 ± 9.8 | 310 ± 13.9 | 36.89 ± 0.3 "
                        "| 6480 ± 259.0 | - |"), lines[2]
    assert lines[3].startswith("| InvertedDoublePendulum-v5 | later | (to run) |"), lines[3]
    assert "cost rate" not in lines[0], "a crash task has no cost columns"


def test_an_arm_whose_runs_differ_in_configuration_is_refused_naming_it(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    mixed = ("results/keeps-learning/InvertedDoublePendulum-v5/sac-bare-s0 "
             "results/baselines/InvertedDoublePendulum-v5/sac-bare-penalty1-s1")
    arms.write_text(f"InvertedDoublePendulum-v5 mixed {mixed}\n")
    done = run_tool(binary, arms)
    assert done.returncode != 0
    assert "InvertedDoublePendulum-v5 mixed" in done.stderr and "2 rows" in done.stderr, done.stderr


def test_shares_divide_each_arms_crashes_by_the_base_arms_on_the_same_task(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    penalty = " ".join(f"results/baselines/InvertedDoublePendulum-v5/sac-bare-penalty1-s{s}" for s in range(3))
    arms.write_text(f"InvertedDoublePendulum-v5 bare {BARE}\nInvertedDoublePendulum-v5 penalty-v1 {penalty}\n"
                    "InvertedDoublePendulum-v5 later\nHopper-v5 bare "
                    + " ".join(f"results/keeps-learning/Hopper-v5/sac-bare-s{s}" for s in range(3)) + "\n")
    done = subprocess.run([sys.executable, str(TOOL), str(arms), "--defender", str(binary), "--shares", "bare"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "| arm | InvertedDoublePendulum-v5 | Hopper-v5 |", lines[0]
    assert lines[2] == "| bare | 1.00 (1.00) | 1.00 (1.00) |", lines[2]
    # The first penalty on IDP: 1102.0 / 1106.7 crashes over the run, 305.7 / 310.3 after the warm-up.
    assert lines[3] == "| penalty-v1 | 1.00 (0.98) |  |", lines[3]
    assert lines[4] == "| later | (to run) |  |", lines[4]
    refused = subprocess.run([sys.executable, str(TOOL), str(arms), "--defender", str(binary), "--shares",
                              "penalty-v1"], capture_output=True, text=True)
    assert refused.returncode != 0 and "Hopper-v5 has no runs of 'penalty-v1'" in refused.stderr, refused.stderr


def test_arm_keeps_only_the_named_arms_and_plots_draws_only_theirs(binary, tmp_path):
    arms = tmp_path / "arms.txt"
    penalty = " ".join(f"results/baselines/InvertedDoublePendulum-v5/sac-bare-penalty1-s{s}" for s in range(3))
    arms.write_text(f"InvertedDoublePendulum-v5 bare {BARE}\nInvertedDoublePendulum-v5 penalty-v1 {penalty}\n")
    plots = tmp_path / "plots"
    done = subprocess.run([sys.executable, str(TOOL), str(arms), "--defender", str(binary), "--arm", "penalty-v1",
                           "--plots", str(plots)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 3 and lines[2].startswith("| InvertedDoublePendulum-v5 | penalty-v1 | 3 |"), lines
    figure = (plots / "InvertedDoublePendulum-v5_sac_crashes.svg").read_text()
    assert "penalty" in figure and "SAC (bare)" not in figure, "the figure holds the named arm's runs only"
    assert (plots / "InvertedDoublePendulum-v5_sac_crashes.png").stat().st_size > 0
    missing = subprocess.run([sys.executable, str(TOOL), str(arms), "--defender", str(binary), "--arm", "nobody"],
                             capture_output=True, text=True)
    assert missing.returncode != 0 and "no arm named nobody" in missing.stderr, missing.stderr
