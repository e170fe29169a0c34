"""The TensorBoard event files of `defender train`, read back with TensorBoard's own readers:
every scalar the run directory's CSV files hold is there at the same environment step; a run
killed with kill -9 and resumed shows one curve with no step twice, equal to the run left alone;
`[log] tensorboard = false` writes none; `defender report --tensorboard` writes the same
episode curves from the CSV files."""

from __future__ import annotations

import pathlib
import signal
import subprocess
import time
from collections import defaultdict

import pytest

pytest.importorskip("tensorboard", reason="tensorboard is in python/requirements-test.txt")
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator  # noqa: E402
from tensorboard.backend.event_processing.event_file_loader import EventFileLoader  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]

# A DEFENDER run of seconds: SAC updates from step 500, an evaluation every 1000 steps.
CONFIG = """\
env = "InvertedDoublePendulum-v5"
algo = "sac"
total_steps = {steps}
eval_freq = 1000
eval_episodes = 2
checkpoint_every_episodes = {every}

[sac]
learning_starts = 500

[defender]
strategy = "MinDemoW5/MinDemoW10"
{extra}"""


def config(tmp: pathlib.Path, steps: int = 2000, every: int = 0, extra: str = "") -> pathlib.Path:
    path = tmp / f"config-{steps}-{every}-{abs(hash(extra))}.toml"
    path.write_text(CONFIG.format(steps=steps, every=every, extra=extra))
    return path


def train(binary, cfg, out, *args) -> subprocess.CompletedProcess:
    done = subprocess.run([str(binary), "train", "--config", str(cfg), "--out", str(out), *args], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done


def event_files(run: pathlib.Path) -> list[pathlib.Path]:
    return sorted(run.glob("events.out.tfevents.*"))


def raw_scalars(run: pathlib.Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar of the run's event files as written (TensorBoard's loader, no purging)."""
    out: dict[str, list[tuple[int, float]]] = defaultdict(list)
    for path in event_files(run):
        for event in EventFileLoader(str(path)).Load():
            if event.HasField("summary"):
                for v in event.summary.value:
                    out[v.tag].append((event.step, v.simple_value))
    return dict(out)


def metrics_rows(run: pathlib.Path) -> list[list[str]]:
    return [line.split(",") for line in (run / "metrics.csv").read_text().splitlines()[1:]]


@pytest.fixture(scope="module")
def run(binary, tmp_path_factory) -> pathlib.Path:
    tmp = tmp_path_factory.mktemp("tb")
    out = tmp / "Hopper-like" / "run0"
    train(binary, config(tmp), out)
    return out


def test_tensorboard_reads_every_scalar_at_environment_steps(run):
    files = event_files(run)
    assert len(files) == 1, files
    acc = EventAccumulator(str(run))
    acc.Reload()
    tags = set(acc.Tags()["scalars"])
    expected = {
        "episode/return", "episode/length", "episode/crashed", "episode/filtered",
        "rollout/ep_rew_mean", "rollout/ep_len_mean",
        "defender/crash_rate", "defender/filter_rate", "defender/crash_rate_recent", "defender/filter_rate_recent",
        "train/critic_loss", "train/mean_q", "train/actor_loss", "train/ent_coef", "train/n_updates",
        "defender/dynamics_error", "defender/dynamics_loss", "defender/mean_safe_cost", "defender/mean_unsafe_cost",
        "defender/filtered_step_rate", "defender/r_task", "time/fps",
        "eval/mean_reward", "eval/std_reward", "eval/mean_ep_length", "eval/mean_cost",
        "eval/shield_mean_reward", "eval/shield_mean_cost", "eval/shield_filtered",
        "safety/crashes", "safety/episode_cost",
    }
    assert expected <= tags, expected - tags
    rows = metrics_rows(run)
    returns = acc.Scalars("episode/return")
    assert [e.step for e in returns] == [int(r[1]) for r in rows]
    assert [e.value for e in returns] == pytest.approx([float(r[2]) for r in rows], rel=1e-6)
    filtered = [e.value for e in acc.Scalars("episode/filtered")]
    assert filtered == [float(r[4] == "filtered") for r in rows]
    crashes = [e.value for e in acc.Scalars("safety/crashes")]
    assert crashes[-1] == sum(r[4] == "crashed" for r in rows)
    assert [e.value for e in acc.Scalars("safety/episode_cost")] == [float(r[6]) for r in rows]
    crash = acc.Scalars("defender/crash_rate")[-1].value
    assert crash == pytest.approx(sum(r[4] == "crashed" for r in rows) / len(rows), rel=1e-6)
    updates = [line.split(",") for line in (run / "updates.csv").read_text().splitlines()[1:]]
    assert [e.step for e in acc.Scalars("train/critic_loss")] == [int(u[0]) for u in updates]
    assert [e.value for e in acc.Scalars("train/critic_loss")] == pytest.approx([float(u[2]) for u in updates], rel=1e-5)
    dynamics = [line.split(",") for line in (run / "dynamics.csv").read_text().splitlines()[1:]]
    assert [e.value for e in acc.Scalars("defender/dynamics_error")] == pytest.approx([float(d[4]) for d in dynamics], rel=1e-5)
    evals = [line.split(",") for line in (run / "eval.csv").read_text().splitlines()[1:]]
    assert [e.step for e in acc.Scalars("eval/mean_reward")] == [int(v[0]) for v in evals]
    # The evaluation with the filter kept: eval.csv's shield columns, row by row.
    header = (run / "eval.csv").read_text().splitlines()[0].split(",")
    for tag, column in (("eval/mean_cost", "mean_cost"), ("eval/shield_mean_reward", "shield_mean_return"),
                        ("eval/shield_mean_cost", "shield_mean_cost"), ("eval/shield_filtered", "shield_filtered")):
        at = header.index(column)
        assert [e.step for e in acc.Scalars(tag)] == [int(v[0]) for v in evals], tag
        assert [e.value for e in acc.Scalars(tag)] == pytest.approx([float(v[at]) for v in evals], rel=1e-6, abs=1e-9), tag
    costs = acc.Scalars("defender/mean_safe_cost")
    assert [e.step for e in costs] == [1000, 2000] and all(c.value > 0 for c in costs)


def test_a_run_killed_and_resumed_has_one_curve_equal_to_the_run_left_alone(binary, run, tmp_path):
    cfg = config(tmp_path, every=20)
    alone = tmp_path / "alone"
    train(binary, cfg, alone)
    out = tmp_path / "killed"
    proc = subprocess.Popen([str(binary), "train", "--config", str(cfg), "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    manifest = out / "checkpoint" / "manifest.json"
    deadline = time.time() + 120
    # Kill once events have been written after a checkpoint: they must go.
    while time.time() < deadline and proc.poll() is None:
        if manifest.exists() and (out / "metrics.csv").exists():
            at = len(metrics_rows(out))
            while proc.poll() is None and len(metrics_rows(out)) < at + 5 and time.time() < deadline:
                time.sleep(0.005)
            break
        time.sleep(0.005)
    if proc.poll() is not None:
        pytest.skip("the run ended before it could be killed after a checkpoint")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = raw_scalars(out)["episode/return"]
    train(binary, cfg, out, "--resume")
    assert len(event_files(out)) == 1
    scalars = raw_scalars(out)
    for tag, points in scalars.items():
        steps = [s for s, _ in points]
        assert len(steps) == len(set(steps)), f"{tag}: a step written twice"
        assert steps == sorted(steps), tag
    left_alone = raw_scalars(alone)
    for tag in ("episode/return", "episode/length", "defender/crash_rate", "train/critic_loss", "eval/mean_reward"):
        assert scalars[tag] == left_alone[tag], tag
    assert len(scalars["episode/return"]) >= len(before)


def test_tensorboard_false_writes_no_event_file(binary, tmp_path):
    out = tmp_path / "quiet"
    train(binary, config(tmp_path, steps=600, extra="\n[log]\ntensorboard = false\n"), out)
    assert (out / "metrics.csv").exists()
    assert event_files(out) == []
    assert "[log]" in (out / "config.toml").read_text()


def test_report_converts_a_runs_csv_files(binary, run, tmp_path):
    out = tmp_path / "tb"
    done = subprocess.run([str(binary), "report", str(run.parent), "--tensorboard", str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    converted = out / run.name
    assert len(event_files(converted)) == 1
    mine, theirs = raw_scalars(converted), raw_scalars(run)
    for tag in ("episode/return", "episode/length", "defender/filter_rate_recent", "train/critic_loss", "defender/dynamics_error", "eval/mean_reward",
                "eval/shield_mean_reward", "eval/shield_filtered"):
        assert mine[tag] == theirs[tag], tag
    # Converting again replaces the file rather than adding a second curve.
    subprocess.run([str(binary), "report", str(run.parent), "--tensorboard", str(out)], check=True, capture_output=True)
    assert len(event_files(converted)) == 1


def test_train_warns_when_the_agent_would_never_update(binary, tmp_path):
    done = train(binary, config(tmp_path, steps=400), tmp_path / "inert")
    assert "warning: [sac] learning_starts = 500 is at or beyond the budget of 400 steps" in done.stderr
    assert (tmp_path / "inert" / "updates.csv").read_text().count("\n") == 1


def test_the_sb3_extra_brings_tensorboard():
    # SB3's `tensorboard_log=` needs it; `pip install ".[sb3]"` must bring it.
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert any(req.startswith("tensorboard") for req in extras["sb3"]), extras["sb3"]
