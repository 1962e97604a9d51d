//! The tools of the slewing-beam toolchain, behind the `beam` command line, by role:
//!
//! - [`identify`]: the model's parameters from logged moves (`beam calibrate`: the paper's
//!   steps in [`identify::calibrate`], the split method in [`identify::split`]), the model
//!   against a log ([`identify::replay`]), and the small least squares they share
//!   ([`identify::lsq`]).
//! - [`design`]: gains by constrained optimisation ([`design::optimize`]), Monte Carlo
//!   robustness ([`design::sweep`]).
//! - [`link`]: the drive's end points on the host: the processor-in-the-loop host
//!   ([`link::pil_host`]), a drive on a serial port ([`link::serial_drive`]), command scripts
//!   ([`link::drive_script`]) and the drive's telemetry ([`link::telemetry`]).
//! - [`io`]: parameter files ([`io::params_file`]), plots ([`io::plot`]) and output files
//!   written whole ([`io::files`]).
//!
//! They all run model-core's controller against the simulated world of `beam-sim`.
#![forbid(unsafe_code)]

pub mod design;
pub mod identify;
pub mod io;
pub mod link;
