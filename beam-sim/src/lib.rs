//! The simulated world the control core is tested against: the nonlinear beam plant, the
//! sensors (encoder counts and strain-bridge codes with noise), the closed-loop runner that
//! drives model-core's `Controller::step` tick by tick, and the metrics of a run.
//!
//! Everything here is `std` and `f64`; the controller it drives is the very `no_std`, `f32`
//! model-core code the firmware runs. The tests in `tests/` run that controller against this
//! plant (physics, closed loop, faults); the tools built on it (the `beam` CLI, the optimiser,
//! calibration, sweeps, the PIL host) live in `beam-tools`.
#![forbid(unsafe_code)]

pub mod commanded;
pub mod decimal;
pub mod metrics;
pub mod plant;
pub mod sensors;
pub mod sim;
