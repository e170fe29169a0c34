//! Checkpoints: a trainer's (SAC on Pendulum: networks, targets, Adam state, replay buffer, JSON
//! state, trainer state) and DEFENDER's dynamics model files beside it, as a resumed run reads them.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use defender_rl::classic::Pendulum;
use defender_rl::{AlgoConfig, Budget, NoHooks, SacConfig, Trainer, TrainerConfig};
use rand::SeedableRng;

use crate::files::crc32;
use crate::scratch;

/// A real checkpoint on disk, and its files' names and bytes as written.
struct Fixture {
    dir: PathBuf,
    names: Vec<String>,
    originals: Vec<Vec<u8>>,
    manifest: Vec<u8>,
}

fn algo() -> AlgoConfig {
    AlgoConfig::Sac(SacConfig {
        net_arch: vec![8, 8],
        batch_size: 8,
        buffer_size: 400,
        learning_starts: 20,
        ..SacConfig::default()
    })
}

fn trainer() -> Trainer<Box<dyn defender_rl::Agent>, Pendulum, Pendulum> {
    let mut config = TrainerConfig::new(0, Budget::Steps(60));
    config.final_eval_episodes = 1;
    let agent = algo().build(3, 1, 0).expect("SAC on Pendulum builds");
    Trainer::new(agent, Pendulum::new(), Pendulum::new(), config).expect("the trainer builds")
}

fn dynamics_dir(ckpt: &Path) -> PathBuf {
    ckpt.join("env/dynamics")
}

/// Trains 60 steps of SAC into a checkpoint and saves a small dynamics model beside it, with a
/// manifest naming every file.
fn build_fixture() -> Fixture {
    let dir = scratch::dir().join("checkpoint");
    let mut t = trainer().with_checkpoint_dir(&dir);
    t.run(&mut NoHooks).expect("a short run");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let config = defender::DynamicsConfig {
        hidden: vec![8],
        buffer_size: 64,
        batch_size: 4,
        learning_starts: 4,
        ..Default::default()
    };
    let mut model = defender::DynamicsModel::new(3, 1, config, &mut rng).expect("a dynamics model");
    for t in 0..10 {
        let o = [f64::from(t), 0.5, -0.5];
        model.observe(&o, &[0.1], &[f64::from(t) + 1.0, 0.5, -0.5]).expect("observe");
    }
    model.save(dynamics_dir(&dir)).expect("save the dynamics model");
    let mut names = Vec::new();
    list(&dir, &dir, &mut names);
    names.retain(|n| n != "manifest.json");
    names.sort();
    write_manifest(&dir, &names);
    let originals = names.iter().map(|n| std::fs::read(dir.join(n)).expect("read back")).collect();
    let manifest = std::fs::read(dir.join("manifest.json")).expect("read back the manifest");
    Fixture { dir, names, originals, manifest }
}

fn fixture() -> &'static Mutex<Fixture> {
    static FIXTURE: OnceLock<Mutex<Fixture>> = OnceLock::new();
    FIXTURE.get_or_init(|| Mutex::new(build_fixture()))
}

/// The checkpoint's files as seeds: each one's index, then its bytes.
pub fn seeds() -> Vec<Vec<u8>> {
    let f = fixture().lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    f.originals
        .iter()
        .enumerate()
        .map(|(i, bytes)| {
            let mut v = vec![i as u8];
            v.extend_from_slice(bytes);
            v
        })
        .collect()
}

/// One file of the checkpoint replaced: the first byte picks which (low 7 bits); with its top bit
/// clear the manifest is rewritten to match, so that the loaders behind the checksum see the
/// bytes, and with it set the manifest is left stale, so that the verification does. Then the
/// run resumes from it (a dynamics file: the model loads from it).
pub fn checkpoint(data: &[u8]) -> bool {
    let Some((&pick, bytes)) = data.split_first() else { return false };
    let f = fixture().lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let which = usize::from(pick & 0x7f) % f.names.len();
    let file = f.dir.join(&f.names[which]);
    if std::fs::write(&file, bytes).is_err() {
        return false;
    }
    if pick & 0x80 == 0 {
        write_manifest(&f.dir, &f.names);
    }
    let ok = if f.names[which].starts_with("env/dynamics/") {
        defender_rl::checkpoint::verify(&f.dir).is_ok()
            && defender::DynamicsModel::load(dynamics_dir(&f.dir)).is_ok()
    } else {
        trainer().resume(&f.dir, &mut NoHooks).is_ok()
    };
    let restored = std::fs::write(&file, &f.originals[which])
        .and_then(|()| std::fs::write(f.dir.join("manifest.json"), &f.manifest));
    // Every later input assumes the fixture intact: a failure to restore it is the harness's.
    restored.expect("restore the checkpoint");
    ok
}

fn list(root: &Path, dir: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).expect("list the checkpoint") {
        let path = entry.expect("a checkpoint entry").path();
        if path.is_dir() {
            list(root, &path, out);
        } else {
            let rel = path.strip_prefix(root).expect("inside the checkpoint");
            out.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
}

/// `manifest.json` naming `names` with their sizes and CRCs (the checkpoint format's own).
fn write_manifest(dir: &Path, names: &[String]) {
    let files: serde_json::Map<String, serde_json::Value> = names
        .iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(n)).unwrap_or_default();
            let entry = serde_json::json!({"bytes": bytes.len(), "crc32": format!("{:08x}", crc32(&bytes))});
            (n.clone(), entry)
        })
        .collect();
    let manifest = serde_json::json!({"format": 1, "files": files});
    std::fs::write(dir.join("manifest.json"), manifest.to_string()).expect("write the manifest");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_of_the_checkpoint_resumes_as_written_and_a_truncated_one_is_refused() {
        for seed in seeds() {
            assert!(checkpoint(&seed), "file {}", seed[0]);
            let stale = [&[seed[0] | 0x80][..], &seed[1..seed.len() / 2]].concat();
            assert!(!checkpoint(&stale), "file {}", seed[0]);
        }
    }
}
