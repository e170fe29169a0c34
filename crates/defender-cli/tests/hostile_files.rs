//! Hostile episode-set files through the `defender` binary, as a user meets them (`ablate
//! --demos`): a deflate bomb, a header declaring 10^12 elements, `ep_len` values whose sum
//! overflows or that are negative, an archive lying about its sizes, an `.npy` header length of
//! 600 MB. Each is refused at once with an error naming the file, the array and what was
//! expected; none panics or allocates what the file declares.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::python;

/// Writes the hostile files into `dir` (Python: numpy for the valid arrays, the zip container by
/// hand so that it can declare what it likes).
const MAKE: &str = r#"
import sys, struct, zlib, io, numpy as np
d = sys.argv[1]

def npy_header(descr, shape):
    shape_s = "(" + "".join(f"{s}, " for s in shape).rstrip(" ") + ")" if len(shape) != 1 else f"({shape[0]},)"
    text = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (descr, shape_s)
    pad = 64 - (10 + len(text) + 1) % 64
    text = text + " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode()

def npy(a):
    b = io.BytesIO()
    np.save(b, a)
    return b.getvalue()

def zip_file(path, entries):
    """entries: (name, method, crc, uncompressed_size, payload)."""
    out, central = bytearray(), bytearray()
    for name, method, crc, size, payload in entries:
        n = name.encode()
        offset = len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, method, 0, 0x21, crc, len(payload), size, len(n), 0) + n
        out += payload
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, method, 0, 0x21, crc, len(payload), size, len(n), 0, 0, 0, 0, 0, offset) + n
    cd_offset = len(out)
    out += central
    out += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(entries), len(entries), len(central), cd_offset, 0)
    open(path, "wb").write(out)

def stored(name, data):
    return (name + ".npy", 0, zlib.crc32(data), len(data), data)

def valid(**override):
    arrays = dict(obs=np.ones((5, 3), np.float32), act=np.zeros((3, 2), np.float32), rew=np.zeros(3, np.float32),
                  ep_len=np.array([2, 1]), crashed=np.array([False, True]))
    return [stored(k, override[k] if k in override else npy(v)) for k, v in arrays.items()]

# A deflate bomb: obs declares 5e7 x 9 float32 (1.8 GB) and really inflates to it, from ~1.8 MB.
header = npy_header("<f4", (50_000_000, 9))
c = zlib.compressobj(9, zlib.DEFLATED, -15)
head = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH)
c = zlib.compressobj(9, zlib.DEFLATED, -15)
block = c.compress(bytes(1_000_000)) + c.flush(zlib.Z_FULL_FLUSH)
stream = head + block * 1800 + b"\x03\x00"
bomb = ("obs.npy", 8, 0, len(header) + 1_800_000_000, stream)
zip_file(d + "/bomb.npz", [bomb] + valid()[1:])

# A header declaring 10^12 elements over 12 bytes of data.
zip_file(d + "/huge.npz", valid(rew=npy_header("<f4", (10**12,)) + bytes(12)))

# ep_len whose sum overflows 64 bits, and a negative one.
big = np.array([2**63 - 1] * 3, dtype=np.int64)
zip_file(d + "/overflow.npz", valid(ep_len=npy(big), crashed=npy(np.array([False, True, True]))))
zip_file(d + "/negative.npz", valid(ep_len=npy(np.array([-1, 4]))))

# A version-3 .npy preamble declaring a 600 MB header (numpy reads at most 10000 bytes).
zip_file(d + "/big_header.npz", valid(rew=b"\x93NUMPY\x03\x00" + struct.pack("<I", 600_000_000) + b"{'descr': '<f4'"))

# An archive whose directory claims 10^9 bytes inflated from a few compressed ones.
small = zlib.compressobj(9, zlib.DEFLATED, -15)
payload = small.compress(npy(np.zeros(3, np.float32))) + small.flush()
zip_file(d + "/liar.npz", valid()[:2] + [("rew.npy", 8, 0, 10**9, payload)] + valid()[3:])
"#;

#[test]
fn hostile_episode_sets_are_refused_at_once_naming_file_array_and_rule() {
    let dir = tempfile::tempdir().unwrap();
    let made = Command::new(python()).arg("-c").arg(MAKE).arg(dir.path()).output().unwrap();
    assert!(made.status.success(), "python: {}", String::from_utf8_lossy(&made.stderr));
    let bomb_len = std::fs::metadata(dir.path().join("bomb.npz")).unwrap().len();
    assert!(bomb_len < 2_500_000, "the bomb is small on disk: {bomb_len} bytes");
    let cases: &[(&str, &[&str])] = &[
        ("bomb.npz", &["array 'obs'", "5 rows", "[50000000, 9]"]),
        ("huge.npz", &["array 'rew'", "shape [1000000000000]", "4000000000000 bytes", "12 bytes"]),
        ("overflow.npz", &["array 'ep_len'", "overflows"]),
        ("negative.npz", &["array 'ep_len'", "N_i >= 1", "ep_len[0] = -1"]),
        ("liar.npz", &["array 'rew'", "more than compression can produce"]),
        ("big_header.npz", &["array 'rew'", "a header of 600000000 bytes"]),
    ];
    for (name, words) in cases {
        let file = dir.path().join(name);
        let file_s = file.to_str().unwrap();
        let out_csv = dir.path().join("scores.csv");
        let start = Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_defender"))
            .args(["ablate", "--demos", file_s, "--episodes", file_s, "--out", out_csv.to_str().unwrap()])
            .output()
            .unwrap();
        let took = start.elapsed();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: accepted\n{err}");
        assert_ne!(out.status.code(), Some(101), "{name}: panicked\n{err}");
        assert!(!err.contains("panicked"), "{name}: panicked\n{err}");
        assert!(err.contains(file_s), "{name}: the error names the file: {err}");
        for w in *words {
            assert!(err.contains(w), "{name}: the error should contain {w:?}: {err}");
        }
        assert!(took < Duration::from_secs(10), "{name}: refused only after {took:?}");
        assert!(!out_csv.exists(), "{name}: no output written");
    }
}
