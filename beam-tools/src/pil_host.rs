//! Processor-in-the-loop: the PIL firmware, running under QEMU's emulated STM32F405, is the
//! drive side of the closed loop, and the plant stays on the host.
//!
//! [`PilDrive`] implements [`DriveLoop`]: each tick it writes one sensor frame to the drive's
//! semihosting stdin and reads one command frame from its stdout (`beam_wire` defines both,
//! and both ends run the same encoder and decoder). QEMU runs under `timeout`, so a drive that
//! hangs ends the run instead of the test. After the run the same sensor stream is replayed
//! through the host's build of the very same controller (`firmware::config`) and the torques
//! compared bit for bit; the instruction-count plugin's log gives the cost of each tick, and
//! the drive's defmt telemetry (on semihosting stderr) is decoded with the ELF.

use crate::telemetry::{self, mode_of, Decoded};
use beam_wire::{
    decode, encode, CommandFrame, DriveMessage, FrameReader, HostMessage, SensorFrame, MAX_FRAME,
};
use firmware::config::{build_controller_for, sequence};
use host_tests::plant::Plant;
use host_tests::sim::{run_with, DriveLoop, SimError, SimOptions, SimResult};
use model_core::LawKind;
use model_core::{ControllerSettings, FaultFlags, RawMeasurement, TorqueCommand};
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};

/// How to run the PIL drive.
#[derive(Clone, Debug)]
pub struct PilConfig {
    /// The PIL firmware (`cargo fw` builds it as `.../release/pil`).
    pub elf: PathBuf,
    /// The QEMU binary.
    pub qemu: String,
    /// The instruction-count plugin, if counting.
    pub plugin: Option<PathBuf>,
    /// Seconds before QEMU is killed.
    pub timeout_s: u32,
    /// The law the drive runs.
    pub controller: LawKind,
    /// Payload, kg (gain schedule and the drive's model).
    pub payload_kg: f32,
}

/// Instructions per tick, from the plugin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InsnStats {
    /// Ticks counted.
    pub ticks: usize,
    /// Fewest in one tick.
    pub min: u64,
    /// Mean over the ticks.
    pub mean: f64,
    /// Most in one tick.
    pub max: u64,
}

/// A finished PIL run.
#[derive(Clone, Debug)]
pub struct PilOutcome {
    /// The closed-loop run, as `simulate` records it.
    pub run: SimResult,
    /// Ticks the drive ran.
    pub ticks: u32,
    /// Largest |torque difference| from the host's replay, N m.
    pub max_torque_diff: f64,
    /// Largest difference from the host's replay in units in the last place of f32.
    pub max_ulps: u64,
    /// Every torque, mode and fault set equal to the host's replay, bit for bit.
    pub identical: bool,
    /// Instructions per tick, when counted.
    pub insns: Option<InsnStats>,
    /// The drive's defmt telemetry.
    pub telemetry: Decoded,
}

/// The emulated drive on the other end of the frames.
pub struct PilDrive {
    child: Child,
    stdin: Option<ChildStdin>,
    stdout: BufReader<ChildStdout>,
    stderr_thread: Option<std::thread::JoinHandle<Vec<u8>>>,
    log: PathBuf,
    timeout_s: u32,
    reader: FrameReader,
    seq: u32,
    settings: ControllerSettings,
    faults: u8,
    /// What was sent and received each tick, for the replay.
    record: Vec<(RawMeasurement, bool, CommandFrame)>,
}

impl PilDrive {
    /// Starts QEMU with the PIL firmware (and the plugin, if any), sends the setup and waits
    /// for the drive to report ready. `settings` are the drive's controller settings.
    pub fn spawn(cfg: &PilConfig, settings: ControllerSettings) -> Result<Self, String> {
        if !cfg.elf.exists() {
            return Err(format!(
                "{}: not found (build the PIL firmware with `cargo fw`)",
                cfg.elf.display()
            ));
        }
        let log = std::env::temp_dir().join(format!(
            "beam-pil-{}-{}.log",
            std::process::id(),
            RUN_ID.fetch_add(1, Ordering::Relaxed)
        ));
        let mut cmd = Command::new("timeout");
        cmd.args(["--kill-after=2", &cfg.timeout_s.to_string(), &cfg.qemu])
            .args(["-machine", "netduinoplus2", "-cpu", "cortex-m4"])
            .args(["-display", "none", "-monitor", "none", "-serial", "null"])
            .args(["-semihosting-config", "enable=on,target=native"]);
        if let Some(plugin) = &cfg.plugin {
            cmd.arg("-plugin")
                .arg(plugin)
                .args(["-d", "plugin", "-D"])
                .arg(&log);
        }
        cmd.arg("-kernel").arg(&cfg.elf);
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("starting `timeout {}`: {e}", cfg.qemu))?;
        let stdin = child.stdin.take();
        let stdout = child.stdout.take();
        let stderr = child.stderr.take();
        let stderr_thread = stderr.map(|mut e| {
            std::thread::spawn(move || {
                let mut bytes = vec![];
                let _ = e.read_to_end(&mut bytes);
                bytes
            })
        });
        let mut drive = PilDrive {
            child,
            stdin,
            stdout: BufReader::new(stdout.ok_or("no stdout pipe")?),
            stderr_thread,
            log,
            timeout_s: cfg.timeout_s,
            reader: FrameReader::new(),
            seq: 0,
            settings,
            faults: 0,
            record: vec![],
        };
        drive.send(&HostMessage::Setup {
            controller: cfg.controller,
            payload_kg: cfg.payload_kg,
        })?;
        match drive.receive() {
            Ok(DriveMessage::Ready) => Ok(drive),
            Ok(DriveMessage::Error(e)) => Err(format!("the PIL drive refused the setup: {e}")),
            Ok(other) => Err(format!("expected `ready` from the drive, got {other:?}")),
            Err(e) => Err(drive.explain(e)),
        }
    }

    /// Sends one message.
    pub fn send(&mut self, msg: &HostMessage) -> Result<(), String> {
        let mut buf = [0u8; MAX_FRAME + 1];
        let frame = encode(msg, &mut buf).map_err(|e| format!("encoding a frame: {e}"))?;
        self.send_raw(frame)
    }

    /// Sends bytes as they are (for tests of the drive's frame checks).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), String> {
        let stdin = self
            .stdin
            .as_mut()
            .ok_or("the link to the drive is closed")?;
        stdin
            .write_all(bytes)
            .and_then(|_| stdin.flush())
            .map_err(|e| format!("writing to the drive: {e} (QEMU exited or timed out)"))
    }

    /// Ends the run: `Stop`, then waits for QEMU. Returns its stderr (the drive's defmt
    /// stream) and the plugin's log, or why the drive did not exit cleanly.
    pub fn finish(mut self) -> Result<(Vec<u8>, String), String> {
        let stop = self.send(&HostMessage::Stop);
        self.stdin = None;
        let (status, stderr, log) = self.wait();
        stop?;
        if !status.success() {
            return Err(format!(
                "the PIL drive exited with {status}{}",
                qemu_message(&stderr)
            ));
        }
        Ok((stderr, log))
    }

    /// Closes the link and waits for QEMU: its status, stderr and the plugin's log.
    pub fn wait(&mut self) -> (std::process::ExitStatus, Vec<u8>, String) {
        self.stdin = None;
        let status = match self.child.wait() {
            Ok(s) => s,
            Err(_) => {
                let _ = self.child.kill();
                self.child.wait().unwrap_or_else(|_| exit_status_failed())
            }
        };
        let stderr = self
            .stderr_thread
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        let log = std::fs::read_to_string(&self.log).unwrap_or_default();
        let _ = std::fs::remove_file(&self.log);
        (status, stderr, log)
    }

    /// An error with what QEMU said and how it ended.
    fn explain(&mut self, e: String) -> String {
        let (status, stderr, _) = self.wait();
        let killed = if status.code() == Some(124) {
            format!(" (killed after {} s)", self.timeout_s)
        } else {
            String::new()
        };
        format!("{e}; QEMU {status}{killed}{}", qemu_message(&stderr))
    }

    /// Receives one message.
    pub fn receive(&mut self) -> Result<DriveMessage, String> {
        let mut byte = [0u8; 1];
        loop {
            let n = self
                .stdout
                .read(&mut byte)
                .map_err(|e| format!("reading from the drive: {e}"))?;
            if n == 0 {
                return Err(if self.reader.partial() {
                    "the drive's output ended in the middle of a frame".into()
                } else {
                    "the drive's output ended (QEMU exited or timed out)".into()
                });
            }
            if let Some(frame) = self.reader.push(byte[0]) {
                let frame = frame.map_err(|e| format!("frame from the drive: {e}"))?;
                return decode(frame).map_err(|e| format!("frame from the drive: {e}"));
            }
        }
    }
}

impl DriveLoop for PilDrive {
    fn settings(&self) -> &ControllerSettings {
        &self.settings
    }

    fn tick(&mut self, raw: &RawMeasurement, start: bool) -> Result<TorqueCommand, SimError> {
        let frame = SensorFrame {
            seq: self.seq,
            encoder_raw: raw.encoder_raw,
            strain_code: raw.strain_root_code,
            amp_fault: raw.amp_fault,
            start,
        };
        self.send(&HostMessage::Sensors(frame))
            .map_err(SimError::Drive)?;
        let c = match self.receive().map_err(SimError::Drive)? {
            DriveMessage::Command(c) if c.seq == self.seq => c,
            DriveMessage::Command(c) => {
                return Err(SimError::Drive(format!(
                    "command frame {} out of order, expected {}",
                    c.seq, self.seq
                )))
            }
            DriveMessage::Error(e) => {
                return Err(SimError::Drive(format!("the PIL drive stopped: {e}")))
            }
            DriveMessage::Ready => {
                return Err(SimError::Drive("the drive sent `ready` mid-run".into()))
            }
        };
        let mode = mode_of(c.mode).ok_or_else(|| {
            SimError::Drive(format!("command frame {}: mode {} unknown", c.seq, c.mode))
        })?;
        self.record.push((*raw, start, c));
        self.faults = c.faults;
        self.seq = self.seq.wrapping_add(1);
        Ok(TorqueCommand {
            torque_nm: c.torque_nm,
            mode,
            faults: FaultFlags(c.faults),
            theta_rad: c.theta_rad,
            // Not sent: the runner evaluates the reference itself.
            theta_ref_rad: f32::NAN,
            strain: c.strain,
        })
    }

    fn faults(&self) -> String {
        FaultFlags(self.faults).to_string()
    }
}

impl Drop for PilDrive {
    fn drop(&mut self) {
        // A run that ended early must not leave QEMU (or the plugin's log) behind.
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

/// Distance between two f32s in units in the last place (0 when the bits are equal).
pub fn ulps(a: f32, b: f32) -> u64 {
    // Map the sign-magnitude bits onto a line where adjacent floats differ by one.
    let key = |x: f32| {
        let b = x.to_bits() as i64;
        if b & (1 << 31) != 0 {
            (1i64 << 31) - b
        } else {
            b
        }
    };
    key(a).abs_diff(key(b))
}

/// Parses the plugin's `insn-count: between markers = N` lines.
pub fn parse_insn_log(text: &str) -> Option<InsnStats> {
    let counts: Vec<u64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("insn-count: between markers = "))
        .filter_map(|n| n.trim().parse().ok())
        .collect();
    Some(InsnStats {
        ticks: counts.len(),
        min: *counts.iter().min()?,
        max: *counts.iter().max()?,
        mean: counts.iter().sum::<u64>() as f64 / counts.len() as f64,
    })
}

static RUN_ID: AtomicU32 = AtomicU32::new(0);

/// Runs the paper's slew with the PIL drive under QEMU against `plant`.
pub fn run_pil<const N: usize>(
    plant: Plant<N>,
    cfg: &PilConfig,
    opts: &SimOptions,
) -> Result<PilOutcome, String> {
    // The host's build of the drive's controller: checks the setup before QEMU starts, and
    // is the reference the drive's torques are compared with.
    let mut host = build_controller_for(cfg.controller, cfg.payload_kg)
        .map_err(|e| format!("controller {}: {e:?}", cfg.controller.name()))?;
    let reference = sequence().map_err(|e| format!("{e:?}"))?[0].clone();
    let elf = std::fs::read(&cfg.elf).map_err(|e| {
        format!(
            "{}: {e} (build the PIL firmware with `cargo fw`)",
            cfg.elf.display()
        )
    })?;
    let mut drive = PilDrive::spawn(cfg, *host.settings())?;
    let run = match run_with(plant, &mut drive, &reference, opts) {
        Ok(run) => run,
        Err(e) => return Err(drive.explain(e.to_string())),
    };
    let record = std::mem::take(&mut drive.record);
    let ticks = drive.seq;
    let (stderr, insn_text) = drive.finish()?;

    // The same sensor stream through the host's build of the same controller.
    let (mut max_diff, mut max_ulps, mut identical) = (0.0f64, 0u64, true);
    for (raw, start, c) in &record {
        let h = host.tick(raw, *start).map_err(|e| e.to_string())?;
        let d = (h.torque_nm as f64 - c.torque_nm as f64).abs();
        max_diff = max_diff.max(d);
        max_ulps = max_ulps.max(ulps(h.torque_nm, c.torque_nm));
        identical &= h.torque_nm.to_bits() == c.torque_nm.to_bits()
            && h.mode as u8 == c.mode
            && h.faults.0 == c.faults;
    }
    let telemetry = telemetry::decode_defmt(&elf, &stderr)?;
    let insns = match &cfg.plugin {
        Some(_) => Some(parse_insn_log(&insn_text).ok_or_else(|| {
            format!("the instruction-count plugin logged no counts: {insn_text}")
        })?),
        None => None,
    };
    Ok(PilOutcome {
        run,
        ticks,
        max_torque_diff: max_diff,
        max_ulps,
        identical,
        insns,
        telemetry,
    })
}

fn exit_status_failed() -> std::process::ExitStatus {
    use std::os::unix::process::ExitStatusExt;
    std::process::ExitStatus::from_raw(1 << 8)
}

/// QEMU's own complaint, if its stderr holds text rather than defmt frames.
fn qemu_message(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("qemu") || l.contains("timeout"))
        .collect();
    if lines.is_empty() {
        String::new()
    } else {
        format!(": {}", lines.join("; "))
    }
}

/// The instruction-count plugin, built with the shared script into `out_dir` when missing.
pub fn build_plugin(tool_dir: &Path, out_dir: &Path) -> Result<PathBuf, String> {
    let script = tool_dir.join("build.sh");
    if !script.exists() {
        return Err(format!(
            "{}: not found (the shared qemu-insn-count tool; or pass --no-insn-count)",
            script.display()
        ));
    }
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let out = out_dir.join("libinsn_count.so");
    let status = Command::new("bash")
        .arg(&script)
        .arg(&out)
        .stdout(Stdio::null())
        .status()
        .map_err(|e| format!("running {}: {e}", script.display()))?;
    if !status.success() || !out.exists() {
        return Err(format!("{} failed ({status})", script.display()));
    }
    Ok(out)
}

/// Where the workspace keeps things: `target/` and the shared tools beside the checkout.
pub mod paths {
    use std::path::PathBuf;

    /// The workspace root.
    pub fn workspace() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// The PIL firmware `cargo fw` builds.
    pub fn pil_elf() -> PathBuf {
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| workspace().join("target"));
        target.join("thumbv7em-none-eabihf/release/pil")
    }

    /// The shared instruction-count tool.
    pub fn insn_tool() -> PathBuf {
        workspace().join("../shared/tools/qemu-insn-count")
    }

    /// Where the plugin is built.
    pub fn plugin_dir() -> PathBuf {
        workspace().join("target/qemu-insn-count")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulps_count_representable_steps_across_zero() {
        assert_eq!(ulps(1.0, 1.0), 0);
        assert_eq!(ulps(1.0, f32::from_bits(1.0f32.to_bits() + 3)), 3);
        assert_eq!(ulps(0.0, -0.0), 0);
        let tiny = f32::from_bits(1);
        assert_eq!(ulps(tiny, -tiny), 2);
    }

    #[test]
    fn insn_lines_give_min_mean_max() {
        let log = "insn-count: between markers = 300\nother\ninsn-count: between markers = 500\ninsn-count: total = 9\n";
        assert_eq!(
            parse_insn_log(log),
            Some(InsnStats {
                ticks: 2,
                min: 300,
                mean: 400.0,
                max: 500
            })
        );
        assert_eq!(parse_insn_log("nothing"), None);
    }
}
