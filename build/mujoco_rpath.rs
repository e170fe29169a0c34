//! Build script shared by every crate whose tests, benches or binaries link `libmujoco.so`.
//!
//! It embeds the folder named by `MUJOCO_DYNAMIC_LINK_DIR` (set by `.cargo/config.toml` to the
//! runtime `make setup` extracts, or by the user) as an rpath, so that those executables run
//! without `LD_LIBRARY_PATH`. `rustc-link-arg` applies to this package's own executables only,
//! hence one line in each such crate's Cargo.toml: `build = "../../build/mujoco_rpath.rs"`.
fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    if let Ok(dir) = std::env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
