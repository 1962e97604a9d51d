//! The generator run on bad table files, as the build script runs it: each must be refused
//! with the file, the row and (where there is one) the field in the message. Also checks the
//! shipped table.

use std::path::Path;

fn load(name: &str) -> gain_table::TableError {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name);
    gain_table::load(&path).unwrap_err()
}

#[test]
fn bad_fixtures_fail_with_row_and_field() {
    let e = load("bad_beta.toml");
    assert!(
        e.to_string()
            .ends_with("bad_beta.toml: row 2: field `beta`: -0.1 must be > 0"),
        "{e}"
    );
    let e = load("unsorted.toml");
    assert_eq!((e.row, e.field), (Some(2), Some("payload_kg")));
    let e = load("missing_field.toml");
    assert_eq!(e.row, Some(1));
    assert!(e.message.contains("missing field `cost_j`"), "{e}");
    let e = load("no_such_file.toml");
    assert!(e.to_string().contains("no_such_file.toml"), "{e}");
}

#[test]
fn the_shipped_table_is_valid_and_covers_0_25_50_g() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
    let rows = gain_table::load(&path).unwrap().rows;
    for controller in [gain_table::LawKind::Smc, gain_table::LawKind::SmcStrain] {
        for payload in [0.0, 0.025, 0.05] {
            assert!(
                rows.iter()
                    .any(|r| r.gains.kind() == controller && r.payload_kg == payload),
                "no {controller} row at {payload} kg"
            );
        }
    }
}

#[test]
fn the_shipped_table_is_in_rendered_form() {
    // `beam optimize --table` writes the file with `render`; a hand edit that drifts from
    // that form (key order, unused keys) shows up here, not as a noisy diff later.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let table = gain_table::parse(&text, "gains.toml").unwrap();
    assert_eq!(gain_table::render(&table), text);
}

#[test]
fn the_steel_example_table_names_its_parameter_file_as_its_plant() {
    // docs/steel: the table `beam optimize --params docs/steel/steel-strip.toml` wrote must
    // carry that file's beam, field for field, and compile.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let table = gain_table::load(&root.join("docs/steel/gains.toml")).unwrap();
    let text = std::fs::read_to_string(root.join("docs/steel/steel-strip.toml")).unwrap();
    let params: beam_model::BeamParams = toml::from_str(&text).unwrap();
    assert_eq!(table.plant.params, params);
    assert_eq!(table.plant.modes, 3);
    let source = gain_table::generate_rust(&table.drive_table().unwrap());
    assert!(source.contains("density_kg_m3: 7850.0"), "{source}");
}
