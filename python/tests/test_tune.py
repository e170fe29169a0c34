"""The same experiment on a (local) Ray cluster through Ray Tune: two tiny trials, one of them
killed with its Tune worker and restarted by Tune from its checkpoint, end exactly as the same
runs made by ``defender sweep``; no ``defender train`` process outlives its trial, and no copy of a
checkpoint staged for Tune outlives its report."""

from __future__ import annotations

import json
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


def metrics(run: pathlib.Path) -> list[str]:
    lines = (run / "metrics.csv").read_text().splitlines()
    # Without wall_seconds, the sixth column (later columns, like cost, follow it).
    return [",".join(f for i, f in enumerate(line.split(",")) if i != 5) for line in lines]


def actor_tensors(run: pathlib.Path) -> bytes:
    data = (run / "actor.safetensors").read_bytes()
    n = int.from_bytes(data[:8], "little")
    return data[8 + n :]


def train_processes(marker: str) -> list[int]:
    """The pids of the `defender train` processes whose command line holds ``marker``, read from
    /proc directly: quick enough to find a run that lives a fraction of a second."""
    pids = []
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                cmdline = open(f"/proc/{entry.name}/cmdline", "rb").read().decode(errors="replace")
            except OSError:
                continue
            if "\0train\0" in cmdline and marker in cmdline:
                pids.append(int(entry.name))
    return pids


def tune_has_checkpoint(sweep: pathlib.Path, strategy: str) -> bool:
    """Whether Tune holds a checkpoint of the run with this strategy (its copy of config.toml)."""
    for config in (sweep / ".sweep" / "tune").glob("*/*/checkpoint_*/config.toml"):
        try:
            if strategy in config.read_text():
                return True
        except OSError:
            continue
    return False


def test_expand_is_the_binarys_expansion(binary, tmp_path):
    runs = expand(SMOKE, tmp_path, binary)
    assert [r["name"] for r in runs] == RUNS
    assert all(r["state"] == "new" for r in runs)
    assert 'strategy = "MinDemoW5/MinDemoW10"' in runs[1]["config"]
    bad = tmp_path / "bad.toml"
    bad.write_text(SMOKE.read_text().replace("seeds = [0]", "seeds = []"))
    with pytest.raises(ValueError, match="grid.seeds is empty"):
        expand(bad, tmp_path, binary)
    inert = tmp_path / "inert.toml"
    inert.write_text(SMOKE.read_text().replace("steps = 1500", "steps = 800"))
    with pytest.warns(UserWarning, match=r"\[sac\] learning_starts = 1000 is at or beyond the budget of 800 steps"):
        expand(inert, tmp_path, binary)


def test_tune_trials_killed_and_restarted_equal_the_local_sweep(binary, tmp_path):
    local = tmp_path / "local"
    subprocess.run([str(binary), "sweep", str(SMOKE), "--out", str(local), "--jobs", "2"], check=True, capture_output=True)

    cluster = tmp_path / "tune"
    killed: list[int] = []

    def kill_a_worker() -> None:
        # A node failure, made deterministic however fast the machine: once the DEFENDER run has
        # a checkpoint, freeze it (SIGSTOP) so it cannot finish first, wait until its trial has
        # handed that checkpoint to Tune, then kill -9 the Tune worker that runs it. The kernel
        # then signals the orphaned `defender train`: SIGTERM (PR_SET_PDEATHSIG) and, as its
        # process group is orphaned with a stopped member, SIGHUP and SIGCONT. Two stop signals
        # end it at once, as a process lost with its node, and Tune restarts the trial, which
        # resumes from the last checkpoint.
        run_dir = cluster / RUNS[1]
        manifest = run_dir / "checkpoint" / "manifest.json"
        deadline = time.time() + 240
        pid = None
        while pid is None and time.time() < deadline:
            pid = next(iter(train_processes(str(run_dir))), None)
        while pid is not None and time.time() < deadline:
            if manifest.exists():
                try:
                    os.kill(pid, signal.SIGSTOP)
                except ProcessLookupError:
                    return  # the run ended before its first checkpoint: no kill to test
                break
            time.sleep(0.001)
        else:
            return
        worker = int(open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[1])
        while time.time() < deadline and not tune_has_checkpoint(cluster, "MinDemoW5/MinDemoW10"):
            time.sleep(0.05)
        time.sleep(0.7)  # and the driver has recorded it (the trial polls every 0.5 s)
        os.kill(worker, signal.SIGKILL)
        killed.append(worker)
        try:
            os.kill(pid, signal.SIGCONT)  # in case its process group is not orphaned
        except ProcessLookupError:
            pass

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        killer = threading.Thread(target=kill_a_worker, daemon=True)
        killer.start()
        results = run_experiment(SMOKE, cluster, binary=binary, max_failures=2, poll_seconds=0.5)
        killer.join(timeout=5)
        # Called again, every run complete: the same results, not None.
        again = run_experiment(SMOKE, cluster, binary=binary)
        assert again is not None and len(again) == len(results) and not again.errors
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
    for result in results:
        run_dir = pathlib.Path(result.config["run"]["dir"])
        summary = json.loads((run_dir / "summary.json").read_text())
        assert result.metrics["total_steps"] == summary["steps"] == 1500, result.metrics
    # The run killed with its worker is one TensorBoard curve with no step twice.
    from tensorboard.backend.event_processing.event_file_loader import EventFileLoader

    (events,) = (cluster / RUNS[1]).glob("events.out.tfevents.*")
    steps = [e.step for e in EventFileLoader(str(events)).Load() if e.HasField("summary")
             and e.summary.value[0].tag == "episode/return"]
    assert steps == sorted(set(steps)) and len(steps) == len(metrics(cluster / RUNS[1])) - 1
    # Every checkpoint copied for Tune was removed once Tune had its own, the killed trial's too.
    assert not list((cluster / ".sweep" / "staging").iterdir()), "a staged checkpoint was left behind"
    report = subprocess.run([str(binary), "report", str(cluster)], capture_output=True, text=True)
    assert report.returncode == 0, report.stderr
    assert "MinDemoW5" in report.stdout
