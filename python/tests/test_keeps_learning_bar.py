"""scripts/keeps_learning_bar.py, which recomputes the keeps-learning bar from committed run
directories: each half of the bar decides the verdict, an incomplete run withholds it, and
``--chosen`` reads another configuration's file."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "keeps_learning_bar.py"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True)


def make_run(folder: pathlib.Path, name: str, crashes: int, evals: list[tuple[float, float]], complete=True):
    """A run of 10 training episodes, ``crashes`` of them crashed, and the given evaluations
    (mean return, mean length)."""
    d = folder / "Hopper-v5" / name
    d.mkdir(parents=True)
    lines = ["episode,total_steps,return,length,outcome,wall_seconds"]
    lines += [f"{i},{10 * (i + 1)},1.0,10,{'crashed' if i < crashes else 'truncated'},0.1" for i in range(10)]
    (d / "metrics.csv").write_text("\n".join(lines) + "\n")
    rows = ["total_steps,mean_return,std_return,mean_length,episodes"]
    rows += [f"{100 * (i + 1)},{ret},0,{length},5" for i, (ret, length) in enumerate(evals)]
    (d / "eval.csv").write_text("\n".join(rows) + "\n")
    (d / "summary.json").write_text(json.dumps({"complete": complete}))


def folder_with(tmp_path, crashes: int, last: float, standing=False, complete=True) -> pathlib.Path:
    f = tmp_path / "kl"
    make_run(f, "sac-bare-s0", 9, [(100.0, 50.0)] * 12)
    evals = [(last, 50.0)] * 12
    if standing:
        evals[0] = (1000.0, 1000.0)  # the healthy reward alone, for the whole horizon
    make_run(f, "sac-x-s0", crashes, evals, complete)
    (f / "chosen.txt").write_text("Hopper-v5/sac-x-s0\n")
    return f


def test_passes_when_both_halves_hold(tmp_path):
    out = run(str(folder_with(tmp_path, crashes=3, last=90.0)))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "| Hopper-v5 | 1 vs 1 bare | 30.0 | 90.0 | 90 | 100 | 0 of 12 | passes |" in out.stdout


def test_each_half_fails_on_its_own(tmp_path):
    crash = run(str(folder_with(tmp_path / "a", crashes=4, last=100.0)))
    reward = run(str(folder_with(tmp_path / "b", crashes=0, last=89.0)))
    standing = run(str(folder_with(tmp_path / "c", crashes=0, last=100.0, standing=True)))
    assert crash.returncode == 1 and "crashes above a third of bare's" in crash.stdout
    assert reward.returncode == 1 and "last-10 eval below 90% of bare's" in reward.stdout
    assert standing.returncode == 1 and "1 standing evaluation(s)" in standing.stdout


def test_an_incomplete_run_withholds_the_verdict(tmp_path):
    out = run(str(folder_with(tmp_path, crashes=0, last=100.0, complete=False)))
    assert out.returncode == 2
    assert "withheld: not complete: Hopper-v5/sac-x-s0" in out.stdout


def test_chosen_names_another_configuration(tmp_path):
    f = folder_with(tmp_path, crashes=0, last=100.0)
    make_run(f, "sac-y-s0", 9, [(100.0, 50.0)] * 12)
    (f / "chosen-y.txt").write_text("Hopper-v5/sac-y-s0\n")
    assert run(str(f)).returncode == 0
    out = run(str(f), "--chosen", "chosen-y.txt")
    assert out.returncode == 1 and "crashes above a third of bare's" in out.stdout
