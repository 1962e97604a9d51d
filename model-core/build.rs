//! Compiles the gain table into model-core: reads `gains.toml` at the workspace root (or the
//! file named by `BEAM_GAIN_TABLE`), validates it, and writes `GAIN_TABLE` to OUT_DIR.
//! A bad table fails the build with the file, row and field in the message.
use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(
        std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    );
    let path = std::env::var_os("BEAM_GAIN_TABLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("..").join("gains.toml"));
    println!("cargo:rerun-if-env-changed=BEAM_GAIN_TABLE");
    println!("cargo:rerun-if-changed={}", path.display());
    let rows = match gain_table::load(&path) {
        Ok(rows) => rows,
        Err(e) => {
            eprintln!("error: invalid gain table: {e}");
            println!("cargo:warning=invalid gain table: {e}");
            std::process::exit(1);
        }
    };
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join("gain_table.rs");
    std::fs::write(&out, gain_table::generate_rust(&rows)).expect("write OUT_DIR/gain_table.rs");
}
