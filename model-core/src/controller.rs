//! The per-tick controller: raw measurement in, saturated torque command out.
//!
//! [`Controller::step`] is the one function the firmware's 1 kHz interrupt and the host's
//! closed-loop simulation both call. It never fails and never panics: every way a reading can
//! be wrong (a bridge at its rail, an encoder jump no hub could make in one tick, strain past
//! the limit, an amplifier fault, a non-finite number) latches a fault that turns the torque
//! off until [`Controller::reset`]. Configuration ([`ControllerSettings`], the law, the move) is
//! validated once by [`Controller::try_build`]; the mutable state is small and fixed-size.
//!
//! The state machine: `Idle` (torque off; the strain offset is averaged, since the beam is at
//! rest) -> `Slewing` (tracking the spline after [`Controller::start_move`]) -> `Holding` (the
//! law keeps regulating the final point) ; any fault -> `Fault` (torque off, latched).

pub use crate::error::{CommandError, ConfigError};
use crate::error::{ParamError, ParamErrorKind};
use crate::law::{ControlLaw, Estimate, LawSet, LawState, ALL_LAWS, ASSUMED_STRAIN_NOISE};
use crate::measure::Instruments;
use crate::measure::{
    angle_rad, AdcSpec, CounterExtender, CounterWidth, EncoderSpec, FixedRate, LowPass,
};
use crate::spline::{RefPoint, Spline};
use core::fmt;

mod brake;
mod monitor;
mod tick;
pub use brake::{Brake, HOLD_HANDOVER_RAD};
#[cfg(feature = "observer")]
use monitor::watch_sensors;
pub use monitor::{ENCODER_RESIDUAL, GAUGE_RESIDUAL};
use tick::mean_code;

/// One tick's raw sensor readings, exactly as the hardware gives them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawMeasurement {
    /// The hardware encoder counter (only its low `counter_bits` are used; it wraps).
    pub encoder_raw: u32,
    /// The root strain bridge ADC code.
    pub strain_root_code: i32,
    /// The amplifier's fault input is asserted.
    pub amp_fault: bool,
    /// A sensor or output driver failed this tick or the last (a bus error, a bridge ADC that
    /// stopped converting): the readings above cannot be trusted.
    pub driver_fault: bool,
}

/// Controller mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Torque off, waiting for a move; the strain offset is being measured.
    #[default]
    Idle,
    /// Tracking the move's spline.
    Slewing,
    /// The move is over; regulating its final position.
    Holding,
    /// A fault was latched; torque off until reset.
    Fault,
}

/// The controller's state as a command sees it ([`Controller::snapshot`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Snapshot {
    /// The mode.
    pub mode: Mode,
    /// The hub angle of the last tick, rad.
    pub theta_rad: f32,
    /// The hub rate (filtered) of the last tick, rad/s.
    pub omega_rad_s: f32,
    /// Time into the move, s: where the next tick evaluates it.
    pub move_elapsed_s: f32,
    /// The latched faults (a gauge fault leaves the drive holding, not in Fault).
    pub faults: FaultFlags,
}

/// A set of latched faults (bit flags).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultFlags(pub u16);

impl FaultFlags {
    /// A derived value (angle, velocity, strain, torque) was NaN or infinite.
    pub const NON_FINITE: FaultFlags = FaultFlags(1 << 0);
    /// The strain ADC sat at a rail: saturated or disconnected bridge.
    pub const ADC_RAIL: FaultFlags = FaultFlags(1 << 1);
    /// The encoder moved further in one tick than the hub physically can.
    pub const ENCODER_JUMP: FaultFlags = FaultFlags(1 << 2);
    /// The root strain exceeded the limit.
    pub const OVER_STRAIN: FaultFlags = FaultFlags(1 << 3);
    /// The amplifier reported a fault.
    pub const AMP_FAULT: FaultFlags = FaultFlags(1 << 4);
    /// A move was started with the hub away from the move's start position.
    pub const START_MISMATCH: FaultFlags = FaultFlags(1 << 5);
    /// A driver reported a failure (see [`RawMeasurement::driver_fault`]).
    pub const DRIVER: FaultFlags = FaultFlags(1 << 6);
    /// The encoder did not move for [`STALL_TICKS`] while the reference moved and the drive
    /// commanded at least [`STALL_TORQUE_FRACTION`] of its torque limit, or the reference
    /// moved two counts a tick or more: a stuck encoder or a blocked hub. (A hub held at rest
    /// against a load is neither.)
    pub const ENCODER_STUCK: FaultFlags = FaultFlags(1 << 7);
    /// The hub left the drive's range by more than [`RANGE_FAULT_MARGIN_RAD`] with the
    /// torque on (widened to the move's start and end where they are outside it).
    pub const OUT_OF_RANGE: FaultFlags = FaultFlags(1 << 8);
    /// The root strain gauge failed: its converter read one code for
    /// [`GAUGE_FROZEN_TICKS`] on end (stuck, or an open bridge read as the zero code), or,
    /// on the observer laws, it read what the observer could not explain (more than
    /// [`GAUGE_RESIDUAL`] off its prediction: reversed, a wrong gain, a drift). Under torque
    /// not a stop: the move and the hold go on on the drive's own law, which reads the
    /// encoder alone (the brake's), and no move is taken until it is cleared
    /// ([`GAUGE_FAULTS`]).
    pub const GAUGE: FaultFlags = FaultFlags(1 << 9);
    /// The board's crystal did not start: it runs on its internal oscillator, whose
    /// frequency is not good enough to drive on. Latched again every tick: torque stays off.
    pub const CLOCK: FaultFlags = FaultFlags(1 << 10);
    /// An observer law's loop rang at rest: the torque swung to a limit from the other side
    /// of zero, again and again, until the gauge's residual passed [`GAUGE_RESIDUAL`] (see
    /// [`RING_STEP`](crate::law::RING_STEP)): the beam has a mode the observer does not
    /// model and the gauge sees. Handled as [`FaultFlags::GAUGE`] is: not a stop, the hold
    /// goes on on the drive's own law, which reads the encoder alone, and no move is taken
    /// until it is cleared.
    pub const RINGING: FaultFlags = FaultFlags(1 << 11);

    /// Names for display, in bit order.
    const NAMES: [&'static str; 12] = [
        "non-finite",
        "adc-rail",
        "encoder-jump",
        "over-strain",
        "amp-fault",
        "start-mismatch",
        "driver",
        "encoder-stuck",
        "out-of-range",
        "gauge",
        "clock",
        "ringing",
    ];

    /// True when no fault is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// True when every flag of `other` is set in `self`.
    pub const fn contains(self, other: FaultFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// Sets the flags of `other`.
    pub fn insert(&mut self, other: FaultFlags) {
        self.0 |= other.0;
    }
}

impl fmt::Display for FaultFlags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return write!(f, "none");
        }
        let mut first = true;
        for (bit, name) in Self::NAMES.iter().enumerate() {
            if self.0 & (1 << bit) != 0 {
                write!(f, "{}{}", if first { "" } else { "," }, name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// What one tick produces: the torque to apply and what the controller saw.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TorqueCommand {
    /// Torque to apply, N m: finite and within the limit, zero unless slewing or holding.
    pub torque_nm: f32,
    /// The mode after this tick.
    pub mode: Mode,
    /// Latched faults.
    pub faults: FaultFlags,
    /// Measured hub angle, rad.
    pub theta_rad: f32,
    /// Reference hub angle, rad.
    pub theta_ref_rad: f32,
    /// Measured root strain (offset removed).
    pub strain: f32,
}

/// Everything about the loop that is not the law or the move. SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerSettings {
    /// Sample period, s.
    pub ts_s: f32,
    /// The hub encoder and its counter.
    pub encoder: EncoderSpec,
    /// The root strain ADC.
    pub adc: AdcSpec,
    /// Hub angle when the encoder counter was zeroed (power-up), rad.
    pub theta_home_rad: f32,
    /// Cutoff of the velocity low-pass, Hz.
    pub velocity_cutoff_hz: f32,
    /// Cutoff of the strain-rate low-pass, Hz.
    pub strain_rate_cutoff_hz: f32,
    /// Drive torque limit, N m.
    pub torque_limit_nm: f32,
    /// Fastest physically possible hub speed, rad/s: a bigger count change in one tick is an
    /// encoder fault.
    pub max_speed_rad_s: f32,
    /// Root strain that trips the over-strain fault (dimensionless).
    pub max_strain: f32,
    /// How far from the move's start the hub may be when a move starts, rad.
    pub start_tolerance_rad: f32,
    /// ADC code of zero strain, used when no idle samples were averaged before a move.
    pub strain_offset_code: i32,
}

impl ControllerSettings {
    /// The settings of a loop reading `instruments`: the paper's 1 kHz, the counter zeroed at
    /// -90 deg (where the paper's slew starts), 200 Hz filters, the reference drive's 10 N m
    /// and its fault thresholds. A drive's own come from its table
    /// ([`DriveTable::settings`](crate::table::DriveTable::settings)).
    pub const fn new(instruments: Instruments) -> Self {
        Self {
            ts_s: crate::DEFAULT_TS_S,
            encoder: instruments.encoder,
            adc: instruments.adc,
            theta_home_rad: -core::f32::consts::FRAC_PI_2,
            velocity_cutoff_hz: LowPass::DEFAULT_CUTOFF_HZ,
            strain_rate_cutoff_hz: LowPass::DEFAULT_CUTOFF_HZ,
            torque_limit_nm: crate::DRIVE_TORQUE_LIMIT_NM,
            // The paper's slew peaks at 15/8 * pi / 0.35 s = 16.8 rad/s.
            max_speed_rad_s: 50.0,
            // Aluminium yields near 4000 microstrain.
            max_strain: 3000e-6,
            start_tolerance_rad: 0.05,
            strain_offset_code: 0,
        }
    }

    /// The instruments the loop reads.
    pub const fn instruments(&self) -> Instruments {
        Instruments {
            encoder: self.encoder,
            adc: self.adc,
        }
    }
}

/// Validated, immutable configuration derived from the settings. In declared order, the law
/// first: the tick reads it most, and at a small offset each gain is one load on the M4F
/// (behind the spline, each needed an address computation too).
#[derive(Clone, Debug, PartialEq)]
#[repr(C)]
struct Config<const K: usize> {
    law: ControlLaw,
    settings: ControllerSettings,
    spline: Spline<K>,
    rad_per_count: f32,
    rad_per_count_fixed: FixedRate,
    strain_per_code: f32,
    /// The ADC's lowest and highest codes (`AdcSpec::at_rail`, computed once).
    rails: (i32, i32),
    /// Below half the counter's range, so below 2^31 (checked when built).
    max_counts_per_tick: u32,
    /// `settings.encoder.width()`, worked out once.
    counter_width: CounterWidth,
    velocity_lpf: LowPass,
    strain_rate_lpf: LowPass,
    /// The drive's own law for this law's rigid inertia ([`Brake::for_law`]).
    brake: Brake,
    /// Ticks of one unchanged gauge code that make a frozen gauge ([`GAUGE_FROZEN_TICKS`]),
    /// or `u32::MAX` where the converter is too coarse to tell a frozen gauge from a quiet
    /// one.
    frozen_code_ticks: u32,
    /// The stall watch's thresholds, worked out once: [`STALL_TORQUE_FRACTION`] of the
    /// torque limit, N m, and the reference's speed at two counts a tick, rad/s.
    stall_torque_nm: f32,
    stall_speed_rad_s: f32,
}

/// Loop state: filters, counters and the mode.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct State {
    mode: Mode,
    faults: FaultFlags,
    counter: CounterExtender,
    omega: f32,
    strain_rate: f32,
    last_strain: Option<f32>,
    zero_sum: i64,
    zero_n: u32,
    /// `zero_sum / zero_n`, computed when a move is commanded.
    zero_mean: f32,
    offset_code: f32,
    start_pending: bool,
    /// The angles the hub may reach under torque in this move (set when it is armed), as
    /// centre and half-width: [`RANGE_RAD`], widened to the move's start and end, plus
    /// [`RANGE_FAULT_MARGIN_RAD`].
    range: (f32, f32),
    ticks: u32,
    /// The spline's segment the last tick evaluated ([`Spline::eval_from`]): 0 when a move
    /// starts, set again when a running move is replaced.
    segment: usize,
    /// Consecutive ticks with no count change under substantial torque.
    stall_ticks: u32,
    /// The gauge's last code and the ticks it has read it on end.
    last_code: i32,
    same_code_ticks: u32,
    /// Consecutive ticks with no count change at all (the sensor monitor's, observer builds).
    #[cfg(feature = "observer")]
    still_ticks: u32,
    /// The law's own state (smc-i's integral, the observer), cleared when a move is armed.
    law_state: LawState,
    /// The last tick's hub angle and root strain (for status and for planning the next move).
    theta: f32,
    strain: f32,
    /// The armed start is a brake ([`Controller::start_brake`]).
    brake_pending: bool,
    /// Ticks run since the controller was built (wraps).
    uptime: u32,
    /// The drive's own law ([`Brake`]) runs, not the table's: a brake, a move or hold after
    /// a gauge fault, or a hold handed over (cleared when the next move starts).
    braking: bool,
    /// Added to the reference's angle: a brake's plan is moved onto the hub where its first
    /// tick finds it (0 for a move).
    ref_offset: f32,
    /// The reference's acceleration at the last slewing tick's point, rad/s^2, that of this
    /// tick is extrapolated from for a law with an observer ([`Brake::takes_gauge_loss`]).
    /// 0 where a move or a brake is taken up: every plan starts with no acceleration (a move
    /// from rest, a brake from a coast).
    last_acc: f32,
}

/// The drive's range, rad: moves are planned within +-this of the encoder's zero (the
/// planner's [`crate::planner::Limits`] default to it), and the hub leaving it by more than
/// [`RANGE_FAULT_MARGIN_RAD`] with the torque on latches [`FaultFlags::OUT_OF_RANGE`].
pub const RANGE_RAD: f32 = core::f32::consts::PI;

/// How far past [`RANGE_RAD`] (or past a move's start or end outside it: a move back into the
/// range, a brake) the hub may go under torque before the range fault latches, rad (10 deg):
/// room for a tracking overshoot.
pub const RANGE_FAULT_MARGIN_RAD: f32 = 10.0 * core::f32::consts::PI / 180.0;

/// The hub rate (filtered) at or below which a move may start, rad/s (about 29 deg/s). A
/// move is planned from rest, so one commanded while the hub still coasts (after `Disable`,
/// say) starts with the reference and the hub apart in rate and saturates the torque. A hub
/// held at its target still dithers by an encoder count, which at 16 384 counts a turn and
/// 1 kHz reads as up to 0.38 rad/s for a tick (0.27 rad/s measured after the filter): that
/// is rest.
pub const REST_RAD_S: f32 = 0.5;

/// Ticks without an encoder count under substantial torque before [`FaultFlags::ENCODER_STUCK`].
/// At a fifth of the aluminium drive's 10 N m limit the free hub (0.027 kg m^2 with the beam)
/// turns about 0.015 rad, nearly 40 counts, in 20 ms from rest, and a moving hub many more:
/// no count at all means the encoder or the hub is stuck, and the loop is pushing blind.
/// (A reversal stops the count for a tick or two, far less.)
pub const STALL_TICKS: u32 = 20;
/// Fraction of the torque limit above which a motionless encoder counts toward a stall.
pub const STALL_TORQUE_FRACTION: f32 = 0.2;

/// Ticks of one unchanged gauge code before the gauge counts as frozen (a converter that
/// stopped converting, an open bridge read as its zero code): [`FaultFlags::GAUGE`]. A
/// converter whose codes are at most a sixteenth of the gauge noise the designs assume
/// ([`crate::law::ASSUMED_STRAIN_NOISE`], 0.6 ue; 0.0006 ue a code for the shipped 24-bit
/// converter at +-5000 ue) reads a live bridge's noise as a new code nearly every tick: two
/// equal codes in a row come about once in 3000 ticks at 0.5 ue of noise, ten never. A
/// coarser converter is not watched this way.
pub const GAUGE_FROZEN_TICKS: u32 = 10;

/// The faults of the gauge's reading alone. Under torque (Slewing, Holding) they latch, no
/// new move or payload is taken until `clear`, and the move and the hold go on without the
/// gauge: the laws that read it only as a term (smc-strain) are given a strain of zero, and
/// the observer laws, whose observer cannot run without it, hand over to the drive's own law
/// ([`Brake`]), which reads the encoder alone. Cutting the torque instead would leave a hub
/// that was moving to coast on. In the Idle mode they latch the Fault mode as any other.
pub const GAUGE_FAULTS: FaultFlags =
    FaultFlags(FaultFlags::GAUGE.0 | FaultFlags::ADC_RAIL.0 | FaultFlags::OVER_STRAIN.0);

/// Idle samples averaged for the strain offset at most (a quarter second at 1 kHz is plenty,
/// and the sum cannot overflow).
const MAX_ZERO_SAMPLES: u32 = 1 << 16;
// `mean_code` divides by at most 2^16.
const _: () = assert!(MAX_ZERO_SAMPLES <= 1 << 16);

/// The per-tick controller, generic over the move's knot capacity `K`.
#[derive(Clone, Debug, PartialEq)]
pub struct Controller<const K: usize> {
    cfg: Config<K>,
    st: State,
}

impl<const K: usize> Controller<K> {
    /// Validates `settings` and builds an idle controller running `law` along `spline`.
    pub fn try_build(
        settings: ControllerSettings,
        law: ControlLaw,
        spline: Spline<K>,
    ) -> Result<Self, ConfigError> {
        let s = &settings;
        let bad = |field, kind| ConfigError::Param(ParamError { field, kind });
        for (field, v) in [
            ("ts_s", s.ts_s),
            ("theta_home_rad", s.theta_home_rad),
            ("velocity_cutoff_hz", s.velocity_cutoff_hz),
            ("strain_rate_cutoff_hz", s.strain_rate_cutoff_hz),
            ("torque_limit_nm", s.torque_limit_nm),
            ("max_speed_rad_s", s.max_speed_rad_s),
            ("max_strain", s.max_strain),
            ("start_tolerance_rad", s.start_tolerance_rad),
        ] {
            if !v.is_finite() {
                return Err(bad(field, ParamErrorKind::NonFinite));
            }
        }
        for (field, v) in [
            ("ts_s", s.ts_s),
            ("torque_limit_nm", s.torque_limit_nm),
            ("max_speed_rad_s", s.max_speed_rad_s),
            ("max_strain", s.max_strain),
            ("start_tolerance_rad", s.start_tolerance_rad),
        ] {
            if !(v > 0.0) {
                return Err(bad(field, ParamErrorKind::NotPositive));
            }
        }
        if s.encoder.counts_per_rev == 0 {
            return Err(bad("encoder.counts_per_rev", ParamErrorKind::NotPositive));
        }
        if !(2..=32).contains(&s.encoder.counter_bits) {
            return Err(bad("encoder.counter_bits", ParamErrorKind::OutOfRange));
        }
        if !(2..=32).contains(&s.adc.bits) {
            return Err(bad("adc.bits", ParamErrorKind::OutOfRange));
        }
        if !(s.adc.full_scale_strain > 0.0 && s.adc.full_scale_strain.is_finite()) {
            return Err(bad("adc.full_scale_strain", ParamErrorKind::NotPositive));
        }
        let velocity_lpf = LowPass::from_cutoff(s.velocity_cutoff_hz, s.ts_s)
            .ok_or(bad("velocity_cutoff_hz", ParamErrorKind::NotPositive))?;
        let strain_rate_lpf = LowPass::from_cutoff(s.strain_rate_cutoff_hz, s.ts_s)
            .ok_or(bad("strain_rate_cutoff_hz", ParamErrorKind::NotPositive))?;
        // The sensors' directions as the scales' signs: nothing more in the tick.
        let fixed_rad_per_count = s.encoder.fixed_rad_per_count();
        let signed_rad_per_count = fixed_rad_per_count.to_f32();
        let max_counts =
            libm::ceilf(s.max_speed_rad_s * s.ts_s / libm::fabsf(signed_rad_per_count));
        // The wrapped difference is only unambiguous below half the counter's range.
        let half_range = (1i64 << (s.encoder.counter_bits - 1)) - 1;
        if !(max_counts < half_range as f32) {
            return Err(bad("max_speed_rad_s", ParamErrorKind::OutOfRange));
        }
        let brake = Brake::for_law(&law);
        let strain_per_code = s.adc.signed_strain_per_code() as f32;
        // In f32, from the scale the tick uses: no double-precision arithmetic on the board.
        let frozen_code_ticks =
            if libm::fabsf(strain_per_code) * 16.0 <= ASSUMED_STRAIN_NOISE as f32 {
                GAUGE_FROZEN_TICKS
            } else {
                u32::MAX
            };
        let cfg = Config {
            settings,
            law,
            spline,
            rad_per_count: signed_rad_per_count,
            rad_per_count_fixed: fixed_rad_per_count,
            strain_per_code,
            rails: (s.adc.min_code(), s.adc.max_code()),
            max_counts_per_tick: max_counts as u32,
            counter_width: s.encoder.width(),
            velocity_lpf,
            strain_rate_lpf,
            brake,
            frozen_code_ticks,
            stall_torque_nm: STALL_TORQUE_FRACTION * s.torque_limit_nm,
            stall_speed_rad_s: 2.0 * libm::fabsf(signed_rad_per_count) / s.ts_s,
        };
        let st = State {
            offset_code: s.strain_offset_code as f32,
            // The encoder's count is zero where it was powered up, which is the home angle:
            // a status or a plan before the first tick sees the hub there, not at 0.
            theta: s.theta_home_rad,
            // No converter reads it but at its rail: the first code is never a repeat.
            last_code: i32::MIN,
            ..State::default()
        };
        Ok(Self { cfg, st })
    }

    /// Arms the move: the next tick starts it if the hub is at the spline's start. From
    /// here on the drive counts as slewing ([`Controller::mode`]).
    pub fn start_move(&mut self) -> Result<(), CommandError> {
        if !self.st.faults.is_empty() {
            return Err(CommandError::Faulted);
        }
        match self.mode() {
            Mode::Fault => Err(CommandError::Faulted),
            Mode::Slewing => Err(CommandError::Busy),
            Mode::Idle | Mode::Holding => {
                self.arm(false);
                Ok(())
            }
        }
    }

    /// Brakes the hub along `spline` (`planner::plan_brake`: from the hub's angle and rate
    /// at some snapshot to rest), in place of whatever runs: from Idle (a hub coasting with
    /// the torque off), Holding (a hold that lost its hub) or Slewing (a move that cannot be
    /// stopped on its own plan). Refused only in the Fault mode.
    ///
    /// The brake is the drive's, not the table law's: the hub is tracked by rigid-body
    /// feedforward and a PD on the hub alone ([`Brake`]), the same for every law, since a
    /// law tuned for moves from rest (a sliding surface, an observer started from rest) can
    /// lose a hub that is turning fast. Its next tick moves the plan onto the hub where it
    /// finds it (the plan was made from a snapshot, and ticks have passed since: a hub at
    /// 25 rad/s turns 0.025 rad a tick), so no start check applies; the plan's rate is the
    /// snapshot's, which a coasting hub keeps. The law takes over again with the next move.
    pub fn start_brake(&mut self, spline: Spline<K>) -> Result<(), CommandError> {
        if self.mode() == Mode::Fault {
            return Err(CommandError::Faulted);
        }
        self.cfg.spline = spline;
        self.arm(true);
        Ok(())
    }

    /// Arms the spline's start for the next tick (a brake's if `brake`).
    fn arm(&mut self, brake: bool) {
        // The range, widened to the move's ends (a move back into it, a brake).
        let (a, b) = (self.cfg.spline.start(), self.cfg.spline.end());
        let (lo, hi) = (a.min(b).min(-RANGE_RAD), a.max(b).max(RANGE_RAD));
        // The strain offset the move will use: the mean of the idle codes so far,
        // which are exactly those the next tick (which takes the start) would see.
        // The 64-bit division runs here, with the command, and not in a tick.
        let st = &mut self.st;
        if st.zero_n > 0 {
            st.zero_mean = mean_code(st.zero_sum, st.zero_n);
        }
        // As centre and half-width: one comparison a tick.
        st.range = ((lo + hi) / 2.0, (hi - lo) / 2.0 + RANGE_FAULT_MARGIN_RAD);
        // The law starts the move from a clear state. Cleared here rather than when
        // the next tick takes the start: no tick runs the law in between, and that
        // first tick is the observer laws' worst.
        st.law_state.restart(&self.cfg.law);
        st.start_pending = true;
        st.brake_pending = brake;
    }

    /// Clears latched faults and returns to `Idle` (torque off). The strain offset is measured
    /// again from the following idle ticks; the last measured angle, rate and strain stay
    /// what they were until the next tick measures them again.
    pub fn reset(&mut self) {
        let st = self.st;
        self.st = State {
            counter: st.counter,
            uptime: st.uptime,
            omega: st.omega,
            theta: st.theta,
            strain: st.strain,
            offset_code: self.cfg.settings.strain_offset_code as f32,
            last_code: i32::MIN,
            ..State::default()
        };
    }

    /// Swaps in a new, already validated law (gains), whole. Refused while slewing.
    pub fn set_law(&mut self, law: ControlLaw) -> Result<(), CommandError> {
        if self.mode() == Mode::Slewing {
            return Err(CommandError::Busy);
        }
        self.cfg.brake = Brake::for_law(&law);
        self.cfg.law = law;
        Ok(())
    }

    /// Swaps in the next move (validated when it was built). Refused while slewing; the move
    /// starts with [`Controller::start_move`].
    pub fn set_spline(&mut self, spline: Spline<K>) -> Result<(), CommandError> {
        if self.mode() == Mode::Slewing {
            return Err(CommandError::Busy);
        }
        self.cfg.spline = spline;
        Ok(())
    }

    /// Replaces the running move, whole, by `spline`, on the same clock: the next tick
    /// evaluates it where it would have evaluated the old one. For a stop, whose spline
    /// equals the old one up to now. Refused unless slewing (or armed to: a move accepted
    /// and not yet started is replaced before it starts).
    pub fn replace_move(&mut self, spline: Spline<K>) -> Result<(), CommandError> {
        if self.mode() != Mode::Slewing {
            return Err(CommandError::NotMoving);
        }
        // The clock stays; the new spline's search starts where this tick's time falls in it,
        // here on the command path, not on the next tick.
        self.st.segment = spline.segment_at(self.st.ticks as f32 * self.cfg.settings.ts_s);
        self.cfg.spline = spline;
        Ok(())
    }

    /// What a command needs to know of the controller, copied (a board takes it from the
    /// tick's resource in a few instructions and plans from it outside).
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            mode: self.mode(),
            theta_rad: self.st.theta,
            omega_rad_s: self.st.omega,
            move_elapsed_s: self.move_elapsed_s(),
            faults: self.st.faults,
        }
    }

    /// Torque off now: back to `Idle` (a latched fault stays latched).
    pub fn disable(&mut self) {
        if self.st.mode != Mode::Fault {
            self.st.mode = Mode::Idle;
        }
        self.st.start_pending = false;
    }

    /// Latches `faults` from outside the tick (a board's clock that did not start): the
    /// Fault mode, torque off, as a fault the tick found would.
    pub fn latch(&mut self, faults: FaultFlags) {
        if faults.is_empty() {
            return;
        }
        self.st.faults.insert(faults);
        self.st.mode = Mode::Fault;
        self.st.start_pending = false;
    }

    /// Ticks run since the controller was built (wraps; a `reset` keeps counting).
    pub fn uptime_ticks(&self) -> u32 {
        self.st.uptime
    }

    /// The hub angle measured by the last tick, rad.
    pub fn theta_rad(&self) -> f32 {
        self.st.theta
    }

    /// The hub rate (filtered) of the last tick, rad/s.
    pub fn omega_rad_s(&self) -> f32 {
        self.st.omega
    }

    /// The root strain (offset removed) of the last tick.
    pub fn strain(&self) -> f32 {
        self.st.strain
    }

    /// Time into the move, s (0 when idle or faulted, and for a move armed but not started).
    pub fn move_elapsed_s(&self) -> f32 {
        if self.st.start_pending {
            return 0.0;
        }
        match self.st.mode {
            Mode::Slewing | Mode::Holding => self.st.ticks as f32 * self.cfg.settings.ts_s,
            Mode::Idle | Mode::Fault => 0.0,
        }
    }

    /// The current mode, as commands see it: a move armed by
    /// [`start_move`](Self::start_move) counts as slewing from then (it starts on the next
    /// tick), so that every later command sees the move it was answered.
    pub fn mode(&self) -> Mode {
        if self.st.start_pending && self.st.mode != Mode::Fault {
            Mode::Slewing
        } else {
            self.st.mode
        }
    }

    /// The law's own state: smc-i's integral, the LQG law's observer estimate.
    pub fn law_state(&self) -> &LawState {
        &self.st.law_state
    }

    /// The law's own state, to change: for a simulation that stands in for the observer
    /// (the true state fed to the law, to measure what the observer costs). A drive never
    /// calls it.
    pub fn law_state_mut(&mut self) -> &mut LawState {
        &mut self.st.law_state
    }

    /// The latched faults.
    pub fn faults(&self) -> FaultFlags {
        self.st.faults
    }

    /// The move.
    pub fn spline(&self) -> &Spline<K> {
        &self.cfg.spline
    }

    /// The validated settings.
    pub fn settings(&self) -> &ControllerSettings {
        &self.cfg.settings
    }
}

#[cfg(test)]
mod tests;
