"""experiments/smoke.toml on a two-node Ray cluster made of the fresh venv's wheel alone: a head
node and a worker node (each ``ray start``, one CPU, a temp dir of its own), one trial on each.
The worker node's raylet is killed mid-run; Tune restarts its trial, which resumes from its
checkpoint, and ``defender report`` of the results equals that of a local ``defender sweep``.

No process outlives the test: this process is made the subreaper of everything it starts, so
the daemons of ``ray start`` stay its descendants, and they are ended by pid at the end. (Not
``ray stop``: it ends every Ray process of the user on the machine, other people's runs too.)
"""

from __future__ import annotations

import ctypes
import os
import pathlib
import shutil
import signal
import socket
import tempfile
import subprocess
import sys
import threading
import time

import pytest
import ray

from defender_rl.tune import find_binary, run_experiment

SOURCE = pathlib.Path(os.environ["DEFENDER_SOURCE_TREE"])
RUNS = ["InvertedDoublePendulum-v5/sac-bare-s0", "InvertedDoublePendulum-v5/sac-MinDemoW5-MinDemoW10-s0"]
_PR_SET_CHILD_SUBREAPER = 36


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def descendants(root: int) -> list[int]:
    children: dict[int, list[int]] = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                stat = open(f"/proc/{entry.name}/stat").read()
            except OSError:
                continue
            children.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry.name))
    out, todo = [], [root]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def end_descendants() -> None:
    """SIGTERM then SIGKILL every process below this one, by pid, and reap them."""
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        pids = descendants(os.getpid())
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.time() + wait
        while time.time() < deadline:
            try:
                while os.waitpid(-1, os.WNOHANG)[0] > 0:
                    pass
            except ChildProcessError:
                pass
            if not descendants(os.getpid()):
                return
            time.sleep(0.1)


def processes() -> dict[int, str]:
    out = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                out[int(entry.name)] = open(f"/proc/{entry.name}/cmdline", "rb").read().decode(errors="replace")
            except OSError:
                continue
    return out


def parent(pid: int) -> int:
    return int(open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[1])


def has_ancestor(pid: int, ancestor: int) -> bool:
    try:
        while pid > 1:
            pid = parent(pid)
            if pid == ancestor:
                return True
    except OSError:
        pass
    return False


def metrics(run: pathlib.Path) -> list[str]:
    """metrics.csv without its wall-time column (the sixth; later columns, like cost, follow it)."""
    lines = (run / "metrics.csv").read_text().splitlines()
    return [",".join(f for i, f in enumerate(line.split(",")) if i != 5) for line in lines]


def tune_has_checkpoint(sweep: pathlib.Path, defender: bool) -> bool:
    """Whether Tune holds a checkpoint of the DEFENDER run (or of the bare one): its copy of
    the run's config.toml."""
    for config in (sweep / ".sweep" / "tune").glob("*/*/checkpoint_*/config.toml"):
        try:
            if ("MinDemoW5/MinDemoW10" in config.read_text()) == defender:
                return True
        except OSError:
            continue
    return False


def report_without_time(binary: pathlib.Path, runs: pathlib.Path) -> list[list[str]]:
    """``defender report --format csv`` without its wall-time columns (``time_pct_*``,
    ``wall_seconds_*``: they differ between any two executions)."""
    done = subprocess.run([str(binary), "report", str(runs), "--format", "csv"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = [line.split(",") for line in done.stdout.strip().splitlines()]
    keep = [i for i, name in enumerate(rows[0]) if not name.startswith(("time_", "wall_"))]
    return [[row[i] for i in keep] for row in rows]


@pytest.fixture
def cluster(tmp_path):
    """A head node and a worker node on this machine, one CPU each; yields (address, the worker
    node's raylet pid)."""
    libc = ctypes.CDLL(None, use_errno=True)
    assert libc.prctl(_PR_SET_CHILD_SUBREAPER, 1) == 0
    port = free_port()
    address = f"127.0.0.1:{port}"
    # Short: Ray's sockets live under it, and a socket's path is at most 107 bytes.
    temp = pathlib.Path(tempfile.mkdtemp(prefix="dray", dir="/tmp"))
    # Quick to declare a node dead (defaults: 5 missed health checks of 3 s).
    # Ray >= 2.5x turns token authentication on for `ray start --head`, with the token in
    # ~/.ray; a cluster on 127.0.0.1 that lives for one test needs none (nor a shared HOME's file).
    os.environ["RAY_AUTH_MODE"] = "disabled"
    env = dict(os.environ, RAY_health_check_period_ms="500", RAY_health_check_failure_threshold="4")
    common = ["--node-ip-address", "127.0.0.1", "--num-cpus", "1", "--object-store-memory", "100000000",
              "--disable-usage-stats", f"--dashboard-agent-listen-port={free_port()}"]  # fmt: skip
    try:
        head = subprocess.run(
            ["ray", "start", "--head", f"--port={port}", "--include-dashboard=false",
             f"--temp-dir={temp / 'h'}", *common],
            env=env, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert head.returncode == 0, head.stderr
        common[-1] = f"--dashboard-agent-listen-port={free_port()}"
        worker = subprocess.run(
            ["ray", "start", f"--address={address}", f"--temp-dir={temp / 'w'}", *common],
            env=env, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert worker.returncode == 0, worker.stderr
        worker_temp = str(temp / "w")
        raylets = [pid for pid, cmd in processes().items() if "raylet" in cmd.split("\0")[0] and worker_temp in cmd]
        assert len(raylets) == 1, raylets
        yield address, raylets[0]
    finally:
        ray.shutdown()
        end_descendants()
        os.environ.pop("RAY_AUTH_MODE", None)
        shutil.rmtree(temp, ignore_errors=True)
        libc.prctl(_PR_SET_CHILD_SUBREAPER, 0)


def test_a_worker_node_lost_mid_run_is_restarted_from_its_checkpoint(cluster, tmp_path):
    address, worker_raylet = cluster
    # The user's inputs, outside the source tree: the experiment file and the demonstrations.
    smoke = tmp_path / "smoke.toml"
    shutil.copy(SOURCE / "experiments" / "smoke.toml", smoke)
    (tmp_path / "data" / "demos").mkdir(parents=True)
    shutil.copy(SOURCE / "data" / "demos" / "InvertedDoublePendulum-v5.npz", tmp_path / "data" / "demos")
    data = {"DEFENDER_DATA": str(tmp_path / "data")}  # where `defender train` finds them
    binary = find_binary()
    assert binary == (pathlib.Path(sys.prefix) / "bin" / "defender").resolve(), binary  # the wheel's command

    local = tmp_path / "local"
    subprocess.run([str(binary), "sweep", str(smoke), "--out", str(local), "--jobs", "2"],
                   env=dict(os.environ, **data), check=True, capture_output=True)  # fmt: skip

    out = tmp_path / "cluster"
    seen: dict[int, str] = {}  # every `defender train` of the cluster run: pid -> command line
    killed: list[int] = []
    done = threading.Event()

    def watch_and_kill() -> None:
        # The trial on the worker node, made deterministic as in tests/test_tune.py: once its
        # run has a checkpoint, freeze it (SIGSTOP) so it cannot finish first, wait until Tune
        # holds that checkpoint, then kill -9 the worker node's raylet: the node is lost, with
        # its Tune worker; the kernel ends the orphaned run (PR_SET_PDEATHSIG, SIGCONT below).
        deadline = time.time() + 300
        target = None
        while not done.is_set() and time.time() < deadline:
            for pid, cmd in processes().items():
                if "\0train\0" in cmd and str(out) in cmd and pid not in seen:
                    seen[pid] = cmd
            if target is None and not killed:
                target = next((p for p, c in seen.items() if has_ancestor(p, worker_raylet)), None)
            if target is not None and not killed:
                run_dir = pathlib.Path(seen[target].split("\0--out\0")[1].split("\0")[0])
                if (run_dir / "checkpoint" / "manifest.json").exists():
                    try:
                        os.kill(target, signal.SIGSTOP)
                    except ProcessLookupError:
                        return  # ended before its first checkpoint: nothing to test
                    while time.time() < deadline and not tune_has_checkpoint(out, "MinDemo" in run_dir.name):
                        time.sleep(0.05)
                    time.sleep(0.7)  # and the driver has recorded it (the trial polls every 0.5 s)
                    os.kill(worker_raylet, signal.SIGKILL)
                    killed.append(target)
                    try:
                        os.kill(target, signal.SIGCONT)
                    except ProcessLookupError:
                        pass
            time.sleep(0.01)

    ray.init(address=address, log_to_driver=False, runtime_env={"env_vars": data})
    watcher = threading.Thread(target=watch_and_kill, daemon=True)
    watcher.start()
    try:
        results = run_experiment(smoke, out, max_failures=2, poll_seconds=0.5)
    finally:
        done.set()
        watcher.join(timeout=10)
    assert killed, "the test never killed the worker node"
    assert results is not None and not results.errors, results.errors
    lost = seen[killed[0]].split("\0--out\0")[1].split("\0")[0]
    restarts = [c for p, c in seen.items() if p != killed[0] and lost in c]
    assert restarts and all("\0--resume" in c for c in restarts), (lost, list(seen.values()))
    for run in RUNS:
        assert metrics(local / run) == metrics(out / run), run
        assert (local / run / "eval.csv").read_text() == (out / run / "eval.csv").read_text(), run
    assert report_without_time(binary, out) == report_without_time(binary, local)
