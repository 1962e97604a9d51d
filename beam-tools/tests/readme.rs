//! The README's task table runs as written: every `cargo beam ...` command in it, in the
//! table's order, from the repository root, with its placeholders (a log, the parameter
//! files model and calibration write, a new gain table) standing for files made here. Commands that
//! need a serial port or QEMU are left to the serial and PIL tests; `cargo fw` and `bash
//! .ci/run` are what CI itself runs. The README's main job, `cargo slew`, runs here too: its
//! alias's arguments, on the binary the tests built, so CI need not build the host profile
//! again only to run it.

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
                // As the shell reads it: `\;` is a `;` that does not end the command.
                "\\;" => ";".to_string(),
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

/// `.cargo/config.toml`'s alias `NAME`, and the arguments it passes to the `beam` binary.
fn alias_args(config: &str, name: &str) -> (String, Vec<String>) {
    let line = config
        .lines()
        .find(|l| l.starts_with(&format!("{name} = \"")))
        .unwrap_or_else(|| panic!("no alias {name} in .cargo/config.toml"));
    let value = line
        .split_once('"')
        .and_then(|(_, rest)| rest.strip_suffix('"'))
        .expect("the alias is one quoted string");
    let (cargo, beam) = value
        .split_once(" -- ")
        .expect("the alias passes its arguments after --");
    assert!(
        cargo.contains("--bin beam"),
        "{name} runs another binary: {cargo}"
    );
    let args = beam.split_whitespace().map(String::from).collect();
    (value.to_string(), args)
}

#[test]
fn the_main_job_runs_as_its_alias_says_and_writes_its_figures() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(
        readme.contains("\ncargo slew\n"),
        "the README's main job is `cargo slew`"
    );
    let config = std::fs::read_to_string(root.join(".cargo/config.toml")).unwrap();
    let (alias, args) = alias_args(&config, "slew");
    assert!(
        readme.contains(&format!("`cargo {alias}`")),
        "the README spells out `cargo slew` as `cargo {alias}`"
    );
    // The alias writes its plot where it is run: run it in a directory of its own.
    let dir = std::env::temp_dir().join(format!("beam-slew-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(&args)
        .current_dir(&dir)
        .output()
        .expect("run beam");
    assert!(
        out.status.success(),
        "`cargo slew` failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    // The paper's slew (0.35 s, 180 deg) with the SMC, on the aluminium beam, settles.
    assert!(
        text.contains("smc slew on the aluminium preset, 3 mode(s)"),
        "{text}"
    );
    assert!(
        text.contains("the move's reference ends at T = 0.350 s"),
        "{text}"
    );
    assert!(
        text.contains("settled (hub 0.05 deg, strain 5 ue) at"),
        "{text}"
    );
    assert!(
        text.lines()
            .any(|l| l.trim_start().starts_with("faults") && l.trim_end().ends_with(" none")),
        "{text}"
    );
    let plot = args
        .iter()
        .skip_while(|a| *a != "--plot")
        .nth(1)
        .expect("the main job writes a plot");
    let png = std::fs::read(dir.join(plot)).unwrap();
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 100_000,
        "{} B",
        png.len()
    );
    std::fs::remove_dir_all(dir).ok();
}
