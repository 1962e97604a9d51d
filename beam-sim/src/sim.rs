//! The closed-loop runner: the continuous plant, the simulated sensors, and the model-core
//! controller sampled at its tick with a zero-order hold on the torque.
//!
//! Each tick the plant's state is read by the sensors into a [`model_core::RawMeasurement`], handed to
//! exactly the `Controller::step` the firmware calls, and the returned torque is held while the
//! plant is integrated to the next tick. The validity guard runs after every tick and ends the
//! run with a [`Breakdown`] rather than let numbers from outside the model through.

use crate::plant::{Breakdown, Plant, State};
use crate::sensors::{SensorConfig, Sensors};
use model_core::controller::ConfigError;
use model_core::law::LawPlant;
use model_core::lqg::{LqgDesign, LqgError, LqgWeights, DESIGN_MODES, MAX_STATES};
use model_core::planner::MAX_WAYPOINTS;
use model_core::spline::paper_slew;
use model_core::{plan_through, Limits, Shaper, Timing, Waypoint};
use model_core::{
    ControlLaw, Controller, ControllerSettings, Law, LawGains, LqgGains, ModalModel, Mode,
    RawMeasurement, SmcGains, SmcIGains, Spline, StrainSmcGains, TorqueCommand,
};

/// The paper's move time AT, s, as the host's metrics use it (model-core's
/// `spline::paper_slew` is the one definition of the slew).
pub const SLEW_TIME_S: f64 = paper_slew::TIME_MS as f64 / 1000.0;

/// The paper's SMC gains picked by hand (model-core's `SmcGains::START`, where their
/// derivation is).
pub const HAND_PICKED_SMC: SmcGains = SmcGains::START;

/// The strain-augmented SMC's hand-picked gains (`StrainSmcGains::START`).
pub const HAND_PICKED_SMC_STRAIN: StrainSmcGains = StrainSmcGains::START;

/// The integral sliding mode's starting gains (`SmcIGains::START`).
pub const HAND_PICKED_SMC_I: SmcIGains = SmcIGains::START;

/// The LQG law's starting weights, those of the shipped rows (`LqgGains::START`).
pub const HAND_PICKED_LQG: LqgGains = LqgGains::START;

/// Knot capacity of the moves the host runs.
pub const MOVE_CAPACITY: usize = model_core::planner::SHAPED_PLAN_KNOTS;

/// How the plant is integrated between ticks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// Fixed-step RK4 with this many steps per controller tick.
    Rk4 {
        /// Steps per tick.
        substeps: u32,
    },
    /// The adaptive DOP853 reference at these tolerances.
    Dop853 {
        /// Relative tolerance.
        rtol: f64,
        /// Absolute tolerance.
        atol: f64,
    },
}

impl Default for Integrator {
    fn default() -> Self {
        // 0.25 ms steps: h * omega_max is about 0.3 for the aluminium beam's fourth mode
        // (about 190 Hz), well inside RK4's stability region; the agreement test with DOP853
        // bounds the error.
        Integrator::Rk4 { substeps: 4 }
    }
}

/// Options of one closed-loop run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimOptions {
    /// Simulated time after the move starts, s.
    pub duration_s: f64,
    /// Plant integrator.
    pub integrator: Integrator,
    /// Idle ticks before the move starts (the controller measures the strain offset).
    pub idle_ticks: u32,
    /// Simulated sensors.
    pub sensors: SensorConfig,
    /// A fault injected during the run, if any.
    pub fault: Option<Injection>,
    /// The move: the paper's slew unless changed.
    pub motion: Motion,
    /// Feed the observer laws the beam's true state instead of their observer's estimate
    /// ([`TrueState`]), to measure what the observer costs. The other laws read the
    /// instruments as always.
    pub true_state: bool,
}

/// A move as the host plans it, with model-core's planner: a minimum-jerk quintic from one
/// angle to another, optionally shaped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Start, rad (the hub is at rest there, and the encoder is zeroed there).
    pub from_rad: f32,
    /// End, rad.
    pub to_rad: f32,
    /// Duration of the base quintic, s (see `timing`).
    pub time_s: f32,
    /// The input shaper applied to the reference.
    pub shaper: Shaper,
    /// Whether the shaped move ends at `time_s` (base move shortened) or later.
    pub timing: Timing,
    /// Waypoints passed on the way to `to_rad` (planned by model-core's planner).
    pub via: Via,
    /// Ignore `time_s` and take the shortest time the planner's limits allow.
    pub shortest: bool,
    /// A shortest move to a target is planned to leave an observer law's reference beam at
    /// rest (`model_core::planner::exact`); other laws and moves plan as before.
    pub exact: bool,
}

/// Waypoints a move passes through before its target, rad: at most
/// `MAX_WAYPOINTS - 1` (the target is the last waypoint).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Via {
    rad: [f32; MAX_WAYPOINTS - 1],
    len: usize,
}

impl Via {
    /// The waypoints `rad`, or `None` if there are more than `MAX_WAYPOINTS - 1`.
    pub fn new(rad: &[f32]) -> Option<Self> {
        let mut via = Via::default();
        via.rad.get_mut(..rad.len())?.copy_from_slice(rad);
        via.len = rad.len();
        Some(via)
    }

    /// The waypoints, rad.
    pub fn as_slice(&self) -> &[f32] {
        &self.rad[..self.len]
    }
}

impl Default for Motion {
    fn default() -> Self {
        Motion {
            from_rad: paper_slew::FROM_RAD,
            to_rad: paper_slew::TO_RAD,
            time_s: paper_slew::TIME_S,
            shaper: Shaper::NONE,
            timing: Timing::Stretch,
            via: Via::default(),
            shortest: false,
            exact: false,
        }
    }
}

impl Motion {
    /// Whether the move goes through the planner (waypoints, or the shortest time), whose
    /// limits need the drive's model.
    pub fn needs_planner(&self) -> bool {
        self.via.len > 0 || self.shortest
    }

    /// A single move with its time: the (shaped) quintic, with no limits applied.
    pub fn quintic(&self) -> Result<Spline<MOVE_CAPACITY>, SimError> {
        model_core::shaper::shaped_quintic(
            self.from_rad,
            self.to_rad,
            self.time_s,
            &self.shaper,
            self.timing,
        )
        .map_err(SimError::Shaper)
    }

    /// The reference spline, planned by model-core (the drive plans with the same code). A
    /// single move with a time is the shaped quintic; a move through waypoints or in the
    /// shortest time goes through the planner, within `limits`.
    pub fn plan(&self, limits: &Limits) -> Result<Spline<MOVE_CAPACITY>, SimError> {
        if !self.needs_planner() {
            return self.quintic();
        }
        if self.timing == Timing::EndOnTime {
            return Err(SimError::Option(
                "a move through waypoints or in the shortest time is stretched by its shaper; it cannot end on time",
            ));
        }
        let mut waypoints = [Waypoint {
            rad: self.to_rad,
            at_s: None,
        }; MAX_WAYPOINTS];
        for (w, &rad) in waypoints.iter_mut().zip(self.via.as_slice()) {
            w.rad = rad;
        }
        let n = self.via.len + 1;
        waypoints[n - 1].rad = self.to_rad;
        let time = (!self.shortest).then_some(self.time_s);
        plan_through(self.from_rad, &waypoints[..n], time, &self.shaper, limits)
            .map(|plan| plan.shaped)
            .map_err(SimError::Plan)
    }
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            duration_s: 2.0,
            integrator: Integrator::default(),
            idle_ticks: 50,
            sensors: SensorConfig::default(),
            fault: None,
            motion: Motion::default(),
            true_state: false,
        }
    }
}

/// A fault injected into the closed loop from `at_s` after the move starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Injection {
    /// What goes wrong.
    pub kind: FaultKind,
    /// When, s after the move starts.
    pub at_s: f64,
}

/// The failures users of motor drives report, as they reach the drive's inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// The encoder counter jumps by this many counts once (a glitch on the A/B lines) and
    /// keeps the offset.
    EncoderGlitch {
        /// Counts added.
        counts: i32,
    },
    /// The encoder counter stops changing (a broken wire or a slipping coupling).
    EncoderStuck,
    /// The strain bridge is disconnected: the converter reads its positive rail.
    StrainDisconnected,
    /// The strain gauge's offset drifts (temperature) by this much strain per second.
    StrainDrift {
        /// Strain per second.
        per_s: f64,
    },
    /// The amplifier's fault line is asserted from then on.
    AmpFault,
    /// An external torque on the hub (N m) for `for_s` seconds, which holds the drive at its
    /// torque limit.
    LoadTorque {
        /// Torque, N m.
        nm: f64,
        /// Duration, s.
        for_s: f64,
    },
    /// One control tick does not run: the amplifier keeps the previous command.
    MissedTick,
}

/// One recorded tick: the true plant state and what the controller did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time since the move started, s.
    pub t: f64,
    /// Hub angle, rad.
    pub theta: f64,
    /// Hub rate, rad/s.
    pub omega: f64,
    /// Reference angle, rad.
    pub theta_ref: f64,
    /// Torque applied over the next tick, N m.
    pub torque: f64,
    /// True root strain.
    pub root_strain: f64,
    /// True mid-span strain.
    pub mid_strain: f64,
    /// Tip deflection, m.
    pub w_tip: f64,
    /// Tip angle, rad.
    pub tip_angle: f64,
    /// Controller mode after the tick.
    pub mode: Mode,
    /// Hub angle as the controller measured it (encoder counts), rad.
    pub theta_meas: f64,
    /// Root strain as the controller measured it (ADC code, offset removed).
    pub root_strain_meas: f64,
    /// Faults latched after the tick.
    pub faults: model_core::FaultFlags,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct SimResult {
    /// One sample per tick from t = 0.
    pub samples: Vec<Sample>,
    /// Set when the validity guard stopped the run: when, and why.
    pub breakdown: Option<(f64, Breakdown)>,
    /// The move's final angle, rad.
    pub theta_final: f64,
    /// When the move's reference ends, s (0.35 for the paper's slew).
    pub move_end_s: f64,
    /// The external load applied, if any: from when to when, s.
    pub load_window: Option<(f64, f64)>,
    /// The controller's latched faults at the end.
    pub faults: model_core::FaultFlags,
}

/// A run that could not start, or whose drive failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The gains or settings were rejected.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The move was rejected.
    #[error("move")]
    Spline(#[source] model_core::SplineError),
    /// The shaped move was rejected.
    #[error("move")]
    Shaper(#[source] model_core::ShaperError),
    /// The planner refused the move.
    #[error("move")]
    Plan(#[source] model_core::PlanError),
    /// An option is out of range.
    #[error("{0}")]
    Option(&'static str),
    /// The beam parameters were rejected.
    #[error(transparent)]
    Beam(#[from] model_core::ParamError),
    /// The modal model could not be built.
    #[error(transparent)]
    Model(#[from] model_core::ModelError),
    /// The drive on the other end of the loop failed (the PIL drive under QEMU).
    #[error(transparent)]
    Drive(Box<dyn std::error::Error + Send + Sync>),
}

/// Controller settings matching the plant and sensors: the torque limit of the beam, the
/// encoder and ADC specs of the sensors, the home angle of the slew's start.
pub fn settings_for<const N: usize>(
    model: &ModalModel<N>,
    sensors: &SensorConfig,
) -> ControllerSettings {
    ControllerSettings {
        encoder: sensors.encoder,
        adc: sensors.adc,
        theta_home_rad: paper_slew::FROM_RAD,
        torque_limit_nm: model.beam.params().torque_limit_nm as f32,
        ..ControllerSettings::new(sensors.instruments())
    }
}

/// The paper's slew (-90 to +90 deg in 0.35 s, quintic).
pub fn paper_slew() -> Result<Spline<MOVE_CAPACITY>, SimError> {
    Spline::quintic(paper_slew::FROM_RAD, paper_slew::TO_RAD, paper_slew::TIME_S)
        .map_err(SimError::Spline)
}

/// Runs the paper's slew on `model` under `law`.
pub fn simulate<const N: usize>(
    model: &ModalModel<N>,
    law: Law,
    opts: &SimOptions,
) -> Result<SimResult, SimError> {
    simulate_mismatched(model, model, law, opts)
}

/// The paper's slew with the controller designed on `nominal` running against `plant`: the
/// robustness case, where the drive's model is not the beam's.
pub fn simulate_mismatched<const N: usize>(
    plant: &ModalModel<N>,
    nominal: &ModalModel<N>,
    law: Law,
    opts: &SimOptions,
) -> Result<SimResult, SimError> {
    simulate_knowing(plant, plant, nominal, Known::NONE, law, opts)
}

/// Which parts of the drive are built on the beam on the hub rather than on the drive's
/// nominal model ([`simulate_knowing`]): what identifying the beam for that part alone could
/// at most give.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Known {
    /// An observer law's model of the beam: the observer's sampled dynamics, its centrifugal
    /// term on the hub, its strain output and its identifier's beam (whose `G` the drive
    /// derives from the reference beam's numbers, so it follows `reference`, as does the
    /// observer's centrifugal term on the modes, which is the reference beam's).
    pub observer: bool,
    /// The observer's Kalman gain.
    pub kalman: bool,
    /// The feedback: the observer laws' regulators and integral gain, and the plant's numbers
    /// every law scales its gains by (`LawPlant::point`). The moving regulator then does not
    /// follow the stiffness the identifier finds (`LqgDesign::k_move_compliance`): it is the
    /// beam's already.
    pub regulator: bool,
    /// The move: an observer law's reference beam and feedforward, and the planner's limits.
    /// A shaper's frequency is the caller's to move.
    pub reference: bool,
}

impl Known {
    /// The drive built on its nominal model alone.
    pub const NONE: Self = Self {
        observer: false,
        kalman: false,
        regulator: false,
        reference: false,
    };
    /// The drive built on the beam itself.
    pub const ALL: Self = Self {
        observer: true,
        kalman: true,
        regulator: true,
        reference: true,
    };

    /// `nominal` with the parts known taken from `beam`, the design made on the beam.
    pub fn take(self, mut nominal: LqgDesign, beam: &LqgDesign) -> LqgDesign {
        let d = &mut nominal;
        if self.observer {
            d.ad = beam.ad;
            d.bd = beam.bd;
            d.strain_coef = beam.strain_coef;
            d.strain_omitted = beam.strain_omitted;
            d.strain_omitted_rate = beam.strain_omitted_rate;
            d.strain_omitted_spin = beam.strain_omitted_spin;
            d.obs_s_hub = beam.obs_s_hub;
            d.count_interval = beam.count_interval;
            d.id_a = beam.id_a;
            d.id_c = beam.id_c;
        }
        if self.kalman {
            d.l = beam.l;
        }
        if self.regulator {
            d.k = beam.k;
            d.k_move = beam.k_move;
            d.k_filter = beam.k_filter;
            d.k_move_filter = beam.k_move_filter;
            // The moving regulator is the beam's already: nothing for the stiffness the
            // identifier finds against the nominal observer to move it by (it would count
            // the beam's difference twice).
            d.k_move_compliance = [0.0; MAX_STATES];
            d.k_move_filter_compliance = 0.0;
            d.ki = beam.ki;
            d.jeff = beam.jeff;
        }
        if self.reference {
            d.ref_ad = beam.ref_ad;
            d.ref_bd = beam.ref_bd;
            d.ref_hub = beam.ref_hub;
            d.ref_s = beam.ref_s;
            d.ref_hz = beam.ref_hz;
            d.mtt = beam.mtt;
            d.viscous = beam.viscous;
            d.torque_limit_nm = beam.torque_limit_nm;
        }
        nominal
    }
}

/// A drive's model with the parts in `known` made on `beam` and the rest on `nominal`.
struct PartlyKnown<P> {
    beam: P,
    nominal: P,
    known: Known,
}

impl<P: LawPlant> LawPlant for PartlyKnown<P> {
    fn point(&self) -> model_core::PlantPoint {
        if self.known.regulator {
            self.beam.point()
        } else {
            self.nominal.point()
        }
    }

    fn lqg(&self, weights: &LqgWeights, ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        let nominal = self.nominal.lqg(weights, ts_s)?;
        if self.known == Known::NONE {
            return Some(nominal);
        }
        let beam = self.beam.lqg(weights, ts_s)?;
        Some(nominal.and_then(|n| beam.map(|b| self.known.take(n, &b))))
    }
}

/// [`simulate_mismatched`] on `plant` with the parts of the drive in `known` built on `beam`
/// rather than on `nominal`: `plant` itself, or a beam with only some of its parameters (what
/// identifying those alone could give).
pub fn simulate_knowing<const N: usize>(
    plant: &ModalModel<N>,
    beam: &ModalModel<N>,
    nominal: &ModalModel<N>,
    known: Known,
    law: Law,
    opts: &SimOptions,
) -> Result<SimResult, SimError> {
    let settings = ControllerSettings {
        theta_home_rad: opts.motion.from_rad,
        ..settings_for(nominal, &opts.sensors)
    };
    // The planner's limits for this law (a floor on the move's time for the lqg law).
    let limits = Limits::for_law(if known.reference { beam } else { nominal }, &law);
    // Designed on the instruments the loop reads (an observer law's noise is theirs).
    let instruments = opts.sensors.instruments();
    let on = PartlyKnown {
        beam: instruments.on(beam),
        nominal: instruments.on(nominal),
        known,
    };
    let law = if opts.true_state {
        ControlLaw::try_build(law, TrueState(on))
    } else {
        ControlLaw::try_build(law, on)
    }
    .map_err(|e| SimError::Config(e.into()))?;
    let limits = if opts.motion.exact {
        limits.with_reference_beam(&law, settings.ts_s)
    } else {
        limits
    };
    let controller = Controller::try_build(settings, law, opts.motion.plan(&limits)?)
        .map_err(SimError::Config)?;
    run(Plant::new(*plant), controller, opts)
}

/// The drive side of the closed loop: what turns one tick's raw readings into a command.
/// The host's own [`Controller`], or the firmware running under QEMU (`crate::pil`).
pub trait DriveLoop {
    /// The controller's settings (tick, home angle, sensor scales).
    fn settings(&self) -> &ControllerSettings;
    /// One tick. `start` asks for the move to start with this tick, as the START button does.
    fn tick(&mut self, raw: &RawMeasurement, start: bool) -> Result<TorqueCommand, SimError>;
    /// The latched faults at the end.
    fn faults(&self) -> model_core::FaultFlags;
    /// The plant's state at the last tick, in an observer's layout (`[theta, q_1, q_2,
    /// theta', q_1', q_2']`), before this tick's readings: the runner calls it with
    /// [`SimOptions::true_state`]. A drive that cannot take it ignores it.
    fn feed_truth(&mut self, _x: &[f32; MAX_STATES]) {}
}

/// A plant whose observer design has no gain ([`SimOptions::true_state`]): the observer
/// only predicts, from the state the runner sets ([`DriveLoop::feed_truth`]) and the torque
/// applied, so the law acts on the true state one tick's prediction ahead, the same
/// instant its own observer would estimate.
pub struct TrueState<P>(pub P);

impl<P: LawPlant> LawPlant for TrueState<P> {
    fn point(&self) -> model_core::PlantPoint {
        self.0.point()
    }

    fn lqg(&self, weights: &LqgWeights, ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        self.0.lqg(weights, ts_s).map(|design| {
            design.map(|mut d| {
                d.l = [[0.0; 2]; MAX_STATES];
                d
            })
        })
    }
}

impl<const K: usize> DriveLoop for Controller<K> {
    fn settings(&self) -> &ControllerSettings {
        Controller::settings(self)
    }

    fn tick(&mut self, raw: &RawMeasurement, start: bool) -> Result<TorqueCommand, SimError> {
        if start && self.start_move().is_err() {
            return Err(SimError::Option(
                "the controller faulted while idle before the move",
            ));
        }
        Ok(self.step(raw))
    }

    fn faults(&self) -> model_core::FaultFlags {
        Controller::faults(self)
    }

    fn feed_truth(&mut self, x: &[f32; MAX_STATES]) {
        self.law_state_mut().lqg.estimate = *x;
    }
}

/// Applies `f` to this tick's raw readings (or load torque, or tick skip).
#[allow(clippy::too_many_arguments)]
fn inject(
    f: Injection,
    t: f64,
    first: bool,
    raw: &mut RawMeasurement,
    stuck_raw: &mut Option<u32>,
    load: &mut f64,
    skip: &mut bool,
    sensors: &SensorConfig,
) {
    let adc = sensors.adc;
    match f.kind {
        FaultKind::EncoderGlitch { counts } => {
            raw.encoder_raw = raw.encoder_raw.wrapping_add(counts as u32) & sensors.encoder.mask();
        }
        FaultKind::EncoderStuck => {
            raw.encoder_raw = *stuck_raw.get_or_insert(raw.encoder_raw);
        }
        FaultKind::StrainDisconnected => raw.strain_root_code = adc.max_code(),
        FaultKind::StrainDrift { per_s } => {
            let drift = (per_s * (t - f.at_s) / adc.signed_strain_per_code()).round();
            let code = raw.strain_root_code as f64 + drift;
            raw.strain_root_code = code.clamp(adc.min_code() as f64, adc.max_code() as f64) as i32;
        }
        FaultKind::AmpFault => raw.amp_fault = true,
        FaultKind::LoadTorque { nm, for_s } => {
            if t < f.at_s + for_s {
                *load = nm;
            }
        }
        FaultKind::MissedTick => *skip = first,
    }
}

/// Runs `controller` against `plant` from rest at the move's start.
pub fn run<const N: usize, const K: usize>(
    plant: Plant<N>,
    mut controller: Controller<K>,
    opts: &SimOptions,
) -> Result<SimResult, SimError> {
    let reference = controller.spline().clone();
    run_with(plant, &mut controller, &reference, opts)
}

/// Runs `drive` against `plant` from rest at the start of `reference`, the move the drive
/// runs when started; `reference` also gives the recorded reference angle.
pub fn run_with<const N: usize, const K: usize, D: DriveLoop>(
    plant: Plant<N>,
    drive: &mut D,
    reference: &Spline<K>,
    opts: &SimOptions,
) -> Result<SimResult, SimError> {
    if !(opts.duration_s.is_finite() && opts.duration_s > 0.0 && opts.duration_s <= 3600.0) {
        return Err(SimError::Option(
            "duration must be a finite number of seconds in (0, 3600]",
        ));
    }
    // The tick as the decimal it was written as (1e-3, not f32's 1.0000000475e-3): the drive's
    // timer period is exact, and the sample times print cleanly.
    let ts_f32 = drive.settings().ts_s;
    let ts = crate::decimal::f32_decimal(ts_f32);
    let theta_home = drive.settings().theta_home_rad as f64;
    let mut sensors = Sensors::new(opts.sensors, theta_home);
    let mut x = State::<N>::at_rest(reference.start() as f64);
    let read = |x: &State<N>, sensors: &mut Sensors| {
        sensors.read(x.theta, plant.outputs(x).root_strain, false)
    };

    for _ in 0..opts.idle_ticks {
        let raw = read(&x, &mut sensors);
        drive.tick(&raw, false)?;
    }
    let ticks = (opts.duration_s / ts).round() as usize;
    let time_of = |k: usize| crate::decimal::tick_time(k, ts);
    let mut samples = Vec::with_capacity(ticks + 1);
    let mut breakdown = None;
    let mut last_cmd = None;
    let mut stuck_raw = None;
    let mut last_x = x;
    for k in 0..=ticks {
        let t = time_of(k);
        let mut raw = read(&x, &mut sensors);
        let mut load = 0.0;
        let mut skip = false;
        if let Some(f) = opts.fault.filter(|f| t >= f.at_s - 1e-12) {
            // The first tick at or after the fault's time.
            let first = t - f.at_s < ts - 1e-12;
            inject(
                f,
                t,
                first,
                &mut raw,
                &mut stuck_raw,
                &mut load,
                &mut skip,
                &opts.sensors,
            );
        }
        if opts.true_state && k > 0 {
            drive.feed_truth(&observed_layout(&last_x));
        }
        let cmd = match (skip, last_cmd) {
            (true, Some(previous)) => previous,
            _ => drive.tick(&raw, k == 0)?,
        };
        last_x = x;
        last_cmd = Some(cmd);
        let tau = plant.saturate(cmd.torque_nm as f64);
        let out = plant.outputs(&x);
        samples.push(Sample {
            t,
            theta: x.theta,
            omega: x.omega,
            theta_ref: reference.eval(t as f32).pos as f64,
            torque: tau,
            root_strain: out.root_strain,
            mid_strain: out.mid_strain,
            w_tip: out.w_tip,
            tip_angle: out.tip_angle,
            mode: cmd.mode,
            theta_meas: cmd.theta_rad as f64,
            root_strain_meas: cmd.strain as f64,
            faults: cmd.faults,
        });
        if k == ticks {
            break;
        }
        x = match opts.integrator {
            Integrator::Rk4 { substeps } => {
                let n = substeps.max(1);
                let h = ts / n as f64;
                (0..n).fold(x, |x, _| plant.rk4_step(&x, tau + load, h))
            }
            Integrator::Dop853 { rtol, atol } => match plant.dop853(&x, tau + load, ts, rtol, atol)
            {
                Ok(next) => next,
                Err(_) => {
                    breakdown = Some((t + ts, Breakdown::NonFinite));
                    break;
                }
            },
        };
        if let Err(why) = plant.check_validity(&x) {
            breakdown = Some((t + ts, why));
            break;
        }
    }
    Ok(SimResult {
        samples,
        breakdown,
        theta_final: reference.end() as f64,
        move_end_s: crate::decimal::f32_decimal(reference.duration_s()),
        load_window: opts.fault.and_then(|f| match f.kind {
            FaultKind::LoadTorque { for_s, .. } => Some((f.at_s, f.at_s + for_s)),
            _ => None,
        }),
        faults: drive.faults(),
    })
}

/// `x` in an observer's layout: the hub, the first [`DESIGN_MODES`] modal coordinates (the
/// plant's and the design's are the same assumed modes of the clamped beam), and their rates.
fn observed_layout<const N: usize>(x: &State<N>) -> [f32; MAX_STATES] {
    let mut out = [0.0f32; MAX_STATES];
    out[0] = x.theta as f32;
    out[1 + DESIGN_MODES] = x.omega as f32;
    for i in 0..DESIGN_MODES.min(N) {
        out[1 + i] = x.q[i] as f32;
        out[2 + DESIGN_MODES + i] = x.qd[i] as f32;
    }
    out
}
