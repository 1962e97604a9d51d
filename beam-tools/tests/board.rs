//! The board's own binary, not the PIL drive: `cargo fw`'s ELF boots on QEMU's STM32F405
//! (`-M netduinoplus2`), with USART1 on a pseudo-terminal, and `beam drive --port` talks to
//! it as to a board on a USB-serial adapter.
//!
//! What QEMU gives the firmware and what it does not (docs/flash-a-drive.md): no clock
//! controller (the crystal never reports ready, so the drive comes up on its internal
//! oscillator with the clock fault latched: what a board with a dead crystal does), no GPIO
//! inputs (the amplifier's fault line reads asserted), TIM3 free-running rather than counting
//! encoder edges (the hub reads as spinning), and no bridge converter on SPI1. So the drive
//! boots in Fault with the torque off, which is what it must do on such a board; the test
//! checks that it boots, that its tick runs, and that it answers and refuses as on `--sim`.

mod common;

use common::qemu_present;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// QEMU, killed when the test ends however it ends.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn board_elf() -> std::path::PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // `cargo fw`: the shipped table's law alone, release (a no-op when it is up to date).
    let status = Command::new(env!("CARGO"))
        .current_dir(&root)
        .env_remove("BEAM_GAIN_TABLE")
        .args([
            "build",
            "-p",
            "firmware",
            "--release",
            "--target",
            "thumbv7em-none-eabihf",
            "--features",
            "drive-law-only",
        ])
        .status()
        .expect("running cargo");
    assert!(
        status.success(),
        "building the board firmware (`cargo fw`) failed"
    );
    root.join("target/thumbv7em-none-eabihf/release/firmware")
}

/// The board's ELF on QEMU, and the pseudo-terminal its USART1 is on.
fn boot(elf: &std::path::Path) -> (Qemu, String) {
    let mut child = Command::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-cpu", "cortex-m4"])
        .args(["-display", "none", "-monitor", "none", "-serial", "pty"])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("starting qemu-system-arm");
    // QEMU prints "char device redirected to /dev/pts/N (label serial0)" on its stdout; the
    // reader keeps draining it afterwards, so QEMU never blocks on a full pipe.
    let stdout = child.stdout.take().unwrap();
    let (found, pty) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(w) = line.split_whitespace().find(|w| w.starts_with("/dev/")) {
                let _ = found.send(w.to_string());
            }
        }
    });
    let qemu = Qemu(child);
    let pty = pty
        .recv_timeout(Duration::from_secs(20))
        .expect("QEMU names the pseudo-terminal of USART1 within 20 s");
    (qemu, pty)
}

/// The `up N ticks` of each status line `beam drive` printed.
fn uptimes(out: &str) -> Vec<u64> {
    out.lines()
        .filter_map(|l| l.split("; up ").nth(1))
        .filter_map(|t| t.split_whitespace().next()?.parse().ok())
        .collect()
}

#[test]
fn the_board_binary_boots_on_the_emulated_mcu_and_answers_with_the_torque_off() {
    if !qemu_present() {
        return;
    }
    let elf = board_elf();
    let (_qemu, pty) = boot(&elf);
    // The firmware waits about 30 ms for a crystal that never comes; give it a moment.
    let started = Instant::now();
    std::thread::sleep(Duration::from_millis(300));
    let out = Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(["drive", "--port", &pty, "--reply-timeout-ms", "3000"])
        .args([
            "status", ";", "wait", "0.5", ";", "status", ";", "move", "10",
        ])
        .args([";", "clear", ";", "status"])
        .output()
        .expect("run beam");
    let text = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    eprintln!(
        "{text}{err}(QEMU up {:.1} s)",
        started.elapsed().as_secs_f64()
    );
    let statuses: Vec<&str> = text.lines().filter(|l| l.contains("Status:")).collect();
    assert_eq!(statuses.len(), 3, "{text}{err}");
    // Up, in Fault with the clock fault (no crystal on QEMU) and the torque off: no move;
    // `clear` does not clear a bad clock.
    for s in &statuses {
        assert!(s.contains("Status: fault;"), "{s}");
        assert!(s.contains("clock"), "{s}");
    }
    assert!(
        text.contains("move 10") && text.contains("Refused(Faulted)"),
        "{text}"
    );
    // The tick runs: its count grew between the first two replies.
    let up = uptimes(&text);
    assert_eq!(up.len(), 3, "{text}");
    assert!(up[1] > up[0], "the tick did not run: {up:?}");
    assert!(text.contains("clear") && text.contains("-> Done"), "{text}");
    assert!(err.contains("refused 1 command"), "{err}");
}
