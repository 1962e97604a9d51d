//! `beam drive`: a script of commands for a commanded drive, against the simulated beam,
//! with the drive either the PIL firmware under QEMU (`--pil`, compared bit for bit with the
//! host's build) or model-core's handler on the host (`--sim`).

use crate::{named, SettleArgs};
use anyhow::{bail, Context};
use beam_sim::commanded::{run_commands, session_script, CommandedRun, Exchange, Step};
use beam_sim::metrics::SettleSpec;
use beam_sim::sensors::SensorConfig;
use beam_tools::link::drive_script;
use beam_tools::link::pil_host::{
    build_plugin, paths, run_pil_commands, InsnProfile, InsnStats, PilConfig,
};
use beam_wire::command::{Command, Outcome, Request};
use clap::Args;
use model_core::LawKind;
use serde_json::json;
use std::path::PathBuf;

#[derive(Args)]
pub struct DriveArgs {
    #[command(flatten)]
    settle: SettleArgs,
    /// With --sim or --pil: the gain table the simulated drive is built from (for --pil, the
    /// one the PIL firmware was built from) [default: $BEAM_GAIN_TABLE, else the
    /// repository's gains.toml].
    #[arg(long, value_name = "FILE", conflicts_with = "port")]
    table: Option<PathBuf>,
    /// Run the commands on the PIL firmware under QEMU, against the simulated beam (and
    /// on the host's build, to compare).
    #[arg(long, conflicts_with_all = ["sim", "port"])]
    pil: bool,
    /// Run the commands on model-core's handler on the host, against the simulated beam.
    #[arg(long, conflicts_with = "port")]
    sim: bool,
    /// A serial port with a drive on it (the board's USART1 at 921 600 baud, through a
    /// USB-serial adapter: /dev/ttyUSB0).
    #[arg(long, value_name = "PORT")]
    port: Option<String>,
    /// With --port: write the telemetry records that arrive (send `stream 1` first) as CSV.
    #[arg(long, value_name = "FILE", requires = "port")]
    record: Option<PathBuf>,
    /// With --record: also plot the recording (hub angle and reference, torque, root
    /// strain; .png or .svg).
    #[arg(long, value_name = "FILE", requires = "record")]
    plot: Option<PathBuf>,
    /// With --port: how long to wait for each reply, ms.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    reply_timeout_ms: u64,
    /// The script: one command per line, `-` for stdin (see below). With --port and no
    /// commands at all, stdin too: each line runs as it is typed.
    #[arg(long, value_name = "FILE", conflicts_with = "session")]
    script: Option<PathBuf>,
    /// The built-in session: moves, waypoints, a payload change, a stop, a fault.
    #[arg(long, conflicts_with = "words")]
    session: bool,
    /// Commands on the command line instead of a script, `;` between them:
    /// `beam drive --port P move 45 0.3 \; done \; status`.
    #[arg(
        value_name = "COMMAND",
        trailing_var_arg = true,
        allow_hyphen_values = true,
        conflicts_with = "script"
    )]
    words: Vec<String>,
    /// Control law the drive runs (gains and shaper from the gain table).
    #[arg(long, value_parser = named::<LawKind>(), default_value = "pd-ff")]
    controller: LawKind,
    /// Payload the drive (and the beam) starts with, kg.
    #[arg(long, default_value_t = 0.0)]
    payload: f64,
    /// Where the hub rests at power-up, deg.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    home: f64,
    /// The PIL firmware [default: target/thumbv7em-none-eabihf/release/pil, built by `cargo pil-fw`; for lqg and smc-modal, release/pil-observer, built by `cargo pil-fw-observer`].
    #[arg(long, value_name = "ELF")]
    elf: Option<PathBuf>,
    /// The QEMU binary.
    #[arg(long, default_value = "qemu-system-arm")]
    qemu: String,
    /// Seconds before QEMU is killed.
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..=3600))]
    timeout: u32,
    /// Do not count instructions (PIL).
    #[arg(long)]
    no_insn_count: bool,
    /// How long `done` waits for a move to end before it gives up, s.
    #[arg(long, value_name = "S", default_value_t = 60.0, value_parser = done_max)]
    done_max: f64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// `--done-max`: 0.01 s to an hour.
fn done_max(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if (0.01..=3600.0).contains(&s) => Ok(s),
        _ => Err(format!("`{text}` is not 0.01 to 3600 s")),
    }
}

/// Simulated time a `--sim` or `--pil` script may ask for at most, s: its waits, and each
/// `done`'s limit and settling, summed (the run keeps every tick, 32 bytes each).
const MAX_SIM_S: f64 = 1800.0;

/// The drive refused `0` of the script's commands (every exchange was printed): `beam drive`
/// exits with code 1 for it, where usage and link errors exit with 2.
#[derive(Debug, thiserror::Error)]
#[error("the drive refused {0} command(s)")]
pub struct Refused(pub usize);

/// Refusals among the replies: the script's result when there are any.
fn refusals<'a>(outcomes: impl Iterator<Item = &'a Outcome>) -> anyhow::Result<()> {
    let n = outcomes
        .filter(|o| matches!(o, Outcome::Refused(_)))
        .count();
    if n > 0 {
        return Err(Refused(n).into());
    }
    Ok(())
}

/// One accepted move's outcome: where it was going, and how the beam was 0.25 s after its
/// planned end.
struct MoveResult {
    command: String,
    target_deg: Option<f64>,
    /// When the move was commanded, s.
    commanded_s: f64,
    /// Settle time from the command, s (the true beam: --sim and --pil only).
    settle_s: Option<f64>,
    end_s: f64,
    hub_err_deg: Option<f64>,
    rms_strain_ue: Option<f64>,
}

pub fn run(a: &DriveArgs) -> anyhow::Result<()> {
    if !a.pil && !a.sim && a.port.is_none() {
        bail!("say where the drive is: --port PORT, --pil (firmware under QEMU) or --sim (host)");
    }
    if !(a.payload.is_finite() && (0.0..=1.0).contains(&a.payload)) {
        bail!("--payload {} must be in [0, 1] kg", a.payload);
    }
    if !(a.home.is_finite() && a.home.abs() <= 180.0) {
        bail!("--home {} must be within +-180 deg", a.home);
    }
    if let Some(port) = &a.port {
        // A session, asked for (`--script -`) or by giving no commands at all: each line
        // runs as it is typed (or piped), its replies printed at once; `quit` or the end of
        // input ends it.
        let given = a.script.is_some() || a.session || !a.words.is_empty();
        if a.script.as_deref() == Some(std::path::Path::new("-")) || !given {
            use std::io::IsTerminal;
            if std::io::stdin().is_terminal() {
                eprintln!(
                    "beam drive: {port}: a command a line, each run as you type it (`status`, `move DEG`, `stop`, ...); `quit` or Ctrl-D ends"
                );
            }
            let lines = std::io::stdin().lines().map_while(Result::ok);
            let batches = lines
                .take_while(|l| !drive_script::is_quit(l))
                .filter_map(
                    |l| match drive_script::parse(&l).map_err(anyhow::Error::from) {
                        Ok(steps) => match for_port(with_done_max(steps, a)) {
                            Ok(steps) => Some(steps),
                            Err(e) => {
                                eprintln!("beam: {e:#} (not sent)");
                                None
                            }
                        },
                        Err(e) => {
                            eprintln!("beam: {e:#} (not sent)");
                            None
                        }
                    },
                );
            return run_port(a, port, batches, true);
        }
        // Checked whole before anything reaches the drive.
        let script = for_port(read_script(a)?)?;
        return run_port(a, port, std::iter::once(script), false);
    }
    let script = read_script(a)?;
    let asked: f64 = script
        .iter()
        .map(|s| match s {
            Step::Wait(t) => *t,
            Step::UntilDone { settle_s, max_s } => settle_s + max_s,
            _ => 0.0,
        })
        .sum();
    if asked > MAX_SIM_S {
        bail!(
            "the script may take {asked:.0} s of simulated time (waits, and each `done`'s --done-max and settling); at most {MAX_SIM_S} s"
        );
    }
    let (run, pil) = run_simulated(a, &script)?;
    let moves = move_results(&run, &a.settle.spec()?);
    report(a, &run, &moves, pil);
    if let Some((false, ulps, _)) = pil {
        bail!("the PIL drive differs from the host build ({ulps} ulps)");
    }
    refusals(run.exchanges.iter().map(|e| &e.reply.outcome))
}

/// The script: from the command line, a file or stdin, or the built-in session; each
/// `done` waits as long as `--done-max` says.
fn read_script(a: &DriveArgs) -> anyhow::Result<Vec<Step>> {
    let script = match (&a.script, a.session) {
        (None, false) if !a.words.is_empty() => {
            let text = a.words.join(" ").replace(';', "\n");
            drive_script::parse(&text).context("the command line")?
        }
        (None, true) => session_script(),
        (Some(path), false) => {
            let text = if path.as_os_str() == "-" {
                std::io::read_to_string(std::io::stdin()).context("stdin")?
            } else {
                std::fs::read_to_string(path).with_context(|| path.display().to_string())?
            };
            drive_script::parse(&text).with_context(|| path.display().to_string())?
        }
        _ => bail!("give the commands: --script FILE (or -), --session, or on the command line (with --port and none of these, they are read from stdin as typed)"),
    };
    Ok(with_done_max(script, a))
}

/// `script` with each `done` waiting as long as --done-max says.
fn with_done_max(script: Vec<Step>, a: &DriveArgs) -> Vec<Step> {
    script
        .into_iter()
        .map(|step| match step {
            Step::UntilDone { settle_s, .. } => Step::UntilDone {
                settle_s,
                max_s: a.done_max,
            },
            other => other,
        })
        .collect()
}

/// `script`, if a drive on a port can run it: the simulated world's steps are refused.
fn for_port(script: Vec<Step>) -> anyhow::Result<Vec<Step>> {
    if let Some(i) = script
        .iter()
        .position(|s| !matches!(s, Step::Send(_) | Step::Wait(_) | Step::UntilDone { .. }))
    {
        bail!("step {}: `attach`, `fault`, `load`, `sensor` and `latency` act on the simulated beam and drive; they have no meaning with --port (nothing was sent)", i + 1);
    }
    Ok(script)
}

/// The PIL run's comparison with the host build: identical, the largest difference in ulps,
/// and the instructions per tick.
type PilSummary = (bool, u64, Option<InsnStats>);

/// The script run against the simulated beam, on the host (`--sim`) or with the firmware
/// under QEMU (`--pil`, with its comparison).
fn run_simulated(
    a: &DriveArgs,
    script: &[Step],
) -> anyhow::Result<(CommandedRun, Option<PilSummary>)> {
    // The simulated beam is the plant the drive was built for (the table's), with the
    // payload on it, read by the drive's instruments.
    let table = beam_tools::io::table_file::required_table(a.table.as_deref())?;
    let params = table.plant.params_with(a.payload);
    let home = a.home.to_radians() as f32;
    let sensors = SensorConfig::reading(table.drive.instruments);
    let (run, pil) = if a.pil {
        let plugin = if a.no_insn_count {
            None
        } else {
            Some(build_plugin(
                &paths::insn_plugin_src(),
                &paths::plugin_dir(),
            )?)
        };
        let cfg = PilConfig {
            elf: a
                .elf
                .clone()
                .unwrap_or_else(|| paths::pil_elf(a.controller)),
            qemu: a.qemu.clone(),
            plugin,
            profile: InsnProfile::Off,
            timeout_s: a.timeout,
            controller: a.controller,
            payload_kg: a.payload as f32,
            table,
        };
        let out = run_pil_commands::<3>(params, &cfg, home, script, sensors)?;
        let summary = (out.identical, out.max_ulps, out.insns);
        (out.pil, Some(summary))
    } else {
        let run = run_commands::<3>(
            params,
            table,
            a.payload as f32,
            a.controller,
            home,
            script,
            sensors,
        )?;
        (run, None)
    };
    Ok((run, pil))
}

/// What ran: every exchange, each move's figures, and the PIL's comparison (JSON or text).
fn report(a: &DriveArgs, run: &CommandedRun, moves: &[MoveResult], pil: Option<PilSummary>) {
    if a.json {
        let exchanges: Vec<_> = run
            .exchanges
            .iter()
            .map(|e| {
                json!({
                    "t_s": e.t,
                    "seq": e.request.seq,
                    "command": describe(&e.request),
                    "reply": format!("{:?}", e.reply.outcome),
                })
            })
            .collect();
        let moves: Vec<_> = moves
            .iter()
            .map(|m| {
                json!({
                    "command": m.command,
                    "target_deg": m.target_deg,
                    "commanded_s": m.commanded_s,
                    "end_s": m.end_s,
                    "settle_s": m.settle_s,
                    "hub_err_deg_end_plus_0_25": m.hub_err_deg,
                    "rms_root_strain_ue_end_plus_0_05_0_25": m.rms_strain_ue,
                })
            })
            .collect();
        let mut o = json!({
            "controller": a.controller.name(),
            "ticks": run.ticks.len(),
            "exchanges": exchanges,
            "moves": moves,
        });
        if let Some((identical, ulps, insns)) = pil {
            o["pil_identical"] = json!(identical);
            o["pil_max_ulps"] = json!(ulps);
            o["insns_min"] = json!(insns.map(|i| i.min));
            o["insns_mean"] = json!(insns.map(|i| i.mean));
            o["insns_max"] = json!(insns.map(|i| i.max));
        }
        println!("{o}");
    } else {
        for e in &run.exchanges {
            print_exchange(e.t, &e.request, &e.reply.outcome);
        }
        for m in moves {
            let f = |x: Option<f64>, d: usize| x.map_or("-".into(), |v| format!("{v:.d$}"));
            println!(
                "  {:<28} settled {} after its command; reference ends {:.3} s after it; 0.25 s later: hub error {} deg, RMS root strain {} ue",
                m.command,
                m.settle_s.map_or("never (before the next move or the end)".into(), |v| format!("{v:.3} s")),
                m.end_s - m.commanded_s,
                f(m.hub_err_deg, 3),
                f(m.rms_strain_ue, 1)
            );
        }
        if let Some((identical, ulps, insns)) = pil {
            println!(
                "  PIL: {} ticks; torques, modes and replies {} the host build's",
                run.ticks.len(),
                if identical {
                    "bit-identical to".to_string()
                } else {
                    format!("differ ({ulps} ulps) from")
                }
            );
            if let Some(i) = insns {
                println!(
                    "  instructions per tick: min {}, mean {:.1}, max {}",
                    i.min, i.mean, i.max
                );
            }
        }
    }
}

/// One exchange as a line: when, the request's number and words, the reply.
fn print_exchange(t: f64, request: &Request, outcome: &Outcome) {
    println!(
        "{:8.3} s  #{:<3} {:<28} -> {}",
        t,
        request.seq,
        describe(request),
        outcome_text(outcome)
    );
}

/// A reply in words: a status with its mode and faults named and its figures in units; the
/// others as the protocol names them.
fn outcome_text(outcome: &Outcome) -> String {
    let Outcome::Status(s) = outcome else {
        return format!("{outcome:?}");
    };
    let mode = match s.mode {
        0 => "idle".to_string(),
        1 => "slewing".to_string(),
        2 => "holding".to_string(),
        3 => "fault".to_string(),
        m => format!("mode {m}"),
    };
    let stream = match s.stream_every {
        0 => "off".to_string(),
        n => format!("every {n} tick(s)"),
    };
    format!(
        "Status: {mode}; faults {}; hub {:.3} deg at {:.2} deg/s; root strain {:.1} ue; move {:.3} of {:.3} s; payload {} kg; law {}; stream {stream}; up {} ticks",
        model_core::FaultFlags(s.faults),
        s.theta_rad.to_degrees(),
        s.omega_rad_s.to_degrees(),
        s.strain * 1e6,
        s.move_elapsed_s,
        s.move_duration_s,
        s.payload_kg,
        s.law.map_or("none", |l| l.name()),
        s.ticks,
    )
}

/// A request in the script's words.
fn describe(r: &Request) -> String {
    match &r.command {
        Command::MoveTo { to_rad, time_s } => format!(
            "move {}{}",
            degrees(*to_rad),
            time_s.map_or(String::new(), |t| format!(" {t}"))
        ),
        Command::MoveThrough { waypoints, time_s } => format!(
            "through {}{}",
            waypoints
                .iter()
                .map(|w| degrees(w.rad))
                .collect::<Vec<_>>()
                .join(","),
            time_s.map_or(String::new(), |t| format!(" {t}"))
        ),
        Command::SetPayload { kg } => format!("payload {kg}"),
        Command::Stop => "stop".into(),
        Command::Disable => "disable".into(),
        Command::ClearFault => "clear".into(),
        Command::Status => "status".into(),
        Command::Stream { every } => format!("stream {every}"),
    }
}

/// An angle the script gave in degrees, as it gave it: the drive's f32 radians back in
/// degrees to 1e-4 deg, its shortest decimal (`179.97`, not a rounded `180.0`).
fn degrees(rad: f32) -> String {
    let deg = (rad.to_degrees() as f64 * 1e4).round() / 1e4;
    format!("{}", deg + 0.0)
}

fn move_results(run: &CommandedRun, settle: &SettleSpec) -> Vec<MoveResult> {
    let target = |e: &Exchange| match &e.request.command {
        Command::MoveTo { to_rad, .. } => Some(to_rad.to_degrees() as f64),
        Command::MoveThrough { waypoints, .. } => {
            waypoints.last().map(|w| w.rad.to_degrees() as f64)
        }
        _ => None,
    };
    // Each accepted move's place in the exchanges and its time.
    let starts: Vec<(usize, f64)> = run
        .exchanges
        .iter()
        .enumerate()
        .filter(|(_, e)| matches!(e.reply.outcome, Outcome::Moving { .. }))
        .map(|(i, e)| (i, e.t))
        .collect();
    run.exchanges
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.reply.outcome {
            Outcome::Moving { duration_s } => {
                let end_s = e.t + duration_s as f64;
                // A move cut short by a stop (answered later, perhaps on the same tick):
                // the stop's own line reports the rest.
                if starts.iter().any(|&(j, t)| j > i && t < end_s) {
                    return Some(MoveResult {
                        command: format!("{} (stopped)", describe(&e.request)),
                        target_deg: None,
                        commanded_s: e.t,
                        settle_s: None,
                        end_s,
                        hub_err_deg: None,
                        rms_strain_ue: None,
                    });
                }
                let target_deg = target(e);
                // Settled before the next move's command (or the run's end).
                let until = starts
                    .iter()
                    .find(|&&(j, _)| j > i)
                    .map_or(f64::INFINITY, |&(_, t)| t);
                Some(MoveResult {
                    command: describe(&e.request),
                    target_deg,
                    commanded_s: e.t,
                    settle_s: target_deg
                        .and_then(|t| run.settle_s(e.t, until, t.to_radians(), settle)),
                    end_s,
                    hub_err_deg: target_deg.and_then(|t| {
                        run.theta_at(end_s + 0.25)
                            .map(|th| (th.to_degrees() - t).abs())
                    }),
                    rms_strain_ue: run.rms_strain_ue(end_s + 0.05, end_s + 0.25),
                })
            }
            _ => None,
        })
        .collect()
}

/// The script on a drive at the end of a serial port, in batches (the whole script, or one
/// per line typed); with `live`, each reply is printed as it comes.
fn run_port(
    a: &DriveArgs,
    port: &str,
    batches: impl Iterator<Item = Vec<Step>>,
    live: bool,
) -> anyhow::Result<()> {
    use beam_tools::link::serial_drive::{write_records_csv, SerialDrive};
    use std::time::{Duration, Instant};
    let timeout = Duration::from_millis(a.reply_timeout_ms);
    if let Some(path) = &a.plot {
        beam_tools::io::plot::check_extension(path)?;
    }
    let mut drive = SerialDrive::open(port, beam_drive::link::BAUD, timeout)?;
    // A progress line while recording, on a terminal only (scripts and tests see none).
    if a.record.is_some() && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        drive.on_progress(|n| eprint!("\rrecording: {n} records"));
    }
    let start = Instant::now();
    let mut exchanges = vec![];
    let live = live && !a.json;
    let steps = || -> anyhow::Result<()> {
        for step in batches.flatten() {
            match &step {
                Step::Send(command) => {
                    let (request, reply) = drive.request(command.clone())?;
                    let t = start.elapsed().as_secs_f64();
                    if live {
                        print_exchange(t, &request, &reply.outcome);
                    }
                    exchanges.push((t, request, reply));
                }
                Step::Wait(s) => drive.listen(Duration::from_secs_f64(*s))?,
                Step::UntilDone { settle_s, max_s } => {
                    let until = Instant::now() + Duration::from_secs_f64(*max_s);
                    loop {
                        let (_, reply) = drive.request(Command::Status)?;
                        match reply.outcome {
                            Outcome::Status(s) if s.mode != model_core::Mode::Slewing as u8 => {
                                break
                            }
                            _ if Instant::now() > until => {
                                bail!("the move did not end within {max_s} s (--done-max)")
                            }
                            _ => drive.listen(Duration::from_millis(20))?,
                        }
                    }
                    drive.listen(Duration::from_secs_f64(*settle_s))?;
                }
                // Refused in `run`, before the port was opened.
                Step::Attach(_)
                | Step::AmpFault(_)
                | Step::Load(_)
                | Step::Sensor(_)
                | Step::Latency(_) => {
                    bail!("`attach`, `fault`, `load`, `sensor` and `latency` have no meaning with --port")
                }
            }
        }
        Ok(())
    };
    if let Err(e) = steps() {
        // What already ran on the drive, then the error.
        for (t, request, reply) in exchanges.iter().filter(|_| !live) {
            print_exchange(*t, request, &reply.outcome);
        }
        return Err(e.context(format!(
            "after {} exchange(s) with the drive",
            exchanges.len()
        )));
    }
    let records = drive.take_records();
    if let Some(path) = &a.record {
        beam_tools::io::files::write_atomically(path, |w| {
            write_records_csv(&records, model_core::DEFAULT_TS_S as f64, w)
        })
        .with_context(|| path.display().to_string())?;
    }
    if let Some(path) = &a.plot {
        let title = format!("{} records from {port}", records.len());
        beam_tools::io::files::plot_atomically(path, |tmp| {
            beam_tools::io::plot::plot_records(
                &records,
                model_core::DEFAULT_TS_S as f64,
                &title,
                tmp,
            )
        })?;
    }
    if a.record.is_some() && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        eprintln!();
    }
    let dropped = records.last().map_or(0, |r| r.dropped);
    if a.json {
        let exchanges: Vec<_> = exchanges
            .iter()
            .map(|(t, request, reply)| {
                json!({
                    "t_s": t,
                    "seq": request.seq,
                    "command": describe(request),
                    "reply": format!("{:?}", reply.outcome),
                })
            })
            .collect();
        println!(
            "{}",
            json!({
                "port": port,
                "exchanges": exchanges,
                "records": records.len(),
                "records_dropped_by_drive": dropped,
                "bad_frames": drive.bad_frames(),
            })
        );
    } else {
        for (t, request, reply) in exchanges.iter().filter(|_| !live) {
            print_exchange(*t, request, &reply.outcome);
        }
        println!(
            "  {} telemetry records ({} dropped by the drive), {} bad frames",
            records.len(),
            dropped,
            drive.bad_frames()
        );
    }
    refusals(exchanges.iter().map(|(_, _, reply)| &reply.outcome))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_move_prints_as_the_script_gave_it() {
        let deg = |d: f32| d.to_radians();
        let to = |d: f32| Request {
            seq: 1,
            command: Command::MoveTo {
                to_rad: deg(d),
                time_s: None,
            },
        };
        assert_eq!(describe(&to(179.97)), "move 179.97");
        assert_eq!(describe(&to(-10.0)), "move -10");
        assert_eq!(describe(&to(0.05)), "move 0.05");
        assert_eq!(describe(&to(-0.0)), "move 0");
    }

    #[test]
    fn a_status_reads_as_words_with_units() {
        let status = Outcome::Status(beam_wire::command::Status {
            mode: 3,
            faults: model_core::FaultFlags::ENCODER_STUCK.0 | model_core::FaultFlags::AMP_FAULT.0,
            theta_rad: core::f32::consts::FRAC_PI_2,
            omega_rad_s: -0.1,
            strain: 41.3e-6,
            move_elapsed_s: 0.235,
            move_duration_s: 0.235,
            payload_kg: 0.025,
            law: Some(LawKind::Smc),
            stream_every: 0,
            ticks: 12_345,
        });
        let text = outcome_text(&status);
        assert!(text.starts_with("Status: fault; faults "), "{text}");
        for word in [
            "amp-fault",
            "encoder-stuck",
            "hub 90.000 deg",
            "-5.73 deg/s",
            "41.3 ue",
            "payload 0.025 kg",
            "law smc",
            "stream off",
            "up 12345 ticks",
        ] {
            assert!(text.contains(word), "{word}: {text}");
        }
        assert!(
            !text.contains("mode: 3") && !text.contains("faults: "),
            "{text}"
        );
    }
}
