//! Every `cargo beam` command in the guides (`docs/*.md`) runs as written, in each guide's
//! order (a chain `a && b` in order), from a scratch directory that sees the repository's
//! `docs/` and `gains.toml` as a clone's root does. The user's own logs the guides name
//! (`log.csv`, `a.csv`, ...) stand for simulated PD moves made here first.
//!
//! A command is left out only for a reason this test names, and the list is printed:
//! a synopsis (brackets, alternatives, `...`), a placeholder for the reader to fill in (an
//! upper-case word such as `C`, `F`, `PORT`), a serial port, QEMU (the PIL tests in
//! `tests/pil.rs` run those paths), a capture only a board makes, or the lab link's logs
//! (`tests/cli.rs` runs the calibration walk-through on them and checks its results). `cargo fw` in a chain
//! is CI's own step.

use std::path::Path;
use std::process::Command;

/// One command as a guide writes it: the guide, and its words after `cargo beam`.
#[derive(Debug)]
struct Found {
    guide: String,
    text: String,
}

/// The `cargo beam ...` commands of `text`, in order: each line of a fenced block and each
/// inline code span (which may wrap lines), split at `&&`.
fn commands(guide: &str, text: &str) -> Vec<Found> {
    let mut out = Vec::new();
    let mut push = |code: &str| {
        for part in code.split("&&") {
            let part = part.split(" # ").next().unwrap_or("").trim();
            if let Some(rest) = part.strip_prefix("cargo beam ") {
                out.push(Found {
                    guide: guide.to_string(),
                    text: rest.trim().to_string(),
                });
            }
        }
    };
    let mut in_fence = false;
    let mut prose = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            prose.push('\n');
            continue;
        }
        if in_fence {
            // A synopsis continues over lines ending in `\`: the whole is one synopsis.
            push(line.trim_end_matches('\\'));
        } else {
            prose.push_str(line);
            prose.push(' ');
        }
    }
    for (i, span) in prose.split('`').enumerate() {
        if i % 2 == 1 {
            push(span);
        }
    }
    out
}

/// Why a command cannot run as written here, if it cannot.
fn left_out(words: &[String]) -> Option<&'static str> {
    let text = words.join(" ");
    if ["[", "]", "(", "{", " | ", "..."]
        .iter()
        .any(|s| text.contains(s))
    {
        return Some("a synopsis");
    }
    let placeholder = |w: &str| {
        let w = w.trim_start_matches('-');
        !w.is_empty()
            && w.chars().next().is_some_and(|c| c.is_ascii_uppercase())
            && w.chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || "/_".contains(c))
    };
    if words.iter().any(|w| placeholder(w)) {
        return Some("a placeholder for the reader to fill in");
    }
    if words.iter().any(|w| w == "--port") {
        return Some("a serial port");
    }
    if words.first().is_some_and(|w| w == "pil") || words.iter().any(|w| w == "--pil") {
        return Some("QEMU (tests/pil.rs runs these paths)");
    }
    if words.first().is_some_and(|w| w == "telemetry") {
        return Some("a capture from a board");
    }
    if words.iter().any(|w| w.contains("docs/lab-link/")) {
        // Checked once, not twice: a calibration on two logs takes minutes in the test build.
        return Some(
            "the lab link's logs: tests/cli.rs (calibrate_fits_the_beam_on_a_tip_sensor) runs the walk-through's calibration and replay and checks what they find",
        );
    }
    None
}

/// Shell words: whitespace splits, a backslash escapes the next character (`\;`).
fn shell_words(text: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => word.extend(chars.next()),
            c if c.is_whitespace() => {
                if !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
            }
            c => word.push(c),
        }
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

#[test]
fn the_extraction_finds_spans_fences_and_chains() {
    let text = "Run `cargo beam simulate --csv a.csv &&\ncargo beam replay a.csv` then\n\
                ```sh\ncargo pil-fw && cargo beam pil   # the PIL\ncargo beam model --json\n```\n\
                and `cargo test`.";
    let found: Vec<String> = commands("g", text).into_iter().map(|f| f.text).collect();
    assert_eq!(
        found,
        [
            "pil",
            "model --json",
            "simulate --csv a.csv",
            "replay a.csv"
        ]
    );
    assert_eq!(
        shell_words("drive --sim move 1 \\; done"),
        ["drive", "--sim", "move", "1", ";", "done"]
    );
    let why = |t: &str| left_out(&shell_words(t));
    assert_eq!(
        why("sweep --controller C --cases 10"),
        Some("a placeholder for the reader to fill in")
    );
    assert_eq!(
        why("drive --pil --home -A/2"),
        Some("a placeholder for the reader to fill in")
    );
    assert_eq!(why("model [--json]"), Some("a synopsis"));
    assert_eq!(
        why("drive --port /dev/ttyUSB0 status"),
        Some("a serial port")
    );
    assert_eq!(why("simulate --controller pd-ff --move 45"), None);
}

#[test]
fn every_cargo_beam_command_in_the_guides_runs_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut guides: Vec<_> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    guides.sort();
    let dir = std::env::temp_dir().join(format!("beam-guides-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The clone's files the commands name, seen from the scratch directory.
    std::os::unix::fs::symlink(root.join("docs"), dir.join("docs")).unwrap();
    std::fs::copy(root.join("gains.toml"), dir.join("gains.toml")).unwrap();
    let beam = |args: &[String]| {
        Command::new(env!("CARGO_BIN_EXE_beam"))
            .args(args)
            .current_dir(&dir)
            .output()
            .expect("run beam")
    };
    // The reader's own logs, as a rig would log them: a simulated PD move each, 0.4 s long
    // in a 2 s log (simulate's default; the paper's method, the slowest command here at
    // about 28 s, takes as long on a 1 s log).
    for (name, to) in [
        ("log.csv", "90"),
        ("a.csv", "90"),
        ("b.csv", "45"),
        ("held-out.csv", "60"),
        ("slew.csv", "90"),
    ] {
        let args = [
            "simulate",
            "--controller",
            "pd",
            "--move",
            to,
            "--from",
            "0",
            "--time",
            "0.4",
            "--csv",
            name,
        ];
        let out = beam(&args.map(String::from));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let (mut ran, mut skipped) = (Vec::new(), Vec::new());
    for guide in &guides {
        let name = guide.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(guide).unwrap();
        for found in commands(&name, &text) {
            let words = shell_words(&found.text);
            if let Some(why) = left_out(&words) {
                skipped.push(format!("{}: `{}`: {why}", found.guide, found.text));
                continue;
            }
            let start = std::time::Instant::now();
            let out = beam(&words);
            let took = start.elapsed().as_secs_f64();
            let code = out.status.code();
            // `drive` exits 1 when the drive refused a command, which a guide shows on
            // purpose; any other failure is the guide's or the tool's.
            let ok = code == Some(0) || (words[0] == "drive" && code == Some(1));
            assert!(
                ok,
                "{}: `cargo beam {}` exited {code:?}: {}",
                found.guide,
                found.text,
                String::from_utf8_lossy(&out.stderr)
            );
            ran.push(format!("{}: `{}` ({took:.1} s)", found.guide, found.text));
        }
    }
    println!("ran {}:\n  {}", ran.len(), ran.join("\n  "));
    println!("left out {}:\n  {}", skipped.len(), skipped.join("\n  "));
    assert!(ran.len() >= 8, "only {} guide commands ran", ran.len());
    std::fs::remove_dir_all(&dir).ok();
}
