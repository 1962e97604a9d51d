//! The gain-table parser on arbitrary text: never a panic; a table that parses renders to
//! text that parses to the same table, and builds into a drive's configuration (its plant's
//! model, its observer designs) or says why not, and a table that builds generates the
//! board's source.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(table) = gain_table::parse(text, "fuzz.toml") {
        let again = gain_table::parse(&gain_table::render(&table), "rendered.toml")
            .expect("a rendered table parses");
        assert_eq!(table, again);
        if let Ok(built) = table.drive_table() {
            let source = gain_table::generate_rust(&built);
            assert!(source.contains("pub const DRIVE"));
        }
    }
});
