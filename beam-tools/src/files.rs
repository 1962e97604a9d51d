//! Output files written whole or not at all: each is written to a temporary file beside its
//! destination and renamed into place, so an error never leaves a partial file behind.

use crate::plot::PlotError;
use host_tests::sim::SimResult;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// A temporary path in the same directory as `path` (so the rename stays on one file system),
/// keeping the extension (the plot backends choose the format by it).
fn temp_beside(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp{ext}", std::process::id()))
}

/// Writes `path` through `fill`, atomically.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = temp_beside(path);
    let result = (|| {
        let mut w = BufWriter::new(fs::File::create(&tmp)?);
        fill(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()
    })();
    match result.and_then(|()| fs::rename(&tmp, path)) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// A file that could not be written: which, and why.
#[derive(Debug, thiserror::Error)]
#[error("{}", .path.display())]
pub struct FileError {
    /// The destination.
    pub path: PathBuf,
    /// Why.
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

/// Draws a plot through `draw` (given a temporary path) and renames it to `path`.
pub fn plot_atomically(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), PlotError>,
) -> Result<(), FileError> {
    let tmp = temp_beside(path);
    let out = draw(&tmp)
        .map_err(Box::from)
        .and_then(|()| fs::rename(&tmp, path).map_err(Box::from));
    if out.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    out.map_err(|source| FileError {
        path: path.to_path_buf(),
        source,
    })
}

/// The trace as CSV. The first five columns are what a drive logs and `beam calibrate` reads:
/// time, applied torque, the hub angle and root strain *as measured* (encoder quantisation,
/// ADC noise and offset removal included) and the mid-span strain (true value: the simulated
/// drive has no mid-span gauge). The rest are the plant's true signals. SI units.
pub fn write_trace_csv(run: &SimResult, w: &mut dyn Write) -> io::Result<()> {
    writeln!(
        w,
        "t_s,torque_nm,theta_rad,root_strain,mid_strain,theta_ref_rad,theta_true_rad,root_strain_true,omega_rad_s,w_tip_m,tip_angle_rad"
    )?;
    for s in &run.samples {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{}",
            s.t,
            s.torque,
            s.theta_meas,
            s.root_strain_meas,
            s.mid_strain,
            s.theta_ref,
            s.theta,
            s.root_strain,
            s.omega,
            s.w_tip,
            s.tip_angle
        )?;
    }
    Ok(())
}
