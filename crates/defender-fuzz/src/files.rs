//! Building the files the targets feed by hand: `.npy` arrays, zip archives of stored entries with
//! correct CRCs (so that a mutated array reaches the `.npy` parser, not the zip checksum), a small
//! valid episode set, and a checkpoint's manifest.

/// The CRC-32 of zip files and of checkpoint manifests.
pub fn crc32(data: &[u8]) -> u32 {
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
pub fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
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
pub fn stored_zip(entries: &[(&str, Vec<u8>)]) -> Vec<u8> {
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
pub fn valid_arrays() -> Vec<(&'static str, Vec<u8>)> {
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
