//! Processor-in-the-loop: the PIL firmware, running under QEMU's emulated STM32F405, is the
//! drive side of the closed loop, and the plant stays on the host.
//!
//! [`PilDrive`] implements [`DriveLoop`]: each tick it writes one sensor frame to the drive's
//! semihosting stdin and reads one command frame from its stdout (`beam_wire` defines both,
//! and both ends run the same encoder and decoder). QEMU runs under `timeout`, so a drive that
//! hangs ends the run instead of the test. After the run the same sensor stream is replayed
//! through the host's build of the very same controller (`beam_drive::config`) and the torques
//! compared bit for bit; the instruction-count plugin's log gives the cost of each tick, and
//! the drive's defmt telemetry (on semihosting stderr) is decoded with the ELF.

use crate::link::telemetry::{self, mode_of, Decoded};
use beam_drive::config::{build_commanded, build_controller_for, sequence_for, BuildError};
use beam_sim::commanded::{run_script, CommandedDrive, CommandedRun, HostDrive, Step};
use beam_sim::plant::Plant;
use beam_sim::sim::{run_with, DriveLoop, SimError, SimOptions, SimResult};
use beam_wire::command::{Reply, Request};
use beam_wire::{
    decode, encode, CommandFrame, DriveError, DriveMessage, FrameError, FrameReader, HostMessage,
    SensorFrame, MAX_FRAME,
};
use model_core::{ControllerSettings, FaultFlags, RawMeasurement, TorqueCommand};
use model_core::{DriveTable, LawKind};
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};

/// Which ticks the instruction-count plugin counts per instruction address.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InsnProfile {
    /// None: the per-tick counts only.
    #[default]
    Off,
    /// Every tick, summed (`profile=on`).
    AllTicks,
    /// The first tick with the most instructions, alone (`profile=worst`): what a budget on
    /// the worst tick is about.
    WorstTick,
}

/// How to run the PIL drive.
#[derive(Clone, Debug)]
pub struct PilConfig {
    /// The PIL firmware (`cargo pil-fw` builds `.../release/pil`, `cargo pil-fw-observer`
    /// `.../release/pil-observer`; see `paths::pil_elf`).
    pub elf: PathBuf,
    /// The QEMU binary.
    pub qemu: String,
    /// The instruction-count plugin, if counting.
    pub plugin: Option<PathBuf>,
    /// Count per instruction address as well (slower), and over which ticks.
    pub profile: InsnProfile,
    /// Seconds before QEMU is killed.
    pub timeout_s: u32,
    /// The law the drive runs.
    pub controller: LawKind,
    /// Payload, kg (gain schedule and the drive's model).
    pub payload_kg: f32,
    /// The gain table the PIL firmware was built from (its `BEAM_GAIN_TABLE`), loaded here:
    /// the host builds the same drive from it to compare against.
    pub table: &'static DriveTable<'static>,
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
    /// The plugin's log as it wrote it (per-address lines too when profiling).
    pub insn_log: String,
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
    faults: u16,
    /// What was sent and received each tick, for the replay.
    record: Vec<(RawMeasurement, bool, CommandFrame)>,
}

impl PilDrive {
    /// Starts QEMU with the PIL firmware (and the plugin, if any), sends the setup and waits
    /// for the drive to report ready. `settings` are the drive's controller settings.
    pub fn spawn(cfg: &PilConfig, settings: ControllerSettings) -> Result<Self, PilError> {
        let setup = HostMessage::Setup {
            controller: cfg.controller,
            payload_kg: cfg.payload_kg,
        };
        Self::spawn_with(cfg, settings, &setup)
    }

    /// Starts QEMU as [`PilDrive::spawn`] does, for a commanded drive idle at `home_rad`:
    /// moves then come only as commands ([`CommandedDrive::handle`]).
    pub fn spawn_commanded(
        cfg: &PilConfig,
        settings: ControllerSettings,
        home_rad: f32,
    ) -> Result<Self, PilError> {
        let setup = HostMessage::SetupCommanded {
            controller: cfg.controller,
            payload_kg: cfg.payload_kg,
            home_rad,
        };
        Self::spawn_with(cfg, settings, &setup)
    }

    fn spawn_with(
        cfg: &PilConfig,
        settings: ControllerSettings,
        setup: &HostMessage,
    ) -> Result<Self, PilError> {
        if !cfg.elf.exists() {
            return Err(PilError::NoFirmware(cfg.elf.clone()));
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
            let mut arg = plugin.clone().into_os_string();
            match cfg.profile {
                InsnProfile::Off => {}
                InsnProfile::AllTicks => arg.push(",profile=on"),
                InsnProfile::WorstTick => arg.push(",profile=worst"),
            }
            cmd.arg("-plugin")
                .arg(arg)
                .args(["-d", "plugin", "-D"])
                .arg(&log);
        }
        cmd.arg("-kernel").arg(&cfg.elf);
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| PilError::Start {
                qemu: cfg.qemu.clone(),
                source,
            })?;
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
            stdout: BufReader::new(stdout.ok_or(PilError::NoPipe)?),
            stderr_thread,
            log,
            timeout_s: cfg.timeout_s,
            reader: FrameReader::new(),
            seq: 0,
            settings,
            faults: 0,
            record: vec![],
        };
        drive.send(setup)?;
        match drive.receive() {
            Ok(DriveMessage::Ready) => Ok(drive),
            Ok(DriveMessage::Error(e)) => Err(PilError::Refused(e)),
            Ok(other) => Err(PilError::NotReady(other)),
            Err(e) => Err(drive.explain(&e)),
        }
    }

    /// Sends one message.
    pub fn send(&mut self, msg: &HostMessage) -> Result<(), PilError> {
        let mut buf = [0u8; MAX_FRAME + 1];
        let frame = encode(msg, &mut buf).map_err(PilError::Encode)?;
        self.send_raw(frame)
    }

    /// Sends bytes as they are (for tests of the drive's frame checks).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        let stdin = self.stdin.as_mut().ok_or(PilError::Closed)?;
        stdin
            .write_all(bytes)
            .and_then(|_| stdin.flush())
            .map_err(PilError::Write)
    }

    /// Ends the run: `Stop`, then waits for QEMU. Returns its stderr (the drive's defmt
    /// stream) and the plugin's log, or why the drive did not exit cleanly.
    pub fn finish(mut self) -> Result<(Vec<u8>, String), PilError> {
        let stop = self.send(&HostMessage::Stop);
        self.stdin = None;
        let (status, stderr, log) = self.wait();
        stop?;
        if !status.success() {
            return Err(PilError::Exited {
                status,
                qemu: qemu_message(&stderr),
            });
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
    fn explain(&mut self, e: &dyn std::error::Error) -> PilError {
        let (status, stderr, _) = self.wait();
        let killed = if status.code() == Some(124) {
            format!(" (killed after {} s)", self.timeout_s)
        } else {
            String::new()
        };
        PilError::Qemu {
            cause: chain(e),
            status,
            killed,
            qemu: qemu_message(&stderr),
        }
    }

    /// Receives one message.
    pub fn receive(&mut self) -> Result<DriveMessage, PilError> {
        let mut byte = [0u8; 1];
        loop {
            let n = self.stdout.read(&mut byte).map_err(PilError::Read)?;
            if n == 0 {
                return Err(if self.reader.partial() {
                    PilError::EndedMidFrame
                } else {
                    PilError::Ended
                });
            }
            if let Some(frame) = self.reader.push(byte[0]) {
                let frame = frame.map_err(PilError::Frame)?;
                return decode(frame).map_err(PilError::Frame);
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
        let drive = |e: PilError| SimError::Drive(Box::new(e));
        self.send(&HostMessage::Sensors(frame)).map_err(drive)?;
        let c = match self.receive().map_err(drive)? {
            DriveMessage::Command(c) if c.seq == self.seq => c,
            DriveMessage::Command(c) => {
                return Err(drive(PilError::OutOfOrder {
                    got: c.seq,
                    expected: self.seq,
                }))
            }
            DriveMessage::Error(e) => return Err(drive(PilError::Stopped(e))),
            DriveMessage::Ready => return Err(drive(PilError::ReadyMidRun)),
            DriveMessage::Reply(r) => return Err(drive(PilError::UnexpectedReply(r))),
        };
        let mode = mode_of(c.mode).ok_or(drive(PilError::UnknownMode {
            seq: c.seq,
            mode: c.mode,
        }))?;
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

    fn faults(&self) -> FaultFlags {
        FaultFlags(self.faults)
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

/// Parses the plugin's `tick-insns N` lines (one per tick).
pub fn parse_insn_log(text: &str) -> Option<InsnStats> {
    let counts: Vec<u64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("tick-insns "))
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

/// What went wrong running the PIL drive.
#[derive(Debug, thiserror::Error)]
pub enum PilError {
    /// The PIL firmware is not there.
    #[error("{}: not found (build the PIL firmware: `cargo pil-fw`, or `cargo pil-fw-observer` for lqg and smc-modal)", .0.display())]
    NoFirmware(PathBuf),
    /// The PIL firmware could not be read.
    #[error("{}: cannot read the PIL firmware (build it: `cargo pil-fw`, or `cargo pil-fw-observer` for lqg and smc-modal)", .path.display())]
    ReadFirmware {
        /// The ELF.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// QEMU (under `timeout`) did not start.
    #[error("starting `timeout {qemu}`")]
    Start {
        /// The QEMU binary.
        qemu: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The child process has no stdout pipe.
    #[error("no stdout pipe to the drive")]
    NoPipe,
    /// The drive answered the setup with an error.
    #[error("the PIL drive refused the setup: {0}")]
    Refused(DriveError),
    /// The drive answered the setup with something other than `Ready`.
    #[error("expected `ready` from the drive, got {0:?}")]
    NotReady(DriveMessage),
    /// A message did not fit a frame.
    #[error("encoding a frame")]
    Encode(#[source] FrameError),
    /// The link was closed before the message.
    #[error("the link to the drive is closed")]
    Closed,
    /// Writing to QEMU's stdin failed.
    #[error("writing to the drive (QEMU exited or timed out)")]
    Write(#[source] std::io::Error),
    /// Reading QEMU's stdout failed.
    #[error("reading from the drive")]
    Read(#[source] std::io::Error),
    /// The drive's output stopped inside a frame.
    #[error("the drive's output ended in the middle of a frame")]
    EndedMidFrame,
    /// The drive's output stopped.
    #[error("the drive's output ended (QEMU exited or timed out)")]
    Ended,
    /// A malformed frame from the drive.
    #[error("frame from the drive")]
    Frame(#[source] FrameError),
    /// A command frame for another tick.
    #[error("command frame {got} out of order, expected {expected}")]
    OutOfOrder {
        /// The frame's tick.
        got: u32,
        /// The tick sent.
        expected: u32,
    },
    /// The drive reported an error and stopped.
    #[error("the PIL drive stopped: {0}")]
    Stopped(DriveError),
    /// `Ready` in the middle of a run.
    #[error("the drive sent `ready` mid-run")]
    ReadyMidRun,
    /// A mode number the controller does not have.
    #[error("command frame {seq}: mode {mode} unknown")]
    UnknownMode {
        /// The frame's tick.
        seq: u32,
        /// The mode number.
        mode: u8,
    },
    /// QEMU exited with a failure status.
    #[error("the PIL drive exited with {status}{qemu}")]
    Exited {
        /// Its status.
        status: std::process::ExitStatus,
        /// What QEMU said, if anything.
        qemu: String,
    },
    /// A failure, with how QEMU ended after it.
    #[error("{cause}; QEMU {status}{killed}{qemu}")]
    Qemu {
        /// The failure, with its causes, as text.
        cause: String,
        /// QEMU's exit status.
        status: std::process::ExitStatus,
        /// " (killed after N s)" when the timeout fired.
        killed: String,
        /// What QEMU said, if anything.
        qemu: String,
    },
    /// The host's build of the drive's configuration failed.
    #[error("controller {kind}: {reason:?}")]
    Config {
        /// The law.
        kind: LawKind,
        /// Why.
        reason: BuildError,
    },
    /// A command reply came where a tick's command frame was due.
    #[error("a command reply ({0:?}) where a tick's frame was due")]
    UnexpectedReply(beam_wire::command::Reply),
    /// A tick's frame (or another message) came where a command's reply was due.
    #[error("no reply to command {0}")]
    NoReply(u16),
    /// The plugin was asked for but logged nothing.
    #[error("the instruction-count plugin logged no counts: {0}")]
    NoCounts(String),
    /// The drive's defmt telemetry did not decode.
    #[error(transparent)]
    Telemetry(#[from] crate::link::telemetry::TelemetryError),
    /// The closed loop failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The plugin's build script is missing.
    #[error("{}: not found (or pass --no-insn-count)", .0.display())]
    NoPluginScript(PathBuf),
    /// Building the plugin failed (gcc missing, or the script failed).
    #[error("building the instruction-count plugin with {}", .script.display())]
    PluginBuild {
        /// The build script.
        script: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

/// An error and its causes as one line, `outer: inner: ...`.
fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut next = e.source();
    while let Some(cause) = next {
        text.push_str(": ");
        text.push_str(&cause.to_string());
        next = cause.source();
    }
    text
}

impl CommandedDrive for PilDrive {
    fn handle(&mut self, request: &Request) -> Result<Reply, SimError> {
        let drive = |e: PilError| SimError::Drive(Box::new(e));
        self.send(&HostMessage::Command(request.clone()))
            .map_err(drive)?;
        match self.receive().map_err(drive)? {
            DriveMessage::Reply(r) if r.seq == request.seq => Ok(r),
            DriveMessage::Error(e) => Err(drive(PilError::Stopped(e))),
            _ => Err(drive(PilError::NoReply(request.seq))),
        }
    }

    fn tick(&mut self, raw: &RawMeasurement) -> Result<TorqueCommand, SimError> {
        DriveLoop::tick(self, raw, false)
    }
}

/// A commanded session run through the PIL drive and through the host's build of the same
/// drive.
#[derive(Clone, Debug)]
pub struct CommandedPilOutcome {
    /// The run through the PIL drive.
    pub pil: CommandedRun,
    /// The same script through the host's build (same plant, same sensor noise).
    pub host: CommandedRun,
    /// Every torque and mode, and every reply, equal bit for bit.
    pub identical: bool,
    /// Largest torque difference, in units in the last place of f32.
    pub max_ulps: u64,
    /// Instructions per tick, when counted.
    pub insns: Option<InsnStats>,
}

/// Runs `script` with the PIL drive (commanded, idle at `home_rad`) against the beam
/// `plant`, and again with the host's build of the same drive; compares them.
pub fn run_pil_commands<const N: usize>(
    plant: model_core::BeamParams,
    cfg: &PilConfig,
    home_rad: f32,
    script: &[Step],
    sensors: beam_sim::sensors::SensorConfig,
) -> Result<CommandedPilOutcome, PilError> {
    let config = |reason| PilError::Config {
        kind: cfg.controller,
        reason,
    };
    let (controller, commander) =
        build_commanded(cfg.table, cfg.controller, cfg.payload_kg, home_rad).map_err(config)?;
    let mut host = HostDrive {
        commander,
        controller,
    };
    let settings = *host.controller.settings();
    let host_run = run_script::<N, _>(plant, &mut host, home_rad, script, sensors)?;
    let mut drive = PilDrive::spawn_commanded(cfg, settings, home_rad)?;
    let pil = match run_script::<N, _>(plant, &mut drive, home_rad, script, sensors) {
        Ok(run) => run,
        Err(e) => return Err(drive.explain(&e)),
    };
    let (_, insn_text) = drive.finish()?;
    let mut max_ulps = 0;
    let mut identical =
        pil.ticks.len() == host_run.ticks.len() && pil.exchanges.len() == host_run.exchanges.len();
    for (p, h) in pil.ticks.iter().zip(&host_run.ticks) {
        max_ulps = max_ulps.max(ulps(p.torque_nm, h.torque_nm));
        identical &= p.torque_nm.to_bits() == h.torque_nm.to_bits() && p.mode == h.mode;
    }
    for (p, h) in pil.exchanges.iter().zip(&host_run.exchanges) {
        identical &= p.reply == h.reply;
    }
    let insns = match &cfg.plugin {
        Some(_) => {
            Some(parse_insn_log(&insn_text).ok_or_else(|| PilError::NoCounts(insn_text.clone()))?)
        }
        None => None,
    };
    Ok(CommandedPilOutcome {
        pil,
        host: host_run,
        identical,
        max_ulps,
        insns,
    })
}

/// Runs the paper's slew with the PIL drive under QEMU against `plant`.
pub fn run_pil<const N: usize>(
    plant: Plant<N>,
    cfg: &PilConfig,
    opts: &SimOptions,
) -> Result<PilOutcome, PilError> {
    // The host's build of the drive's controller: checks the setup before QEMU starts, and
    // is the reference the drive's torques are compared with.
    let config = |reason| PilError::Config {
        kind: cfg.controller,
        reason,
    };
    let mut host =
        build_controller_for(cfg.table, cfg.controller, cfg.payload_kg).map_err(config)?;
    let reference =
        sequence_for(cfg.table, cfg.controller, cfg.payload_kg).map_err(config)?[0].clone();
    let elf = std::fs::read(&cfg.elf).map_err(|source| PilError::ReadFirmware {
        path: cfg.elf.clone(),
        source,
    })?;
    let mut drive = PilDrive::spawn(cfg, *host.settings())?;
    let run = match run_with(plant, &mut drive, &reference, opts) {
        Ok(run) => run,
        Err(e) => return Err(drive.explain(&e)),
    };
    let record = std::mem::take(&mut drive.record);
    let ticks = drive.seq;
    let (stderr, insn_text) = drive.finish()?;

    // The same sensor stream through the host's build of the same controller.
    let (mut max_diff, mut max_ulps, mut identical) = (0.0f64, 0u64, true);
    for (raw, start, c) in &record {
        let h = host.tick(raw, *start)?;
        let d = (h.torque_nm as f64 - c.torque_nm as f64).abs();
        max_diff = max_diff.max(d);
        max_ulps = max_ulps.max(ulps(h.torque_nm, c.torque_nm));
        identical &= h.torque_nm.to_bits() == c.torque_nm.to_bits()
            && h.mode as u8 == c.mode
            && h.faults.0 == c.faults;
    }
    let telemetry = telemetry::decode_defmt(&elf, &stderr)?;
    let insns = match &cfg.plugin {
        Some(_) => {
            Some(parse_insn_log(&insn_text).ok_or_else(|| PilError::NoCounts(insn_text.clone()))?)
        }
        None => None,
    };
    Ok(PilOutcome {
        run,
        ticks,
        max_torque_diff: max_diff,
        max_ulps,
        identical,
        insns,
        insn_log: insn_text,
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

/// The instruction-count plugin (`beam-tools/qemu-plugin`), built with its script into
/// `out_dir` when missing or older than its source. Needs gcc.
pub fn build_plugin(plugin_src: &Path, out_dir: &Path) -> Result<PathBuf, PilError> {
    let script = plugin_src.join("build.sh");
    if !script.exists() {
        return Err(PilError::NoPluginScript(script));
    }
    let failed = |source| PilError::PluginBuild {
        script: script.clone(),
        source,
    };
    std::fs::create_dir_all(out_dir).map_err(failed)?;
    let out = out_dir.join("libtick_insns.so");
    let status = Command::new("bash")
        .arg(&script)
        .arg(&out)
        .stdout(Stdio::null())
        .status()
        .map_err(failed)?;
    if !status.success() || !out.exists() {
        return Err(failed(std::io::Error::other(format!(
            "the script failed ({status})"
        ))));
    }
    Ok(out)
}

/// Where the workspace keeps things: `target/` and the plugin's source.
pub mod paths {
    use std::path::PathBuf;

    /// The workspace root.
    pub fn workspace() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// The PIL firmware that runs law `kind`: `pil` (`cargo pil-fw`), or for an observer
    /// law `pil-observer` (`cargo pil-fw-observer`).
    pub fn pil_elf(kind: model_core::LawKind) -> PathBuf {
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| workspace().join("target"));
        let name = if kind.has_observer() {
            "pil-observer"
        } else {
            "pil"
        };
        target.join("thumbv7em-none-eabihf/release").join(name)
    }

    /// The instruction-count plugin's source and build script.
    pub fn insn_plugin_src() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("qemu-plugin")
    }

    /// Where the plugin is built.
    pub fn plugin_dir() -> PathBuf {
        workspace().join("target/qemu-plugin")
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
        let log = "tick-insns 300\nother\ntick-insns 500\ntick-insns-total 9\n";
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
