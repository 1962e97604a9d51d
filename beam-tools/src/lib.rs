//! The tools of the slewing-beam toolchain, behind the `beam` command line: gain design
//! ([`optimize`]), parameter identification from a logged move ([`calibrate`]) and the
//! model against a log ([`replay`]), command scripts for a commanded drive
//! ([`drive_script`]), Monte Carlo robustness ([`sweep`]), the processor-in-the-loop host
//! ([`pil_host`]), a drive on a serial port ([`serial_drive`]), the drive's telemetry
//! ([`telemetry`]), parameter files ([`params_file`]), gain tables read at run time
//! ([`table`]), plots ([`plot`]) and output files written whole ([`files`]).
//!
//! They all run model-core's controller against the simulated world of `host-tests`.
#![forbid(unsafe_code)]

pub mod calibrate;
pub mod drive_script;
pub mod files;
pub mod lsq;
pub mod optimize;
pub mod params_file;
pub mod pil_host;
pub mod plot;
pub mod replay;
pub mod serial_drive;
pub mod split;
pub mod sweep;
pub mod table;
pub mod telemetry;
