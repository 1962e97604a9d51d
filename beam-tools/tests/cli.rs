//! The `beam` binary as a user runs it: JSON keys, exit codes, files written whole.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn beam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(args)
        .output()
        .expect("run beam")
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("beam-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn model_json_has_every_key_for_each_preset_and_mode_count() {
    for preset in ["table1", "aluminium"] {
        for modes in 1..=4 {
            let v = json(&beam(&[
                "model",
                "--preset",
                preset,
                "--modes",
                &modes.to_string(),
                "--json",
            ]));
            for key in [
                "preset",
                "modes",
                "ei",
                "rho",
                "mtt",
                "jeff",
                "h",
                "mqq",
                "kqq",
                "g",
                "clamped_hz",
                "pinned_hz",
            ] {
                assert!(v.get(key).is_some(), "{preset} {modes}: no `{key}`");
            }
            assert_eq!(v["clamped_hz"].as_array().unwrap().len(), modes);
            assert_eq!(v["mqq"].as_array().unwrap().len(), modes);
            assert_eq!(v["preset"], preset);
        }
    }
}

#[test]
fn simulate_json_reports_metrics_or_a_breakdown() {
    let keys = [
        "max_track_err_deg",
        "err_deg_t0_6",
        "err_deg_t2_0",
        "max_root_strain_ue_after_move",
        "rms_root_strain_ue_0_4_0_6",
        "max_mid_strain_ue_after_move",
        "peak_torque_nm",
        "settle_s",
        "move_end_s",
        "cost_j",
        "err_deg_end_plus_0_25",
        "rms_root_strain_ue_end_plus_0_05_0_25",
        "cost_j_end_plus",
        "tip_settle_0_5deg_s",
        "breakdown_at_s",
    ];
    let v = json(&beam(&[
        "simulate",
        "--preset",
        "aluminium",
        "--modes",
        "3",
        "--controller",
        "pd",
        "--kp",
        "20",
        "--kd",
        "1",
        "--json",
    ]));
    for k in keys {
        assert!(v.get(k).is_some(), "no `{k}`");
    }
    assert!(v["breakdown_at_s"].is_null() && v["cost_j"].as_f64().unwrap() > 0.0);
    assert_eq!(v["gains"]["kp"], 20.0);
    // Any gain by its name: `--gain` sets the gain of that name, the same as its own flag,
    // and the JSON names every gain and setting the law has, and only those.
    let by_name = json(&beam(&[
        "simulate",
        "--controller",
        "smc-i",
        "--gain",
        "wi=30",
        "--gain",
        "c=0.5",
        "--json",
    ]));
    let by_flag = json(&beam(&[
        "simulate",
        "--controller",
        "smc-i",
        "--wi",
        "30",
        "--c",
        "0.5",
        "--json",
    ]));
    assert_eq!(by_name, by_flag);
    let gains = by_name["gains"].as_object().unwrap();
    assert_eq!(
        (gains["wi"].as_f64(), gains["c"].as_f64()),
        (Some(30.0), Some(0.5))
    );
    let mut keys: Vec<&str> = gains.keys().map(|k| k.as_str()).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["a", "beta", "c", "switching", "w", "wi"]);
    for (args, says) in [
        (
            &["--controller", "smc", "--gain", "kp=3"][..],
            "--kp does not apply to --controller smc",
        ),
        (
            &["--controller", "pd", "--switching", "sat"][..],
            "--switching does not apply",
        ),
        (
            &["--controller", "smc", "--model-terms"][..],
            "--model-terms does not apply",
        ),
        (&["--gain", "w"][..], "expected NAME=VALUE"),
        (&["--gain", "w=fast"][..], "`fast`"),
    ] {
        let out = beam(&[&["simulate"][..], args].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    let v = json(&beam(&[
        "simulate",
        "--preset",
        "table1",
        "--controller",
        "smc",
        "--json",
    ]));
    assert!(v["breakdown_at_s"].as_f64().unwrap() > 0.0);
    assert!(v["cost_j"].is_null() && v["rms_root_strain_ue_0_4_0_6"].is_null());
}

#[test]
fn simulate_writes_the_csv_and_both_plot_formats() {
    let dir = scratch("files");
    let (csv, png, svg) = (
        dir.join("run.csv"),
        dir.join("run.png"),
        dir.join("run.svg"),
    );
    for plot in [&png, &svg] {
        let out = beam(&[
            "simulate",
            "--controller",
            "smc-strain",
            "--modes",
            "2",
            "--duration",
            "0.7",
            "--csv",
            csv.to_str().unwrap(),
            "--plot",
            plot.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::metadata(plot).unwrap().len() > 1000);
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert!(lines
        .next()
        .unwrap()
        .starts_with("t_s,torque_nm,theta_rad,root_strain,mid_strain"));
    assert_eq!(lines.count(), 701, "0.7 s at 1 kHz, both ends included");
    // Nothing temporary is left beside the outputs.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_input_exits_2_with_one_line_and_writes_nothing() {
    let dir = scratch("bad");
    let csv = dir.join("x.csv");
    let csv_arg = csv.to_str().unwrap();
    let cases: [&[&str]; 8] = [
        &["model", "--modes", "5"],
        &["model", "--preset", "steel"],
        &["simulate", "--duration", "nan", "--csv", csv_arg],
        &["simulate", "--duration", "-1", "--csv", csv_arg],
        &[
            "simulate",
            "--controller",
            "pd",
            "--w",
            "3",
            "--csv",
            csv_arg,
        ],
        &["simulate", "--w", "0", "--csv", csv_arg],
        &["simulate", "--tip-mass", "-0.1", "--csv", csv_arg],
        &[
            "simulate",
            "--plot",
            "/nonexistent-dir/x.png",
            "--csv",
            csv_arg,
        ],
    ];
    for args in cases {
        let out = beam(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.trim().is_empty(), "{args:?}: silent");
        assert!(
            out.stdout.is_empty(),
            "{args:?}: printed {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
    // Our own validation errors are one line naming the culprit.
    let out = beam(&["simulate", "--w", "0"]);
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "beam: error: `w` must be > 0"
    );
    // A failed plot must not leave the CSV written before it half-done or renamed.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        leftovers.iter().all(|n| n.to_string_lossy() == "x.csv"),
        "{leftovers:?}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn optimize_sweep_and_calibrate_run_and_report_json() {
    let v = json(&beam(&[
        "optimize",
        "--controller",
        "smc",
        "--samples",
        "16",
        "--starts",
        "1",
        "--local-evals",
        "10",
        "--json",
    ]));
    for k in [
        "gains",
        "feasible",
        "cost_j",
        "angle_term",
        "strain_term",
        "metrics",
        "pd_baseline_metrics",
        "evaluations",
    ] {
        assert!(v.get(k).is_some(), "optimize: no `{k}`");
    }
    let angle = v["angle_term"].as_f64().unwrap();
    let strain = v["strain_term"].as_f64().unwrap();
    assert!((angle + strain - v["cost_j"].as_f64().unwrap()).abs() < 1e-9 * (angle + strain));
    let v = json(&beam(&["sweep", "--cases", "20", "--json"]));
    assert_eq!(v["cases"], 20);
    let p = &v["metrics"]["rms_root_strain_ue_0_4_0_6"];
    assert!(
        p["p50"].as_f64().unwrap() <= p["p95"].as_f64().unwrap()
            && p["p95"].as_f64().unwrap() <= p["max"].as_f64().unwrap()
    );
    // A move's time given: the unshaped paper's SMC ends every move then.
    let v = json(&beam(&[
        "sweep",
        "--controller",
        "smc",
        "--moves",
        "45",
        "--move-time",
        "0.5",
        "--cases",
        "4",
        "--no-peer",
        "--json",
    ]));
    let end = &v["metrics"]["move_end_s"];
    for k in ["p50", "max"] {
        assert!((end[k].as_f64().unwrap() - 0.5).abs() < 1e-6, "{end}");
    }
}

#[test]
fn optimize_writes_a_valid_table_row() {
    let dir = scratch("table");
    let table = dir.join("gains.toml");
    let t = table.to_str().unwrap();
    for payload in ["0.02", "0.0"] {
        let out = beam(&[
            "optimize",
            "--payload",
            payload,
            "--samples",
            "16",
            "--starts",
            "1",
            "--local-evals",
            "10",
            "--table",
            t,
            "--json",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let rows = gain_table::load(&table).unwrap().rows;
    assert_eq!(
        rows.iter().map(|r| r.payload_kg).collect::<Vec<_>>(),
        [0.0, 0.02],
        "sorted by payload"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn moves_shapers_loads_and_robust_design_reject_bad_input_in_one_line() {
    let cases: [(&[&str], &str); 23] = [
        (&["simulate", "--shaper", "zvd"], "--shaper-hz"),
        (&["simulate", "--time", "fast"], "shortest"),
        (
            &[
                "simulate",
                "--from",
                "0",
                "--move",
                "45",
                "--via",
                "1,2,3,4,5,6,7,8",
            ],
            "at most 7",
        ),
        (&["simulate", "--via", "nan"], "--via"),
        (
            &[
                "simulate", "--from", "0", "--move", "200", "--time", "shortest",
            ],
            "outside the range",
        ),
        (
            &[
                "simulate", "--from", "0", "--move", "45", "--via", "10", "--time", "0.02",
            ],
            "needs",
        ),
        (
            &[
                "simulate",
                "--time",
                "shortest",
                "--shaper",
                "zvd",
                "--shaper-hz",
                "5",
                "--end-on-time",
            ],
            "cannot end on time",
        ),
        (&["simulate", "--shaper-hz", "5"], "--shaper"),
        (
            &["simulate", "--shaper", "bumpy", "--shaper-hz", "5"],
            "--shaper",
        ),
        (
            &["simulate", "--shaper", "zvd", "--shaper-hz", "-3"],
            "frequency",
        ),
        (&["simulate", "--move", "nan"], "--move"),
        (&["simulate", "--time", "0"], "--time"),
        (&["simulate", "--load-nm", "0.5"], "--load-at"),
        (&["optimize", "--robust", "20000"], "--robust"),
        (&["sweep", "--moves", "-5"], "--moves"),
        (&["sweep", "--shortest"], "--moves"),
        (
            &["sweep", "--moves", "45", "--move-time", "0"],
            "--move-time",
        ),
        (
            &["sweep", "--moves", "45", "--move-time", "0.3", "--shortest"],
            "--move-time",
        ),
        (&["calibrate", "x.csv", "--columns", "t=x:hours"], "hours"),
        (&["calibrate", "x.csv", "--windows", "0.1,0.2"], "--windows"),
        (
            &[
                "calibrate",
                "x.csv",
                "--method",
                "paper",
                "--known-density",
                "7850",
            ],
            "--method split",
        ),
        (&["replay", "/nonexistent/log.csv"], "/nonexistent/log.csv"),
        (&["replay", "x.csv", "--plot", "out.gif"], ".png or .svg"),
    ];
    for (args, says) in cases {
        let out = beam(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    // A move, a shaper and a load that are fine give the hold figures.
    let v = json(&beam(&[
        "simulate",
        "--controller",
        "pd-ff",
        "--move",
        "30",
        "--from",
        "0",
        "--time",
        "0.2",
        "--shaper",
        "zvd",
        "--shaper-hz",
        "5",
        "--load-nm",
        "0.5",
        "--load-at",
        "1.0",
        "--load-until",
        "1.5",
        "--json",
    ]));
    assert!(v["hold_max_dev_deg"].as_f64().unwrap() > 0.0, "{v}");
    assert!(v.get("hold_recover_s").is_some(), "{v}");
    // Without a load the hold keys are absent, as before.
    let v = json(&beam(&["simulate", "--controller", "pd", "--json"]));
    assert!(v.get("hold_max_dev_deg").is_none(), "{v}");
}

#[test]
fn new_commands_reject_bad_input_with_exit_2() {
    let dir = scratch("bad2");
    let bad_csv = dir.join("bad.csv");
    std::fs::write(&bad_csv, "t_s,torque_nm,theta_rad,root_strain\n0,1,2,x\n").unwrap();
    let short_csv = dir.join("short.csv");
    std::fs::write(&short_csv, "t_s,torque_nm\n0,1\n").unwrap();
    let cases: [&[&str]; 13] = [
        &["calibrate", "/nonexistent/log.csv"],
        &["calibrate", bad_csv.to_str().unwrap()],
        &["calibrate", short_csv.to_str().unwrap()],
        &["optimize", "--bound", "w=5:1"],
        &["optimize", "--w2", "nan"],
        &["optimize", "--damping-ratio", "0.005,0.02"],
        &["sweep", "--spread", "2"],
        &["sweep", "--damping-ratio", "0.02,0.005"],
        &["sweep", "--damping-ratio", "0.005"],
        &["sweep", "--damping-ratio", "0,0.02"],
        &["sweep", "--trace", "t.csv"],
        &["sweep", "--cases", "8", "--case", "8"],
        &["simulate", "--params", "/nonexistent/p.toml"],
    ];
    for args in cases {
        let out = beam(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.trim().is_empty() && out.stdout.is_empty(), "{args:?}");
    }
    let out = beam(&["calibrate", bad_csv.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("line 2: column `root_strain`"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn pil_and_telemetry_reject_bad_input_with_exit_2_and_write_nothing() {
    let dir = scratch("pil");
    let out_csv = dir.join("out.csv");
    let empty = dir.join("empty.txt");
    std::fs::write(&empty, "INFO drive up\n").unwrap();
    // The same commands on the command line.
    let v = json(&beam(&[
        "drive", "--sim", "--json", "move", "30", ";", "done",
    ]));
    assert_eq!(v["moves"].as_array().unwrap().len(), 1);
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "tlm 1 2 3 4.0 nope 6 7 1 0\n").unwrap();
    let gap = dir.join("gap.txt");
    std::fs::write(&gap, "tlm 1 0 0 0 0 0 0 1 0\ntlm 3 0 0 0 0 0 0 1 0\n").unwrap();
    let out = out_csv.to_str().unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["pil", "--elf", "/nonexistent/pil", "--no-insn-count"],
            "/nonexistent/pil",
        ),
        (
            &["pil", "--duration", "nan", "--no-insn-count"],
            "--duration",
        ),
        (&["pil", "--timeout", "0"], "--timeout"),
        (
            &[
                "telemetry",
                "/nonexistent/raw.defmt",
                "--elf",
                "/x",
                "--out",
                out,
            ],
            "/nonexistent/raw.defmt",
        ),
        (
            &["telemetry", empty.to_str().unwrap(), "--text", "--out", out],
            "no move",
        ),
        (
            &["telemetry", bad.to_str().unwrap(), "--text", "--out", out],
            "theta_rad",
        ),
        (
            &["telemetry", gap.to_str().unwrap(), "--text", "--out", out],
            "dropped",
        ),
    ];
    for (args, says) in cases {
        let o = beam(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(o.stdout.is_empty(), "{args:?}");
        assert!(!out_csv.exists(), "{args:?} wrote a file");
    }
    // Decoded text from a probe becomes the calibration CSV.
    let good = dir.join("good.txt");
    std::fs::write(
        &good,
        "INFO drive up\n[INFO ] tlm 9 0 0 0 -1.5707964 -1.5707964 0 0 0\n\
         [INFO ] tlm 10 0 12 0.5 -1.5707964 -1.5707964 1e-6 1 0\n\
         [INFO ] tlm 11 3 14 0.75 -1.5703 -1.5707 2e-6 1 0\n",
    )
    .unwrap();
    let o = beam(&["telemetry", good.to_str().unwrap(), "--text", "--out", out]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&out_csv).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[0].starts_with("t_s,tick,"));
    assert_eq!(lines[1], "0,10,0,12,0.5,-1.5707964,-1.5707964,0.000001,1,0");
    assert!(lines[2].starts_with("0.001,11,3,14,0.75,"));
    std::fs::remove_dir_all(dir).ok();
}

/// Every subcommand, each kind of bad input: a missing file, a malformed file, an option out
/// of range, a non-finite number. Each exits with code 2 and exactly one line on stderr,
/// prints nothing on stdout, and leaves no file behind.
#[test]
fn every_subcommand_rejects_each_kind_of_bad_input_in_one_line() {
    let dir = scratch("every");
    let bad_toml = dir.join("bad.toml");
    std::fs::write(&bad_toml, "ei_nm2 = [1, 2\n").unwrap();
    let bad_csv = dir.join("bad.csv");
    std::fs::write(&bad_csv, "t_s,torque_nm,theta_rad,root_strain\n0,1,2\n").unwrap();
    let bad_tlm = dir.join("bad.txt");
    std::fs::write(&bad_tlm, "tlm 1 2 3 4.0 5 6 7 eight 0\n").unwrap();
    let not_elf = dir.join("not.elf");
    std::fs::write(&not_elf, "not an ELF").unwrap();
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    let inputs = [&bad_toml, &bad_csv, &bad_tlm, &not_elf];
    let p = |p: &PathBuf| p.to_str().unwrap().to_string();
    let (bt, bc, bl, ne) = (p(&bad_toml), p(&bad_csv), p(&bad_tlm), p(&not_elf));
    let out_csv = format!("{o}.csv");
    let out_png = format!("{o}.png");
    let out_toml = format!("{o}.toml");
    let out_bmp = format!("{o}.bmp");
    let cases: Vec<Vec<&str>> = vec![
        // model
        vec!["model", "--params", "/nonexistent/p.toml"],
        vec!["model", "--params", &bt],
        vec!["model", "--modes", "9"],
        vec!["model", "--payload", "nan"],
        vec!["model", "--payload", "-1"],
        // simulate
        vec![
            "simulate",
            "--params",
            "/nonexistent/p.toml",
            "--csv",
            &out_csv,
        ],
        vec!["simulate", "--params", &bt, "--csv", &out_csv],
        vec!["simulate", "--duration", "0", "--csv", &out_csv],
        vec![
            "simulate",
            "--controller",
            "pd",
            "--kp",
            "inf",
            "--plot",
            &out_png,
        ],
        vec!["simulate", "--plot", &out_bmp],
        // optimize
        vec![
            "optimize",
            "--params",
            "/nonexistent/p.toml",
            "--table",
            &out_toml,
        ],
        vec!["optimize", "--table", &bt],
        vec!["optimize", "--samples", "0", "--table", &out_toml],
        vec!["optimize", "--w2", "nan", "--table", &out_toml],
        // calibrate
        vec!["calibrate", "/nonexistent/log.csv", "--out", &out_toml],
        vec!["calibrate", &bc, "--out", &out_toml],
        vec!["calibrate", &bc, "--evals", "0", "--out", &out_toml],
        vec!["calibrate", &bc, "--params", &bt, "--out", &out_toml],
        // sweep
        vec![
            "sweep",
            "--params",
            "/nonexistent/p.toml",
            "--csv",
            &out_csv,
        ],
        vec!["sweep", "--params", &bt, "--csv", &out_csv],
        vec!["sweep", "--cases", "0", "--csv", &out_csv],
        vec!["sweep", "--payload-max", "nan", "--csv", &out_csv],
        vec![
            "sweep",
            "--table",
            "/nonexistent/gains.toml",
            "--csv",
            &out_csv,
        ],
        vec!["sweep", "--table", &bt, "--csv", &out_csv],
        // pil
        vec![
            "pil",
            "--elf",
            "/nonexistent/pil",
            "--no-insn-count",
            "--telemetry",
            &out_csv,
        ],
        vec!["pil", "--elf", &ne, "--no-insn-count", "--csv", &out_csv],
        vec!["pil", "--timeout", "0", "--csv", &out_csv],
        vec![
            "pil",
            "--duration",
            "inf",
            "--no-insn-count",
            "--csv",
            &out_csv,
        ],
        // telemetry
        vec!["telemetry", "/nonexistent/raw", "--text", "--out", &out_csv],
        vec!["telemetry", &bl, "--text", "--out", &out_csv],
        vec!["telemetry", &bl, "--elf", &ne, "--out", &out_csv],
        vec!["telemetry", &bl, "--text", "--ts", "nan", "--out", &out_csv],
    ];
    for args in &cases {
        let r = beam(args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: not one line:\n{err}");
        assert!(r.stdout.is_empty(), "{args:?}");
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| !inputs.contains(&p))
            .collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
    eprintln!("{} bad invocations, each refused in one line", cases.len());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn sweep_reads_a_table_at_run_time_and_writes_each_case_draw() {
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../gains.toml");
    let args = |table: Option<&str>, csv: &str| {
        let mut a = vec![
            "sweep".to_string(),
            "--controller".into(),
            "smc-i".into(),
            "--cases".into(),
            "8".into(),
            "--moves".into(),
            "15,90".into(),
            "--coulomb-max".into(),
            "0.05".into(),
            "--csv".into(),
            csv.into(),
            "--json".into(),
        ];
        if let Some(t) = table {
            a.extend(["--table".to_string(), t.to_string()]);
        }
        a
    };
    let dir = scratch("sweep-table");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    let run = |table, csv: &PathBuf| {
        let argv = args(table, csv.to_str().unwrap());
        json(&beam(&argv.iter().map(String::as_str).collect::<Vec<_>>()))
    };
    // The shipped table read at run time runs exactly what the compiled one does.
    let (compiled, loaded) = (run(None, &a), run(Some(shipped), &b));
    assert_eq!(compiled["metrics"], loaded["metrics"]);
    assert_eq!(compiled["peer_metrics"], loaded["peer_metrics"]);
    let text = std::fs::read_to_string(&a).unwrap();
    assert_eq!(text, std::fs::read_to_string(&b).unwrap());
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "coulomb_nm",
        "move_deg",
        "ctl_peak_torque_nm",
        "peer_err_deg_t0_6",
    ] {
        assert!(header.contains(&col), "no column {col}: {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8);
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for r in &rows {
        assert_eq!(r.len(), header.len());
        let coulomb: f64 = r[at("coulomb_nm")].parse().unwrap();
        assert!((0.0..=0.05).contains(&coulomb));
    }
    // Cases take the moves in turn.
    let moves: Vec<&str> = rows.iter().map(|r| r[at("move_deg")]).collect();
    assert_eq!(moves[..4], ["15", "90", "15", "90"]);
    // One case alone (`--case`) is that row of the sweep: the same draw, the same settle
    // time, and its trace.
    let trace = dir.join("trace.csv");
    let mut argv = args(None, "unused.csv");
    argv.retain(|x| x != "--csv" && x != "unused.csv");
    argv.extend(["--case", "3", "--trace", trace.to_str().unwrap()].map(String::from));
    let one = json(&beam(&argv.iter().map(String::as_str).collect::<Vec<_>>()));
    let row = &rows[3];
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    assert_eq!(one["case"], 3);
    assert_eq!(
        num(&one["draw"]["ei_scale"]),
        row[at("ei_scale")].parse::<f64>().unwrap()
    );
    assert_eq!(
        num(&one["draw"]["payload_kg"]),
        row[at("payload_kg")].parse::<f64>().unwrap()
    );
    let settle: f64 = row[at("ctl_settle_s")].parse().unwrap();
    assert_eq!(
        one["settle_s"].as_f64().unwrap_or(f64::INFINITY),
        settle,
        "{one}"
    );
    let traced = std::fs::read_to_string(&trace).unwrap();
    assert!(traced.starts_with("t_s,torque_nm,theta_rad,"));
    // 1 kHz over the sweep's 4 s, from t = 0 inclusive.
    assert_eq!(
        traced.lines().count(),
        1 + 4001,
        "{}",
        traced.lines().count()
    );
    // A damping ratio drawn from a range: the CSV's scale is over the preset's 1 %, and the
    // other draws are the same cases.
    let c = dir.join("c.csv");
    let mut argv = args(None, c.to_str().unwrap());
    argv.extend(["--damping-ratio".to_string(), "0.005,0.02".to_string()]);
    let v = json(&beam(&argv.iter().map(String::as_str).collect::<Vec<_>>()));
    assert_eq!(v["damping_ratio"], serde_json::json!([0.005, 0.02]));
    assert_eq!(compiled["damping_ratio"], serde_json::Value::Null);
    let ranged = std::fs::read_to_string(&c).unwrap();
    for (r, line) in rows.iter().zip(ranged.lines().skip(1)) {
        let q: Vec<&str> = line.split(',').collect();
        let scale: f64 = q[at("damping_scale")].parse().unwrap();
        assert!((0.5..=2.0).contains(&scale), "{scale}");
        assert_eq!(q[at("ei_scale")], r[at("ei_scale")]);
        assert_eq!(q[at("payload_kg")], r[at("payload_kg")]);
    }
    // A table without the controller's rows is refused, naming the file.
    let shipped_text = std::fs::read_to_string(shipped).unwrap();
    let mut parts = shipped_text.split("\n[[row]]");
    // The header and the [plant] (not the shipped [drive], which runs smc), then only the
    // pd-ff rows.
    let head = parts.next().unwrap();
    let head = head.split("\n[drive]").next().unwrap().to_string();
    let only_pd_ff: String = head
        + &parts
            .filter(|r| r.contains("controller = \"pd-ff\""))
            .map(|r| format!("\n[[row]]{r}"))
            .collect::<String>();
    let t = dir.join("pd-ff.toml");
    std::fs::write(&t, only_pd_ff).unwrap();
    let out = beam(
        &args(Some(t.to_str().unwrap()), a.to_str().unwrap())
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("pd-ff.toml") && err.contains("no smc-i row"),
        "{err}"
    );
}

#[test]
fn simulate_plans_moves_through_waypoints_in_the_shortest_time() {
    // The planner's shortest 180 deg quintic is speed-bound: 15/8 * pi / T = 20 rad/s at
    // T = 0.2945 s (its torque, 5.7 N m, is within 60 % of 10 N m there). The planner keeps
    // a margin (0.1 % on the time, 0.1 % in its speed bound) and rounds up to whole
    // milliseconds, so it ends within 1 % of that.
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate", "--controller", "pd-ff", "--json"];
        args.extend_from_slice(extra);
        json(&beam(&args))
    };
    let end = |v: &serde_json::Value| v["move_end_s"].as_f64().unwrap();
    let paper = run(&["--shaper", "none"]);
    assert!((end(&paper) - 0.35).abs() < 1e-6, "{}", end(&paper));
    let fast = run(&["--shaper", "none", "--time", "shortest"]);
    let t_speed = 15.0 / 8.0 * std::f64::consts::PI / 20.0;
    assert!(
        end(&fast) >= t_speed && end(&fast) <= t_speed * 1.01,
        "{}",
        end(&fast)
    );
    // With the table's shaper the beam is left quiet and the hub at rest within 0.5 deg
    // 0.25 s after each move, through waypoints too.
    for extra in [
        &["--time", "shortest"][..],
        &[
            "--from", "0", "--move", "45", "--via", "10,-30", "--time", "shortest",
        ],
    ] {
        let v = run(extra);
        assert!(
            v["err_deg_end_plus_0_25"].as_f64().unwrap() < 0.5,
            "{extra:?}: {v}"
        );
        assert_eq!(v["faults"], "none");
    }
}

#[test]
fn drive_runs_a_script_on_the_host_and_rejects_bad_input_in_one_line() {
    let dir = scratch("drive");
    let script = dir.join("s.txt");
    std::fs::write(
        &script,
        "# to 30 deg and back through 10\nmove 30\ndone\nthrough 10,0\ndone\nstatus\nstop\n",
    )
    .unwrap();
    let s = script.to_str().unwrap();
    // The stop at rest is refused: every exchange is still printed, and the exit code is 1.
    let out = beam(&["drive", "--sim", "--script", s, "--json"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("refused 1 command"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let replies: Vec<&str> = v["exchanges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["reply"].as_str().unwrap())
        .collect();
    assert_eq!(replies.len(), 4);
    assert!(replies[0].starts_with("Moving") && replies[1].starts_with("Moving"));
    assert!(replies[2].starts_with("Status"));
    // Stop at rest: nothing to stop.
    assert_eq!(replies[3], "Refused(NotMoving)");
    let moves = v["moves"].as_array().unwrap();
    assert_eq!(moves.len(), 2);
    for m in moves {
        assert!(
            m["hub_err_deg_end_plus_0_25"].as_f64().unwrap() < 0.5,
            "{m}"
        );
        // Settled (0.05 deg, 5 ue) before the next command, within the move and its 0.4 s.
        assert!(m["settle_s"].as_f64().is_some(), "{m}");
    }
    // The same commands on the command line.
    let v = json(&beam(&[
        "drive", "--sim", "--json", "move", "30", ";", "done",
    ]));
    assert_eq!(v["moves"].as_array().unwrap().len(), 1);
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "move 30\nfly 3\n").unwrap();
    let b = bad.to_str().unwrap();
    for (args, says) in [
        (vec!["drive", "--script", s], "--pil"),
        (
            vec!["drive", "--port", "/nonexistent/tty", "--script", s],
            "opening /nonexistent/tty",
        ),
        (vec!["drive", "--sim"], "--script"),
        (vec!["drive", "--sim", "--script", b], "line 2"),
        (
            vec!["drive", "--sim", "--script", "/nonexistent/s"],
            "/nonexistent/s",
        ),
        (
            vec!["drive", "--sim", "--session", "--payload", "2"],
            "--payload",
        ),
        // A script for a port is checked whole before the port is opened.
        (
            vec![
                "drive",
                "--port",
                "/nonexistent/tty",
                "status",
                ";",
                "attach",
                "0.1",
            ],
            "nothing was sent",
        ),
        // Simulated time is capped (each tick is kept).
        (
            vec![
                "drive", "--sim", "wait", "600", ";", "wait", "600", ";", "wait", "600", ";",
                "wait", "1",
            ],
            "at most 1800 s",
        ),
        (
            vec![
                "drive",
                "--sim",
                "--done-max",
                "0.05",
                "move",
                "90",
                ";",
                "done",
            ],
            "did not end",
        ),
        (
            vec!["drive", "--sim", "--done-max", "0", "status"],
            "--done-max",
        ),
    ] {
        let out = beam(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn calibrate_fits_several_logs_at_once_and_reports_each() {
    let dir = scratch("calibrate-many");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    for (path, extra) in [
        (&a, vec![]),
        (&b, vec!["--move", "30", "--from", "-15", "--time", "0.2"]),
    ] {
        let mut args = vec![
            "simulate",
            "--controller",
            "pd",
            "--duration",
            "0.8",
            "--csv",
            path.to_str().unwrap(),
        ];
        args.extend(extra);
        assert!(beam(&args).status.success());
    }
    let (sa, sb) = (a.to_str().unwrap(), b.to_str().unwrap());
    let v = json(&beam(&["calibrate", sa, sb, "--evals", "20", "--json"]));
    let logs = v["logs"].as_array().unwrap();
    assert_eq!(logs.len(), 2);
    // Each log's windows are its own (PD 20/1 takes longer to come within 2 % of a 30 deg
    // move, 0.6 deg, than within 2 % of the 180 deg slew): found per log, not shared.
    let end = |i: usize| logs[i]["windows_s"][1].as_f64().unwrap();
    assert!(end(1) > 0.2 && end(1) != end(0), "{logs:?}");
    for l in logs {
        assert!(l["rms_theta_err_rad"].as_f64().unwrap().is_finite());
    }
    let out = beam(&["calibrate", sa, sb, "--windows", "0,0.3,0.6"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("one log"));

    // The split: with the density known the torque scale is measured, written to the
    // parameter file's [sensors] and applied by replay.
    let found = dir.join("found.toml");
    let fo = found.to_str().unwrap();
    let v = json(&beam(&[
        "calibrate",
        sa,
        sb,
        "--method",
        "split",
        "--known-density",
        "2700",
        "--evals",
        "30",
        "--out",
        fo,
        "--plot",
        dir.join("cal.svg").to_str().unwrap(),
        "--json",
    ]));
    // One figure per log, each with the model against the log.
    for f in ["cal.svg", "cal-2.svg"] {
        let svg = std::fs::read_to_string(dir.join(f)).unwrap();
        assert!(
            svg.contains("Hub rate") && svg.contains("Root strain"),
            "{f}"
        );
    }
    let split = &v["split"];
    assert_eq!(split["reference"], "density");
    assert_eq!(split["offset_fitted"], false);
    let scale = split["sensors"]["torque_scale"].as_f64().unwrap();
    // The simulated drive's torque reads true.
    assert!((scale - 1.0).abs() < 0.1, "{split}");
    let text = std::fs::read_to_string(&found).unwrap();
    assert!(
        text.contains("[sensors]") && text.contains("torque_scale"),
        "{text}"
    );
    let traces = dir.join("traces.csv");
    let r = json(&beam(&[
        "replay",
        sa,
        "--params",
        fo,
        "--csv",
        traces.to_str().unwrap(),
        "--json",
    ]));
    assert!(r["beam_rel_err"].as_f64().unwrap() < 0.15, "{r}");
    // The traces: a header naming log and model, and a row per logged sample (mid-span
    // strain included: the project's own logs carry it).
    let text = std::fs::read_to_string(&traces).unwrap();
    let logged = std::fs::read_to_string(&a).unwrap().lines().count();
    assert_eq!(text.lines().count(), logged, "one row per sample");
    assert!(text.starts_with(
        "t_s,theta_log_rad,theta_model_rad,omega_log_rad_s,omega_model_rad_s,root_strain_log,root_strain_model,mid_strain_log,mid_strain_model\n"
    ));
    let out = beam(&["calibrate", sa, "--method", "split", "--known-density", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("known density"));

    // The mass-change method: the second move logged again with 50 g at the tip. The
    // masses, one per log, fix the level: the density is found (the aluminium beam's,
    // 2700 kg/m^3) and the drive's true torque measured.
    let c = dir.join("c.csv");
    let args = [
        "simulate",
        "--controller",
        "pd",
        "--duration",
        "1.2",
        "--payload",
        "0.05",
        "--move",
        "30",
        "--from",
        "-15",
        "--time",
        "0.2",
        "--csv",
        c.to_str().unwrap(),
    ];
    assert!(beam(&args).status.success());
    let sc = c.to_str().unwrap();
    let v = json(&beam(&[
        "calibrate",
        sb,
        sc,
        "--method",
        "split",
        "--tip-masses",
        "0,0.05",
        "--evals",
        "30",
        "--json",
    ]));
    let split = &v["split"];
    assert_eq!(split["reference"], "tip_mass", "{split}");
    let density = v["identified"]["density_kg_m3"].as_f64().unwrap();
    let scale = split["sensors"]["torque_scale"].as_f64().unwrap();
    eprintln!("mass change: density {density}, torque scale {scale}");
    assert!((density / 2700.0 - 1.0).abs() < 0.05, "{v}");
    assert!((scale - 1.0).abs() < 0.05, "{split}");
    for (masses, says) in [
        ("0,0.05,0.1", "3 masses for 2 logs"),
        ("0,-0.05", "finite and >= 0"),
    ] {
        let out = beam(&["calibrate", sb, sc, "--tip-masses", masses]);
        assert_eq!(out.status.code(), Some(2), "{masses}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(says),
            "{masses}"
        );
    }
    // One mass for every log: nothing to fix the level with.
    let out = beam(&[
        "calibrate",
        sc,
        "--method",
        "split",
        "--tip-masses",
        "0.05",
        "--evals",
        "30",
    ]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("torque taken to read true"));
}

#[test]
fn calibrate_json_carries_its_warnings_and_prints_them_on_stderr() {
    // One logged move cannot tell the hub's inertia from the beam's density (both make up
    // the rigid inertia the move mostly shows): the warning must reach a user of --json.
    let dir = scratch("calibrate-warnings");
    let log = dir.join("log.csv");
    let sim = beam(&[
        "simulate",
        "--controller",
        "pd",
        "--duration",
        "2",
        "--csv",
        log.to_str().unwrap(),
    ]);
    assert!(sim.status.success());
    let out = beam(&[
        "calibrate",
        log.to_str().unwrap(),
        "--method",
        "split",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    let warnings: Vec<&str> = v["warnings"]
        .as_array()
        .expect("a `warnings` array")
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("jm_kgm2") && w.contains("density_kg_m3")),
        "{warnings:?}"
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    for w in &warnings {
        assert!(
            stderr.contains(&format!("warning: {w}")),
            "{w} not on stderr"
        );
    }
}

#[test]
fn calibrate_by_default_splits_and_says_when_a_result_sits_on_a_bound_or_logs_disagree() {
    let dir = scratch("calibrate-disagree");
    // The aluminium beam, and the same beam a tenth and two and a half times as stiff.
    let params = |name: &str, ei_factor: f64| {
        let mut p = model_core::BeamParams::aluminium();
        p.ei_nm2 *= ei_factor;
        let path = dir.join(name);
        std::fs::write(&path, beam_tools::io::params_file::render(&p, "test beam")).unwrap();
        path
    };
    let log = |name: &str, params: &PathBuf, extra: &[&str]| {
        let path = dir.join(name);
        let mut args = vec![
            "simulate",
            "--params",
            params.to_str().unwrap(),
            "--controller",
            "pd",
            "--duration",
            "0.8",
            "--csv",
            path.to_str().unwrap(),
        ];
        args.extend(extra);
        let out = beam(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        path.to_str().unwrap().to_string()
    };
    let second = ["--move", "30", "--from", "-15", "--time", "0.2"];
    let same = params("same.toml", 1.0);
    let (a, b) = (log("a.csv", &same, &[]), log("b.csv", &same, &second));
    let stiffer = log("c.csv", &params("stiffer.toml", 1.1), &second);
    let far = log("d.csv", &params("far.toml", 2.5), &[]);
    let calibrate = |logs: &[&str]| {
        let mut args = vec!["calibrate"];
        args.extend(logs);
        args.push("--json");
        let out = beam(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v = json(&out);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let warnings: Vec<String> = v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap().to_string())
            .collect();
        for w in &warnings {
            assert!(stderr.contains(w.as_str()), "{w} not on stderr");
        }
        (v, warnings)
    };
    // Two moves of one beam agree; each was calibrated alone as well.
    let (v, warnings) = calibrate(&[&a, &b]);
    assert_eq!(v["method"], "split", "the default method");
    assert_eq!(v["each_log"].as_array().unwrap().len(), 2);
    assert!(
        !warnings.iter().any(|w| w.contains("disagree on")),
        "{warnings:?}"
    );
    // A move of a beam 10 % stiffer: its first mode is 5 % higher, far beyond the
    // intervals of either log alone.
    let (_, warnings) = calibrate(&[&a, &stiffer]);
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("disagree on ei_nm2") && w.contains("c.csv")),
        "{warnings:?}"
    );
    // A beam 2.5 times as stiff as the guess: step 1's search ends at twice the guess.
    let (v, warnings) = calibrate(&[&far]);
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("ei_nm2 ended") && w.contains("upper bound")),
        "{warnings:?}"
    );
    let at = &v["split"]["at_bound"][0];
    assert_eq!(at["name"], "ei_nm2", "{v}");
    assert_eq!(at["side"], "upper", "{v}");
}

#[test]
fn calibrate_cuts_a_log_of_several_moves_and_by_time_and_drops_an_unwired_gauge() {
    let dir = scratch("calibrate-cuts");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    let sim = |path: &PathBuf, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--controller",
            "pd",
            "--duration",
            "1.5",
            "--csv",
            path.to_str().unwrap(),
        ];
        args.extend(extra);
        assert!(beam(&args).status.success());
    };
    sim(&a, &[]);
    sim(&b, &["--from", "90", "--move", "-60", "--time", "0.3"]);
    // One log of both moves, the second's clock continued (a rig's 3 s log).
    let (ta, tb) = (
        std::fs::read_to_string(&a).unwrap(),
        std::fs::read_to_string(&b).unwrap(),
    );
    let last_t: f64 = ta
        .lines()
        .last()
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let mut both = ta.clone();
    for line in tb.lines().skip(1) {
        let (t, rest) = line.split_once(',').unwrap();
        let t: f64 = t.parse().unwrap();
        both.push_str(&format!("{},{rest}\n", t + last_t + 1e-3));
    }
    let multi = dir.join("multi.csv");
    std::fs::write(&multi, &both).unwrap();
    let m = multi.to_str().unwrap();
    let v = json(&beam(&["calibrate", m, "--evals", "30", "--json"]));
    let logs: Vec<&str> = v["logs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["log"].as_str().unwrap())
        .collect();
    assert_eq!(logs.len(), 2, "{logs:?}");
    assert!(logs[0].contains("move 1 of 2") && logs[1].contains("move 2 of 2"));
    // The second move starts 1.5 s into the log: its cut begins after the first move's
    // settling, with its rest kept, and the first mode comes out as the beam's (5.48 Hz).
    let starts: Vec<f64> = v["logs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["windows_s"][0].as_f64().unwrap())
        .collect();
    assert!(starts[1] >= 0.1, "{starts:?}");
    let hz = v["identified"]["clamped_hz"][0].as_f64().unwrap();
    assert!((hz / 5.4825 - 1.0).abs() < 0.01, "{hz}");
    // The first move starts at once in the log: too little rest, said so.
    let warnings = v["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("move 1 of 2")
                && w.as_str().unwrap().contains("rest")),
        "{warnings:?}"
    );
    // Cut by time to the second move alone: one log, named as the file.
    let v = json(&beam(&[
        "calibrate",
        m,
        "--from",
        "1.3",
        "--evals",
        "30",
        "--json",
    ]));
    assert_eq!(v["logs"].as_array().unwrap().len(), 1);
    assert_eq!(v["logs"][0]["log"], m);
    // A mid-span gauge that reads zero throughout is not measured.
    let header = ta.lines().next().unwrap();
    let mid = header.split(',').position(|c| c == "mid_strain").unwrap();
    let zeroed: String = ta
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return format!("{l}\n");
            }
            let mut f: Vec<&str> = l.split(',').collect();
            f[mid] = "0";
            format!("{}\n", f.join(","))
        })
        .collect();
    let z = dir.join("zero-mid.csv");
    std::fs::write(&z, zeroed).unwrap();
    let v = json(&beam(&[
        "calibrate",
        z.to_str().unwrap(),
        "--evals",
        "30",
        "--json",
    ]));
    assert!(
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("not measured")),
        "{v}"
    );
    // Bad cuts are usage errors in one line.
    for (args, says) in [
        (
            vec!["calibrate", m, "--from", "2", "--to", "1"],
            "before --to",
        ),
        (vec!["calibrate", m, "--from", "2.99"], "samples"),
        (
            vec!["calibrate", m, "--windows", "0,0.3,0.6"],
            "holds 2 moves",
        ),
    ] {
        let out = beam(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn calibrate_takes_the_encoders_counts_when_given() {
    let dir = scratch("encoder-counts");
    let log = dir.join("log.csv");
    let log = log.to_str().unwrap();
    let out = beam(&["simulate", "--controller", "pd", "--csv", log]);
    assert!(out.status.success());
    // Found in the angle: the simulated drive's 16384 counts a turn.
    let found = beam(&["calibrate", log]);
    let text = String::from_utf8_lossy(&found.stdout);
    assert!(text.contains("(16384 counts a turn)"), "{text}");
    // Given: said so, and used whatever the angle shows.
    let given = beam(&["calibrate", log, "--encoder-counts", "4096"]);
    let text = String::from_utf8_lossy(&given.stdout);
    assert!(
        given.status.success(),
        "{}",
        String::from_utf8_lossy(&given.stderr)
    );
    assert!(
        text.contains("encoder step (given): 1.534e-3 rad (4096 counts a turn)"),
        "{text}"
    );
    let paper = beam(&[
        "calibrate",
        log,
        "--method",
        "paper",
        "--encoder-counts",
        "4096",
    ]);
    assert_eq!(paper.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&paper.stderr).contains("apply to --method split"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn calibrate_finds_a_gauges_lag_and_takes_it_out_by_default() {
    // A PD move logged with the strain 40 ms late (40 rows at 1 kHz), as a gauge amplifier's
    // filter or a strain clock behind the encoder's would log it.
    let dir = scratch("strain-lag");
    let (log, late) = (dir.join("log.csv"), dir.join("late.csv"));
    let out = beam(&[
        "simulate",
        "--controller",
        "pd",
        "--move",
        "60",
        "--from",
        "0",
        "--time",
        "0.5",
        "--csv",
        log.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(&log).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    let strain_cols: Vec<usize> = rows[0]
        .iter()
        .enumerate()
        .filter(|(_, c)| **c == "root_strain" || **c == "mid_strain")
        .map(|(i, _)| i)
        .collect();
    assert_eq!(strain_cols.len(), 2);
    let lagged: Vec<String> = (0..rows.len())
        .map(|k| {
            let mut row = rows[k].clone();
            if k > 0 {
                for &c in &strain_cols {
                    row[c] = rows[(k.saturating_sub(40)).max(1)][c];
                }
            }
            row.join(",")
        })
        .collect();
    std::fs::write(&late, lagged.join("\n") + "\n").unwrap();
    let truth = json(&beam(&["model", "--json"]))["clamped_hz"][0]
        .as_f64()
        .unwrap();
    let out = beam(&["calibrate", late.to_str().unwrap(), "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("lags") && err.contains("by 0.040 s"), "{err}");
    let found = json(&out)["identified"]["clamped_hz"][0].as_f64().unwrap();
    assert!(
        (found / truth - 1.0).abs() < 0.01,
        "{found} against {truth}"
    );
    // Taken as logged, the lag ruins the fit: the first mode 10 % or more off, or no
    // rigid body at all.
    let as_logged = beam(&[
        "calibrate",
        late.to_str().unwrap(),
        "--strain-delay",
        "0",
        "--json",
    ]);
    if as_logged.status.success() {
        let off = json(&as_logged)["identified"]["clamped_hz"][0]
            .as_f64()
            .unwrap();
        assert!((off / truth - 1.0).abs() > 0.1, "{off} against {truth}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn calibrate_fits_a_torque_it_cannot_place_in_either_direction_by_default() {
    // A PD move of 60 deg, whose overshoot swings back for more than a fifth of its moving
    // time (so the balance sees both directions), logged with the torque 50 mN m above
    // what the drive applied: a torque sensor's zero off, or the same as Coulomb friction
    // that differs by 100 mN m between the directions, while the hub moves. The default
    // invocation finds that the balance cannot place it, says so, fits the offset and
    // recovers it and Jm within their intervals. (On the same move out and back without the
    // offset, the offset fitted anyway is -1.3e-4 +- 1.6e-4 N m and the residual does not
    // fall: nothing is fitted.)
    let dir = scratch("unplaced-offset");
    let path = dir.join("log.csv");
    let out = beam(&[
        "simulate",
        "--controller",
        "pd",
        "--from",
        "-30",
        "--move",
        "30",
        "--duration",
        "1.5",
        "--csv",
        path.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let col = header.split(',').position(|c| c == "torque_nm").unwrap();
    let raised: Vec<String> = lines
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(String::from).collect();
            f[col] = (f[col].parse::<f64>().unwrap() + 0.05).to_string();
            f.join(",")
        })
        .collect();
    std::fs::write(&path, format!("{header}\n{}\n", raised.join("\n"))).unwrap();
    // (The gauge's lag is not what this is about: given as none, it is not searched for.)
    let out = beam(&[
        "calibrate",
        path.to_str().unwrap(),
        "--strain-delay",
        "0",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    assert_eq!(v["split"]["offset_fitted"], true, "{v}");
    let interval = |name: &str| {
        let u = v["uncertainty"]
            .as_array()
            .unwrap()
            .iter()
            .find(|u| u["name"] == name)
            .unwrap_or_else(|| panic!("{name}: {v}"));
        (u["value"].as_f64().unwrap(), u["std_err"].as_f64().unwrap())
    };
    let (offset, sd) = interval("torque_offset_nm");
    assert!((offset - 0.05).abs() < 2.0 * sd, "{offset} +- {sd}");
    // The starting parameters are the preset the move was simulated on: the truth.
    let truth_jm = v["guess"]["jm_kgm2"].as_f64().unwrap();
    let (jm, sd) = interval("jm_kgm2");
    assert!(
        (jm - truth_jm).abs() < 2.0 * sd,
        "{jm} +- {sd} against {truth_jm}"
    );
    let said = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains("could not place"));
    assert!(said, "{}", v["warnings"]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn calibrate_fits_the_beam_on_a_tip_sensor_where_there_is_no_root_gauge() {
    // The walk-through of docs/calibrate-your-rig.md ("Your own rig, from a raw CSV"), its
    // commands as written there (with --json to read the result): the lab link of
    // docs/lab-link, made by its make.sh from `beam simulate` on truth.toml. A 20 g tip
    // mass, no strain gauge, a tip sensor read in mm to 0.05 mm with noise that lags the
    // encoder by 15 ms, the torque in mN m, the hub in degrees, time in ms. Two moves, from
    // the user's starting parameters (guess.toml: handbook steel, the hub's inertia 25 %
    // high, no friction), with the default invocation and a column map.
    let lab = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/lab-link");
    let file = |name: &str| lab.join(name).to_str().unwrap().to_string();
    let dir = scratch("tip-sensor");
    let found_toml = dir.join("lab.toml");
    let columns = "t=time_ms:ms,theta=hub_deg:deg,torque=torque_mNm:mnm,tip=tip_mm:mm";
    let v = json(&beam(&[
        "calibrate",
        &file("out.csv"),
        &file("back.csv"),
        "--params",
        &file("guess.toml"),
        "--columns",
        columns,
        "--out",
        found_toml.to_str().unwrap(),
        "--plot",
        dir.join("lab.png").to_str().unwrap(),
        "--json",
    ]));
    assert!(dir.join("lab.png").exists() && dir.join("lab-2.png").exists());
    assert_eq!(v["split"]["beam_signal"], "tip deflection", "{v}");
    assert_eq!(v["split"]["beam_unit"], "mm", "{v}");
    assert!(v["logs"][1]["rms_tip_err_mm"].is_f64(), "{v}");
    // The beam's fit (hub prescribed) within three times the sensor's noise and step
    // (0.03 mm and 0.05 mm: 0.033 mm RMS together).
    assert!(v["split"]["beam_rms_err"].as_f64().unwrap() < 0.1, "{v}");
    // The sensor's lag, fitted with the beam, within a millisecond.
    let lag = v["split"]["sensors"]["strain_delay_s"].as_f64().unwrap();
    assert!((lag - 0.015).abs() < 0.001, "{lag}");
    // The first clamped mode within 1 % of the truth's, and each fitted parameter the
    // truth has within two of its sigmas.
    let truth = json(&beam(&["model", "--params", &file("truth.toml"), "--json"]));
    let (found, true_hz) = (
        v["identified"]["clamped_hz"][0].as_f64().unwrap(),
        truth["clamped_hz"][0].as_f64().unwrap(),
    );
    assert!(
        (found / true_hz - 1.0).abs() < 0.01,
        "{found} against {true_hz}"
    );
    let true_value = |name: &str| {
        let line = std::fs::read_to_string(lab.join("truth.toml"))
            .unwrap()
            .lines()
            .find(|l| l.starts_with(&format!("{name} =")))
            .map(|l| l.split('=').nth(1).unwrap().trim().parse::<f64>().unwrap());
        line.unwrap_or_else(|| panic!("{name} not in truth.toml"))
    };
    for u in v["uncertainty"].as_array().unwrap() {
        let name = u["name"].as_str().unwrap();
        if name == "gauge_scale" {
            continue;
        }
        let (x, sd, t) = (
            u["value"].as_f64().unwrap(),
            u["std_err"].as_f64().unwrap(),
            true_value(name),
        );
        assert!((x - t).abs() < 2.0 * sd, "{name}: {x} +- {sd} against {t}");
    }
    // The held-out move replayed (the lag from the parameter file): the tip's deflection
    // within 15 % RMS, and the traces under the tip's own columns.
    let traces = dir.join("traces.csv");
    let r = json(&beam(&[
        "replay",
        &file("held-out.csv"),
        "--params",
        found_toml.to_str().unwrap(),
        "--columns",
        columns,
        "--plot",
        dir.join("held-out.png").to_str().unwrap(),
        "--csv",
        traces.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(r["beam_unit"], "mm", "{r}");
    assert_eq!(r["strain_delay_s"].as_f64(), Some(lag), "{r}");
    assert!(r["beam_rel_err"].as_f64().unwrap() < 0.15, "{r}");
    let text = std::fs::read_to_string(&traces).unwrap();
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with("tip_m_log,tip_m_model"));
    // The paper's method fits the root gauge's position: refused in one line, naming the
    // method that works. Mapping both a strain and a tip is refused too.
    for args in [
        vec![
            "calibrate",
            &file("out.csv"),
            "--columns",
            columns,
            "--method",
            "paper",
        ],
        vec![
            "calibrate",
            &file("out.csv"),
            "--columns",
            "t=time_ms:ms,strain=hub_deg,tip=tip_mm:mm",
        ],
    ] {
        let out = beam(&args.iter().map(|s| s.as_ref()).collect::<Vec<&str>>());
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains("split") || err.contains("one beam signal"),
            "{err}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_run_quietly() {
    // `beam simulate | head -1`: the reader is gone before the summary is printed.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(["simulate", "--duration", "3"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(141), "{err}");
}
