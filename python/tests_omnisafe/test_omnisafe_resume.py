"""tools/peers/omnisafe_saclag.py's checkpoints (tools/peers/omnisafe_checkpoint.py) in the peer venv:
`make test-omnisafe`, outside `make test`.

Here: a run killed (SIGKILL, at moments the test does not choose within an epoch) before its first
checkpoint, between two later ones, and after OmniSafe's Lagrange multiplier has started to move,
then rerun with the same command each time, ends with the same episodes.csv and evals.csv rows (all
but wall_seconds), the same progress.csv (all but Time/*) and the same TensorBoard scalars as the
run left alone; a rerun with other arguments is refused and changes nothing; and a pickled
OmniSafe adapter, MuJoCo mid-episode, steps on bit-identically.
"""

from __future__ import annotations

import csv
import glob
import io
import json
import pathlib
import pickle
import signal
import subprocess
import sys
import time
import warnings

import torch

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "peers"))

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
    import omnisafe_checkpoint as ck  # noqa: E402 (imports OmniSafe)

TASK = "SafetyHopperVelocity-v1"
# 120 epochs of 10 steps: past SACLag's 100 warm-up epochs, after which the multiplier moves
# (each epoch also runs one evaluation episode). Checkpoints every 15 epochs: 15, 30, ..., 120.
ARGS = ["--env", TASK, "--seed", "1", "--steps", "1200", "--steps-per-epoch", "10",
        "--start-learning-steps", "100", "--checkpoint-every", "15"]


def command(out: pathlib.Path, *args: str) -> list[str]:
    return [sys.executable, str(ROOT / "tools" / "peers" / "omnisafe_saclag.py"), *(args or ARGS), "--out", str(out)]


def rows(path: pathlib.Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def without(table: list[dict[str, str]], drop) -> list[dict[str, str]]:  # noqa: ANN001
    return [{k: v for k, v in r.items() if not drop(k)} for r in table]


def progress(out: pathlib.Path) -> list[dict[str, str]]:
    (path,) = glob.glob(str(out / f"SACLag-{{{TASK}}}" / "seed-*" / "progress.csv"))
    return rows(pathlib.Path(path))


def scalars(out: pathlib.Path, tag: str) -> list[tuple[int, str]]:
    """(step, value) of one TensorBoard scalar over all of the run's event files, in file order
    (the value's repr: the first epoch's means are NaN)."""
    from tensorboard.backend.event_processing.event_file_loader import EventFileLoader

    found = []
    for path in sorted(glob.glob(str(out / f"SACLag-{{{TASK}}}" / "seed-*" / "tb" / "events.out.tfevents.*"))):
        for event in EventFileLoader(path).Load():
            found += [(event.step, repr(v.tensor.float_val[0])) for v in event.summary.value if v.tag == tag]
    return found


def count(path: pathlib.Path) -> int:
    """Data rows of a CSV file (0 when it is missing)."""
    return max(0, len(path.read_text().splitlines()) - 1) if path.exists() else 0


def run_until_killed(out: pathlib.Path, when) -> dict | None:  # noqa: ANN001
    """Runs the command until when(meta) holds (meta: the checkpoint's, None before the first),
    then SIGKILLs it; returns the meta it was killed at."""
    with open(out.parent / f"{out.name}.log", "a") as log:
        proc = subprocess.Popen(command(out), stdout=log, stderr=subprocess.STDOUT)
        try:
            while proc.poll() is None:
                meta = ck.read_meta(str(out / "checkpoint")) if (out / "run.json").exists() else None
                if when(meta):
                    proc.send_signal(signal.SIGKILL)
                    proc.wait()
                    return meta
                time.sleep(0.05)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    log = (out.parent / f"{out.name}.log").read_text()
    raise AssertionError(f"the run ended before it could be killed: {log[-3000:]}")


def test_a_killed_run_resumes_to_the_run_left_alone(tmp_path):
    alone = tmp_path / "alone"
    done = subprocess.run(command(alone), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]

    out = tmp_path / "killed"
    # Before the first checkpoint: the rerun starts again (its rows and OmniSafe's folder go).
    run_until_killed(out, lambda meta: meta is None and count(out / "episodes.csv") >= 2)
    # After a checkpoint, once episodes were written after it: the rerun cuts them off.
    cut = {}

    def past(epoch: int):  # noqa: ANN202
        def when(meta: dict | None) -> bool:
            if meta is None or meta["epoch"] < epoch:
                return False
            rows_now = count(out / "episodes.csv"), count(out / "evals.csv")
            if rows_now[0] > meta["recorder"]["episodes"] and rows_now[1] >= meta["recorder"]["evals"] + 2:
                cut[epoch] = rows_now, meta["recorder"]
                return True
            return False
        return when

    killed = run_until_killed(out, past(45))
    # Another run's arguments are refused, and nothing of the killed run changes.
    before = {p: p.read_bytes() for p in (out / "episodes.csv", out / "evals.csv", out / "run.json")}
    other = list(ARGS)
    other[ARGS.index("--seed") + 1] = "2"
    refused = subprocess.run(command(out, *other), capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "seed: 1 there, 2 now" in refused.stderr, refused.stderr
    assert {p: p.read_bytes() for p in before} == before
    # After OmniSafe's 100 warm-up epochs: the multiplier and its optimiser are under way.
    killed = run_until_killed(out, past(105))
    assert killed["epoch"] >= 105 and set(cut) == {45, 105}, cut
    done = subprocess.run(command(out), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "resuming" in done.stdout

    def wall(key: str) -> bool:
        return key == "wall_seconds"

    def clock(key: str) -> bool:
        return key.startswith("Time/")

    assert without(rows(out / "episodes.csv"), wall) == without(rows(alone / "episodes.csv"), wall)
    assert without(rows(out / "evals.csv"), wall) == without(rows(alone / "evals.csv"), wall)
    assert len(rows(alone / "evals.csv")) == 120
    theirs, ours = progress(alone), progress(out)
    assert without(ours, clock) == without(theirs, clock)
    multiplier = [float(r["Metrics/LagrangeMultiplier"]) for r in theirs]
    assert len(set(multiplier[:100])) == 1 and len(set(multiplier[100:])) > 1, multiplier
    for tag in ("Metrics/EpRet", "Metrics/LagrangeMultiplier", "Loss/Loss_pi"):
        assert scalars(out, tag) == scalars(alone, tag), tag
    run = json.loads((out / "run.json").read_text())
    assert run["complete"] and run["env_steps"] == 1200 and len(run["resumed_at_steps"]) == 2
    assert not (out / "checkpoint").exists()  # removed once complete
    # The run directory converted from both is the same but for the clock.
    assert without(rows(out / "metrics.csv"), wall) == without(rows(alone / "metrics.csv"), wall)
    # Rerun once complete: nothing to do.
    again = subprocess.run(command(out), capture_output=True, text=True, timeout=120)
    assert again.returncode == 0 and "nothing to do" in again.stdout


def test_a_pickled_adapter_steps_on_bit_identically():
    # OmniSafe's off-policy adapter for the task, mid-episode: MuJoCo's state, the wrappers'
    # counters and normaliser, the episode's running sums and np_random go with it.
    from omnisafe.adapter.offpolicy_adapter import OffPolicyAdapter
    from omnisafe.utils.config import get_default_kwargs_yaml

    cfgs = get_default_kwargs_yaml("SACLag", TASK, "off-policy")
    adapter = OffPolicyAdapter(TASK, 1, 0, cfgs)
    # As tools/peers/omnisafe_saclag.py does. It also makes the evaluation environment picklable:
    # MuJoCo 2.3.3 crashes pickling an MjData that mj_forward never ran on (a reset runs it).
    adapter._eval_env.set_seed(0)
    torch.manual_seed(0)
    actions = torch.rand(600, 1, 3) * 2 - 1

    def step(a, action):  # noqa: ANN001, ANN202
        obs, reward, cost, terminated, truncated, info = a.step(action)
        a._log_value(reward=reward, cost=cost, info=info)
        if terminated or truncated:
            a._reset_log(0)
        return torch.cat([obs.flatten(), reward, cost, terminated.float(), truncated.float(), a._ep_ret, a._ep_len])

    for action in actions[:37]:
        step(adapter, action)
    buffer = io.BytesIO()
    ck._Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(adapter)
    copy = pickle.loads(buffer.getvalue())
    ours = torch.stack([step(copy, a) for a in actions[37:]])
    theirs = torch.stack([step(adapter, a) for a in actions[37:]])
    assert torch.equal(ours, theirs)
    assert theirs[:, -1].min() == 0  # episodes ended and began again on the way
