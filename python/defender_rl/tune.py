"""Run a defender experiment file on a Ray cluster, through Ray Tune.

The same experiment file that ``defender sweep`` runs on one machine (``experiments/*.toml``)
runs here as one Tune trial per run, each with ``{"cpu": 1}``. A trial is an ordinary
``defender train`` process writing an ordinary run directory, so ``defender report`` reads the
results of both schedulers alike::

    import ray
    from defender_rl.tune import run_experiment

    ray.init()                       # or ray.init(address="auto") on a cluster
    run_experiment("experiments/table1.toml", "results/table1", binary="target/release/defender")
    # then: defender report results/table1

- Metrics are reported to Tune as the run goes (steps, episodes, crash and filter rates, the
  last evaluation), read from the run's ``metrics.csv`` and ``eval.csv``.
- Each new checkpoint of the run (``checkpoint/``, written every 2 minutes and at every stop)
  becomes Tune's checkpoint, with the run's ``config.toml``: a failed or preempted trial is
  restarted by Tune (``max_failures``) from it, on any node, and resumes exactly.
- No orphans: the ``defender train`` process is told by the kernel to stop (SIGTERM, then it
  checkpoints) when the Tune worker that started it dies, however it dies.

The expansion of the grid is the binary's own (``defender sweep --list --json``): one home for
what an experiment file means. The run directories must be on storage every node reaches (or
Tune's checkpoints carry the runs between nodes).
"""

from __future__ import annotations

import ctypes
import glob
import json
import os
import shutil
import signal
import subprocess
import sysconfig
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

__all__ = ["expand", "find_binary", "run_experiment"]

_PR_SET_PDEATHSIG = 1


def find_binary(binary: str | os.PathLike[str] | None = None) -> Path:
    """The ``defender`` binary: ``binary`` if given, else ``$DEFENDER_BIN``, else the
    ``defender`` command the defender-rl wheel installed beside this Python (so that every node
    of a cluster with the wheel has it, on the PATH or not), else ``defender`` on the PATH.
    Raises ``FileNotFoundError`` naming what was tried."""
    tried = []
    # The wheel's command, if this install carries the binary (a build from source does not).
    wheel = (Path(__file__).parent / "bin" / "defender").exists() and shutil.which("defender", path=sysconfig.get_path("scripts"))
    for candidate in (binary, os.environ.get("DEFENDER_BIN"), wheel, shutil.which("defender")):
        if candidate:
            path = Path(candidate).resolve()
            if path.is_file() and os.access(path, os.X_OK):
                return path
            tried.append(str(path))
    raise FileNotFoundError(
        "cannot find the defender binary (tried: "
        + (", ".join(tried) or "nothing")
        + "); install the defender-rl wheel (it carries the command), or build it with "
        "`cargo build --release -p defender-cli` and pass binary=... or set DEFENDER_BIN"
    )


def expand(experiment: str | os.PathLike[str], out: str | os.PathLike[str], binary=None) -> list[dict[str, Any]]:
    """The runs of an experiment file, as ``defender sweep --list --json`` expands them: a list
    of ``{"name", "dir", "state", "config"}`` (``config``: the run's TOML). Raises
    ``ValueError`` with the binary's message for a bad experiment file; the binary's warnings
    (a setting that leaves part of a run inert, such as ``learning_starts`` beyond the budget)
    become Python ``UserWarning``\ s."""
    exe = find_binary(binary)
    done = subprocess.run(
        [str(exe), "sweep", str(experiment), "--out", str(out), "--list", "--json"],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise ValueError(done.stderr.strip() or f"defender sweep --list failed ({done.returncode})")
    for line in done.stderr.splitlines():
        if line.startswith("warning: "):
            warnings.warn(line.removeprefix("warning: "), UserWarning, stacklevel=2)
    return [json.loads(line) for line in done.stdout.splitlines() if line.strip()]


def _die_with_parent() -> None:
    # Runs in the child between fork and exec: SIGTERM it when the Tune worker dies.
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def _progress(run_dir: Path) -> dict[str, Any]:
    metrics: dict[str, Any] = {"total_steps": 0, "episodes": 0, "crash_pct": 0.0, "filtered_pct": 0.0}
    try:
        lines = (run_dir / "metrics.csv").read_text().splitlines()
    except OSError:
        lines = []
    # Whole rows only (a row being appended may be cut): as many fields as the header, which
    # grows at its end when a column is added (cost).
    width = lines[0].count(",") if lines else 0
    rows = [r.split(",") for r in lines[1:] if r.count(",") == width]
    if rows:
        n = len(rows)
        metrics.update(
            total_steps=int(rows[-1][1]),
            episodes=n,
            episode_return=float(rows[-1][2]),
            crash_pct=100.0 * sum(r[4] == "crashed" for r in rows) / n,
            filtered_pct=100.0 * sum(r[4] == "filtered" for r in rows) / n,
        )
    try:
        evals = (run_dir / "eval.csv").read_text().splitlines()[1:]
        if evals:
            metrics["eval_mean_return"] = float(evals[-1].split(",")[1])
    except (OSError, ValueError, IndexError):
        pass
    return metrics


def _stage_checkpoint(run_dir: Path, staging: Path, prefix: str, last: float | None) -> tuple[float, str] | None:
    """A copy of the run's current checkpoint and config.toml for Tune, in a new directory under
    ``staging``, or None if there is no checkpoint, it is the one staged last (``last``), or it was
    being replaced while copied (the next poll tries again). The caller removes the copy once Tune
    has its own."""
    # Written last into a checkpoint: its time identifies one complete checkpoint.
    manifest = run_dir / "checkpoint" / "manifest.json"
    try:
        before = manifest.stat().st_mtime_ns
    except OSError:
        return None
    if before == last:
        return None
    stage = tempfile.mkdtemp(prefix=prefix, dir=staging)
    try:
        shutil.copytree(run_dir / "checkpoint", Path(stage) / "checkpoint")
        shutil.copy2(run_dir / "config.toml", Path(stage) / "config.toml")
        if manifest.stat().st_mtime_ns != before:
            raise OSError("replaced while copied")
    except OSError:
        shutil.rmtree(stage, ignore_errors=True)
        return None
    return before, stage


def _trial(config: dict[str, Any]) -> None:
    """One Tune trial: one ``defender train`` run, resumed from Tune's checkpoint if any."""
    from ray import tune

    run = config["run"]
    run_dir = Path(run["dir"])
    sweep = Path(config["sweep_dir"]) / ".sweep"
    flat = run["name"].replace("/", "__")
    for sub in ("configs", "logs", "staging"):
        (sweep / sub).mkdir(parents=True, exist_ok=True)
    # Copies of checkpoints on their way to Tune. A trial's worker killed mid-report leaves its
    # copy behind; the restarted trial removes it (one trial per run, so none is in use).
    staging, prefix = sweep / "staging", f"{flat}-"
    for stale in staging.glob(f"{glob.escape(prefix)}*"):
        shutil.rmtree(stale, ignore_errors=True)
    config_path = sweep / "configs" / f"{flat}.toml"
    config_path.write_text(run["config"])
    run_dir.parent.mkdir(parents=True, exist_ok=True)

    restored = tune.get_checkpoint()
    if restored is not None and not (run_dir / "checkpoint").exists():
        # Restarted on a node without the run's files: they come from Tune's copy.
        with restored.as_directory() as d:
            run_dir.mkdir(parents=True, exist_ok=True)
            shutil.copytree(Path(d) / "checkpoint", run_dir / "checkpoint")
            shutil.copy2(Path(d) / "config.toml", run_dir / "config.toml")

    # The driver's binary, or this node's own (the wheel installed elsewhere on this node).
    binary = config["binary"] if Path(config["binary"]).is_file() else str(find_binary())
    args = [binary, "train", "--config", str(config_path), "--out", str(run_dir)]
    if (run_dir / "config.toml").exists():
        args.append("--resume")
    env = dict(os.environ, DEFENDER_NN_THREADS="1")
    with open(sweep / "logs" / f"{flat}.log", "a") as log:
        proc = subprocess.Popen(args, stdout=log, stderr=log, stdin=subprocess.DEVNULL, env=env, preexec_fn=_die_with_parent)
    last_checkpoint = None
    last_metrics = None
    # The staged copy not yet handed to Tune. tune.report persists a checkpoint by copying it
    # before it returns and leaves the directory it was given: that one is ours to remove.
    stage = None
    try:
        while True:
            code = proc.poll()
            metrics = _progress(run_dir)
            staged = _stage_checkpoint(run_dir, staging, prefix, last_checkpoint)
            checkpoint = None
            if staged is not None:
                last_checkpoint, stage = staged
                checkpoint = tune.Checkpoint.from_directory(stage)
            if code is not None:
                break
            if checkpoint is not None or metrics != last_metrics:
                tune.report(metrics, checkpoint=checkpoint)
                last_metrics = metrics
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)
                stage = None
            time.sleep(config.get("poll_seconds", 2.0))
        if code != 0:
            tail = (sweep / "logs" / f"{flat}.log").read_text().strip().splitlines()[-5:]
            raise RuntimeError(f"defender train for {run['name']} exited with {code}:\n" + "\n".join(tail))
        summary = json.loads((run_dir / "summary.json").read_text())
        final = {**_progress(run_dir), **{k: summary[k] for k in ("acc_reward", "crash_pct", "filtered_pct", "wall_seconds")}}
        # The budget's last steps belong to an episode the budget cut, which metrics.csv (one row
        # per finished episode) does not hold: summary.json counts every step.
        final["total_steps"] = summary["steps"]
        tune.report({**final, "complete": True}, checkpoint=checkpoint)
    finally:
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)
        if proc.poll() is None:
            # Tune stopped the trial: the run checkpoints at its next episode end and exits.
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=120)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def run_experiment(
    experiment: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    binary: str | os.PathLike[str] | None = None,
    max_failures: int = 3,
    poll_seconds: float = 2.0,
    name: str | None = None,
):
    """Runs every run of ``experiment`` that is not complete as a Ray Tune trial (``{"cpu": 1}``
    each) into the sweep directory ``out`` and returns Tune's ``ResultGrid``. Call
    ``ray.init(...)`` first to choose the cluster (a local one otherwise). Runs already complete
    are skipped; a trial that fails is restarted from its last checkpoint up to ``max_failures``
    times. Called again when every run is complete, it returns the ``ResultGrid`` of the Tune
    experiment that ran them (restored from ``out/.sweep/tune/NAME``), or ``None`` when Tune never
    ran them (a sweep made by ``defender sweep``)."""
    from ray import tune

    exe = find_binary(binary)
    out = Path(out).resolve()
    runs = [r for r in expand(experiment, out, exe) if r["state"] != "complete"]
    trainable = tune.with_resources(_trial, {"cpu": 1})
    name = name or Path(experiment).stem
    if not runs:
        previous = out / ".sweep" / "tune" / name
        if tune.Tuner.can_restore(str(previous)):
            return tune.Tuner.restore(str(previous), trainable=trainable).get_results()
        return None
    tuner = tune.Tuner(
        trainable,
        param_space={
            "run": tune.grid_search(runs),
            "binary": str(exe),
            "sweep_dir": str(out),
            "poll_seconds": poll_seconds,
        },
        run_config=tune.RunConfig(
            name=name,
            storage_path=str(out / ".sweep" / "tune"),
            failure_config=tune.FailureConfig(max_failures=max_failures),
            checkpoint_config=tune.CheckpointConfig(num_to_keep=1),
            verbose=1,
        ),
    )
    return tuner.fit()
