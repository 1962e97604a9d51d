//! The gain table: one row of controller gains per operating point (payload), checked into
//! the repository as TOML, validated, and made into the drive's configuration
//! ([`model_core::DriveTable`]): loaded at run time by the host tools ([`open`]), compiled in
//! as `const` data by the firmware's build ([`generate_rust`]).
//!
//! The same code serves these users: the firmware's build script (a bad table fails the build
//! with a message naming the file, the row and the field), the host tools (`beam simulate
//! --table`, `beam optimize`, which appends or replaces a row and writes the table back), and
//! the tests (which feed it bad fixtures).
//! Rows are grouped by controller; within a controller they are sorted by payload with no
//! duplicates, so the controller can interpolate between neighbours at run time.

use beam_kinds::GainRule;
pub use beam_kinds::{LawKind, Preset, Settings, ShaperKind, Switching};
use beam_kinds::{Search, Setting};
use beam_model::plant::PlantPoint;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The drive core the tables are built for (for a build script that has no dependency of its own on it).
pub use model_core;

mod drive;
mod drive_table;
mod plant;
pub use drive::{encoder_reads_the_hub, DriveSpec, ENCODER_TOP_RAD_S};
pub use drive_table::{design_at, generate_rust, open, LoadedTable};
pub use plant::{PlantParts, PlantSpec, DESIGN_STEP_KG, PLANT_STEP_KG};

/// A whole table: the plant its gains were designed for, the drive it configures, and the
/// rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// The `[plant]` table.
    pub plant: PlantSpec,
    /// The `[drive]` table (absent: the shipped drive's values, running the first row's law).
    pub drive: DriveSpec,
    /// The `[[row]]`s, grouped by controller, each group sorted by payload.
    pub rows: Vec<Row>,
}

/// Largest payload a row may describe, kg (the beam carries grams, not kilograms).
pub const MAX_PAYLOAD_KG: f64 = 1.0;

/// One gain set, as written in the file: what every row has, and the gains of its law.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The payload (tip mass) this row is for, kg.
    pub payload_kg: f64,
    /// The law (the row's `controller` key) and its gains.
    pub gains: Gains,
    /// The cost J they achieved (for the record).
    pub cost_j: f64,
    /// The input shaper designed with the gains (`shaper = "none"` or absent: none).
    pub shaper: ShaperRow,
}

/// A row's input shaper: keys `shaper`, `shaper_hz`, `shaper_damping`, `shaper_tolerance`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaperRow {
    /// The impulse train.
    pub kind: ShaperKind,
    /// The shaped mode's frequency, Hz.
    pub hz: f64,
    /// Its damping ratio.
    pub damping: f64,
    /// EI's vibration tolerance.
    pub tolerance: f64,
}

impl ShaperRow {
    /// No shaping.
    pub const NONE: ShaperRow = ShaperRow {
        kind: ShaperKind::None,
        hz: 0.0,
        damping: 0.0,
        tolerance: 0.05,
    };
}

/// The keys every row has besides `controller` and the gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Common {
    payload_kg: f64,
    cost_j: f64,
    #[serde(default)]
    shaper: ShaperKind,
    #[serde(default)]
    shaper_hz: f64,
    #[serde(default)]
    shaper_damping: f64,
    #[serde(default = "default_tolerance")]
    shaper_tolerance: f64,
}

fn default_tolerance() -> f64 {
    0.05
}

/// A law's gains as the table stores them (f64; the build rounds them to the f32 the drive
/// runs): the law (the row's `controller` key), its gains in the order of its specs
/// ([`LawKind::gains`], which name the row's keys) and its settings
/// ([`LawKind::settings`]). A row has exactly its law's keys, so `c` on an `smc` row is an
/// unknown field; nothing here names a law's gains.
#[derive(Clone, Debug, PartialEq)]
pub struct Gains {
    kind: LawKind,
    values: Vec<f64>,
    settings: Settings,
}

impl Gains {
    /// Law `kind`'s gains from `values` in the order of its specs (missing ones zero, extra
    /// ones dropped: a law's fixed-size values pass as they are) and its settings (only the
    /// law's own are kept).
    pub fn new(kind: LawKind, values: &[f64], settings: Settings) -> Gains {
        let n = kind.gain_names().len();
        let mut v: Vec<f64> = values.iter().copied().take(n).collect();
        v.resize(n, 0.0);
        Gains {
            kind,
            values: v,
            settings: settings.of(kind),
        }
    }

    /// The law these gains are for.
    pub fn kind(&self) -> LawKind {
        self.kind
    }

    /// The gains in the order of the law's specs.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The gains in the order of the law's specs, to edit.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// The settings (those the law does not have at their defaults). They cannot be
    /// interpolated between payloads, so all rows of a law must agree on them.
    pub fn settings(&self) -> Settings {
        self.settings
    }

    /// The gain `name`, if the law has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.kind.gain_index(name).map(|i| self.values[i])
    }

    /// The gains' numbers, named as in the file, in the specs' order.
    pub fn numbers(&self) -> Vec<(&'static str, f64)> {
        self.kind
            .gain_names()
            .iter()
            .copied()
            .zip(self.values.iter().copied())
            .collect()
    }

    /// The gains read from a row's keys (without `controller` and the common keys), by the
    /// law's specs. `Err((field, why))`.
    fn from_table(kind: LawKind, t: &toml::Table) -> Result<Self, (Option<&'static str>, String)> {
        let mut values: Vec<Option<f64>> = vec![None; kind.gain_names().len()];
        let mut settings = Settings::DEFAULT;
        for (key, v) in t {
            if let Some(i) = kind.gain_index(key) {
                let name = kind.gain_names()[i];
                values[i] = Some(match v {
                    toml::Value::Float(x) => *x,
                    toml::Value::Integer(x) => *x as f64,
                    other => {
                        return Err((
                            Some(name),
                            format!("expected a number, found {}", other.type_str()),
                        ))
                    }
                });
                continue;
            }
            let setting = kind.settings().iter().copied().find(|s| s.name() == key);
            match (setting, v) {
                (Some(Setting::Switching), toml::Value::String(name)) => {
                    settings.switching = name
                        .parse()
                        .map_err(|e| (Some("switching"), format!("`{name}`: {e}")))?;
                }
                (Some(Setting::ModelTerms), toml::Value::Boolean(b)) => settings.model_terms = *b,
                (Some(s), other) => {
                    let wanted = match s {
                        Setting::Switching => "a string",
                        Setting::ModelTerms => "true or false",
                    };
                    return Err((
                        Some(s.name()),
                        format!("expected {wanted}, found {}", other.type_str()),
                    ));
                }
                (None, _) => {
                    let expected: Vec<String> = kind
                        .gain_names()
                        .iter()
                        .copied()
                        .chain(kind.settings().iter().map(|s| s.name()))
                        .map(|k| format!("`{k}`"))
                        .collect();
                    return Err((
                        None,
                        format!(
                            "{kind}: unknown field `{key}`, expected one of {}",
                            expected.join(", ")
                        ),
                    ));
                }
            }
        }
        let mut out = Vec::with_capacity(values.len());
        for (spec, v) in kind.gains().zip(values) {
            match v.or(spec.default) {
                Some(v) => out.push(v),
                None => {
                    return Err((
                        Some(spec.name),
                        format!("{kind}: missing field `{}`", spec.name),
                    ))
                }
            }
        }
        Ok(Gains {
            kind,
            values: out,
            settings,
        })
    }

    /// The gains' keys, in the specs' order (a gain at its default left out), then the
    /// settings.
    fn to_table(&self) -> toml::Table {
        let mut t = toml::Table::new();
        for (spec, &v) in self.kind.gains().zip(&self.values) {
            if spec.default != Some(v) {
                t.insert(spec.name.into(), v.into());
            }
        }
        for s in self.kind.settings() {
            let v = match s {
                Setting::Switching => self.settings.switching.name().into(),
                Setting::ModelTerms => self.settings.model_terms.into(),
            };
            t.insert(s.name().into(), v);
        }
        t
    }
}

/// A rejected table: where and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}{}{}: {message}", row.map(|r| format!(": row {r}")).unwrap_or_default(), field.map(|f| format!(": field `{f}`")).unwrap_or_default())]
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

/// Parses and validates the table text; `file` names it in errors. Every row's law is checked
/// against the plant at its payload (a strain blend the plant cannot take is refused here).
pub fn parse(text: &str, file: &str) -> Result<Table, TableError> {
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
    if let Some(key) = table
        .keys()
        .find(|k| !["row", "plant", "drive"].contains(&k.as_str()))
    {
        return Err(err(
            None,
            None,
            format!("unknown top-level key `{key}` (expected [plant], [drive] and [[row]] tables)"),
        ));
    }
    let plant = match table.get("plant") {
        Some(v) => PlantSpec::from_value(v).map_err(|(field, m)| err(None, field, m))?,
        None => {
            return Err(err(
                None,
                None,
                "the table has no [plant]: name the plant its gains were designed for, \
                 `[plant]` with `modes = 3` and `preset = \"aluminium\"` or the beam's \
                 parameters (as `beam calibrate` writes them)"
                    .into(),
            ))
        }
    };
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
            rows.push(row_from_value(v).map_err(|(field, m)| err(Some(i + 1), field, m))?);
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
        let kind = r.gains.kind();
        if let Some(prev) = rows[..i].iter().rev().find(|p| p.gains.kind() == kind) {
            if r.payload_kg == prev.payload_kg {
                return Err(err(
                    Some(i + 1),
                    Some("payload_kg"),
                    format!("duplicates an earlier {kind} row"),
                ));
            }
            if r.payload_kg < prev.payload_kg {
                return Err(err(
                    Some(i + 1),
                    Some("payload_kg"),
                    format!(
                        "rows of {kind} must be sorted by payload ({} after {})",
                        r.payload_kg, prev.payload_kg
                    ),
                ));
            }
            let (s, prev_s) = (r.gains.settings(), prev.gains.settings());
            for (field, same) in [
                ("switching", s.switching == prev_s.switching),
                ("model_terms", s.model_terms == prev_s.model_terms),
                ("shaper", r.shaper.kind == prev.shaper.kind),
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
    for (i, r) in rows.iter().enumerate() {
        check_against_plant(r, &plant)
            .map_err(|(field, message)| err(Some(i + 1), Some(field), message))?;
    }
    let drive = match table.get("drive") {
        Some(v) => DriveSpec::from_value(v).map_err(|(field, m)| err(None, Some(field), m))?,
        None => DriveSpec {
            law: rows[0].gains.kind(),
            ..DriveSpec::default()
        },
    };
    drive
        .check(&rows, plant.params.torque_limit_nm)
        .map_err(|(field, m)| err(None, Some(field), m))?;
    Ok(Table { plant, drive, rows })
}

/// What a row's law needs of the plant at its payload: a strain blend within the rule the
/// laws apply ([`PlantPoint::blend_ratio`]).
fn check_against_plant(r: &Row, plant: &PlantSpec) -> Result<(), (&'static str, String)> {
    let blend = r.gains.kind().gains().zip(r.gains.values());
    let Some((spec, &c)) = blend.into_iter().find(|(g, _)| g.search == Search::Blend) else {
        return Ok(());
    };
    let point = plant
        .point(r.payload_kg as f32 as f64)
        .map_err(|(field, why)| (field.unwrap_or("payload_kg"), why))?;
    // As the drive holds the gain, in f32.
    let c32 = c as f32;
    match point.blend_ratio(c32) {
        Some(_) => Ok(()),
        None => Err((
            spec.name,
            format!(
                "{c}: the blend leaves 1 - c gamma = {:.3} of the hub's input gain on this \
                 plant (at least {} is needed)",
                1.0 - c32 * point.strain_coupling(),
                PlantPoint::MIN_BLEND_RATIO
            ),
        )),
    }
}

/// One `[[row]]` table: its `controller` names the law, whose gains are the keys besides the
/// common ones. `Err((field, why))`.
fn row_from_value(v: &toml::Value) -> Result<Row, (Option<&'static str>, String)> {
    let mut table = v
        .as_table()
        .cloned()
        .ok_or((None, "a row must be a table".to_string()))?;
    let kind = match table.remove("controller") {
        None => return Err((None, "missing field `controller`".into())),
        Some(toml::Value::String(name)) => name
            .parse::<LawKind>()
            .map_err(|e| (Some("controller"), format!("`{name}`: {e}")))?,
        Some(other) => {
            return Err((
                Some("controller"),
                format!("expected a string, found {}", other.type_str()),
            ))
        }
    };
    const COMMON: [&str; 6] = [
        "payload_kg",
        "cost_j",
        "shaper",
        "shaper_hz",
        "shaper_damping",
        "shaper_tolerance",
    ];
    let mut common = toml::Table::new();
    for key in COMMON {
        if let Some(v) = table.remove(key) {
            common.insert(key.to_string(), v);
        }
    }
    let message = |e: toml::de::Error| (None, e.message().trim().to_string());
    let c: Common = toml::Value::Table(common.clone())
        .try_into()
        .map_err(message)?;
    // A shaper's settings without a shaper would be dropped when the table is written back:
    // refused instead (a fuzzed table found it).
    if c.shaper == ShaperKind::None {
        const SETTINGS: [&str; 3] = ["shaper_hz", "shaper_damping", "shaper_tolerance"];
        if let Some(key) = SETTINGS.into_iter().find(|k| common.contains_key(*k)) {
            return Err((
                Some(key),
                "is given without a shaper (`shaper = \"zv\"`, `\"zvd\"` or `\"ei\"`)".into(),
            ));
        }
    }
    let gains = Gains::from_table(kind, &table)?;
    Ok(Row {
        payload_kg: c.payload_kg,
        gains,
        cost_j: c.cost_j,
        shaper: ShaperRow {
            kind: c.shaper,
            hz: c.shaper_hz,
            damping: c.shaper_damping,
            tolerance: c.shaper_tolerance,
        },
    })
}

/// Checks one row's values; `Err((field, why))`.
fn validate_row(r: &Row) -> Result<(), (&'static str, String)> {
    let mut numbers = vec![
        ("payload_kg", r.payload_kg),
        ("cost_j", r.cost_j),
        ("shaper_hz", r.shaper.hz),
        ("shaper_damping", r.shaper.damping),
        ("shaper_tolerance", r.shaper.tolerance),
    ];
    numbers.extend(r.gains.numbers());
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
    if r.shaper.kind != ShaperKind::None {
        if !(r.shaper.hz > 0.0) {
            return Err(("shaper_hz", format!("{} must be > 0", r.shaper.hz)));
        }
        if !(0.0..1.0).contains(&r.shaper.damping) {
            return Err((
                "shaper_damping",
                format!("{} is outside [0, 1)", r.shaper.damping),
            ));
        }
        if r.shaper.kind == ShaperKind::Ei
            && !(r.shaper.tolerance > 0.0 && r.shaper.tolerance < 0.5)
        {
            return Err((
                "shaper_tolerance",
                format!("{} is outside (0, 0.5)", r.shaper.tolerance),
            ));
        }
    }
    // Each gain by its law's sign rule (beam-kinds' `LawKind::gains`, which the law's own
    // validation in model-core reads too). The blend's own limit (1 - c gamma >= 0.2)
    // needs the plant: `check_against_plant`.
    let kind = r.gains.kind();
    for (field, v) in r.gains.numbers() {
        let Some(spec) = kind.gain(field) else {
            continue;
        };
        spec.check(v).map_err(|rule| {
            let why = match rule {
                GainRule::NonFinite => "is not finite",
                GainRule::NotPositive => "must be > 0",
                GainRule::Negative => "must be >= 0",
            };
            (field, format!("{v} {why}"))
        })?;
    }
    Ok(())
}

/// Reads and validates the table at `path`.
pub fn load(path: &Path) -> Result<Table, TableError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| TableError {
        file: file.clone(),
        row: None,
        field: None,
        message: e.to_string(),
    })?;
    parse(&text, &file)
}

/// The table as TOML text, the plant first, rows in the order given, with a header
/// explaining the file.
pub fn render(table: &Table) -> String {
    let mut out = String::from(
        "# Gain table: a drive's configuration. The host tools load it when they run (--table, or\n\
         # BEAM_GAIN_TABLE); the firmware's build compiles it in (BEAM_GAIN_TABLE=FILE cargo fw).\n\
         # [plant]: the beam the gains were designed for; its modal model is computed on the host.\n\
         # One [[row]] per controller and payload; rows of a controller sorted by payload_kg. The\n\
         # drive interpolates gains between neighbouring payloads and accepts payloads from 0 to\n\
         # the heaviest row. [drive]: the law the drive runs, its starting payload, and its\n\
         # instruments' scales (the observer laws are designed on them).\n\
         # Written by `beam optimize --table`; edit by hand with care: every load validates it.\n",
    );
    out.push('\n');
    out.push_str(&table.plant.render());
    out.push('\n');
    out.push_str(&table.drive.render());
    for r in &table.rows {
        out.push('\n');
        out.push_str("[[row]]\n");
        let mut t = toml::Table::new();
        t.insert("controller".into(), r.gains.kind().name().into());
        t.insert("payload_kg".into(), r.payload_kg.into());
        t.extend(r.gains.to_table());
        t.insert("cost_j".into(), r.cost_j.into());
        if r.shaper.kind != ShaperKind::None {
            t.insert("shaper".into(), r.shaper.kind.name().into());
            t.insert("shaper_hz".into(), r.shaper.hz.into());
            t.insert("shaper_damping".into(), r.shaper.damping.into());
            if r.shaper.kind == ShaperKind::Ei {
                t.insert("shaper_tolerance".into(), r.shaper.tolerance.into());
            }
        }
        out.push_str(&toml::to_string(&t).unwrap_or_default());
    }
    out
}

/// Inserts `row`, replacing the row of the same controller and payload if there is one,
/// keeping each controller's rows sorted by payload.
pub fn upsert(rows: &mut Vec<Row>, row: Row) {
    let kind = row.gains.kind();
    if let Some(existing) = rows
        .iter_mut()
        .find(|r| r.gains.kind() == kind && r.payload_kg == row.payload_kg)
    {
        *existing = row;
        return;
    }
    let at = rows
        .iter()
        .rposition(|r| r.gains.kind() == kind && r.payload_kg < row.payload_kg)
        .map(|i| i + 1)
        .or_else(|| rows.iter().position(|r| r.gains.kind() == kind))
        .unwrap_or(rows.len());
    rows.insert(at, row);
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[plant]
modes = 3
preset = "aluminium"

[[row]]
controller = "smc"
payload_kg = 0.0
w = 10.0
a = 1000.0
beta = 0.1
cost_j = 1.0

[[row]]
controller = "smc"
payload_kg = 0.05
w = 12.0
a = 900.0
beta = 0.1
cost_j = 2.0
"#;

    fn bad(from: &str, to: &str) -> TableError {
        assert!(GOOD.contains(from), "fixture lacks {from}");
        parse(&GOOD.replacen(from, to, 1), "gains.toml").unwrap_err()
    }

    #[test]
    fn a_good_table_round_trips() {
        let table = parse(GOOD, "gains.toml").unwrap();
        assert_eq!(table.rows.len(), 2);
        assert_eq!(parse(&render(&table), "x").unwrap(), table);
        assert!(generate_rust(&table.drive_table().unwrap()).contains(
            "::model_core::Law::from_values(::model_core::LawKind::Smc, [10.0, 1000.0, 0.1, 0.0, 0.0]"
        ));
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
        let e = bad("controller = \"smc\"", "controller = \"lqr\"");
        assert_eq!((e.row, e.field), (Some(1), Some("controller")));
        assert_eq!(
            e.message,
            "`lqr`: unknown control law; expected one of pd, smc, smc-strain, pd-ff, smc-i, lqg, smc-modal"
        );
        assert_eq!(bad("modes = 3", "modes = 7").field, Some("modes"));
        let e = bad("preset = \"aluminium\"", "preset = \"steel\"");
        assert!(e.message.contains("unknown variant `steel`"), "{e}");
        // The plant: the preset's fields written out are the same plant; a field out of
        // range is named; a partial beam names the first missing field; a preset with
        // fields is ambiguous; a plant carrying a payload is refused.
        let fields = toml::to_string(&beam_model::BeamParams::aluminium()).unwrap();
        let t = parse(&GOOD.replacen("preset = \"aluminium\"\n", &fields, 1), "g").unwrap();
        assert_eq!(t.plant.params, beam_model::BeamParams::aluminium());
        let beam = |key: &str, value: &str| {
            let edited: String = fields
                .lines()
                .map(|l| match l.starts_with(&format!("{key} = ")) {
                    true => format!("{key} = {value}\n"),
                    false => format!("{l}\n"),
                })
                .collect();
            bad("preset = \"aluminium\"\n", &edited)
        };
        let e = beam("ei_nm2", "-1.0");
        assert_eq!((e.row, e.field), (None, Some("ei_nm2")));
        assert_eq!(e.message, "[plant]: `ei_nm2` must be > 0");
        let e = beam("tip_mass_kg", "0.1");
        assert_eq!(e.field, Some("tip_mass_kg"), "{e}");
        let e = bad("preset = \"aluminium\"", "length_m = 0.5");
        assert!(e.message.contains("missing field `width_m`"), "{e}");
        let e = bad(
            "preset = \"aluminium\"",
            "preset = \"aluminium\"\nei_nm2 = 1.0",
        );
        assert!(e.message.contains("not both"), "{e}");
        let e = parse(
            &GOOD.replacen("[plant]\nmodes = 3\npreset = \"aluminium\"\n", "", 1),
            "g",
        )
        .unwrap_err();
        assert!(e.message.starts_with("the table has no [plant]"), "{e}");
        // A gain the law does not have is not part of its row.
        let e = bad("a = 900.0", "a = 900.0\nkp = 3.0");
        assert_eq!(e.row, Some(2));
        assert!(e.message.starts_with("smc: unknown field `kp`"), "{e}");
        // Syntax and schema errors still say where, and name the field they can.
        let e = bad("w = 12.0", "w = \"fast\"");
        assert_eq!((e.row, e.field), (Some(2), Some("w")));
        assert_eq!(e.message, "expected a number, found string");
        let e = bad("beta = 0.1\ncost_j = 2.0", "cost_j = 2.0");
        assert_eq!((e.row, e.field), (Some(2), Some("beta")));
        assert_eq!(e.message, "smc: missing field `beta`");
        let e = bad("w = 12.0", "w = 12.0\nswitching = \"bang\"");
        assert_eq!(e.field, Some("switching"));
        assert!(e.message.contains("expected one of tanh, sat, sign"), "{e}");
        let e = bad("w = 12.0", "w = 12.0\nmodel_terms = true");
        assert!(
            e.message.starts_with("smc: unknown field `model_terms`"),
            "{e}"
        );
        // An integer is a number.
        assert!(parse(&GOOD.replacen("w = 12.0", "w = 12", 1), "g").is_ok());
        let e = bad(
            "beta = 0.1\ncost_j = 1.0",
            "beta = 0.1\ngain = 3\ncost_j = 1.0",
        );
        assert!(e.message.contains("unknown field"), "{e}");
        assert_eq!(
            parse("[plant]\nmodes = 1\npreset = \"table1\"\n", "g.toml")
                .unwrap_err()
                .to_string(),
            "g.toml: the table has no [[row]]"
        );
    }

    /// A drive of an observer law may ask for exact moves: the flag reads back, is rendered
    /// only when set, and reaches the board's compiled `DRIVE`.
    #[test]
    fn an_observer_drive_may_ask_for_exact_moves() {
        let shipped = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml"),
        )
        .unwrap();
        let text = shipped.replacen(
            "law = \"smc\"\n",
            "law = \"smc-modal\"\nexact_moves = true\n",
            1,
        );
        assert_ne!(text, shipped, "the shipped table's [drive] runs smc");
        let t = parse(&text, "gains.toml").unwrap();
        assert!(t.drive.exact_moves);
        assert_eq!(parse(&render(&t), "g").unwrap(), t);
        assert!(render(&t).contains("\nexact_moves = true\n"));
        let source = generate_rust(&t.drive_table().unwrap());
        assert!(source.contains("exact_moves: true"), "{source}");
        let t = parse(&shipped, "gains.toml").unwrap();
        assert!(!t.drive.exact_moves && !render(&t).contains("exact_moves"));
        assert!(generate_rust(&t.drive_table().unwrap()).contains("exact_moves: false"));
    }

    #[test]
    fn every_gain_a_row_holds_is_one_of_its_laws_specs() {
        // Every law's row, from the shipped table: each number that is a gain has the
        // law's spec, and every spec is among the row's numbers.
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml"),
        )
        .unwrap();
        let rows = parse(&text, "gains.toml").unwrap().rows;
        for kind in [
            LawKind::Smc,
            LawKind::SmcStrain,
            LawKind::PdFf,
            LawKind::SmcI,
            LawKind::Lqg,
            LawKind::SmcModal,
        ] {
            let row = rows.iter().find(|r| r.gains.kind() == kind).unwrap();
            let names: Vec<&str> = row.gains.numbers().iter().map(|n| n.0).collect();
            let mut sorted = names.clone();
            sorted.sort_unstable();
            let mut specs: Vec<&str> = kind.gain_names().to_vec();
            specs.sort_unstable();
            assert_eq!(sorted, specs, "{kind}");
        }
    }

    #[test]
    fn a_gain_with_a_default_may_be_left_out_and_is_left_out_when_written() {
        // smc-i's blend defaults to 0 (the surface on the hub angle alone).
        let text = GOOD
            .replace("\"smc\"", "\"smc-i\"")
            .replace("beta = 0.1\n", "beta = 0.1\nwi = 25.0\n");
        let t = parse(&text, "g").unwrap();
        assert_eq!(t.rows[0].gains.get("c"), Some(0.0));
        assert!(!render(&t).contains("\nc = "), "{}", render(&t));
        let with = text.replacen("wi = 25.0", "wi = 25.0\nc = 0.5", 1);
        let t = parse(&with, "g").unwrap();
        assert_eq!(t.rows[0].gains.get("c"), Some(0.5));
        assert!(render(&t).contains("\nc = 0.5\n"));
        assert_eq!(parse(&render(&t), "g").unwrap(), t);
    }

    #[test]
    fn the_drive_is_checked_against_the_rows_and_the_plant() {
        let with = |drive: &str| {
            parse(
                &GOOD.replacen("\n[[row]]", &format!("\n[drive]\n{drive}\n\n[[row]]"), 1),
                "g",
            )
        };
        // Absent: the shipped drive's values, running the first row's law.
        let t = parse(GOOD, "g").unwrap();
        assert_eq!(t.drive.law, LawKind::Smc);
        assert_eq!(t.drive.encoder_counts_per_rev, 16384);
        // Rendered and parsed back, the same drive.
        let t = with("law = \"smc\"\npayload_kg = 0.05\nencoder_counts_per_rev = 4000").unwrap();
        assert_eq!(
            (t.drive.payload_kg, t.drive.encoder_counts_per_rev),
            (0.05, 4000)
        );
        assert_eq!(parse(&render(&t), "g").unwrap(), t);
        let field = |d: &str| with(d).unwrap_err().field;
        assert_eq!(field("law = \"pd-ff\""), Some("law"));
        assert_eq!(field("payload_kg = 0.06"), Some("payload_kg"));
        assert_eq!(field("payload_kg = -0.01"), Some("payload_kg"));
        assert_eq!(
            field("encoder_counts_per_rev = 0"),
            Some("encoder_counts_per_rev")
        );
        assert_eq!(field("adc_bits = 40"), Some("adc_bits"));
        assert_eq!(field("strain_full_scale = 0.0"), Some("strain_full_scale"));
        // The counter must move less than half its range a tick at the 50 rad/s the drive
        // takes as possible: 2^15 - 2 counts a millisecond are 98.2 rad/s at 2^21 counts a
        // turn, and 49.1 rad/s at 2^22.
        assert!(with("encoder_counts_per_rev = 2097152").is_ok());
        let e = with("encoder_counts_per_rev = 4194304").unwrap_err();
        assert_eq!(e.field, Some("encoder_counter_bits"));
        assert!(e.message.contains("49.1 rad/s"), "{e}");
        assert!(with("encoder_counts_per_rev = 4194304\nencoder_counter_bits = 24").is_ok());
        // The amplifier must reach the plant's 10 N m.
        let e = with("torque_full_scale_nm = 8.0").unwrap_err();
        assert_eq!(e.field, Some("torque_full_scale_nm"));
        assert!(e.message.contains("10 N m"), "{e}");
        assert!(with("pwm_hz = 3")
            .unwrap_err()
            .message
            .contains("unknown field"));
        // A rig wired the other way round: the three directions, rendered only when set.
        let r = with("encoder_reversed = true\nstrain_reversed = true\ntorque_reversed = true")
            .unwrap();
        assert!(r.drive.encoder_reversed && r.drive.strain_reversed && r.drive.torque_reversed);
        assert_eq!(parse(&render(&r), "g").unwrap(), r);
        let source = generate_rust(&r.drive_table().unwrap());
        assert!(
            source.contains("counter_bits: 16, reversed: true"),
            "{source}"
        );
        assert!(source.contains("torque_reversed: true"), "{source}");
        assert!(!render(&parse(GOOD, "g").unwrap()).contains("reversed"));
        // Exact moves are planned on an observer law's reference beam: not smc's.
        let e = with("exact_moves = true").unwrap_err();
        assert_eq!(e.field, Some("exact_moves"));
        assert!(e.message.contains("observer law"), "{e}");
        // PD runs on its baseline gains without rows.
        assert_eq!(with("law = \"pd\"").unwrap().drive.law, LawKind::Pd);
        let source = generate_rust(&t.drive_table().unwrap());
        assert!(
            source.contains("counts_per_rev: 4000, counter_bits: 16"),
            "{source}"
        );
    }

    #[test]
    fn a_shapers_settings_without_a_shaper_are_refused_not_dropped() {
        // Found by fuzzing: the row parsed, and the setting vanished when the table was
        // written back.
        let e = bad("w = 12.0", "w = 12.0\nshaper_damping = 0.07");
        assert_eq!((e.row, e.field), (Some(2), Some("shaper_damping")));
        let e = bad("w = 12.0", "w = 12.0\nshaper = \"none\"\nshaper_hz = 4.0");
        assert_eq!(e.field, Some("shaper_hz"));
        let zvd =
            |w: &str| format!("{w}\nshaper = \"zvd\"\nshaper_hz = 4.0\nshaper_damping = 0.05");
        let text = GOOD.replacen("w = 10.0", &zvd("w = 10.0"), 1).replacen(
            "w = 12.0",
            &zvd("w = 12.0"),
            1,
        );
        let t = parse(&text, "g").unwrap();
        assert_eq!(parse(&render(&t), "g").unwrap(), t);
    }

    #[test]
    fn upsert_replaces_or_inserts_in_payload_order() {
        let mut table = parse(GOOD, "g").unwrap();
        let rows = &mut table.rows;
        let mut mid = rows[0].clone();
        mid.payload_kg = 0.025;
        upsert(rows, mid.clone());
        assert_eq!(
            rows.iter().map(|r| r.payload_kg).collect::<Vec<_>>(),
            [0.0, 0.025, 0.05]
        );
        let w = LawKind::Smc.gain_index("w").unwrap();
        mid.gains.values_mut()[w] = 99.0;
        upsert(rows, mid.clone());
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[1], mid);
        assert!(parse(&render(&table), "g").is_ok());
    }
}
