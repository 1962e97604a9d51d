//! The drive assembled from its configuration: its controller, its commanded drive and the
//! start button's moves, each from a [`DriveTable`] passed in, and the board's fixed numbers
//! (clock, PWM).
//!
//! Built once at start-up, outside the loop, and validated there: if anything is wrong the
//! drive never enables the amplifier. The board passes the table its build compiled in (the
//! `firmware` crate's `TABLE`); the PIL host and `beam drive --sim` pass the table they
//! loaded, so both ends build the same drive. Nothing of the model is computed here.

use model_core::commands::{CommandedController, Commander, CommanderIn, SetupError};
use model_core::law::{LawSet, ALL_LAWS};
use model_core::shaper::shaped_quintic;
use model_core::{
    ConfigError, Controller, DriveTable, LawKind, ShaperError, Spline, SplineError, Timing,
};

/// Knots per move: room for any planned move, shaped (the button's moves, a shaped quintic,
/// use six). One capacity for both kinds of move keeps one controller type in the binary,
/// which the instruction counts showed to matter (two made LLVM inline less in the tick).
pub const MOVE_KNOTS: usize = model_core::planner::SHAPED_PLAN_KNOTS;

/// The paper's slew: -90 deg to +90 deg in 0.35 s, and back (model-core's `paper_slew`).
pub const SLEW_FROM_RAD: f32 = model_core::spline::paper_slew::FROM_RAD;
/// End of the outward slew, rad.
pub const SLEW_TO_RAD: f32 = model_core::spline::paper_slew::TO_RAD;
/// Duration of each slew, s.
pub const SLEW_TIME_S: f32 = model_core::spline::paper_slew::TIME_S;

/// The core clock the board runs at, Hz (8 MHz crystal, PLL).
pub const SYSCLK_HZ: u32 = 168_000_000;
/// The amplifier's PWM frequency, Hz: above hearing, well within the amplifier's input range.
pub const PWM_HZ: u32 = 20_000;
/// TIM1's counts per PWM period at [`SYSCLK_HZ`] and [`PWM_HZ`]: the duty's full scale, as on
/// the board (the PIL drive's fake PWM uses it too).
pub const PWM_PERIOD_COUNTS: u16 = (SYSCLK_HZ / PWM_HZ) as u16;

// The period fits the timer's 16 bits and the loop runs at model-core's rate.
const _: () = assert!(SYSCLK_HZ / PWM_HZ <= u16::MAX as u32);
const _: () = assert!(SYSCLK_HZ % PWM_HZ == 0);

/// The amplifier's scale for `table`'s drive: torque at full duty (its `[drive]`).
pub const fn torque_scale(table: &DriveTable<'_>) -> crate::amplifier::TorqueScale {
    crate::amplifier::TorqueScale {
        full_scale_nm: table.drive.torque_full_scale_nm,
    }
}

/// Why a drive's configuration is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum BuildError {
    /// The law at the payload: out of the plant's range, no rows, or invalid gains.
    Setup(SetupError),
    /// The controller settings.
    Config(ConfigError),
    /// A move (shaped or not).
    Shape(ShaperError),
    /// The commanded drive's resting move.
    Rest(SplineError),
}

/// The controller for `table`'s drive carrying `payload_kg`, running `kind` built in the law
/// set `LAWS` (the board's holds its law alone), idle and armed with `first` (the board's:
/// its start button's first move).
pub fn controller_with<const LAWS: LawSet>(
    table: &DriveTable<'_>,
    kind: LawKind,
    payload_kg: f32,
    first: Spline<MOVE_KNOTS>,
) -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let law = table
        .build_law_in::<LAWS>(kind, payload_kg)
        .map_err(BuildError::Setup)?;
    Controller::try_build(table.settings(SLEW_FROM_RAD), law, first).map_err(BuildError::Config)
}

/// The controller for `table`'s drive carrying `payload_kg`, running `kind`, armed with the
/// first move of [`sequence_for`].
pub fn build_controller_for(
    table: &DriveTable<'_>,
    kind: LawKind,
    payload_kg: f32,
) -> Result<Controller<MOVE_KNOTS>, BuildError> {
    build_controller_in::<ALL_LAWS>(table, kind, payload_kg)
}

/// [`build_controller_for`] in a build that holds the laws `LAWS` (the PIL drive built as the
/// board is).
pub fn build_controller_in<const LAWS: LawSet>(
    table: &DriveTable<'_>,
    kind: LawKind,
    payload_kg: f32,
) -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let [first, _] = sequence_for(table, kind, payload_kg)?;
    controller_with::<LAWS>(table, kind, payload_kg, first)
}

/// A commanded drive for `table`: its controller, idle at `home_rad` (the encoder's zero),
/// and the handler its commands go through, running `kind` scheduled for `payload_kg`.
pub fn build_commanded<'t>(
    table: &'t DriveTable<'t>,
    kind: LawKind,
    payload_kg: f32,
    home_rad: f32,
) -> Result<(CommandedController, Commander<'t>), BuildError> {
    build_commanded_in::<ALL_LAWS>(table, kind, payload_kg, home_rad)
}

/// [`build_commanded`] in a build that holds the laws `LAWS` (the PIL drive built as the
/// board is).
pub fn build_commanded_in<'t, const LAWS: LawSet>(
    table: &'t DriveTable<'t>,
    kind: LawKind,
    payload_kg: f32,
    home_rad: f32,
) -> Result<(CommandedController, CommanderIn<'t, LAWS>), BuildError> {
    let (commander, law) =
        CommanderIn::<LAWS>::try_new(table, kind, payload_kg).map_err(BuildError::Setup)?;
    // Until the first command plans a move, the controller holds a move of no length.
    let rest = Spline::try_build(&[(0.0, home_rad), (1.0, home_rad)]).map_err(BuildError::Rest)?;
    let controller =
        Controller::try_build(table.settings(home_rad), law, rest).map_err(BuildError::Config)?;
    Ok((controller, commander))
}

/// The move of `moves` whose start is nearest `theta_rad` (none for a non-finite angle).
pub fn nearest<const K: usize>(moves: &[Spline<K>], theta_rad: f32) -> Option<&Spline<K>> {
    if !theta_rad.is_finite() {
        return None;
    }
    let distance = |s: &Spline<K>| libm::fabsf(s.start() - theta_rad);
    moves
        .iter()
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))
}

/// The start button's move sequence for law `kind` at `payload_kg` on `table`'s drive: the
/// paper's slew out and back, shaped by the law's table shaper (if any), which lengthens each
/// move by the shaper's duration.
pub fn sequence_for(
    table: &DriveTable<'_>,
    kind: LawKind,
    payload_kg: f32,
) -> Result<[Spline<MOVE_KNOTS>; 2], BuildError> {
    let shaper = table.shaper(kind, payload_kg);
    let plan = |from, to| {
        shaped_quintic(from, to, SLEW_TIME_S, &shaper, Timing::Stretch).map_err(BuildError::Shape)
    };
    Ok([
        plan(SLEW_FROM_RAD, SLEW_TO_RAD)?,
        plan(SLEW_TO_RAD, SLEW_FROM_RAD)?,
    ])
}
