//! Control core for sliding-mode control of a slewing flexible beam.
//!
//! This crate is `no_std`, allocation-free and fixed-size so that the very same code runs in
//! the Cortex-M4F drive's 1 kHz loop and, under `cargo test`, against the simulated nonlinear
//! beam on the host. It is layered so that configuration is built and validated once, outside
//! the hot path, and the per-tick [`controller::Controller::step`] never fails and never panics:
//!
//! - [`beam`]: physical parameters, the two presets, validation.
//! - [`modal`]: the assumed-modes model (mode shapes, mass, stiffness and foreshortening
//!   matrices, frequencies) of DESIGN section 2, in `f64` because it is computed once.
//! - [`spline`]: the rest-to-rest reference (quintic and multi-knot C2).
//! - [`measure`]: raw counts and ADC codes to angle, velocity and strain.
//! - [`law`]: the paper's SMC, the strain-augmented SMC and the PD baseline.
//! - [`controller`]: the per-tick step, its state machine and fault detection.
//!
//! SI units inside; names carry units where they are not obvious (`torque_nm`).
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod beam;
pub mod controller;
pub mod gains;
pub mod law;
pub mod linalg;
pub mod measure;
pub mod modal;
pub mod spline;

/// The controller sample period used by the paper's testbed and by default everywhere: 1 kHz.
pub const DEFAULT_TS_S: f32 = 1.0e-3;

pub use beam::{Beam, BeamParams, ParamError, Preset};

pub use controller::{
    CommandError, ConfigError, Controller, ControllerSettings, FaultFlags, Mode, RawMeasurement,
    TorqueCommand,
};
pub use law::{ControlLaw, Law, LawKind, PdGains, SmcGains, StrainSmcGains, Switching};
pub use measure::{AdcSpec, EncoderSpec};
pub use modal::{ModalModel, ModelError};
pub use spline::{RefPoint, Spline, SplineError};
