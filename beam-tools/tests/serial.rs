//! `beam drive --port` against a drive on a pseudo-terminal: the firmware's link and
//! model-core's command handler, ticking in a thread, stand in for the board at the other
//! end of a real tty.

mod common;

use beam_drive::link::Link;
use beam_wire::command::Record;
use model_core::commands::Commander;
use model_core::{Controller, LawKind, RawMeasurement, Spline};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A drive on `port`: bytes to the link, requests to the handler, a tick every millisecond
/// (the hub held still), records while streaming; until `stop`. It answers the first
/// `answers` requests and then falls silent (a drive that hangs or a cable pulled), each
/// reply sent `late` after its request came (a drive slow to answer); with `stray`, a byte of
/// noise is on the line before the first request.
fn fake_drive(
    mut port: TTYPort,
    stop: Arc<AtomicBool>,
    answers: usize,
    late: Duration,
    stray: bool,
) {
    let mut answered = 0;
    let table = common::shipped();
    let (mut commander, law) = Commander::try_new(table, LawKind::PdFf, 0.0).unwrap();
    let rest = Spline::try_build(&[(0.0, 0.0), (1.0, 0.0)]).unwrap();
    let mut ctl =
        Controller::try_build(table.settings(-std::f32::consts::FRAC_PI_2), law, rest).unwrap();
    let mut link = Link::<4096>::new();
    port.set_timeout(Duration::from_millis(1)).unwrap();
    // A stray byte on the line before the host's first request (noise at power-up): the
    // host's leading delimiter cuts it off, the drive answers it `BadFrame`, and the
    // request still gets its own reply.
    if stray {
        link.receive_byte(0x42);
    }
    let start = Instant::now();
    let mut tick = 0u32;
    let mut buf = [0u8; 256];
    let mut pending: Vec<(Instant, beam_wire::command::Reply)> = vec![];
    while !stop.load(Ordering::Relaxed) {
        if let Ok(n) = port.read(&mut buf) {
            for &b in &buf[..n] {
                link.receive_byte(b);
            }
        }
        while let Some(request) = link.next_request() {
            if answered < answers {
                let reply = commander.handle(&mut ctl, &request);
                pending.push((Instant::now() + late, reply));
                answered += 1;
            }
        }
        while pending
            .first()
            .is_some_and(|(due, _)| *due <= Instant::now())
        {
            link.reply(&pending.remove(0).1);
        }
        while (tick as u128) < start.elapsed().as_millis() {
            // A live bridge at zero strain: its code moves with its noise.
            let t = ctl.step(&RawMeasurement {
                strain_root_code: beam_drive::fakes::bridge_noise(tick),
                ..Default::default()
            });
            let every = commander.stream_every() as u32;
            if every > 0 && tick % every == 0 {
                link.record(&Record {
                    tick,
                    torque_nm: t.torque_nm,
                    theta_rad: t.theta_rad,
                    theta_ref_rad: t.theta_ref_rad,
                    strain: t.strain,
                    mode: t.mode as u8,
                    faults: t.faults.0,
                    dropped: 0,
                });
            }
            tick += 1;
        }
        let mut out = vec![];
        while let Some(b) = link.next_tx_byte() {
            out.push(b);
        }
        if !out.is_empty() {
            port.write_all(&out).unwrap();
        }
    }
}

#[test]
fn beam_drive_talks_to_a_drive_over_a_tty_and_records_its_stream() {
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the tty's name");
    let stop = Arc::new(AtomicBool::new(false));
    let drive = {
        let stop = stop.clone();
        std::thread::spawn(move || fake_drive(master, stop, usize::MAX, Duration::ZERO, true))
    };
    let dir = std::env::temp_dir().join(format!("beam-serial-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let script = dir.join("s.txt");
    std::fs::write(
        &script,
        "status\nstop\nstream 1\nwait 0.3\nstream 0\npayload -1\nstatus\n",
    )
    .unwrap();
    let csv = dir.join("rec.csv");
    let png = dir.join("rec.png");
    let out = Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(["drive", "--port", &path, "--script"])
        .arg(&script)
        .arg("--record")
        .arg(&csv)
        .arg("--plot")
        .arg(&png)
        .arg("--json")
        .output()
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    drive.join().unwrap();
    drop(slave);
    // The stop at rest and the negative payload are refused: exit code 1, every exchange
    // printed all the same.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("refused 2 command"), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let replies: Vec<&str> = v["exchanges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["reply"].as_str().unwrap())
        .collect();
    assert_eq!(replies.len(), 6, "{replies:?}");
    assert!(replies[0].starts_with("Status"), "{}", replies[0]);
    assert_eq!(replies[1], "Refused(NotMoving)");
    assert_eq!(replies[2], "Done");
    assert_eq!(replies[3], "Done");
    assert_eq!(replies[4], "Refused(BadArgument)");
    assert_eq!(v["bad_frames"], 0);
    // A record for every tick of the 0.3 s (or so: the drive ticks by the wall clock),
    // consecutive, none dropped.
    let n = v["records"].as_u64().unwrap();
    assert!((100..=3000).contains(&n), "{n} records");
    assert_eq!(v["records_dropped_by_drive"], 0);
    let text = std::fs::read_to_string(&csv).unwrap();
    let ticks: Vec<u64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(ticks.len() as u64, n);
    assert!(
        ticks.windows(2).all(|w| w[1] == w[0] + 1),
        "ticks consecutive"
    );
}

#[test]
fn a_drive_that_falls_silent_mid_script_leaves_what_ran_printed_and_exits_2() {
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the tty's name");
    let stop = Arc::new(AtomicBool::new(false));
    let drive = {
        let stop = stop.clone();
        std::thread::spawn(move || fake_drive(master, stop, 2, Duration::ZERO, true))
    };
    let out = Command::new(env!("CARGO_BIN_EXE_beam"))
        .args([
            "drive",
            "--port",
            &path,
            "--reply-timeout-ms",
            "300",
            "status",
            ";",
            "stream",
            "0",
            ";",
            "status",
        ])
        .output()
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    drive.join().unwrap();
    drop(slave);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("after 2 exchange(s)"), "{stderr}");
    // The two that ran on the drive are on stdout.
    assert_eq!(stdout.lines().count(), 2, "{stdout}");
    assert!(
        stdout.contains("status") && stdout.contains("stream 0"),
        "{stdout}"
    );
}

#[test]
fn a_late_reply_to_an_earlier_run_is_never_taken_for_this_runs() {
    // The drive answers 400 ms after each request. Run A gives up after 200 ms: the drive
    // carries its move out all the same and replies once A has gone. Run B's move, refused by
    // the drive (A's move runs, or has faulted on a hub that does not turn), must not print
    // A's `Moving`.
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the tty's name");
    let stop = Arc::new(AtomicBool::new(false));
    let drive = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            fake_drive(master, stop, usize::MAX, Duration::from_millis(400), false)
        })
    };
    let run = |timeout_ms: &str, to: &str| {
        Command::new(env!("CARGO_BIN_EXE_beam"))
            .args([
                "drive",
                "--port",
                &path,
                "--reply-timeout-ms",
                timeout_ms,
                "move",
                to,
            ])
            .output()
            .unwrap()
    };
    let a = run("200", "10");
    let b = run("2000", "-10");
    stop.store(true, Ordering::Relaxed);
    drive.join().unwrap();
    drop(slave);
    let a_err = String::from_utf8_lossy(&a.stderr);
    assert_eq!(a.status.code(), Some(2), "{a_err}");
    // A says what the drive may be doing, and how to ask.
    assert!(
        a_err.contains("may have received it") && a_err.contains("status"),
        "{a_err}"
    );
    let (b_out, b_err) = (
        String::from_utf8_lossy(&b.stdout),
        String::from_utf8_lossy(&b.stderr),
    );
    assert!(!b_out.contains("Moving"), "B took A's reply: {b_out}");
    assert!(b_out.contains("Refused"), "{b_out}");
    assert_eq!(b.status.code(), Some(1), "{b_out}{b_err}");
}

#[test]
fn typed_at_a_terminal_each_line_runs_as_it_comes_and_quit_ends_the_session() {
    // Asked for with `--script -`, or by giving no commands at all.
    typed_session(&["--script", "-"]);
    typed_session(&[]);
}

fn typed_session(how: &[&str]) {
    use std::io::BufRead;
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the tty's name");
    let stop = Arc::new(AtomicBool::new(false));
    let drive = {
        let stop = stop.clone();
        std::thread::spawn(move || fake_drive(master, stop, usize::MAX, Duration::ZERO, false))
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(["drive", "--port", &path])
        .args(how)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let (lines_tx, lines) = std::sync::mpsc::channel();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout)
            .lines()
            .map_while(Result::ok)
        {
            let _ = lines_tx.send(line);
        }
    });
    // The first line's reply comes while the input is still open: it ran as it came.
    stdin.write_all(b"status\n").unwrap();
    stdin.flush().unwrap();
    let first = lines
        .recv_timeout(Duration::from_secs(10))
        .expect("the reply to the first line, before any more input");
    assert!(
        first.contains("status") && first.contains("Status: idle"),
        "{first}"
    );
    // A mistyped line is reported and skipped, not the end of the session.
    stdin.write_all(b"mvoe 10\nstatus\n").unwrap();
    stdin.flush().unwrap();
    let second = lines.recv_timeout(Duration::from_secs(10)).unwrap();
    assert!(second.contains("Status: idle"), "{second}");
    // `quit` ends it; what follows is not run.
    stdin.write_all(b"quit\nmove 10\n").unwrap();
    drop(stdin);
    let status = child.wait().unwrap();
    let rest: Vec<String> = lines.try_iter().collect();
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    drive.join().unwrap();
    drop(slave);
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("unknown command `mvoe`"), "{stderr}");
    assert!(rest.iter().all(|l| !l.contains("move 10")), "{rest:?}");
}
