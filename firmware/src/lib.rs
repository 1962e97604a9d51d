//! The board's gain table, compiled in: the one place a drive's configuration is a constant.
//!
//! `build.rs` reads `gains.toml` at the workspace root (or the file `BEAM_GAIN_TABLE` names,
//! a relative path taken from the workspace root), builds it as the host tools do
//! (`gain_table::open`: the plant's model and the observer laws' designs computed on the
//! host) and writes it out as `const` data, with the start button's two moves. [`TABLE`] is
//! the board's drive: its `[drive]` law's rows and designs only, so the board links nothing
//! else; [`ALL_LAWS`] is the same drive with every law's, for the PIL drive. Everything that
//! builds a drive from them is in `beam-drive`, which takes the table as an argument.
//!
//! The binary (`src/main.rs`, `src/board.rs`) names the STM32F405's concrete types and runs
//! the drive's tick from the 1 kHz timer; on the host it is a stub pointing at `cargo fw`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

use beam_drive::config::{controller_with, BuildError, MOVE_KNOTS};
use model_core::law::LawSet;
use model_core::{Controller, DriveTable, LawKind, Spline};

include!(concat!(env!("OUT_DIR"), "/gain_table.rs"));
include!(concat!(env!("OUT_DIR"), "/button_moves.rs"));

/// The board's drive: the table's plant and `[drive]`, with its law's rows and designs alone.
pub const TABLE: DriveTable<'static> = DriveTable {
    plant: &PLANT,
    drive: DRIVE,
    rows: rows_for(DRIVE.law),
    designs: designs_for(DRIVE.law),
};

/// The same drive with every law's rows and designs: what the PIL drive runs, which can be
/// set up for any law ([`LAWS`] says which it holds).
pub const ALL_LAWS: DriveTable<'static> = DriveTable {
    rows: ALL_ROWS,
    designs: ALL_DESIGNS,
    ..TABLE
};

/// The law the board runs (the table's `[drive]`).
pub const CONTROLLER: LawKind = DRIVE.law;
/// The laws this build holds: with `drive-law-only` (the board, `cargo fw`) its law alone, so
/// the others' code is not in the binary and a command for another is refused, and the tanh
/// switching function only if one of the law's rows switches by it; else every law. Passed
/// to the core as a const generic (`ControlLaw::try_build_in`, `Drive::tick_in`).
pub const LAWS: LawSet = if cfg!(feature = "drive-law-only") {
    if model_core::table::any_switches_by_tanh(TABLE.rows) {
        model_core::law::only(CONTROLLER)
    } else {
        model_core::law::without_tanh(model_core::law::only(CONTROLLER))
    }
} else {
    model_core::law::ALL_LAWS
};
/// The board's command handler: its table, in its law set.
pub type BoardCommander = model_core::commands::CommanderIn<'static, LAWS>;
/// The payload it starts with, kg (the table's `[drive]`).
pub const PAYLOAD_KG: f32 = DRIVE.payload_kg;
/// The amplifier's scale (the table's `[drive]`).
pub const TORQUE_SCALE: beam_drive::amplifier::TorqueScale =
    beam_drive::config::torque_scale(&TABLE);
/// Positive torque needs the amplifier's direction pin low (the table's `[drive]`): the
/// amplifier's `REVERSED` parameter.
pub const TORQUE_REVERSED: bool = DRIVE.torque_reversed;

/// The board's controller ([`CONTROLLER`] at [`PAYLOAD_KG`]), idle, armed with the start
/// button's first move.
pub fn build_controller() -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let [first, _] = sequence()?;
    controller_with::<LAWS>(&TABLE, CONTROLLER, PAYLOAD_KG, first)
}

/// The start button's moves, out to +90 deg and back to -90 deg, from the knots the build
/// computed on the host (the board links none of the shaping).
pub fn sequence() -> Result<[Spline<MOVE_KNOTS>; 2], BuildError> {
    let spline = |m: &model_core::shaper::MoveKnots| {
        m.spline()
            .map_err(|e| BuildError::Shape(model_core::ShaperError::Spline(e)))
    };
    Ok([spline(&BUTTON_MOVES[0])?, spline(&BUTTON_MOVES[1])?])
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_drive::config::{build_controller_for, sequence_for, SLEW_FROM_RAD};
    use model_core::Mode;

    #[test]
    fn the_compiled_configuration_builds_and_starts_idle() {
        let c = build_controller().unwrap();
        assert_eq!(c.mode(), Mode::Idle);
        assert_eq!(c.spline().start(), SLEW_FROM_RAD);
        let [out, back] = sequence().unwrap();
        // The sequence closes: each move starts where the previous one ends.
        assert_eq!(out.end(), back.start());
        assert_eq!(back.end(), out.start());
    }

    #[test]
    fn the_buttons_moves_built_on_the_host_are_the_moves_shaped_at_run_time() {
        // The build computed the knots on the host; shaping the moves here again must give
        // the same splines, bit for bit.
        assert_eq!(
            sequence().unwrap(),
            sequence_for(&TABLE, CONTROLLER, PAYLOAD_KG).unwrap()
        );
        let c = build_controller().unwrap();
        let by_law = build_controller_for(&TABLE, CONTROLLER, PAYLOAD_KG).unwrap();
        assert_eq!(c.spline(), by_law.spline());
    }

    #[test]
    fn the_compiled_table_is_the_table_the_host_loads() {
        // The same file read at run time, as the host tools read it: every number the board
        // holds, bit for bit (f32 printed and read back), the designs included.
        let path = std::env::var("BEAM_GAIN_TABLE")
            .ok()
            .filter(|p| !p.is_empty())
            .map(|p| {
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("..")
                    .join(p)
            })
            .unwrap_or_else(|| {
                std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml")
            });
        let loaded = gain_table::open(&path).unwrap();
        assert_eq!(loaded.table(), ALL_LAWS);
        assert!(TABLE.rows.iter().all(|r| r.law.kind() == CONTROLLER));
        assert!(!ALL_LAWS.designs.is_empty());
    }
}
