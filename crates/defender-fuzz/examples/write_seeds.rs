//! Writes the built seeds of every target into `fuzz/corpus/<target>/` (see `defender_fuzz::seeds`).

use std::path::Path;

fn main() -> std::io::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    for target in defender_fuzz::TARGETS {
        let seeds = defender_fuzz::seeds::built(target.name);
        if seeds.is_empty() {
            continue;
        }
        let dir = root.join(target.name);
        std::fs::create_dir_all(&dir)?;
        for (name, bytes) in seeds {
            std::fs::write(dir.join(&name), bytes)?;
        }
        println!("{}: {}", target.name, dir.display());
    }
    Ok(())
}
