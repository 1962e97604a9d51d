//! Control core for sliding-mode control of a slewing flexible beam.
//!
//! This crate is `no_std`, allocation-free and fixed-size so that the very same code runs in
//! the Cortex-M4F drive's 1 kHz loop and, under `cargo test`, against the simulated nonlinear
//! beam on the host. It is layered so that configuration is built and validated once, outside
//! the hot path, and the per-tick [`controller::Controller::step`] never fails and never panics:
//!
//! - [`beam`], [`modal`], [`linalg`], [`plant`]: the beam's parameters, its assumed-modes
//!   model and the plant the drive is built for, from the `beam-model` crate (re-exported).
//! - [`table`]: the drive's configuration as one value, [`DriveTable`] (plant, instruments,
//!   law, gains, shapers, observer designs), and gain scheduling over the payload. Passed in
//!   by whoever builds the drive; nothing here reads a table from a file or a global.
//! - [`spline`]: the rest-to-rest reference (quintic and multi-knot C2); [`knots`]: the
//!   knot capacity of each kind of move.
//! - [`shaper`]: ZV, ZVD and EI input shapers, and shaped moves as splines.
//! - [`measure`]: raw counts and ADC codes to angle, velocity and strain.
//! - [`law`]: the paper's SMC, the strain-augmented SMC and the PD baseline.
//! - [`controller`]: the per-tick step, its state machine and fault detection.
//! - [`error`]: every error type, with `Display` and `core::error::Error`.
//!
//! SI units inside; names carry units where they are not obvious (`torque_nm`). The model,
//! the laws and the tick are explained in the repository's `docs/design.md`.
//!
//! # Example
//!
//! Build the aluminium beam's 3-mode model, the paper's SMC with gains of your own, and a
//! controller for the paper's slew reading the reference drive's instruments; then run ticks
//! as the drive does, raw readings in and torque out:
//!
//! ```
//! use model_core::table::Instruments;
//! use model_core::{
//!     Beam, BeamParams, ControlLaw, Controller, ControllerSettings, Mode, ModalModel,
//!     PlantPoint, RawMeasurement, SmcGains, Spline, Switching,
//! };
//! use core::f32::consts::FRAC_PI_2;
//!
//! let beam = Beam::try_build(BeamParams::aluminium())?;
//! let model = ModalModel::<3>::try_build(&beam)?;
//! let gains = SmcGains { w: 80.0, a: 10.0, beta: 1.2, switching: Switching::Tanh };
//! let law = ControlLaw::try_build(gains.law(), PlantPoint::of(&model))?;
//! let slew = Spline::<2>::quintic(-FRAC_PI_2, FRAC_PI_2, 0.35)?;
//! // The encoder counter reads 0 at -90 deg, where the slew starts.
//! let settings = ControllerSettings::new(Instruments::DEFAULT);
//! let mut controller = Controller::try_build(settings, law, slew)?;
//!
//! // Idle: torque off while the strain offset is measured.
//! let at_rest = RawMeasurement::default();
//! assert_eq!(controller.step(&at_rest).torque_nm, 0.0);
//!
//! // Start the move; with the hub held at the start, the reference runs away from it, so the
//! // law pushes the hub forward, within the drive's limit.
//! controller.start_move().expect("idle and not faulted");
//! let mut out = controller.step(&at_rest);
//! for _ in 0..20 {
//!     out = controller.step(&at_rest);
//! }
//! assert_eq!(out.mode, Mode::Slewing);
//! assert!(out.torque_nm > 0.0 && out.torque_nm <= 10.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub use beam_model::{beam, linalg, lqg, modal, plant};
pub mod commands;
pub mod controller;
pub mod error;
pub mod knots;
pub mod law;
pub mod measure;
pub mod planner;
pub mod shaper;
pub mod spline;
pub mod table;

/// The control loop's rate, Hz: the paper's testbed and the drive's TIM2 tick.
pub const LOOP_HZ: u32 = 1_000;

/// The controller sample period used by the paper's testbed and by default everywhere: one
/// tick of [`LOOP_HZ`].
pub const DEFAULT_TS_S: f32 = 1.0 / LOOP_HZ as f32;

pub use beam_model::DRIVE_TORQUE_LIMIT_NM;

pub use beam::{Beam, BeamParams, ParamError, Preset};

pub use controller::{
    CommandError, ConfigError, Controller, ControllerSettings, FaultFlags, Mode, RawMeasurement,
    Snapshot, TorqueCommand,
};
pub use law::{
    ControlLaw, Law, LawGains, LawKind, LawState, LqgGains, PdFfGains, PdGains, Settings, SmcGains,
    SmcIGains, SmcModalGains, StrainSmcGains, Switching,
};
pub use measure::{AdcSpec, EncoderSpec};
pub use modal::{ModalModel, ModelError};
pub use planner::{plan_move, plan_through, Limits, PlanError, PlannedMove, Waypoint};
pub use plant::{Plant, PlantPoint};
pub use shaper::{Shaper, ShaperError, ShaperKind, Timing};
pub use spline::{RefPoint, Spline, SplineError};
pub use table::{DriveConfig, DriveTable, GainRow, Instruments};
