//! Episode-set files (SPEC section 8) against real numpy: numpy loads what we write, we load what
//! numpy writes, and every kind of invalid file is refused with an error naming file, array and rule.

#![allow(clippy::unwrap_used)] // test and bench helpers fail loudly on purpose

use std::path::{Path, PathBuf};
use std::process::Command;

use defender::{EpisodeSet, Meta, Mode};

/// The project's test venv (numpy), made by `make setup`.
fn python() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.deps/venv/bin/python");
    assert!(
        root.exists(),
        "{} is missing: run `make setup` (it creates the test venv with numpy)",
        root.display()
    );
    root
}

/// Runs a numpy script with `sys.argv[1] = dir`; returns stdout. Fails the test on a Python error.
fn run_numpy(script: &str, dir: &Path) -> String {
    let out = Command::new(python()).arg("-c").arg(script).arg(dir).output().expect("run python");
    assert!(out.status.success(), "python failed:\n{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

fn demo_set() -> EpisodeSet {
    let meta = Meta { env_id: Some("Hopper-v5".into()), provenance: Some("test".into()), ..Meta::default() };
    let mut set = EpisodeSet::new(3, 2, meta).unwrap();
    // Episode 0: 2 transitions, safe; episode 1: 1 transition, crashed.
    set.push_episode(
        &[0.5, 1.0, -1.5, 2.0, 2.5, 3.0, 4.0, 4.5, 5.25],
        &[0.1, 0.2, 0.3, 0.4],
        &[1.0, -2.5],
        false,
    )
    .unwrap();
    set.push_episode(&[9.0, 8.0, 7.0, 6.0, 5.0, 4.0], &[-1.0, 1.0], &[0.75], true).unwrap();
    set
}

#[test]
fn numpy_loads_what_we_write() {
    let dir = tempfile::tempdir().unwrap();
    demo_set().save(dir.path().join("demos.npz")).unwrap();
    let script = r#"
import sys, json, numpy as np
d = np.load(sys.argv[1] + "/demos.npz")  # allow_pickle defaults to False: no pickles inside
assert sorted(d.files) == ["act", "crashed", "ep_len", "meta", "obs", "rew"], d.files
assert d["obs"].dtype == np.float32 and d["obs"].shape == (5, 3), (d["obs"].dtype, d["obs"].shape)
assert d["act"].dtype == np.float32 and d["act"].shape == (3, 2)
assert d["rew"].dtype == np.float32 and d["rew"].shape == (3,)
assert d["ep_len"].dtype == np.int64 and d["ep_len"].tolist() == [2, 1]
assert d["crashed"].dtype == np.bool_ and d["crashed"].tolist() == [False, True]
assert d["meta"].dtype == np.uint8
meta = json.loads(d["meta"].tobytes().decode("utf-8"))
assert meta["env_id"] == "Hopper-v5" and meta["obs_dim"] == 3 and meta["act_dim"] == 2, meta
assert meta["provenance"] == "test"
assert d["obs"][4].tolist() == [6.0, 5.0, 4.0]
assert d["rew"].tolist() == [1.0, -2.5, 0.75]
print("ok")
"#;
    assert_eq!(run_numpy(script, dir.path()).trim(), "ok");
}

#[test]
fn we_load_what_numpy_writes_float32_float64_and_compressed() {
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
import sys, json, numpy as np
d = sys.argv[1]
obs = np.arange(5 * 3, dtype=np.float64).reshape(5, 3) / 4
act = np.linspace(-1, 1, 6).reshape(3, 2)
rew = np.array([1.0, -2.5, 0.75])
ep_len = np.array([2, 1], dtype=np.int64)
crashed = np.array([False, True])
meta = np.frombuffer(json.dumps({"env_id": "Hopper-v5", "obs_dim": 3, "act_dim": 2, "made_by": "numpy"}).encode(), dtype=np.uint8)
np.savez(d + "/f64.npz", obs=obs, act=act, rew=rew, ep_len=ep_len, crashed=crashed, meta=meta)
np.savez(d + "/f32.npz", obs=obs.astype(np.float32), act=act.astype(np.float32), rew=rew.astype(np.float32), ep_len=ep_len, crashed=crashed)
np.savez_compressed(d + "/zipped.npz", obs=np.asfortranarray(obs), act=act, rew=rew, ep_len=ep_len, crashed=crashed)
"#;
    run_numpy(script, dir.path());
    let expected_obs: Vec<f32> = (0..15).map(|i| i as f32 / 4.0).collect();
    for name in ["f64.npz", "f32.npz", "zipped.npz"] {
        let set = EpisodeSet::load(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((set.len(), set.obs_dim(), set.act_dim(), set.transitions()), (2, 3, 2, 3), "{name}");
        let all_obs: Vec<f32> = set.episodes().flat_map(|e| e.obs.to_vec()).collect();
        assert_eq!(all_obs, expected_obs, "{name}");
        assert_eq!(set.episode(1).act, &[0.6f32, 1.0], "{name}");
        assert_eq!(set.episode(0).rew, &[1.0, -2.5], "{name}");
        assert_eq!(set.group_sizes(), (1, 1), "{name}");
        assert_eq!(set.episode(0).sequence(Mode::StateAction).len(), 2 * 5);
    }
    let set = EpisodeSet::load(dir.path().join("f64.npz")).unwrap();
    assert_eq!(set.meta().env_id.as_deref(), Some("Hopper-v5"));
    assert_eq!(set.meta().extra["made_by"], "numpy");
    // And what we write back, numpy reads with the extra key kept.
    set.save(dir.path().join("back.npz")).unwrap();
    let check = r#"
import sys, json, numpy as np
d = np.load(sys.argv[1] + "/back.npz")
print(json.loads(d["meta"].tobytes())["made_by"], d["obs"].dtype)
"#;
    assert_eq!(run_numpy(check, dir.path()).trim(), "numpy float32");
}

/// Each case: a numpy expression overriding one array of a valid set (or deleting it with None),
/// and the words the error must contain besides the file name.
const INVALID: &[(&str, &str, &[&str])] = &[
    ("missing_obs", "obs=None", &["'obs'", "expected an array of this name"]),
    ("missing_crashed", "crashed=None", &["'crashed'"]),
    ("obs_rows", "obs=np.zeros((4, 3))", &["'obs'", "5 rows", "sum(N_i + 1)"]),
    ("obs_1d", "obs=np.zeros(15)", &["'obs'", "2-D"]),
    ("act_rows", "act=np.zeros((4, 2))", &["'act'", "3 rows", "sum(N_i)"]),
    ("rew_len", "rew=np.zeros(2)", &["'rew'", "shape [3]"]),
    (
        "obs_nan",
        "obs=np.where(np.arange(15).reshape(5,3)==7, np.nan, 1.0)",
        &["'obs'", "finite", "NaN", "index 7"],
    ),
    ("act_inf", "act=np.full((3,2), np.inf)", &["'act'", "finite"]),
    ("rew_int", "rew=np.array([1, 2, 3])", &["'rew'", "float32"]),
    ("ep_len_zero", "ep_len=np.array([3, 0]), crashed=np.array([False, True])", &["'ep_len'", "N_i >= 1"]),
    ("ep_len_float", "ep_len=np.array([2.0, 1.0])", &["'ep_len'", "int64"]),
    (
        "empty",
        "obs=np.zeros((0,3)), act=np.zeros((0,2)), rew=np.zeros(0), ep_len=np.zeros(0, dtype=np.int64), crashed=np.zeros(0, dtype=bool)",
        &["'ep_len'", "at least one episode"],
    ),
    ("crashed_len", "crashed=np.array([True])", &["'crashed'", "shape [2]"]),
    ("crashed_int", "crashed=np.array([0, 1])", &["'crashed'", "bool"]),
    ("meta_dims", "meta=np.frombuffer(b'{\"obs_dim\": 4}', dtype=np.uint8)", &["'meta'", "obs_dim = 3"]),
    ("meta_json", "meta=np.frombuffer(b'not json', dtype=np.uint8)", &["'meta'", "JSON"]),
    ("meta_dtype", "meta=np.array([1.0, 2.0])", &["'meta'", "uint8"]),
    ("object_array", "rew=np.array([1.0, 'a', None], dtype=object)", &["'rew'"]),
];

#[test]
fn invalid_files_are_refused_naming_file_array_and_rule() {
    let dir = tempfile::tempdir().unwrap();
    let mut script = String::from(
        r#"
import sys, numpy as np
d = sys.argv[1]
def base():
    return dict(obs=np.ones((5, 3)), act=np.zeros((3, 2)), rew=np.zeros(3), ep_len=np.array([2, 1]), crashed=np.array([False, True]))
def case(name, **kw):
    arrays = base()
    arrays.update(kw)
    np.savez(d + "/" + name + ".npz", **{k: v for k, v in arrays.items() if v is not None})
"#,
    );
    for (name, change, _) in INVALID {
        script.push_str(&format!("case({name:?}, {change})\n"));
    }
    script.push_str("open(d + '/not_a_zip.npz', 'w').write('hello')\n");
    run_numpy(&script, dir.path());
    for (name, _, words) in INVALID {
        let path = dir.path().join(format!("{name}.npz"));
        let err = EpisodeSet::load(&path).expect_err(name).to_string();
        assert!(err.contains(&path.display().to_string()), "{name}: the error names the file: {err}");
        for w in *words {
            assert!(err.contains(w), "{name}: the error should contain {w:?}: {err}");
        }
    }
    let err = EpisodeSet::load(dir.path().join("not_a_zip.npz")).unwrap_err().to_string();
    assert!(err.contains("not_a_zip.npz") && err.contains("zip"), "{err}");
    let err = EpisodeSet::load(dir.path().join("absent.npz")).unwrap_err().to_string();
    assert!(err.contains("absent.npz"), "{err}");
}

#[test]
fn a_demonstration_set_without_a_group_is_refused_on_use() {
    let dir = tempfile::tempdir().unwrap();
    run_numpy(
        r#"
import sys, numpy as np
np.savez(sys.argv[1] + "/safe_only.npz", obs=np.ones((5, 3)), act=np.zeros((3, 2)), rew=np.zeros(3), ep_len=np.array([2, 1]), crashed=np.array([False, False]))
"#,
        dir.path(),
    );
    let path = dir.path().join("safe_only.npz");
    let set = EpisodeSet::load(&path).unwrap();
    let err = set.require_both_groups().unwrap_err().to_string();
    assert!(err.contains("safe_only.npz") && err.contains("unsafe group is empty"), "{err}");
}

#[test]
fn saving_is_atomic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("demos.npz");
    demo_set().save(&path).unwrap();
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["demos.npz"], "no temporary file is left behind");
    // Saving into a missing directory fails cleanly and names the path.
    let err = demo_set().save(dir.path().join("no/such/dir.npz")).unwrap_err().to_string();
    assert!(err.contains("dir.npz"), "{err}");
}
