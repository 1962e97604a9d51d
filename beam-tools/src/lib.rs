//! The tools of the slewing-beam toolchain, behind the `beam` command line, by role:
//!
//! - [`identify`]: the model's parameters from logged moves (`beam calibrate`: the paper's
//!   steps in [`identify::calibrate`], the split method in [`identify::split`]), the model
//!   against a log ([`identify::replay`]), what a user should know about a calibration
//!   ([`identify::warnings`]), and the small least squares they share ([`identify::lsq`]).
//! - [`design`]: gains by constrained optimisation ([`design::optimize`]), Monte Carlo
//!   robustness ([`design::sweep`]).
//! - [`link`]: the drive's end points on the host: the processor-in-the-loop host
//!   ([`link::pil_host`]), a drive on a serial port ([`link::serial_drive`]), command scripts
//!   ([`link::drive_script`]) and the drive's telemetry ([`link::telemetry`]).
//! - [`fit`]: the search design and identification share: bounded quantities on the unit
//!   cube, a Latin hypercube, a multi-start local search.
//! - [`io`]: parameter files ([`io::params_file`]), gain tables loaded at run time
//!   ([`io::table_file`]), plots ([`io::plot`]) and output files written whole
//!   ([`io::files`]).
//!
//! They all run model-core's controller against the simulated world of `beam-sim`.
#![forbid(unsafe_code)]

pub mod design;
pub mod fit;
pub mod identify;
pub mod io;
pub mod link;
