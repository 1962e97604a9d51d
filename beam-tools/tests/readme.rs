//! The README's task table runs as written: every `cargo beam ...` command in it, in the
//! table's order, from the repository root, with its placeholders (a log, the parameter
//! files model and calibration write, a new gain table) standing for files made here. Commands that
//! need a serial port or QEMU are left to the serial and PIL tests; `cargo slew`, `cargo fw`
//! and `bash .ci/run` are what CI itself runs.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The command column's code of each table row that runs `cargo beam`.
fn readme_commands(readme: &str) -> Vec<String> {
    readme
        .lines()
        .filter(|l| l.starts_with('|'))
        .filter_map(|l| l.split('|').nth(2))
        .filter_map(|cell| cell.trim().strip_prefix("`cargo beam "))
        .filter_map(|rest| rest.strip_suffix('`'))
        .map(str::to_string)
        .collect()
}

#[test]
fn every_cargo_beam_command_in_the_readme_table_runs_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let commands = readme_commands(&readme);
    let dir = std::env::temp_dir().join(format!("beam-readme-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = |name: &str| -> PathBuf { dir.join(name) };
    let beam = |args: &[String]| {
        Command::new(env!("CARGO_BIN_EXE_beam"))
            .args(args)
            .current_dir(&root)
            .output()
            .expect("run beam")
    };
    // The log the calibration rows read: a PD move, as a rig would log it.
    let log = file("log.csv");
    let out = beam(
        &[
            "simulate",
            "--controller",
            "pd",
            "--csv",
            log.to_str().unwrap(),
        ]
        .map(String::from),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut ran = Vec::new();
    for command in &commands {
        if command.contains("PORT") || command.starts_with("pil") {
            continue;
        }
        let args: Vec<String> = command
            .split_whitespace()
            .map(|word| match word {
                "LOG.csv" => log.display().to_string(),
                "found.toml" => file("found.toml").display().to_string(),
                "mine.toml" => file("mine.toml").display().to_string(),
                "my-gains.toml" => file("my-gains.toml").display().to_string(),
                _ => word.to_string(),
            })
            .collect();
        let out = beam(&args);
        assert!(
            out.status.success(),
            "`cargo beam {command}` failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        ran.push(command.clone());
    }
    // The table's design loop really ran: the gain table it wrote names the calibrated plant.
    let table = std::fs::read_to_string(file("my-gains.toml")).unwrap();
    assert!(
        table.contains("[plant]") && table.contains("ei_nm2 = "),
        "{table}"
    );
    assert!(
        ran.len() >= 7,
        "only {} README commands ran: {ran:?}",
        ran.len()
    );
    std::fs::remove_dir_all(dir).ok();
}
