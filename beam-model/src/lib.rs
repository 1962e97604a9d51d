//! The slewing beam as physics: its parameters, its assumed-modes model, and the plant a
//! drive is built for.
//!
//! `no_std`, allocation-free, in `f64`: everything here is computed once, on the host (the
//! gain table's build script compiles the plant into the drive as constants, so the drive
//! links none of the model's soft-float code) or when a host tool sets up a simulation.
//!
//! - [`beam`]: physical parameters, the two presets, validation ([`ParamError`]).
//! - [`modal`]: the assumed-modes model (mode shapes, mass, stiffness and foreshortening
//!   matrices, frequencies) of docs/design.md, section 2 ([`ModelError`]).
//! - [`plant`]: the model reduced to what the control laws and the planner read, at one
//!   payload ([`plant::PlantPoint`]) and over a payload grid ([`plant::Plant`]).
//! - [`linalg`]: the small dense linear algebra the model needs.
//! - [`sqrt`]: the square root as the drive's FPU takes it.
//! - [`lqg`]: the sampled linear model, a steady-state Kalman filter (the modal state
//!   observer) and LQR state feedback with integral action.
#![cfg_attr(not(test), no_std)]
// Denied, not forbidden: `sqrt::sqrtf`'s one FPU instruction is the crate's only unsafe block.
#![deny(unsafe_code)]

pub mod beam;
pub mod linalg;
pub mod lqg;
pub mod modal;
pub mod plant;
pub mod sqrt;

/// The drive's torque limit, N m: the controller saturates at it, the amplifier's full scale
/// equals it (so saturation never clips twice), and the presets' plant carries it.
pub const DRIVE_TORQUE_LIMIT_NM: f32 = 10.0;

pub use beam::{Beam, BeamParams, Preset};
pub use beam::{ParamError, ParamErrorKind};
pub use modal::ModalModel;
pub use modal::ModelError;
pub use plant::{Plant, PlantPoint};
