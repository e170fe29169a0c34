//! Fuzzing on stable Rust: an in-process mutation fuzzer (no nightly, no libFuzzer) over what
//! `defender` reads from users: episode-set files (the `.npz` container, the `.npy` headers, the
//! `meta` JSON), the run configuration (`train --config`), strategy names, and checkpoints.
//!
//! Each target starts from a seed corpus (`fuzz/corpus/<target>/` plus inputs built here), then
//! applies random stacks of mutations (bit flips, interesting bytes and numbers, insertions,
//! deletions, splices) from a fixed seed. An input that panics, or that makes the target allocate
//! more than its bound (peak live bytes on the fuzzing thread, measured by a counting allocator),
//! is saved under `target/fuzz-crashes/` and fails the test. Accepted inputs join the corpus, so
//! mutations drift towards valid files. There is no coverage feedback (that needs nightly or
//! AFL's instrumentation), so this finds what random structure-aware mutation finds.
//!
//! `cargo test -p defender-cli --bin defender fuzz` runs the smoke (a few seconds per target);
//! `DEFENDER_FUZZ_SECONDS=600 DEFENDER_FUZZ_ITERATIONS=100000000 cargo test --release -p
//! defender-cli --bin defender fuzz -- --ignored --nocapture` the long budgets of
//! docs/benchmarks.md.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::Instant;

// ---------------------------------------------------------------------------------------------
// Counting allocator: live and peak bytes of the calling thread.

thread_local! {
    static LIVE: Cell<i64> = const { Cell::new(0) };
    static PEAK: Cell<i64> = const { Cell::new(0) };
}

struct Tracking;

fn grew(by: usize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get().saturating_add(by as i64);
        live.set(now);
        let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
    });
}

fn shrank(by: usize) {
    let _ = LIVE.try_with(|live| live.set(live.get().saturating_sub(by as i64)));
}

// SAFETY: every method forwards to `System` with the caller's arguments; counting has no effect on
// the memory handed out.
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size >= layout.size() {
            grew(new_size - layout.size());
        } else {
            shrank(layout.size() - new_size);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Tracking = Tracking;

/// Starts a measurement: returns the live bytes now, and resets the peak to them.
fn start_measure() -> i64 {
    let live = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(live));
    live
}

fn peak_since(base: i64) -> u64 {
    (PEAK.with(Cell::get) - base).max(0) as u64
}

// ---------------------------------------------------------------------------------------------
// The mutation engine.

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { (self.next() % n as u64) as usize }
    }
}

/// Tokens that matter to the formats under test: numbers at the edges, dtype strings, JSON and
/// TOML punctuation, Python literals of `.npy` headers.
const TOKENS: &[&[u8]] = &[
    b"-1",
    b"0",
    b"1",
    b"18446744073709551615",
    b"9223372036854775807",
    b"-9223372036854775808",
    b"4294967296",
    b"1e308",
    b"-1e308",
    b"nan",
    b"inf",
    b"1e999",
    b"[]",
    b"{}",
    b"\"",
    b"(",
    b")",
    b",",
    b"'",
    b"<f4",
    b"<f8",
    b"|b1",
    b"<i8",
    b">u8",
    b"|O",
    b"True",
    b"False",
    b"'shape': (",
    b"'fortran_order': True",
    b"100000000000",
    b"\x00",
    b"\xff",
    b"=",
    b"[defender]",
    b"[sac]",
    b"net_arch = [",
    b"buffer_size = ",
    b"/",
    b"W",
    b"Mean",
    b"Min",
    b"Demo",
    b"Both",
];

fn mutate(rng: &mut Rng, data: &mut Vec<u8>, corpus: &[Vec<u8>], max_len: usize) {
    for _ in 0..1 + rng.below(6) {
        let len = data.len();
        match rng.below(10) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = [0u8, 1, 0x7f, 0x80, 0xff, b'0', b'9', b' '][rng.below(8)];
            }
            2 if len > 0 => {
                let i = rng.below(len);
                data[i] = rng.next() as u8;
            }
            3 => {
                let i = rng.below(len + 1);
                let n = 1 + rng.below(16);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                data.splice(i..i, bytes);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                data.drain(i..i + n);
            }
            5 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                let chunk = data[i..i + n].to_vec();
                let at = rng.below(len + 1);
                data.splice(at..at, chunk);
            }
            6 if !corpus.is_empty() => {
                let other = &corpus[rng.below(corpus.len())];
                if !other.is_empty() {
                    let from = rng.below(other.len());
                    let at = rng.below(len + 1);
                    data.truncate(at);
                    data.extend_from_slice(&other[from..]);
                }
            }
            7 => {
                let token = TOKENS[rng.below(TOKENS.len())];
                let i = rng.below(len + 1);
                if rng.below(2) == 0 || i + token.len() > len {
                    data.splice(i..i, token.iter().copied());
                } else {
                    data[i..i + token.len()].copy_from_slice(token);
                }
            }
            8 if len >= 8 => {
                // A little-endian integer at a random place set to an edge value.
                let i = rng.below(len - 7);
                let v: u64 = [0, 1, u64::MAX, u64::from(u32::MAX), 1 << 40, i64::MAX as u64][rng.below(6)];
                let width = [2usize, 4, 8][rng.below(3)];
                data[i..i + width].copy_from_slice(&v.to_le_bytes()[..width]);
            }
            9 if len > 0 => data.truncate(rng.below(len)),
            _ => {}
        }
    }
    data.truncate(max_len);
}

/// How long a target runs: whichever of the two limits comes first.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Budget {
    pub iterations: u64,
    pub seconds: f64,
}

/// What a run of a target did.
#[derive(Debug)]
pub(crate) struct Report {
    pub target: &'static str,
    pub iterations: u64,
    pub accepted: u64,
    pub seconds: f64,
    pub peak_bytes: u64,
    pub corpus: usize,
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} inputs in {:.1} s ({} accepted), 0 panics, peak allocation {:.2} MiB, corpus {}",
            self.target,
            self.iterations,
            self.seconds,
            self.accepted,
            self.peak_bytes as f64 / (1 << 20) as f64,
            self.corpus
        )
    }
}

fn crash_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/fuzz-crashes")
}

fn save_crash(target: &str, i: u64, input: &[u8]) -> PathBuf {
    let dir = crash_dir();
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("{target}-{i}.bin"));
    let _ = std::fs::write(&path, input);
    path
}

/// Runs `target` on the seeds, then on mutations of the corpus, until the budget is spent.
/// `target` returns whether the input was accepted (accepted inputs join the corpus).
///
/// # Panics
/// On a panic of the target or an allocation peak above `max_bytes`, after saving the input.
pub(crate) fn run(
    name: &'static str,
    seeds: Vec<Vec<u8>>,
    budget: Budget,
    max_len: usize,
    max_bytes: u64,
    target: &mut dyn FnMut(&[u8]) -> bool,
) -> Report {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ name.len() as u64);
    let mut corpus = seeds;
    assert!(!corpus.is_empty(), "{name}: empty seed corpus");
    let started = Instant::now();
    let (mut i, mut accepted, mut peak) = (0u64, 0u64, 0u64);
    while i < budget.iterations && started.elapsed().as_secs_f64() < budget.seconds {
        let input = if (i as usize) < corpus.len() {
            corpus[i as usize].clone()
        } else {
            let mut data = corpus[rng.below(corpus.len())].clone();
            mutate(&mut rng, &mut data, &corpus, max_len);
            data
        };
        let base = start_measure();
        let outcome = catch_unwind(AssertUnwindSafe(|| target(&input)));
        let used = peak_since(base);
        peak = peak.max(used);
        match outcome {
            Err(_) => {
                let path = save_crash(name, i, &input);
                panic!("fuzz target {name}: input {i} panicked; saved to {}", path.display());
            }
            Ok(ok) => {
                if used > max_bytes {
                    let path = save_crash(name, i, &input);
                    panic!(
                        "fuzz target {name}: input {i} allocated {used} bytes at peak (bound {max_bytes}); saved to {}",
                        path.display()
                    );
                }
                if ok {
                    accepted += 1;
                    if i as usize >= corpus.len() && corpus.len() < 2000 {
                        corpus.push(input);
                    }
                }
            }
        }
        i += 1;
    }
    Report {
        target: name,
        iterations: i,
        accepted,
        seconds: started.elapsed().as_secs_f64(),
        peak_bytes: peak,
        corpus: corpus.len(),
    }
}

/// The committed seed corpus of `target`: every file of `fuzz/corpus/<target>/`.
pub(crate) fn corpus(target: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target);
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("corpus entry").path())
        .collect();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).expect("corpus file")).collect()
}

// ---------------------------------------------------------------------------------------------
// Building files by hand (the fuzzer needs zip entries with correct CRCs around mutated bytes).

fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// An `.npy` file (version 1.0) of `descr` and `shape` around raw `data`.
pub(crate) fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(ToString::to_string).collect();
    let shape = if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let mut text = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    let pad = 64 - (10 + text.len() + 1) % 64;
    text.push_str(&" ".repeat(pad % 64));
    text.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(text.len() as u16).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out.extend_from_slice(data);
    out
}

/// A zip archive of stored entries with correct CRCs.
pub(crate) fn stored_zip(entries: &[(&str, Vec<u8>)]) -> Vec<u8> {
    let (mut out, mut central) = (Vec::new(), Vec::new());
    for (name, data) in entries {
        let offset = out.len() as u32;
        let (crc, size, n) = (crc32(data), data.len() as u32, name.len() as u16);
        let put = |v: &mut Vec<u8>, fields: &[u32], widths: &[usize]| {
            for (f, w) in fields.iter().zip(widths) {
                v.extend_from_slice(&f.to_le_bytes()[..*w]);
            }
        };
        put(
            &mut out,
            &[0x0403_4B50, 20, 0, 0, 0, 0x21, crc, size, size, u32::from(n), 0],
            &[4, 2, 2, 2, 2, 2, 4, 4, 4, 2, 2],
        );
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(data);
        put(
            &mut central,
            &[0x0201_4B50, 20, 20, 0, 0, 0, 0x21, crc, size, size, u32::from(n), 0, 0, 0, 0, 0, offset],
            &[4, 2, 2, 2, 2, 2, 2, 4, 4, 4, 2, 2, 2, 2, 2, 4, 4],
        );
        central.extend_from_slice(name.as_bytes());
    }
    let cd_offset = out.len() as u32;
    let cd_len = central.len() as u32;
    out.extend_from_slice(&central);
    let count = entries.len() as u16;
    out.extend_from_slice(&0x0605_4B50u32.to_le_bytes());
    out.extend_from_slice(&[0, 0, 0, 0]);
    out.extend_from_slice(&count.to_le_bytes());
    out.extend_from_slice(&count.to_le_bytes());
    out.extend_from_slice(&cd_len.to_le_bytes());
    out.extend_from_slice(&cd_offset.to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out
}

fn le<T: Copy, const N: usize>(values: &[T], bytes: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&v| bytes(v)).collect()
}

/// The arrays of a small valid episode set (2 episodes, obs_dim 3, act_dim 2), as `.npy` files.
pub(crate) fn valid_arrays() -> Vec<(&'static str, Vec<u8>)> {
    let obs: Vec<f32> = (0..15).map(|i| i as f32 / 4.0).collect();
    vec![
        ("obs.npy", npy("<f4", &[5, 3], &le(&obs, f32::to_le_bytes))),
        ("act.npy", npy("<f4", &[3, 2], &le(&[0.5f32, -0.5, 0.1, 0.2, 0.3, 0.4], f32::to_le_bytes))),
        ("rew.npy", npy("<f4", &[3], &le(&[1.0f32, -2.5, 0.75], f32::to_le_bytes))),
        ("ep_len.npy", npy("<i8", &[2], &le(&[2i64, 1], i64::to_le_bytes))),
        ("crashed.npy", npy("|b1", &[2], &[0, 1])),
        ("meta.npy", {
            let meta = br#"{"env_id": "Hopper-v5", "obs_dim": 3, "act_dim": 2}"#;
            npy("|u1", &[meta.len()], meta)
        }),
    ]
}

// ---------------------------------------------------------------------------------------------
// The targets.

/// Episode-set files as bytes on disk (`EpisodeSet::load`).
pub(crate) fn episode_set(budget: Budget) -> Report {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("set.npz");
    let mut seeds = corpus("episode_set");
    seeds.push(stored_zip(&valid_arrays()));
    run("episode_set", seeds, budget, 16 << 10, 64 << 20, &mut |input| {
        std::fs::write(&path, input).expect("write the input");
        defender::EpisodeSet::load(&path).is_ok()
    })
}

/// One array of an otherwise valid episode set (first byte: which), inside a zip whose CRCs are
/// right, so that the `.npy` header, data and `meta` JSON parsers see every mutation.
pub(crate) fn npy_arrays(budget: Budget) -> Report {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("set.npz");
    let base = valid_arrays();
    let seeds: Vec<Vec<u8>> = base
        .iter()
        .enumerate()
        .map(|(i, (_, bytes))| {
            let mut v = vec![i as u8];
            v.extend_from_slice(bytes);
            v
        })
        .collect();
    run("npy_arrays", seeds, budget, 16 << 10, 64 << 20, &mut |input| {
        let Some((&which, bytes)) = input.split_first() else { return false };
        let mut arrays = base.clone();
        let which = usize::from(which) % arrays.len();
        arrays[which].1 = bytes.to_vec();
        std::fs::write(&path, stored_zip(&arrays)).expect("write the input");
        defender::EpisodeSet::load(&path).is_ok()
    })
}

/// `defender train --config` files.
pub(crate) fn config(budget: Budget) -> Report {
    run("config", corpus("config"), budget, 8 << 10, 16 << 20, &mut |input| {
        crate::run_config::read_config_str(&String::from_utf8_lossy(input)).is_ok()
    })
}

/// Strategy names and lists (`--strategy`, the ablation's `--strategies`).
pub(crate) fn strategy(budget: Budget) -> Report {
    run("strategy", corpus("strategy"), budget, 256, 1 << 20, &mut |input| {
        let text = String::from_utf8_lossy(input);
        let one = text.parse::<defender::Strategy>().is_ok();
        let list = defender::Strategy::parse_list(&text).is_ok();
        one || list
    })
}

/// A checkpoint: a trainer's (SAC on Pendulum) and DEFENDER's dynamics model. The first byte
/// picks the file whose content the rest replaces; with its top bit clear the manifest is
/// rewritten to match, so that the loaders behind the checksum see the mutation.
pub(crate) fn checkpoint(budget: Budget) -> Report {
    use defender_rl::classic::Pendulum;
    use defender_rl::{AlgoConfig, Budget as Steps, NoHooks, SacConfig, Trainer, TrainerConfig};
    use rand::SeedableRng;

    let root = tempfile::tempdir().expect("tempdir");
    let ckpt = root.path().join("checkpoint");
    let algo = AlgoConfig::Sac(SacConfig {
        net_arch: vec![8, 8],
        batch_size: 8,
        buffer_size: 400,
        learning_starts: 20,
        ..SacConfig::default()
    });
    let config = {
        let mut c = TrainerConfig::new(0, Steps::Steps(60));
        c.final_eval_episodes = 1;
        c
    };
    let build = || {
        let agent = algo.build(3, 1, 0).expect("agent");
        Trainer::new(agent, Pendulum::new(), Pendulum::new(), config.clone()).expect("trainer")
    };
    let mut trainer = build().with_checkpoint_dir(&ckpt);
    trainer.run(&mut NoHooks).expect("a short run");
    // DEFENDER's dynamics model, as its environment saves it, beside the trainer's files.
    let dynamics_dir = ckpt.join("env/dynamics");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let dyn_config = defender::DynamicsConfig {
        hidden: vec![8],
        buffer_size: 64,
        batch_size: 4,
        learning_starts: 4,
        ..Default::default()
    };
    let mut model = defender::DynamicsModel::new(3, 1, dyn_config, &mut rng).expect("dynamics model");
    for t in 0..10 {
        let o = [t as f64, 0.5, -0.5];
        model.observe(&o, &[0.1], &[t as f64 + 1.0, 0.5, -0.5]).expect("observe");
    }
    model.save(&dynamics_dir).expect("save the dynamics model");
    // Rewrite the manifest with the dynamics files included.
    let mut names = Vec::new();
    list(&ckpt, &ckpt, &mut names);
    names.retain(|n| n != "manifest.json");
    names.sort();
    write_manifest(&ckpt, &names);
    let originals: Vec<Vec<u8>> = names.iter().map(|n| std::fs::read(ckpt.join(n)).expect("read")).collect();
    let manifest = std::fs::read(ckpt.join("manifest.json")).expect("manifest");
    let seeds: Vec<Vec<u8>> = originals
        .iter()
        .enumerate()
        .map(|(i, bytes)| {
            let mut v = vec![i as u8];
            v.extend_from_slice(bytes);
            v
        })
        .collect();
    let max_len = originals.iter().map(Vec::len).max().unwrap_or(0) + 1024;
    run("checkpoint", seeds, budget, max_len, 64 << 20, &mut |input| {
        let Some((&pick, bytes)) = input.split_first() else { return false };
        let which = usize::from(pick & 0x7f) % names.len();
        let file = ckpt.join(&names[which]);
        std::fs::write(&file, bytes).expect("write the input");
        if pick & 0x80 == 0 {
            write_manifest(&ckpt, &names);
        }
        let ok = if names[which].starts_with("env/dynamics/") {
            defender_rl::checkpoint::verify(&ckpt).is_ok()
                && defender::DynamicsModel::load(&dynamics_dir).is_ok()
        } else {
            let mut t = build();
            t.resume(&ckpt, &mut NoHooks).is_ok()
        };
        std::fs::write(&file, &originals[which]).expect("restore");
        std::fs::write(ckpt.join("manifest.json"), &manifest).expect("restore the manifest");
        ok
    })
}

fn list(root: &Path, dir: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).expect("read_dir") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            list(root, &path, out);
        } else {
            let rel = path.strip_prefix(root).expect("inside").to_string_lossy().replace('\\', "/");
            out.push(rel);
        }
    }
}

fn write_manifest(dir: &Path, names: &[String]) {
    let files: serde_json::Map<String, serde_json::Value> = names
        .iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(n)).expect("read");
            (n.clone(), serde_json::json!({"bytes": bytes.len(), "crc32": format!("{:08x}", crc32(&bytes))}))
        })
        .collect();
    let manifest = serde_json::json!({"format": 1, "files": files});
    std::fs::write(dir.join("manifest.json"), serde_json::to_vec(&manifest).expect("json"))
        .expect("manifest");
}

// ---------------------------------------------------------------------------------------------

#[cfg(test)]
mod tests {
    use super::*;

    /// The smoke run in `make test`: a few seconds per target.
    fn smoke() -> Budget {
        Budget { iterations: 3_000, seconds: 4.0 }
    }

    /// The long run: `DEFENDER_FUZZ_SECONDS` / `DEFENDER_FUZZ_ITERATIONS` per target.
    fn long() -> Budget {
        let get = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok()).unwrap_or(d);
        Budget {
            iterations: get("DEFENDER_FUZZ_ITERATIONS", 1e9) as u64,
            seconds: get("DEFENDER_FUZZ_SECONDS", 300.0),
        }
    }

    #[test]
    fn crc32_is_zips() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn fuzz_smoke_episode_set() {
        eprintln!("{}", episode_set(smoke()));
    }

    #[test]
    fn fuzz_smoke_npy_arrays() {
        eprintln!("{}", npy_arrays(smoke()));
    }

    #[test]
    fn fuzz_smoke_config() {
        eprintln!("{}", config(smoke()));
    }

    #[test]
    fn fuzz_smoke_strategy() {
        eprintln!("{}", strategy(smoke()));
    }

    #[test]
    fn fuzz_smoke_checkpoint() {
        eprintln!("{}", checkpoint(Budget { iterations: 400, seconds: 4.0 }));
    }

    #[test]
    #[ignore = "the long fuzzing budgets of docs/benchmarks.md; minutes per target"]
    fn fuzz_long() {
        let which = std::env::var("DEFENDER_FUZZ_TARGET").unwrap_or_default();
        type Target = fn(Budget) -> Report;
        let targets: [(&str, Target); 5] = [
            ("episode_set", episode_set),
            ("npy_arrays", npy_arrays),
            ("config", config),
            ("strategy", strategy),
            ("checkpoint", checkpoint),
        ];
        for (name, target) in targets {
            if which.is_empty() || which == name {
                eprintln!("{}", target(long()));
            }
        }
    }
}
