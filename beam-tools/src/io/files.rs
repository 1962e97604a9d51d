//! Output files written whole or not at all: each is written to a temporary file beside its
//! destination and renamed into place, so an error never leaves a partial file behind.
//!
//! A destination that exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is
//! written through instead: renaming onto it would replace the device node with a plain file,
//! and for `/dev/null`, run as root, break every program on the machine that reads it.

use crate::io::plot::PlotError;
use beam_sim::sim::SimResult;
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

/// Whether `path` (followed through symlinks) is something that exists and is neither a regular
/// file nor a directory: a device, a FIFO or a socket, to be written into rather than replaced.
fn is_special(path: &Path) -> bool {
    fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Opens an existing special file for writing (no create, no truncate: neither means anything
/// for a device or a FIFO).
fn open_special(path: &Path) -> io::Result<fs::File> {
    fs::OpenOptions::new().write(true).open(path)
}

/// Writes `path` through `fill`, atomically (or straight into it if it is a device or a FIFO).
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    if is_special(path) {
        let mut w = BufWriter::new(open_special(path)?);
        fill(&mut w)?;
        return w.flush();
    }
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

/// Draws a plot through `draw` (given a temporary path) and renames it to `path`. A device or
/// FIFO gets the finished image copied into it, from a temporary file in the system's
/// temporary directory (never beside it, in `/dev`).
pub fn plot_atomically(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), PlotError>,
) -> Result<(), FileError> {
    let special = is_special(path);
    let tmp = if special {
        std::env::temp_dir().join(temp_beside(path).file_name().unwrap_or_default())
    } else {
        temp_beside(path)
    };
    let out = draw(&tmp).map_err(Box::from).and_then(|()| {
        if special {
            fs::File::open(&tmp)
                .and_then(|mut from| io::copy(&mut from, &mut open_special(path)?))
                .map(drop)
                .and_then(|()| fs::remove_file(&tmp))
        } else {
            fs::rename(&tmp, path)
        }
        .map_err(Box::from)
    });
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

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::FileTypeExt;

    /// A FIFO in a fresh directory, and a thread that reads everything written into it.
    fn fifo(name: &str) -> (PathBuf, std::thread::JoinHandle<Vec<u8>>) {
        let dir = std::env::temp_dir().join(format!("beam-files-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        let status = std::process::Command::new("mkfifo")
            .arg(&path)
            .status()
            .expect("mkfifo (coreutils) runs");
        assert!(status.success());
        let reader = {
            let path = path.clone();
            std::thread::spawn(move || fs::read(path).unwrap())
        };
        (path, reader)
    }

    fn is_fifo(path: &Path) -> bool {
        fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_fifo())
    }

    #[test]
    fn a_fifo_is_written_into_not_replaced() {
        let (path, reader) = fifo("trace.csv");
        write_atomically(&path, |w| w.write_all(b"t_s,torque_nm\n0,0\n")).unwrap();
        // Checked before the join: a reader left waiting on a replaced FIFO never returns.
        assert!(is_fifo(&path), "the FIFO was replaced by a regular file");
        assert_eq!(reader.join().unwrap(), b"t_s,torque_nm\n0,0\n");
        let dir = path.parent().unwrap();
        let left: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(
            left,
            vec![path.clone()],
            "a temporary file was left beside it"
        );
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_plot_into_a_fifo_arrives_whole_and_leaves_no_temporary_file() {
        let (path, reader) = fifo("plot.png");
        let mut drawn_at = None;
        plot_atomically(&path, |tmp| {
            drawn_at = Some(tmp.to_path_buf());
            fs::write(tmp, b"\x89PNG image").map_err(|e| PlotError::Draw(e.to_string()))
        })
        .unwrap();
        assert!(is_fifo(&path), "the FIFO was replaced by a regular file");
        assert_eq!(reader.join().unwrap(), b"\x89PNG image");
        let drawn_at = drawn_at.unwrap();
        assert_ne!(
            drawn_at.parent(),
            path.parent(),
            "drawn beside a special file"
        );
        assert!(!drawn_at.exists(), "the temporary image was left behind");
        fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }

    #[test]
    fn a_regular_file_is_still_replaced_whole() {
        let dir = std::env::temp_dir().join(format!("beam-files-{}-regular", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.csv");
        fs::write(&path, "old").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("failed midway"))
        });
        assert!(err.is_err());
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        write_atomically(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1);
        fs::remove_dir_all(&dir).unwrap();
    }
}
