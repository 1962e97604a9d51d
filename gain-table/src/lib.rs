//! The gain table: one row of controller gains per operating point (payload), checked into
//! the repository as TOML, validated, and turned into `const` data for model-core.
//!
//! The same code serves three users: model-core's build script (a bad table fails the build
//! with a message naming the file, the row and the field), `beam optimize` (which appends or
//! replaces a row and writes the table back), and the tests (which feed it bad fixtures).
//! Rows are grouped by controller; within a controller they are sorted by payload with no
//! duplicates, so the controller can interpolate between neighbours at run time.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// Largest payload a row may describe, kg (the beam carries grams, not kilograms).
pub const MAX_PAYLOAD_KG: f64 = 1.0;

/// Controllers a row may be for.
pub const CONTROLLERS: [&str; 3] = ["pd", "smc", "smc-strain"];

/// Switching functions a row may use.
pub const SWITCHINGS: [&str; 3] = ["tanh", "sat", "sign"];

/// Presets a row may have been found for.
pub const PRESETS: [&str; 2] = ["table1", "aluminium"];

/// One gain set, as written in the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Row {
    /// Controller variant: `pd`, `smc` or `smc-strain`.
    pub controller: String,
    /// The payload (tip mass) this row is for, kg.
    pub payload_kg: f64,
    /// PD proportional gain, N m/rad (pd only).
    #[serde(default)]
    pub kp: f64,
    /// PD derivative gain, N m s/rad (pd only).
    #[serde(default)]
    pub kd: f64,
    /// SMC surface slope W, 1/s.
    #[serde(default)]
    pub w: f64,
    /// SMC switching gain A, rad/s^2.
    #[serde(default)]
    pub a: f64,
    /// SMC boundary-layer slope beta, s/rad.
    #[serde(default)]
    pub beta: f64,
    /// Strain blend c, rad per unit strain (smc-strain only).
    #[serde(default)]
    pub c: f64,
    /// Switching function: `tanh`, `sat` or `sign`.
    #[serde(default = "default_switching")]
    pub switching: String,
    /// smc-strain: keep the model terms.
    #[serde(default)]
    pub model_terms: bool,
    /// The preset the gains were found for.
    pub preset: String,
    /// Flexible modes of the model they were found with.
    pub modes: u32,
    /// The cost J they achieved (for the record).
    pub cost_j: f64,
}

fn default_switching() -> String {
    "tanh".to_string()
}

/// A rejected table: where and why.
#[derive(Clone, Debug, PartialEq)]
pub struct TableError {
    /// The file, as given.
    pub file: String,
    /// 1-based row number (`None` for a syntax error of the whole file).
    pub row: Option<usize>,
    /// The offending field, if one.
    pub field: Option<&'static str>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(r) = self.row {
            write!(f, ": row {r}")?;
        }
        if let Some(field) = self.field {
            write!(f, ": field `{field}`")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for TableError {}

/// Parses and validates the table text; `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<Vec<Row>, TableError> {
    let err = |row, field, message: String| TableError {
        file: file.to_string(),
        row,
        field,
        message,
    };
    // Syntax first (with the line), then each row on its own so schema errors name the row.
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let start = e.span().map_or(0, |s| s.start.min(text.len()));
        let line = text[..start].matches('\n').count() + 1;
        let rows_before = text[..start]
            .lines()
            .filter(|l| l.trim() == "[[row]]")
            .count();
        err(
            Some(rows_before).filter(|&n| n > 0),
            None,
            format!("line {line}: {}", e.message().trim()),
        )
    })?;
    if let Some(key) = table.keys().find(|k| k.as_str() != "row") {
        return Err(err(
            None,
            None,
            format!("unknown top-level key `{key}` (expected [[row]] tables)"),
        ));
    }
    let mut rows = Vec::new();
    if let Some(value) = table.get("row") {
        let list = value.as_array().ok_or_else(|| {
            err(
                None,
                None,
                "`row` must be an array of [[row]] tables".into(),
            )
        })?;
        for (i, v) in list.iter().enumerate() {
            let row = Row::deserialize(v.clone())
                .map_err(|e| err(Some(i + 1), None, e.message().trim().to_string()))?;
            rows.push(row);
        }
    }
    if rows.is_empty() {
        return Err(err(None, None, "the table has no [[row]]".into()));
    }
    for (i, r) in rows.iter().enumerate() {
        validate_row(r).map_err(|(field, message)| err(Some(i + 1), Some(field), message))?;
    }
    // Within each controller: strictly increasing payload.
    for (i, r) in rows.iter().enumerate() {
        if let Some(prev) = rows[..i]
            .iter()
            .rev()
            .find(|p| p.controller == r.controller)
        {
            if r.payload_kg == prev.payload_kg {
                return Err(err(
                    Some(i + 1),
                    Some("payload_kg"),
                    format!("duplicates an earlier {} row", r.controller),
                ));
            }
            if r.payload_kg < prev.payload_kg {
                return Err(err(
                    Some(i + 1),
                    Some("payload_kg"),
                    format!(
                        "rows of {} must be sorted by payload ({} after {})",
                        r.controller, r.payload_kg, prev.payload_kg
                    ),
                ));
            }
            for (field, same) in [
                ("switching", r.switching == prev.switching),
                ("model_terms", r.model_terms == prev.model_terms),
                ("preset", r.preset == prev.preset),
                ("modes", r.modes == prev.modes),
            ] {
                if !same {
                    return Err(err(
                        Some(i + 1),
                        Some(field),
                        "differs from the row before it: rows of one controller are interpolated, so they must agree".to_string(),
                    ));
                }
            }
        }
    }
    Ok(rows)
}

/// Checks one row's fields; `Err((field, why))`.
fn validate_row(r: &Row) -> Result<(), (&'static str, String)> {
    if !CONTROLLERS.contains(&r.controller.as_str()) {
        return Err((
            "controller",
            format!("`{}` is not one of {CONTROLLERS:?}", r.controller),
        ));
    }
    if !SWITCHINGS.contains(&r.switching.as_str()) {
        return Err((
            "switching",
            format!("`{}` is not one of {SWITCHINGS:?}", r.switching),
        ));
    }
    if !PRESETS.contains(&r.preset.as_str()) {
        return Err((
            "preset",
            format!("`{}` is not one of {PRESETS:?}", r.preset),
        ));
    }
    if !(1..=4).contains(&r.modes) {
        return Err(("modes", format!("{} is not 1 to 4", r.modes)));
    }
    let numbers = [
        ("payload_kg", r.payload_kg),
        ("kp", r.kp),
        ("kd", r.kd),
        ("w", r.w),
        ("a", r.a),
        ("beta", r.beta),
        ("c", r.c),
        ("cost_j", r.cost_j),
    ];
    for (field, v) in numbers {
        if !v.is_finite() {
            return Err((field, format!("{v} is not finite")));
        }
        // f32 at run time: keep well inside its range.
        if v.abs() > 1e9 {
            return Err((field, format!("{v} is out of range (|x| <= 1e9)")));
        }
    }
    if !(0.0..=MAX_PAYLOAD_KG).contains(&r.payload_kg) {
        return Err((
            "payload_kg",
            format!("{} is outside 0..={MAX_PAYLOAD_KG} kg", r.payload_kg),
        ));
    }
    if r.cost_j < 0.0 {
        return Err(("cost_j", "a cost cannot be negative".into()));
    }
    let positive = |field, v: f64| {
        if v > 0.0 {
            Ok(())
        } else {
            Err((field, format!("{v} must be > 0")))
        }
    };
    let non_negative = |field, v: f64| {
        if v >= 0.0 {
            Ok(())
        } else {
            Err((field, format!("{v} must be >= 0")))
        }
    };
    let unused = |field, v: f64| {
        if v == 0.0 {
            Ok(())
        } else {
            Err((
                field,
                format!("does not apply to {} (must be 0 or absent)", r.controller),
            ))
        }
    };
    match r.controller.as_str() {
        "pd" => {
            non_negative("kp", r.kp)?;
            non_negative("kd", r.kd)?;
            for (f, v) in [("w", r.w), ("a", r.a), ("beta", r.beta), ("c", r.c)] {
                unused(f, v)?;
            }
        }
        other => {
            positive("w", r.w)?;
            non_negative("a", r.a)?;
            positive("beta", r.beta)?;
            unused("kp", r.kp)?;
            unused("kd", r.kd)?;
            if other == "smc" {
                unused("c", r.c)?;
                if r.model_terms {
                    return Err(("model_terms", "applies to smc-strain only".into()));
                }
            }
        }
    }
    Ok(())
}

/// Reads and validates the table at `path`.
pub fn load(path: &Path) -> Result<Vec<Row>, TableError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| TableError {
        file: file.clone(),
        row: None,
        field: None,
        message: e.to_string(),
    })?;
    parse(&text, &file)
}

/// The table as TOML text, rows in the order given, with a header explaining the file.
pub fn render(rows: &[Row]) -> String {
    let mut out = String::from(
        "# Gain table compiled into model-core (and so into the firmware) by model-core/build.rs.\n\
         # One [[row]] per controller and payload; rows of a controller sorted by payload_kg.\n\
         # The controller interpolates gains between neighbouring payloads, clamped at the ends.\n\
         # Written by `beam optimize --table`; edit by hand with care: the build validates it.\n",
    );
    for r in rows {
        out.push('\n');
        out.push_str("[[row]]\n");
        out.push_str(&toml::to_string(r).unwrap_or_default());
    }
    out
}

/// Inserts `row`, replacing the row of the same controller and payload if there is one,
/// keeping each controller's rows sorted by payload.
pub fn upsert(rows: &mut Vec<Row>, row: Row) {
    if let Some(existing) = rows
        .iter_mut()
        .find(|r| r.controller == row.controller && r.payload_kg == row.payload_kg)
    {
        *existing = row;
        return;
    }
    let at = rows
        .iter()
        .rposition(|r| r.controller == row.controller && r.payload_kg < row.payload_kg)
        .map(|i| i + 1)
        .or_else(|| rows.iter().position(|r| r.controller == row.controller))
        .unwrap_or(rows.len());
    rows.insert(at, row);
}

/// Rust source defining `GAIN_TABLE: &[GainRow]` for model-core's `gains` module.
pub fn generate_rust(rows: &[Row]) -> String {
    let mut out =
        String::from("// Generated by model-core/build.rs from the gain table. Do not edit.\n");
    out.push_str("/// The compiled gain table, grouped by controller, sorted by payload.\n");
    out.push_str("pub const GAIN_TABLE: &[GainRow] = &[\n");
    for r in rows {
        let switching = match r.switching.as_str() {
            "sat" => "Switching::Sat",
            "sign" => "Switching::Sign",
            _ => "Switching::Tanh",
        };
        let law = match r.controller.as_str() {
            "pd" => format!("Law::Pd(PdGains {{ kp: {:?}, kd: {:?} }})", r.kp as f32, r.kd as f32),
            kind => format!(
                "Law::{}(SmcGains {{ w: {:?}, a: {:?}, beta: {:?}, c: {:?}, switching: {switching}, model_terms: {} }})",
                if kind == "smc" { "Smc" } else { "SmcStrain" },
                r.w as f32,
                r.a as f32,
                r.beta as f32,
                r.c as f32,
                r.model_terms
            ),
        };
        out.push_str(&format!(
            "    GainRow {{ payload_kg: {:?}, law: {law} }},\n",
            r.payload_kg as f32
        ));
    }
    out.push_str("];\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[[row]]
controller = "smc"
payload_kg = 0.0
w = 10.0
a = 1000.0
beta = 0.1
preset = "aluminium"
modes = 3
cost_j = 1.0

[[row]]
controller = "smc"
payload_kg = 0.05
w = 12.0
a = 900.0
beta = 0.1
preset = "aluminium"
modes = 3
cost_j = 2.0
"#;

    fn bad(from: &str, to: &str) -> TableError {
        assert!(GOOD.contains(from), "fixture lacks {from}");
        parse(&GOOD.replacen(from, to, 1), "gains.toml").unwrap_err()
    }

    #[test]
    fn a_good_table_round_trips() {
        let rows = parse(GOOD, "gains.toml").unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(parse(&render(&rows), "x").unwrap(), rows);
        assert!(generate_rust(&rows).contains("Law::Smc(SmcGains { w: 10.0, a: 1000.0"));
    }

    #[test]
    fn errors_name_the_file_row_and_field() {
        let e = bad("w = 12.0", "w = nan");
        assert_eq!((e.row, e.field), (Some(2), Some("w")));
        assert_eq!(
            e.to_string(),
            "gains.toml: row 2: field `w`: NaN is not finite"
        );
        assert_eq!(bad("beta = 0.1", "beta = 0.0").field, Some("beta"));
        assert_eq!(bad("w = 10.0", "w = -1.0").field, Some("w"));
        assert_eq!(
            bad("payload_kg = 0.05", "payload_kg = 0.0").message,
            "duplicates an earlier smc row"
        );
        let e = bad("payload_kg = 0.0\n", "payload_kg = 0.07\n");
        assert_eq!((e.row, e.field), (Some(2), Some("payload_kg")));
        assert_eq!(
            bad("controller = \"smc\"", "controller = \"lqr\"").field,
            Some("controller")
        );
        assert_eq!(bad("modes = 3", "modes = 7").field, Some("modes"));
        assert_eq!(
            bad("preset = \"aluminium\"", "preset = \"steel\"").field,
            Some("preset")
        );
        assert_eq!(bad("a = 900.0", "a = 900.0\nkp = 3.0").field, Some("kp"));
        // Syntax and schema errors still say where.
        let e = bad("w = 12.0", "w = \"fast\"");
        assert_eq!(e.row, Some(2));
        let e = bad("beta = 0.1\npreset", "beta = 0.1\ngain = 3\npreset");
        assert!(e.message.contains("unknown field"), "{e}");
        assert_eq!(
            parse("", "g.toml").unwrap_err().to_string(),
            "g.toml: the table has no [[row]]"
        );
    }

    #[test]
    fn upsert_replaces_or_inserts_in_payload_order() {
        let mut rows = parse(GOOD, "g").unwrap();
        let mut mid = rows[0].clone();
        mid.payload_kg = 0.025;
        upsert(&mut rows, mid.clone());
        assert_eq!(
            rows.iter().map(|r| r.payload_kg).collect::<Vec<_>>(),
            [0.0, 0.025, 0.05]
        );
        mid.w = 99.0;
        upsert(&mut rows, mid);
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[1].w, 99.0);
        assert!(parse(&render(&rows), "g").is_ok());
    }
}
