"""scripts/crash_by_window.py, the helper docs/results.md uses to read a run's crash rate as it
trains: the right counts per window, and a clear error for a folder that is not a run."""

from __future__ import annotations

import pathlib
import subprocess
import sys

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "crash_by_window.py"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True)


def test_counts_episodes_and_evaluations_per_window(tmp_path):
    d = tmp_path / "sweep" / "Hopper-v5" / "sac-bare-s0"
    d.mkdir(parents=True)
    (d / "metrics.csv").write_text(
        "episode,total_steps,return,length,outcome,wall_seconds\n"
        "0,40,1.0,40,crashed,0.1\n"
        "1,100,1.0,60,filtered,0.2\n"  # ends on the window's last step: still the first window
        "2,150,1.0,50,truncated,0.3\n"
        "3,190,1.0,40,crashed,0.4\n"
    )
    (d / "eval.csv").write_text(
        "total_steps,mean_return,std_return,mean_length,episodes\n"
        "100,12.4,0,10,5\n"
        "150,20.0,0,10,5\n"
        "200,30.6,0,10,5\n"
    )
    out = run(str(d), "--window", "100")
    assert out.returncode == 0, out.stderr
    rows = out.stdout.splitlines()[2:]
    assert rows == [
        "| sweep/Hopper-v5/sac-bare-s0 | 0-100 | 2 | 50.0 | 50.0 | 12 | 12 |",
        "| sweep/Hopper-v5/sac-bare-s0 | 100-200 | 2 | 50.0 | 0.0 | 25 | 31 |",
    ]


def test_a_folder_that_is_not_a_run_is_refused(tmp_path):
    out = run(str(tmp_path))
    assert out.returncode == 1
    assert f"{tmp_path}: no metrics.csv" in out.stderr
    assert run(str(tmp_path), "--window", "0").returncode == 2
