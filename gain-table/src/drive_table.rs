//! A table made into the drive's configuration, [`model_core::DriveTable`]: its plant
//! computed on the host, its rows in the drive's `f32`, and the observer laws' designs made
//! on their own payload grid ([`PlantSpec::design_payloads`]). The host tools load any table
//! with [`open`] at run time; the firmware's build compiles the same value in as `const`
//! data with [`generate_rust`].

use crate::{PlantSpec, Row, Table, TableError};
use model_core::lqg::LqgDesign;
use model_core::table::{DesignRow, DriveConfig, GainRow, Instruments};
use model_core::{
    AdcSpec, Beam, ControlLaw, DriveTable, EncoderSpec, Law, LawKind, ModalModel, Plant, Shaper,
};
use std::path::Path;

/// A drive's configuration owned on the host: what [`LoadedTable::table`] lends as a
/// [`DriveTable`].
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedTable {
    /// The plant on its payload grid (its frequency table leaked: a tool holds one plant for
    /// its run).
    pub plant: Plant,
    /// The `[drive]`.
    pub drive: DriveConfig,
    /// The rows as the drive runs them.
    pub rows: Vec<GainRow>,
    /// The observer laws' designs on their payload grid (`PlantSpec::design_payloads`).
    pub designs: Vec<DesignRow>,
}

impl LoadedTable {
    /// The drive's configuration, for as long as the program runs (the table is leaked: for
    /// a tool or a test that runs one drive configuration throughout).
    pub fn leak(self) -> &'static DriveTable<'static> {
        let table = Box::leak(Box::new(self)).table();
        Box::leak(Box::new(table))
    }

    /// The drive's configuration.
    pub fn table(&self) -> DriveTable<'_> {
        DriveTable {
            plant: &self.plant,
            drive: self.drive,
            rows: &self.rows,
            designs: &self.designs,
        }
    }
}

/// Reads, validates and builds the table at `path` ([`Table::drive_table`]).
pub fn open(path: &Path) -> Result<LoadedTable, TableError> {
    crate::load(path)?.drive_table().map_err(|e| TableError {
        file: path.display().to_string(),
        ..e
    })
}

impl Table {
    /// The drive this table configures: the plant's model computed on the host, the rows in
    /// the drive's `f32` ([`Row::gain_row`]) and, for each observer law with rows, its
    /// design on the design grid ([`PlantSpec::design_payloads`]) for the gains scheduled
    /// there, on the table's own instruments. Fails, naming the field, for a plant whose model cannot be built or
    /// an observer row with no design.
    pub fn drive_table(&self) -> Result<LoadedTable, TableError> {
        let why = |field: Option<&'static str>, message: String| TableError {
            file: String::new(),
            row: None,
            field,
            message,
        };
        let plant = self
            .plant
            .plant(&self.rows)
            .map_err(|(field, message)| why(field, message))?
            .leak();
        let drive = self.drive.config();
        let rows: Vec<GainRow> = self.rows.iter().map(Row::gain_row).collect();
        let mut designs = Vec::new();
        for &kind in LawKind::ALL.iter().filter(|k| k.has_observer()) {
            let table = DriveTable {
                plant: &plant,
                drive,
                rows: &rows,
                designs: &[],
            };
            // On the design grid (every row's payload, an even number of steps at most
            // DESIGN_STEP_KG apart between them), each for the gains scheduled there: mixing
            // designs made a whole row apart (25 g) cost the beam a fifth of a second of
            // settling between them.
            for payload_kg in PlantSpec::design_payloads(&self.rows) {
                let payload_kg = payload_kg as f32;
                let Some(law) = table.law(kind, payload_kg) else {
                    break;
                };
                let design =
                    design_at(&plant, drive.instruments, law, payload_kg).map_err(|e| {
                        why(
                            None,
                            format!("{kind} at {payload_kg} kg has no design: {e}"),
                        )
                    })?;
                designs.push(DesignRow {
                    kind,
                    payload_kg,
                    design,
                });
            }
        }
        Ok(LoadedTable {
            plant,
            drive,
            rows,
            designs,
        })
    }
}

/// The observer design of `law` on `plant` carrying `payload_kg`, read by `instruments`, as
/// a host tool builds it (`ControlLaw::try_build` on the modal model there).
pub fn design_at(
    plant: &Plant,
    instruments: Instruments,
    law: Law,
    payload_kg: f32,
) -> Result<LqgDesign, String> {
    let beam = Beam::try_build(plant.params_with(payload_kg as f64)).map_err(|e| e.to_string())?;
    fn on<const N: usize>(beam: &Beam, i: Instruments, law: Law) -> Result<LqgDesign, String> {
        let model = ModalModel::<N>::try_build(beam).map_err(|e| e.to_string())?;
        let built = ControlLaw::try_build(law, i.on(&model)).map_err(|e| e.to_string())?;
        built
            .observer_design()
            .copied()
            .ok_or_else(|| "not an observer law".into())
    }
    match plant.modes {
        1 => on::<1>(&beam, instruments, law),
        2 => on::<2>(&beam, instruments, law),
        3 => on::<3>(&beam, instruments, law),
        _ => on::<4>(&beam, instruments, law),
    }
}

impl Row {
    /// The row as the drive runs it: gains and shaper rounded to `f32`.
    pub fn gain_row(&self) -> GainRow {
        let mut values = [0.0f32; model_core::law::MAX_GAINS];
        for (v, &g) in values.iter_mut().zip(self.gains.values()) {
            *v = g as f32;
        }
        GainRow {
            payload_kg: self.payload_kg as f32,
            law: Law::from_values(self.gains.kind(), values, self.gains.settings()),
            shaper: Shaper {
                kind: self.shaper.kind,
                freq_hz: self.shaper.hz as f32,
                damping: self.shaper.damping as f32,
                tolerance: self.shaper.tolerance as f32,
            },
        }
    }
}

impl crate::DriveSpec {
    /// The hub encoder and the root strain converter.
    pub fn instruments(&self) -> Instruments {
        Instruments {
            encoder: EncoderSpec {
                counts_per_rev: self.encoder_counts_per_rev,
                counter_bits: self.encoder_counter_bits,
                reversed: self.encoder_reversed,
            },
            adc: AdcSpec {
                bits: self.adc_bits,
                full_scale_strain: self.strain_full_scale,
                reversed: self.strain_reversed,
            },
        }
    }

    /// The `[drive]` as the drive holds it.
    pub fn config(&self) -> DriveConfig {
        DriveConfig {
            law: self.law,
            payload_kg: self.payload_kg as f32,
            instruments: self.instruments(),
            torque_full_scale_nm: self.torque_full_scale_nm as f32,
            torque_reversed: self.torque_reversed,
            exact_moves: self.exact_moves,
        }
    }
}

/// Rust source for a board's compiled configuration, to be included in a module of a crate
/// that depends on model-core: `PLANT`, `DRIVE`, each law's rows (`ROWS_SMC`, ...) and
/// designs (`DESIGNS_LQG`, ...), `ALL_ROWS` and `ALL_DESIGNS`, and the `const fn`s
/// `rows_for` and `designs_for`, so a board built for one law links only that law's
/// (`TABLE` takes its `[drive]` law's alone). Every `f32` is printed so it reads back exactly.
pub fn generate_rust(t: &LoadedTable) -> String {
    let mut out =
        String::from("// Generated from the gain table by the firmware's build. Do not edit.\n");
    let parts = crate::PlantParts {
        plant: Plant {
            first_hz: &[],
            ..t.plant
        },
        first_hz: t.plant.first_hz.to_vec(),
    };
    out.push_str(&crate::plant::generate_plant(&parts));
    out.push_str(&crate::drive::generate(&t.drive));
    let mut rows_for = String::new();
    let mut designs_for = String::new();
    let mut all_rows = String::new();
    let mut all_designs = String::new();
    for &kind in LawKind::ALL {
        let suffix = kind.name().to_uppercase().replace('-', "_");
        out.push_str(&format!(
            "/// The rows of `{kind}`, sorted by payload.\npub const ROWS_{suffix}: &[::model_core::GainRow] = &[\n"
        ));
        for r in t.rows.iter().filter(|r| r.law.kind() == kind) {
            let row = row_source(r);
            out.push_str(&row);
            all_rows.push_str(&row);
        }
        out.push_str("];\n");
        out.push_str(&format!(
            "/// The observer designs of `{kind}`, by payload.\npub const DESIGNS_{suffix}: &[::model_core::table::DesignRow] = &[\n"
        ));
        for d in t.designs.iter().filter(|d| d.kind == kind) {
            let design = format!(
                "    ::model_core::table::DesignRow {{ kind: ::model_core::LawKind::{kind:?}, payload_kg: {:?}, design: ::model_core::lqg::{:?} }},\n",
                d.payload_kg, d.design
            );
            out.push_str(&design);
            all_designs.push_str(&design);
        }
        out.push_str("];\n");
        rows_for.push_str(&format!(
            "        ::model_core::LawKind::{kind:?} => ROWS_{suffix},\n"
        ));
        designs_for.push_str(&format!(
            "        ::model_core::LawKind::{kind:?} => DESIGNS_{suffix},\n"
        ));
    }
    out.push_str(&format!(
        "/// The rows of law `kind` (in a const context, only that law's rows are linked).\n\
         pub const fn rows_for(kind: ::model_core::LawKind) -> &'static [::model_core::GainRow] {{\n    \
         match kind {{\n{rows_for}    }}\n}}\n\
         /// The observer designs of law `kind` (none for a law without an observer).\n\
         pub const fn designs_for(kind: ::model_core::LawKind) -> &'static [::model_core::table::DesignRow] {{\n    \
         match kind {{\n{designs_for}    }}\n}}\n\
         /// Every row, grouped by law, each law's sorted by payload.\n\
         pub const ALL_ROWS: &[::model_core::GainRow] = &[\n{all_rows}];\n\
         /// Every observer design.\n\
         pub const ALL_DESIGNS: &[::model_core::table::DesignRow] = &[\n{all_designs}];\n"
    ));
    out
}

/// `r` as a Rust expression: the law through `Law::from_values` (a `const fn`), so no law's
/// fields are named here.
fn row_source(r: &GainRow) -> String {
    let values: Vec<String> = r.law.values().iter().map(|v| format!("{v:?}")).collect();
    let s = r.law.settings();
    format!(
        "    ::model_core::GainRow {{ payload_kg: {:?}, law: ::model_core::Law::from_values(::model_core::LawKind::{:?}, [{}], ::model_core::law::Settings {{ switching: ::model_core::Switching::{:?}, model_terms: {} }}), \
         shaper: ::model_core::Shaper {{ kind: ::model_core::ShaperKind::{:?}, freq_hz: {:?}, damping: {:?}, tolerance: {:?} }} }},\n",
        r.payload_kg,
        r.law.kind(),
        values.join(", "),
        s.switching,
        s.model_terms,
        r.shaper.kind,
        r.shaper.freq_hz,
        r.shaper.damping,
        r.shaper.tolerance
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Between its designs, the shipped table's schedule is the design made at the payload
    /// no further off than the drive's schedule was before it took the quadratic through
    /// three: the straight line through designs at most 5 g apart (13 a law, where there are
    /// now 9) was 1.17 % (lqg) and 1.74 % (smc-modal) of an entry's size off at worst, this
    /// 0.68 % and 1.41 % (2026-11-28), at a quarter, half and three quarters of each step.
    #[test]
    fn the_scheduled_design_is_the_design_made_at_the_payload() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
        let loaded = open(&path).unwrap();
        let table = loaded.table();
        for kind in [LawKind::Lqg, LawKind::SmcModal] {
            let made = |p: f32| {
                let law = table.law(kind, p).unwrap();
                design_at(&loaded.plant, loaded.drive.instruments, law, p)
                    .unwrap()
                    .entries()
                    .to_vec()
            };
            let rows: Vec<&DesignRow> = loaded.designs.iter().filter(|r| r.kind == kind).collect();
            assert_eq!(rows.len(), 9, "{kind}");
            // Each entry's size: its largest over the rows (an entry that is zero throughout,
            // or a rounding's worth, as lqg's integral gain of 1e-11, is held to 1e-6).
            let size: Vec<f32> = (0..rows[0].design.entries().len())
                .map(|i| {
                    rows.iter()
                        .map(|r| r.design.entries()[i].abs())
                        .fold(1e-6, f32::max)
                })
                .collect();
            let mut worst = (0.0f32, 0.0f32, 0);
            for pair in rows.windows(2) {
                for k in 1..4 {
                    let p = pair[0].payload_kg
                        + (pair[1].payload_kg - pair[0].payload_kg) * k as f32 / 4.0;
                    let scheduled = table.designed_plant(kind, p).unwrap().design.unwrap();
                    let scheduled = scheduled.entries();
                    for (i, (s, m)) in scheduled.iter().zip(made(p)).enumerate() {
                        let off = (s - m).abs() / size[i];
                        if off > worst.0 {
                            worst = (off, p, i);
                        }
                    }
                }
            }
            let before = if kind == LawKind::Lqg { 0.0117 } else { 0.0174 };
            assert!(
                worst.0 < before,
                "{kind}: entry {} at {} kg is {} of its size off",
                worst.2,
                worst.1,
                worst.0
            );
        }
    }
}
