"""EpisodeSet in numpy: the .npz contract of SPEC section 8, round trips, pickling, bad input."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from defender_rl import DefenderError, EpisodeSet

from conftest import HOPPER_DEMOS


def small_arrays():
    rng = np.random.default_rng(0)
    ep_len = np.array([3, 2, 4])
    return {
        "obs": rng.normal(size=(int(ep_len.sum() + len(ep_len)), 5)).astype(np.float32),
        "act": rng.uniform(-1, 1, size=(int(ep_len.sum()), 2)).astype(np.float32),
        "rew": rng.normal(size=int(ep_len.sum())).astype(np.float32),
        "ep_len": ep_len.astype(np.int64),
        "crashed": np.array([False, True, False]),
        "meta": {"env_id": "Toy-v0", "provenance": "test", "anything": [1, 2]},
    }


def test_from_arrays_to_arrays_round_trip():
    a = small_arrays()
    s = EpisodeSet.from_arrays(**a)
    assert len(s) == 3 and s.obs_dim == 5 and s.act_dim == 2 and s.group_sizes == (2, 1)
    assert s.env_id == "Toy-v0" and s.transitions == 9
    b = s.to_arrays()
    for k in ("obs", "act", "rew", "ep_len", "crashed"):
        np.testing.assert_array_equal(b[k], a[k])
        assert b[k].dtype == a[k].dtype
    assert b["meta"]["anything"] == [1, 2] and b["meta"]["obs_dim"] == 5
    e = s.episode(1)
    np.testing.assert_array_equal(e["obs"], a["obs"][4:7])
    np.testing.assert_array_equal(e["act"], a["act"][3:5])
    assert e["crashed"] is True
    assert s.episode(-1)["rew"].shape == (4,)
    with pytest.raises(IndexError):
        s.episode(3)


def test_save_then_np_load(tmp_path):
    a = small_arrays()
    s = EpisodeSet.from_arrays(**a)
    path = tmp_path / "set.npz"
    s.save(path)
    with np.load(path) as f:
        assert sorted(f.files) == ["act", "crashed", "ep_len", "meta", "obs", "rew"]
        for k in ("obs", "act", "rew", "ep_len", "crashed"):
            np.testing.assert_array_equal(f[k], a[k])
        assert f["obs"].dtype == np.float32 and f["ep_len"].dtype == np.int64 and f["crashed"].dtype == bool
        import json

        assert json.loads(f["meta"].tobytes())["provenance"] == "test"
    again = EpisodeSet.load(path)
    assert again == s
    # A file numpy writes (float64 arrays) loads too.
    np.savez(tmp_path / "np.npz", **{k: (v.astype(np.float64) if v.dtype == np.float32 else v) for k, v in a.items() if k != "meta"})
    assert EpisodeSet.load(tmp_path / "np.npz").to_arrays()["obs"].shape == a["obs"].shape


def test_shipped_demonstrations_match_np_load():
    s = EpisodeSet.load(HOPPER_DEMOS)
    arrays = s.to_arrays()
    with np.load(HOPPER_DEMOS) as f:
        for k in ("obs", "act", "rew", "ep_len", "crashed"):
            np.testing.assert_array_equal(arrays[k], f[k])
    assert s.env_id == "Hopper-v5" and s.obs_dim == 11 and s.act_dim == 3
    assert s.group_sizes == (int((~arrays["crashed"]).sum()), int(arrays["crashed"].sum()))
    first = s.select_demos(3)
    assert first.group_sizes == (3, 3)


def test_pickle_and_dict_input():
    s = EpisodeSet.from_arrays(**small_arrays())
    t = pickle.loads(pickle.dumps(s))
    assert t == s and t.meta == s.meta
    u = EpisodeSet.from_episodes([s.episode(i) for i in range(len(s))], meta=s.meta)
    assert u == s


def test_from_arrays_bad_input_names_the_array():
    a = small_arrays()
    cases = [
        (dict(obs=a["obs"][:-1]), r"obs: expected 12 rows"),
        (dict(act=a["act"][:, :1].repeat(2, 0)), r"act: expected 9 rows"),
        (dict(rew=a["rew"][:5]), r"rew: expected 9 rows"),
        (dict(crashed=np.array([True])), r"crashed: expected one flag per episode \(3 episodes"),
        (dict(ep_len=np.array([3, 0, 5])), r"ep_len: episode 1 has 0 transitions"),
        (dict(obs=a["obs"][:, 0]), r"obs: expected a 2-D array"),
        (dict(meta={"obs_dim": 7}), r"obs_dim|meta"),
    ]
    nan_obs = a["obs"].copy()
    nan_obs[4, 2] = np.nan
    cases.append((dict(obs=nan_obs), r"obs: row 4, column 2 is not finite"))
    for change, pattern in cases:
        with pytest.raises(DefenderError, match=pattern):
            EpisodeSet.from_arrays(**{**a, **change})
    with pytest.raises(DefenderError, match="obs: cannot be read"):
        EpisodeSet.from_arrays(**{**a, "obs": "abc"})
    with pytest.raises(TypeError, match="meta"):
        EpisodeSet.from_arrays(**{**a, "meta": 5})


def test_load_errors(tmp_path):
    with pytest.raises(OSError, match="missing.npz"):
        EpisodeSet.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "partial.npz", obs=np.zeros((2, 2)))
    with pytest.raises(DefenderError, match="partial.npz.*'act'"):
        EpisodeSet.load(tmp_path / "partial.npz")
    with pytest.raises(DefenderError, match="empty"):
        EpisodeSet.from_episodes([])
