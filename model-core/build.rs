//! Compiles the gain table into model-core: reads `gains.toml` at the workspace root (or the
//! file named by `BEAM_GAIN_TABLE`, a relative path taken from the workspace root),
//! validates it, computes its plant's modal model on its payload grid, and writes `PLANT` and
//! `GAIN_TABLE` to OUT_DIR. A bad table fails the build with the file, row and field in the
//! message.
use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(
        std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    );
    let root = manifest.join("..");
    // Cargo runs build scripts in the package's directory, not where the user typed the
    // command: a relative path is taken from the workspace root, as the docs say.
    let path = std::env::var_os("BEAM_GAIN_TABLE")
        .filter(|p| !p.is_empty())
        .map(|p| root.join(p))
        .unwrap_or_else(|| root.join("gains.toml"));
    println!("cargo:rerun-if-env-changed=BEAM_GAIN_TABLE");
    println!("cargo:rerun-if-changed={}", path.display());
    let table = gain_table::load(&path).unwrap_or_else(|e| fail(e));
    let source = gain_table::generate_rust(&table).unwrap_or_else(|e| {
        fail(gain_table::TableError {
            file: path.display().to_string(),
            ..e
        })
    });
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join("gain_table.rs");
    std::fs::write(&out, source).expect("write OUT_DIR/gain_table.rs");
}

fn fail(e: gain_table::TableError) -> ! {
    eprintln!("error: invalid gain table: {e}");
    println!("cargo:warning=invalid gain table: {e}");
    std::process::exit(1);
}
