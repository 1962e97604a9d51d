//! Which laws this build of model-core holds (`law::ONLY_LAW`), and nothing else.
//!
//! Without the `drive-law-only` feature (the host, the PIL drive) every law is built in and
//! no table is read: the drive's configuration is passed in at run time
//! (`table::DriveTable`), and editing a gain table rebuilds nothing here. With it (the board,
//! `cargo fw`), the board holds only its table's `[drive] law`: this reads that one key of the
//! table the firmware is built from (`BEAM_GAIN_TABLE`, a relative path taken from the
//! workspace root, or the repository's `gains.toml`), so the other laws' code is left out.
//! The firmware's build validates the whole table.
use std::path::PathBuf;
use std::str::FromStr;

use beam_kinds::LawKind;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed=build.rs");
    let only = if std::env::var_os("CARGO_FEATURE_DRIVE_LAW_ONLY").is_some() {
        println!("cargo:rerun-if-env-changed=BEAM_GAIN_TABLE");
        let path = table_path();
        println!("cargo:rerun-if-changed={}", path.display());
        let law = drive_law(&path).unwrap_or_else(|e| {
            eprintln!("error: gain table {}: {e}", path.display());
            println!("cargo:warning=gain table {}: {e}", path.display());
            std::process::exit(1)
        });
        format!("Some(::beam_kinds::LawKind::{law:?})")
    } else {
        "None".to_string()
    };
    std::fs::write(out.join("only_law.rs"), only).expect("write OUT_DIR/only_law.rs");
}

/// The table the board is built from: as the firmware's build finds it.
fn table_path() -> PathBuf {
    let root = PathBuf::from(
        std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    )
    .join("..");
    std::env::var_os("BEAM_GAIN_TABLE")
        .filter(|p| !p.is_empty())
        .map(|p| root.join(p))
        .unwrap_or_else(|| root.join("gains.toml"))
}

/// The table's `[drive] law`, or the default drive's without one.
fn drive_law(path: &PathBuf) -> Result<LawKind, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| e.to_string())?;
    match table.get("drive").and_then(|d| d.get("law")) {
        None => Ok(LawKind::DEFAULT_DRIVE),
        Some(toml::Value::String(name)) => {
            LawKind::from_str(name).map_err(|e| format!("[drive] law: {e}"))
        }
        Some(v) => Err(format!("[drive] law: {v} is not a law's name")),
    }
}
