//! The dynamics model's behaviour: learning, schedules, refusals, checkpoints.

use super::*;

/// A linear system s' = A s + B a with a known answer.
fn step(s: &[f64], a: &[f64]) -> Vec<f64> {
    vec![0.9 * s[0] + 0.1 * s[1] + 0.5 * a[0], -0.2 * s[0] + 0.95 * s[1] + 0.3 * a[0], s[2] + 0.05]
}

fn small_config() -> DynamicsConfig {
    DynamicsConfig {
        hidden: vec![64, 64],
        batch_size: 64,
        buffer_size: 5000,
        learning_rate: 1e-3,
        train_freq: 1,
        ..Default::default()
    }
}

#[test]
fn learns_a_linear_system_and_tracks_its_error() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
    let mut s = vec![0.5, -0.5, 0.0];
    let mut first = None;
    for t in 0..3000 {
        let a = [rng.random_range(-1.0..1.0)];
        let n = step(&s, &a);
        m.observe(&s, &a, &n).unwrap();
        if t == 99 {
            first = Some(m.prediction_error().mean);
        }
        s = if t % 50 == 49 {
            vec![rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0]
        } else {
            n
        };
    }
    let err = m.prediction_error();
    assert_eq!(err.count, 3000);
    assert_eq!(m.gradient_steps(), 3000, "one gradient step per real step");
    let first = first.unwrap();
    assert!(err.ema < first / 10.0, "the error falls: first 100 mean {first}, now ema {}", err.ema);
    let s = [0.2, 0.1, 1.0];
    let p = m.predict(&s, &[0.5]).unwrap();
    let truth = step(&s, &[0.5]);
    for k in 0..3 {
        assert!((p[k] - truth[k]).abs() < 0.05, "{p:?} vs {truth:?}");
    }
}

#[test]
fn train_freq_and_gradient_steps_are_honoured() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let cfg = DynamicsConfig { train_freq: 4, gradient_steps: 2, learning_starts: 8, ..small_config() };
    let mut m = DynamicsModel::new(3, 1, cfg, &mut rng).unwrap();
    for t in 0..20 {
        let s = [t as f64, 0.0, 0.0];
        m.observe(&s, &[0.0], &step(&s, &[0.0])).unwrap();
    }
    // Rounds at real steps 8, 12, 16, 20 (buffer >= 8): 4 rounds x 2 steps.
    assert_eq!(m.gradient_steps(), 8);
    assert!(m.last_loss().is_finite());
}

#[test]
fn bad_transitions_are_refused() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
    assert!(m.observe(&[0.0; 2], &[0.0], &[0.0; 3]).is_err());
    assert!(m.observe(&[0.0; 3], &[0.0; 2], &[0.0; 3]).is_err());
    assert!(m.observe(&[0.0; 3], &[f64::NAN], &[0.0; 3]).is_err());
    assert_eq!(m.buffer_len(), 0);
    assert!(DynamicsModel::new(3, 1, DynamicsConfig { batch_size: 0, ..small_config() }, &mut rng).is_err());
}

/// Sizes that would abort the process (a failed allocation) or panic (a capacity overflow)
/// when the model is built are refused by `validate`, naming the key.
#[test]
fn sizes_beyond_memory_are_refused_by_name() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for (config, key) in [
        (DynamicsConfig { hidden: vec![1 << 40], ..small_config() }, "hidden = [1099511627776]"),
        (DynamicsConfig { hidden: vec![3, 1 << 33], ..small_config() }, "hidden = [3, 8589934592]"),
        (DynamicsConfig { batch_size: 1 << 62, ..small_config() }, "batch_size = 4611686018427387904"),
    ] {
        let err = DynamicsModel::new(3, 1, config, &mut rng).unwrap_err().to_string();
        assert!(err.contains(key), "{err}");
    }
}

#[test]
fn save_and_load_continue_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
    let mut s = vec![0.1, 0.2, 0.0];
    for _ in 0..100 {
        let a = [rng.random_range(-1.0..1.0)];
        let n = step(&s, &a);
        m.observe(&s, &a, &n).unwrap();
        s = n;
    }
    let dir = tempfile::tempdir().unwrap();
    m.save(dir.path()).unwrap();
    let mut back = DynamicsModel::load(dir.path()).unwrap();
    for _ in 0..50 {
        let a = [rng.random_range(-1.0..1.0)];
        let n = step(&s, &a);
        m.observe(&s, &a, &n).unwrap();
        back.observe(&s, &a, &n).unwrap();
        s = n;
    }
    assert_eq!(m.predict(&s, &[0.3]).unwrap(), back.predict(&s, &[0.3]).unwrap());
    assert_eq!(m.prediction_error(), back.prediction_error());
    assert_eq!(m.gradient_steps(), back.gradient_steps());
    std::fs::remove_file(dir.path().join("dynamics_buffer.bin")).unwrap();
    assert!(DynamicsModel::load(dir.path()).unwrap_err().to_string().contains("dynamics_buffer.bin"));
}

/// `observe`s `n` transitions of the linear system from a fixed start; returns the last state.
fn feed(m: &mut DynamicsModel, rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    let mut s = vec![0.1, 0.2, 0.0];
    for _ in 0..n {
        let a = [rng.random_range(-1.0..1.0)];
        let next = step(&s, &a);
        m.observe(&s, &a, &next).unwrap();
        s = next;
    }
    s
}

/// Rewrites a checkpoint saved in the current format into the format written before the
/// transition store was a replay buffer: the store as `dynamics_buffer.npz` in ring order with
/// `pos` and `len` in the JSON, and the RNG as `rng_seed`, `rng_stream` and `rng_word_pos`.
fn to_legacy_format(m: &DynamicsModel, dir: &std::path::Path, transitions: &[(Vec<f64>, f64, Vec<f64>)]) {
    let cap = m.config.buffer_size;
    let len = transitions.len().min(cap);
    let pos = transitions.len() % cap;
    let (mut obs, mut act, mut next) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..len {
        // Ring row i holds the latest transition t with t % cap == i.
        let t = (i..transitions.len()).step_by(cap).next_back().unwrap();
        obs.extend(transitions[t].0.iter().map(|&v| v as f32));
        act.push(transitions[t].1 as f32);
        next.extend(transitions[t].2.iter().map(|&v| v as f32));
    }
    let npz_path = dir.join("dynamics_buffer.npz");
    crate::atomic::write_atomic(&npz_path, |w| {
        let mut npz = crate::npz::NpzWriter::new(w, &npz_path);
        npz.write("obs", &[len, 3], &obs)?;
        npz.write("act", &[len, 1], &act)?;
        npz.write("next_obs", &[len, 3], &next)?;
        npz.finish()?;
        Ok(())
    })
    .unwrap();
    std::fs::remove_file(dir.join("dynamics_buffer.bin")).unwrap();
    let json = dir.join("dynamics_state.json");
    let mut state: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let s = state.as_object_mut().unwrap();
    assert!(s.remove("rng").is_some());
    s.insert("pos".into(), pos.into());
    s.insert("len".into(), len.into());
    s.insert("rng_seed".into(), m.rng.get_seed().to_vec().into());
    s.insert("rng_stream".into(), m.rng.get_stream().into());
    s.insert("rng_word_pos".into(), m.rng.get_word_pos().to_string().into());
    std::fs::write(&json, serde_json::to_vec_pretty(&state).unwrap()).unwrap();
}

/// Checkpoints of runs started before the store became a replay buffer still load, and the
/// model goes on bit for bit, with a ring that has wrapped (the next write mid-ring) and one
/// that has not.
#[test]
fn checkpoints_of_the_earlier_format_load_and_continue_bit_for_bit() {
    for n in [40, 100] {
        let cfg = DynamicsConfig { buffer_size: 64, batch_size: 16, hidden: vec![16], ..small_config() };
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut m = DynamicsModel::new(3, 1, cfg, &mut rng).unwrap();
        let mut transitions = Vec::new();
        let mut s = vec![0.1, 0.2, 0.0];
        for _ in 0..n {
            let a = rng.random_range(-1.0..1.0);
            let next = step(&s, &[a]);
            m.observe(&s, &[a], &next).unwrap();
            transitions.push((s, a, next.clone()));
            s = next;
        }
        let dir = tempfile::tempdir().unwrap();
        m.save(dir.path()).unwrap();
        to_legacy_format(&m, dir.path(), &transitions);
        let mut back = DynamicsModel::load(dir.path()).unwrap();
        assert_eq!(back.buffer_len(), n.min(64));
        let mut actions = ChaCha8Rng::seed_from_u64(10);
        let (end_m, end_back) = (feed(&mut m, &mut actions.clone(), 50), feed(&mut back, &mut actions, 50));
        assert_eq!(end_m, end_back);
        assert_eq!(m.last_loss().to_bits(), back.last_loss().to_bits(), "n = {n}");
        assert_eq!(m.predict(&s, &[0.3]).unwrap(), back.predict(&s, &[0.3]).unwrap());
        assert_eq!(m.prediction_error(), back.prediction_error());
        // Saved again, it is in the current format, with no stale store beside it.
        back.save(dir.path()).unwrap();
        assert!(!dir.path().join("dynamics_buffer.npz").exists());
        let text = std::fs::read_to_string(dir.path().join("dynamics_state.json")).unwrap();
        assert!(text.contains("\"word_pos\"") && !text.contains("rng_word_pos"), "{text}");
    }
}

/// An earlier checkpoint whose `pos` and `len` contradict its ring is refused, naming the file.
#[test]
fn an_inconsistent_earlier_checkpoint_is_refused() {
    let cfg = DynamicsConfig { buffer_size: 64, batch_size: 16, hidden: vec![16], ..small_config() };
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut m = DynamicsModel::new(3, 1, cfg, &mut rng).unwrap();
    let transitions: Vec<_> =
        (0..10).map(|t| (vec![t as f64, 0.0, 0.0], 0.1, vec![t as f64 + 1.0, 0.0, 0.0])).collect();
    for (s, a, n) in &transitions {
        m.observe(s, &[*a], n).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    m.save(dir.path()).unwrap();
    to_legacy_format(&m, dir.path(), &transitions);
    let json = dir.path().join("dynamics_state.json");
    let text = std::fs::read_to_string(&json).unwrap().replace("\"pos\": 10", "\"pos\": 3");
    std::fs::write(&json, text).unwrap();
    let err = DynamicsModel::load(dir.path()).unwrap_err().to_string();
    assert!(err.contains("dynamics_buffer.npz") && err.contains("pos 3"), "{err}");
}
