//! The `beam` binary on moves and scripts: a sweep over a table read at run time, moves
//! planned through waypoints, a drive script on the host.

mod common;

use common::{beam, json, scratch};
use std::path::PathBuf;

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
fn sweep_builds_the_parts_of_the_drive_it_is_told_on_the_drawn_beam() {
    let run = |known: &[&str]| {
        let mut argv = vec![
            "sweep",
            "--controller",
            "smc-modal",
            "--cases",
            "4",
            "--moves",
            "45",
            "--shortest",
            "--no-peer",
            "--json",
        ];
        argv.extend(known);
        json(&beam(&argv))
    };
    let all = run(&["--drive-knows-beam"]);
    let parts = run(&["--drive-knows", "observer,kalman,regulator,reference"]);
    let some = run(&["--drive-knows", "observer,reference"]);
    let none = run(&[]);
    // Every part is the whole drive; the JSON says which parts were known.
    assert_eq!(all["metrics"], parts["metrics"]);
    assert_eq!(all["drive_knows"], parts["drive_knows"]);
    assert_eq!(
        some["drive_knows"],
        serde_json::json!({"observer": true, "kalman": false, "regulator": false, "reference": true})
    );
    assert!(none.get("drive_knows").is_none());
    assert_ne!(some["metrics"], all["metrics"]);
    assert_ne!(some["metrics"], none["metrics"]);
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
