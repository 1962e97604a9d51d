//! The drive's end points on the host: the emulated drive, a drive on a serial port, command
//! scripts, and the drive's telemetry.

pub mod drive_script;
pub mod pil_host;
pub mod serial_drive;
pub mod telemetry;
