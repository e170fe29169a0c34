//! Build script shared by every crate whose tests, benches or binaries link `libmujoco.so`.
//!
//! It embeds the folder named by `MUJOCO_DYNAMIC_LINK_DIR` (set by `.cargo/config.toml` to the
//! runtime `make setup` extracts, or by the user) as an rpath, so that those executables run
//! without `LD_LIBRARY_PATH`. `rustc-link-arg` applies to this package's own executables only,
//! hence a `build.rs` symlink to this file in each such crate (a symlink, not a `build =` path
//! outside the crate, so that `cargo package` and the sdist accept the crate).
//!
//! `DEFENDER_RPATH`, when set, replaces that folder: `make wheel` sets it to
//! `$ORIGIN/../../mujoco`, the installed `mujoco` package beside the wheel's `defender_rl`, so
//! that the shipped binary names no folder of the machine that built it.
fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    println!("cargo::rerun-if-env-changed=DEFENDER_RPATH");
    if std::env::var("DEFENDER_RPATH").is_ok() {
        // The wheel links against glibc 2.17's symbols (zig), and libmujoco.so itself needs newer
        // ones (powf@GLIBC_2.27): those are the mujoco package's requirement, checked by pip
        // through its own wheel tag, not ours; the linker is told not to hold them against us.
        println!("cargo::rustc-link-arg=-Wl,--allow-shlib-undefined");
    }
    let rpath = std::env::var("DEFENDER_RPATH").or_else(|_| std::env::var("MUJOCO_DYNAMIC_LINK_DIR"));
    if let Ok(dir) = rpath {
        println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
