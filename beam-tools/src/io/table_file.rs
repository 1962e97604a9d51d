//! Which gain table a command runs with, loaded at run time: the file given (`--table`), or
//! the one the firmware is built from: `BEAM_GAIN_TABLE` if set (a relative path taken from
//! the repository's root, as the firmware's build takes it), else the repository's
//! `gains.toml`. Only the path is known when the tool is built; the file is read when it
//! runs, so editing a table rebuilds nothing on the host.

use anyhow::Context;
use model_core::DriveTable;
use std::path::{Path, PathBuf};

/// The repository this tool was built in.
fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The table a command takes when none is given: `BEAM_GAIN_TABLE` if set (relative to the
/// repository's root, as the firmware's build reads it), else the repository's `gains.toml`;
/// `None` if that file does not exist (a tool moved away from its repository).
pub fn default_table_path() -> Option<PathBuf> {
    let path = std::env::var_os("BEAM_GAIN_TABLE")
        .filter(|p| !p.is_empty())
        .map(|p| repository().join(p))
        .unwrap_or_else(|| repository().join("gains.toml"));
    path.exists().then_some(path)
}

/// Loads and builds the table at `path` (plant, rows, the observer laws' designs), for the
/// rest of the run.
pub fn load_table(path: &Path) -> anyhow::Result<&'static DriveTable<'static>> {
    let loaded =
        gain_table::open(path).with_context(|| format!("gain table {}", path.display()))?;
    Ok(loaded.leak())
}

/// The table at `given`, or the default one ([`default_table_path`]); `None` if neither
/// exists.
pub fn table_or_default(
    given: Option<&Path>,
) -> anyhow::Result<Option<&'static DriveTable<'static>>> {
    match given.map(Path::to_path_buf).or_else(default_table_path) {
        Some(path) => load_table(&path).map(Some),
        None => Ok(None),
    }
}

/// The table at `given` or the default one, which a command that builds a drive needs.
pub fn required_table(given: Option<&Path>) -> anyhow::Result<&'static DriveTable<'static>> {
    table_or_default(given)?.context(
        "no gain table: give --table FILE (the repository's gains.toml is not where this tool \
         was built)",
    )
}
