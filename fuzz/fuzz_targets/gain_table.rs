//! The gain-table parser on arbitrary text: never a panic; a table that parses renders to
//! text that parses to the same rows.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(rows) = gain_table::parse(text, "fuzz.toml") {
        let again = gain_table::parse(&gain_table::render(&rows), "rendered.toml")
            .expect("a rendered table parses");
        assert_eq!(rows, again);
        let _ = gain_table::generate_rust(&rows);
    }
});
