//! The repository's shipped gain table, loaded at run time as the host tools load a table:
//! the drive configuration the tests run against where they want the shipped gains.

use model_core::DriveTable;
use std::sync::OnceLock;

/// The shipped `gains.toml`, loaded once.
pub fn shipped() -> &'static DriveTable<'static> {
    static TABLE: OnceLock<&'static DriveTable<'static>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
        gain_table::open(&path)
            .expect("the shipped gain table loads")
            .leak()
    })
}
