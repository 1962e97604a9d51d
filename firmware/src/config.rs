//! The drive's compiled-in configuration: which beam, which payload, which gains, which moves.
//!
//! Built once at start-up, outside the loop, and validated there: if anything here is wrong
//! the drive never enables the amplifier. The plant and the gains come from the table
//! compiled from `gains.toml` (or the file `BEAM_GAIN_TABLE` names): model-core's `PLANT`,
//! whose modal model the build computed on the host, and the law's rows of the table
//! (`rows_for`), scheduled on the payload. Nothing of the model is computed here.

use model_core::commands::{CommandedController, Commander, SetupError};
use model_core::gains::{
    rows_for, schedule_design, schedule_shaper, DesignRow, DesignedPlant, GainRow, DRIVE, PLANT,
};
use model_core::shaper::shaped_quintic;
use model_core::{
    ConfigError, ControlLaw, Controller, ControllerSettings, Law, LawKind, ParamError, ShaperError,
    Spline, SplineError, Timing,
};

/// Knots per move: room for any planned move, shaped (the button's moves, a shaped quintic,
/// use six). One capacity for both kinds of move keeps one controller type in the binary,
/// which the instruction counts showed to matter (two made LLVM inline less in the tick).
pub const MOVE_KNOTS: usize = model_core::planner::SHAPED_PLAN_KNOTS;
/// The payload this drive starts with, kg (the table's `[drive]`).
pub const PAYLOAD_KG: f32 = DRIVE.payload_kg;
/// The control law the drive runs (the table's `[drive]`).
pub const CONTROLLER: LawKind = DRIVE.law;
include!(concat!(env!("OUT_DIR"), "/button_moves.rs"));
include!(concat!(env!("OUT_DIR"), "/observer_designs.rs"));
/// The table's rows of [`CONTROLLER`]: the only rows the board links (a drive cannot change
/// its law).
pub const ROWS: &[GainRow] = rows_for(CONTROLLER);

/// The law `kind` for `payload_kg`: the compiled table's rows interpolated on the payload, or
/// for PD without rows, the baseline gains. `None` if the table has no row for an SMC.
pub fn compiled_law(kind: LawKind, payload_kg: f32) -> Option<Law> {
    model_core::gains::scheduled_law(rows_for(kind), kind, payload_kg)
}

/// The designs of [`CONTROLLER`]'s rows: the only designs the board links (none unless it
/// runs an observer law).
pub const DESIGNS: &[DesignRow] = designs_for(CONTROLLER);

/// The compiled plant at `payload_kg` with, for an observer law `kind`, its design scheduled
/// on the payload from `rows`, the designs build.rs made at the law's rows ([`designs_for`]);
/// `None` outside the plant's payloads. Without the `observer` feature an observer law is
/// still refused when it is built.
pub fn designed_plant(kind: LawKind, payload_kg: f32, rows: &[DesignRow]) -> Option<DesignedPlant> {
    let point = PLANT.at(payload_kg)?;
    Some(DesignedPlant {
        point,
        design: schedule_design(rows, kind, payload_kg),
    })
}

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
/// Torque at 100 % PWM duty, N m (the amplifier's current scale times the motor's torque
/// constant; the table's `[drive]`): at least the controller's torque limit, so saturation
/// never clips twice (the table's build checks it).
pub const FULL_SCALE_TORQUE_NM: f32 = DRIVE.torque_full_scale_nm;
/// The amplifier's scale (the table's `[drive]`).
pub const TORQUE_SCALE: crate::amplifier::TorqueScale = crate::amplifier::TorqueScale {
    full_scale_nm: FULL_SCALE_TORQUE_NM,
};
/// Positive torque needs the amplifier's direction pin low (the table's `[drive]`): the
/// amplifier's `REVERSED` parameter.
pub const TORQUE_REVERSED: bool = DRIVE.torque_reversed;

// The period fits the timer's 16 bits and the loop runs at model-core's rate.
const _: () = assert!(SYSCLK_HZ / PWM_HZ <= u16::MAX as u32);
const _: () = assert!(SYSCLK_HZ % PWM_HZ == 0);

/// Why the compiled-in configuration is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum BuildError {
    /// The payload is outside the compiled plant's range.
    Payload,
    /// The gain table has no row for the controller.
    NoGains,
    /// The gains.
    Gains(ParamError),
    /// The controller settings.
    Config(ConfigError),
    /// A move (shaped or not).
    Shape(ShaperError),
    /// The commanded drive's handler.
    Setup(SetupError),
    /// The commanded drive's resting move.
    Rest(SplineError),
}

/// The drive's controller ([`CONTROLLER`] at [`PAYLOAD_KG`]), idle, armed with the first move.
pub fn build_controller() -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let [first, _] = sequence()?;
    controller_with(CONTROLLER, PAYLOAD_KG, DESIGNS, first)
}

/// The controller for the compiled plant carrying `payload_kg`, running `kind`, armed with
/// the first move of [`sequence_for`].
pub fn build_controller_for(
    kind: LawKind,
    payload_kg: f32,
) -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let [first, _] = sequence_for(kind, payload_kg)?;
    controller_with(kind, payload_kg, designs_for(kind), first)
}

fn controller_with(
    kind: LawKind,
    payload_kg: f32,
    designs: &[DesignRow],
    first: Spline<MOVE_KNOTS>,
) -> Result<Controller<MOVE_KNOTS>, BuildError> {
    let gains = compiled_law(kind, payload_kg).ok_or(BuildError::NoGains)?;
    // With the observer laws, on the plant with their designs; without, on the plant alone
    // (an observer law is refused), so the board links nothing of them.
    #[cfg(feature = "observer")]
    let (law, plant) = {
        let plant = designed_plant(kind, payload_kg, designs).ok_or(BuildError::Payload)?;
        let law = ControlLaw::try_build(gains, plant).map_err(BuildError::Gains)?;
        (law, plant.point)
    };
    #[cfg(not(feature = "observer"))]
    let (law, plant) = {
        let _ = designs;
        let plant = PLANT.at(payload_kg).ok_or(BuildError::Payload)?;
        let law = ControlLaw::try_build(gains, plant).map_err(BuildError::Gains)?;
        (law, plant)
    };
    let settings = ControllerSettings {
        theta_home_rad: SLEW_FROM_RAD,
        torque_limit_nm: plant.torque_limit_nm,
        ..ControllerSettings::default()
    };
    Controller::try_build(settings, law, first).map_err(BuildError::Config)
}

/// A commanded drive for the compiled plant: its controller, idle at `home_rad` (the
/// encoder's zero), and the handler its commands go through, running `kind` scheduled for
/// `payload_kg`.
pub fn build_commanded(
    kind: LawKind,
    payload_kg: f32,
    home_rad: f32,
) -> Result<(CommandedController, Commander), BuildError> {
    let (commander, law) =
        Commander::try_new(&PLANT, rows_for(kind), designs_for(kind), kind, payload_kg)
            .map_err(BuildError::Setup)?;
    let settings = ControllerSettings {
        theta_home_rad: home_rad,
        torque_limit_nm: PLANT.params.torque_limit_nm as f32,
        ..ControllerSettings::default()
    };
    // Until the first command plans a move, the controller holds a move of no length.
    let rest = Spline::try_build(&[(0.0, home_rad), (1.0, home_rad)]).map_err(BuildError::Rest)?;
    let controller = Controller::try_build(settings, law, rest).map_err(BuildError::Config)?;
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

/// The move sequence the start button steps through: out to +90 deg, back to -90 deg
/// ([`sequence_for`] of [`CONTROLLER`] at [`PAYLOAD_KG`], its knots computed by the build).
pub fn sequence() -> Result<[Spline<MOVE_KNOTS>; 2], BuildError> {
    let spline = |m: &model_core::shaper::MoveKnots| {
        m.spline()
            .map_err(|e| BuildError::Shape(ShaperError::Spline(e)))
    };
    Ok([spline(&BUTTON_MOVES[0])?, spline(&BUTTON_MOVES[1])?])
}

/// The move sequence for law `kind` at `payload_kg`: the paper's slew out and back, shaped by
/// the law's table shaper (if any), which lengthens each move by the shaper's duration.
pub fn sequence_for(kind: LawKind, payload_kg: f32) -> Result<[Spline<MOVE_KNOTS>; 2], BuildError> {
    let shaper = schedule_shaper(rows_for(kind), kind, payload_kg);
    let plan = |from, to| {
        shaped_quintic(from, to, SLEW_TIME_S, &shaper, Timing::Stretch).map_err(BuildError::Shape)
    };
    Ok([
        plan(SLEW_FROM_RAD, SLEW_TO_RAD)?,
        plan(SLEW_TO_RAD, SLEW_FROM_RAD)?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
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
            sequence_for(CONTROLLER, PAYLOAD_KG).unwrap()
        );
        let c = build_controller().unwrap();
        let by_law = build_controller_for(CONTROLLER, PAYLOAD_KG).unwrap();
        assert_eq!(c.spline(), by_law.spline());
    }
}
