//! The drive's configuration as the CLI takes it: any gain table, loaded when the command
//! runs (`--table`), its instruments used for the simulated sensors and the observer laws'
//! designs; and `beam flash`, which flashes what was built and says what is missing.

mod common;

use common::{beam, json, scratch, shipped_path as shipped};
use std::path::{Path, PathBuf};
use std::process::Output;

/// The shipped table with `[drive]`'s `key = value` lines replaced, written to `dir`.
fn table_with(dir: &Path, name: &str, replace: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(shipped()).unwrap();
    for (from, to) in replace {
        assert!(text.contains(from), "the shipped table has no `{from}`");
        text = text.replacen(from, to, 1);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_rig_with_a_coarser_encoder_gets_its_own_observer_design_and_sensors() {
    // The same beam and gains; one table's drive reads the hub with 1024 counts a turn
    // instead of 16 384. The lqg law is designed on each table's encoder and the simulated
    // encoder is each table's: the runs differ, and the default (the shipped table) is the
    // fine one, not the coarse one.
    let dir = scratch("encoder");
    let coarse = table_with(
        &dir,
        "coarse.toml",
        &[(
            "encoder_counts_per_rev = 16384",
            "encoder_counts_per_rev = 1024",
        )],
    );
    let run = |table: Option<&Path>| {
        let mut args = vec!["simulate", "--controller", "lqg", "--json"];
        if let Some(t) = table {
            args.extend(["--table", t.to_str().unwrap()]);
        }
        json(&beam(&args))
    };
    let (default, fine, coarse) = (run(None), run(Some(&shipped())), run(Some(&coarse)));
    assert_eq!(default, fine);
    assert_ne!(fine["cost_j"], coarse["cost_j"]);
    // Both still damp the beam: the coarse drive is a worse drive, not a broken one.
    for v in [&fine, &coarse] {
        assert_eq!(v["faults"], "none", "{v}");
        assert!(v["breakdown_at_s"].is_null(), "{v}");
    }
}

/// A table whose drive plans exact moves (`exact_moves = true`) has `simulate` plan its
/// law's shortest move as the drive does, exact on the reference beam, as `--exact` does
/// on the shipped table; the shipped table plans the longer shaped quintic.
#[test]
fn a_table_that_asks_for_exact_moves_has_simulate_plan_them() {
    let dir = scratch("exact");
    let exact = table_with(
        &dir,
        "exact.toml",
        &[(
            "law = \"smc\"\n",
            "law = \"smc-modal\"\nexact_moves = true\n",
        )],
    );
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate", "--controller", "smc-modal", "--json"];
        args.extend(["--from", "-22.5", "--move", "22.5", "--time", "shortest"]);
        args.extend(extra);
        json(&beam(&args))
    };
    let asked = run(&["--table", exact.to_str().unwrap()]);
    let flag = run(&["--exact"]);
    let quintic = run(&[]);
    assert_eq!(asked["move_end_s"], flag["move_end_s"]);
    assert_eq!(asked["settle_s"], flag["settle_s"]);
    let end = |v: &serde_json::Value| v["move_end_s"].as_f64().unwrap();
    assert!(
        end(&asked) < end(&quintic) - 0.03,
        "{asked} against {quintic}"
    );
}

#[test]
fn a_table_given_is_the_table_used_and_a_bad_one_is_refused_by_name() {
    let dir = scratch("bad");
    // Gains from the table given: another smc row at no payload changes the run.
    let other = table_with(
        &dir,
        "other.toml",
        &[("w = 81.08396\na = 10.000463", "w = 40.0\na = 10.000463")],
    );
    let a = json(&beam(&["simulate", "--json"]));
    let b = json(&beam(&[
        "simulate",
        "--json",
        "--table",
        other.to_str().unwrap(),
    ]));
    assert_eq!(b["gains"]["w"], 40.0);
    assert_ne!(a["gains"]["w"], b["gains"]["w"]);
    // A table that does not parse, or is not there: exit 2, the file named, one line.
    let broken = dir.join("broken.toml");
    std::fs::write(&broken, "[drive]\nlaw = \"nope\"\n").unwrap();
    for path in [broken, dir.join("missing.toml")] {
        let out = beam(&["simulate", "--table", path.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&*path.to_string_lossy()), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
}

#[test]
fn flash_flashes_what_was_built_and_says_what_is_missing() {
    let dir = scratch("flash");
    let err = |out: &Output| {
        assert_eq!(out.status.code(), Some(2));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // No firmware built: it says how to build it, and does not build it.
    let missing = dir.join("firmware");
    let e = err(&beam(&["flash", "--elf", missing.to_str().unwrap()]));
    assert!(e.contains("cargo fw"), "{e}");
    // A file that is not the board's firmware (the host's stub binary, say).
    let host = dir.join("host");
    std::fs::write(&host, b"\x7fELF\x02\x01\x01\0\0\0\0\0\0\0\0\0\x02\0\x3e\0").unwrap();
    let e = err(&beam(&["flash", "--elf", host.to_str().unwrap()]));
    assert!(e.contains("not firmware for the board"), "{e}");
    // An ARM ELF, and no probe-rs: the install command, not cargo's "could not execute".
    let arm = dir.join("arm");
    std::fs::write(
        &arm,
        b"\x7fELF\x01\x01\x01\0\0\0\0\0\0\0\0\0\x02\0\x28\0\x01\0",
    )
    .unwrap();
    let e = err(&beam(&[
        "flash",
        "--elf",
        arm.to_str().unwrap(),
        "--probe-rs",
        dir.join("no-probe-rs").to_str().unwrap(),
    ]));
    assert!(e.contains("cargo install probe-rs-tools"), "{e}");
}
