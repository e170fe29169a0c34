"""The same experiment on a (local) Ray cluster through Ray Tune: two tiny trials, one of them
killed with its Tune worker and restarted by Tune from its checkpoint, end exactly as the same
runs made by ``defender sweep``; no ``defender train`` process outlives its trial."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import threading
import time

import pytest

ray = pytest.importorskip("ray", reason="ray[tune] is in python/requirements-test.txt")

from defender_rl.tune import expand, run_experiment  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
SMOKE = ROOT / "experiments" / "smoke.toml"
RUNS = ["InvertedDoublePendulum-v5/sac-bare-s0", "InvertedDoublePendulum-v5/sac-MinDemoW5-MinDemoW10-s0"]


@pytest.fixture(scope="module")
def binary() -> pathlib.Path:
    exe = ROOT / "target" / "release" / "defender"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "-p", "defender-cli"], cwd=ROOT, check=True)
    return exe


def metrics(run: pathlib.Path) -> list[str]:
    return [line.rsplit(",", 1)[0] for line in (run / "metrics.csv").read_text().splitlines()]


def actor_tensors(run: pathlib.Path) -> bytes:
    data = (run / "actor.safetensors").read_bytes()
    n = int.from_bytes(data[:8], "little")
    return data[8 + n :]


def train_processes(marker: str) -> list[int]:
    out = subprocess.run(["pgrep", "-f", marker], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def test_expand_is_the_binarys_expansion(binary, tmp_path):
    runs = expand(SMOKE, tmp_path, binary)
    assert [r["name"] for r in runs] == RUNS
    assert all(r["state"] == "new" for r in runs)
    assert 'strategy = "MinDemoW5/MinDemoW10"' in runs[1]["config"]
    bad = tmp_path / "bad.toml"
    bad.write_text(SMOKE.read_text().replace("seeds = [0]", "seeds = []"))
    with pytest.raises(ValueError, match="grid.seeds is empty"):
        expand(bad, tmp_path, binary)


def test_tune_trials_killed_and_restarted_equal_the_local_sweep(binary, tmp_path):
    local = tmp_path / "local"
    subprocess.run([str(binary), "sweep", str(SMOKE), "--out", str(local), "--jobs", "2"], check=True, capture_output=True)

    cluster = tmp_path / "tune"
    killed: list[int] = []

    def kill_a_worker() -> None:
        # A node failure: once the DEFENDER run has a checkpoint, kill -9 the Tune worker that
        # runs it; the kernel then stops its `defender train` (SIGTERM), and Tune restarts the
        # trial from its last reported checkpoint.
        run_dir = cluster / RUNS[1]
        deadline = time.time() + 240
        while time.time() < deadline:
            if (run_dir / "checkpoint" / "manifest.json").exists():
                pids = train_processes(str(run_dir))
                if pids:
                    worker = int(open(f"/proc/{pids[0]}/stat").read().rsplit(")", 1)[1].split()[1])
                    time.sleep(0.7)  # let the trial report that checkpoint to Tune (polls every 0.5 s)
                    os.kill(worker, signal.SIGKILL)
                    killed.append(worker)
                    return
            time.sleep(0.05)

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        killer = threading.Thread(target=kill_a_worker, daemon=True)
        killer.start()
        results = run_experiment(SMOKE, cluster, binary=binary, max_failures=2, poll_seconds=0.5)
        killer.join(timeout=5)
    finally:
        ray.shutdown()
    assert killed, "the test never killed a worker"
    assert results is not None and not results.errors, results.errors
    deadline = time.time() + 30
    while train_processes(str(cluster)) and time.time() < deadline:
        time.sleep(0.2)
    assert not train_processes(str(cluster)), "a defender train process outlived its trial"
    for run in RUNS:
        assert metrics(local / run) == metrics(cluster / run), run
        assert (local / run / "eval.csv").read_text() == (cluster / run / "eval.csv").read_text(), run
        assert actor_tensors(local / run) == actor_tensors(cluster / run), run
    report = subprocess.run([str(binary), "report", str(cluster)], capture_output=True, text=True)
    assert report.returncode == 0, report.stderr
    assert "MinDemoW5" in report.stdout
