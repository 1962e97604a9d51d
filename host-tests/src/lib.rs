//! Host side of the slewing-beam toolchain: the nonlinear plant, simulated sensors, the
//! closed-loop runner around the model-core controller, metrics, plots and the `beam` CLI.
//!
//! Everything here is `std` and `f64`; the controller it drives is the very `no_std`, `f32`
//! model-core code the firmware runs.

pub mod calibrate;
pub mod io;
pub mod metrics;
pub mod optimize;
pub mod pil;
pub mod plant;
pub mod plot;
pub mod preset_file;
pub mod sensors;
pub mod sim;
pub mod sweep;
pub mod telemetry;
