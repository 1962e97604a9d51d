//! A stand-in for a second teaching rig, as a new user meets it: a steel strip whose first
//! clamped mode is near 1.7 Hz, on a hub whose friction drags more one way (28 mN m turning
//! up, 12 mN m down), logged at 1 kHz with the hub angle rounded to 1 mrad, a tip sensor in
//! place of a strain gauge (rounded to 1 mm), and a torque derived from the motor's voltage
//! (10 % high, 20 mN m of offset, noise); each log a 0.1 rad step, up or down, after
//! seconds at rest. The starting parameters have the strip 10 % thick (its
//! thickness is known to +-10 %). Before, the default `beam calibrate` refused every one of
//! these (a negative density from the torque balance, the offset taken for the move's
//! start); the first clamped mode must now come out within 3 % of the truth on each log
//! and on both, and a step held out must be predicted.

mod common;

use beam_tools::io::params_file;
use model_core::BeamParams;

/// The rig: a 0.62 m strip of 0.8 mm steel on a hub of 0.01 kg m^2, with friction.
fn truth() -> BeamParams {
    let (e, w, t) = (200e9, 0.02, 0.0008);
    BeamParams {
        length_m: 0.62,
        width_m: w,
        thickness_m: t,
        hub_radius_m: 0.05,
        density_kg_m3: 7850.0,
        ei_nm2: e * w * t * t * t / 12.0,
        jm_kgm2: 0.01,
        viscous_nms: 0.002,
        // Friction that drags more turning positive: 28 mN m up, 12 mN m down.
        coulomb_nm: 0.02,
        coulomb_asym_nm: 0.008,
        tip_mass_kg: 0.0,
        damping_ratio: 0.01,
        root_gauge_m: 0.0,
        mid_gauge_m: 0.31,
        ..BeamParams::aluminium()
    }
}

/// The drawing's parameters: the strip 10 % thick (EI +33 %, mass +10 %, the first mode
/// +10 %; its thickness is known to +-10 %), and no difference of friction by direction.
fn drawing() -> BeamParams {
    let t = truth();
    let thick = 1.1 * t.thickness_m;
    BeamParams {
        thickness_m: thick,
        ei_nm2: 200e9 * t.width_m * thick * thick * thick / 12.0,
        coulomb_asym_nm: 0.0,
        ..t
    }
}

/// The rig's log of a PD step from `from` to `to` rad in 0.3 s: 2 s at rest, then 5 s.
fn rig_log(from: f32, to: f32, seed: u64) -> String {
    rig_log_filtered(from, to, seed, 0.0)
}

/// [`rig_log`] with the tip sensor read through a first-order filter of time constant
/// `tau_s` (0: none).
fn rig_log_filtered(from: f32, to: f32, seed: u64, tau_s: f64) -> String {
    let csv = common::pd_move_csv(truth(), from, to, 0.3, 5.0);
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (torque, theta, tip) = (col("torque_nm"), col("theta_true_rad"), col("w_tip_m"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let mut gauss = common::gauss(seed);
    let round = |v: f64, q: f64| (v / q).round() * q;
    let mut out = String::from("time,volts_torque,hub,tip\n");
    let rest = 2000;
    let mut filtered = 0.0;
    for k in 0..rest + rows.len() {
        let r = &rows[k.saturating_sub(rest)];
        // At rest before the move the PD holds the hub with no torque.
        let tau = if k < rest { 0.0 } else { r[torque] };
        let (th, w) = if k < rest {
            (from as f64, 0.0)
        } else {
            (r[theta], r[tip])
        };
        // The sensor's filter (backward Euler at 1 kHz), updated before it is read: with
        // no filter the reading is this sample's deflection, not the last one's.
        filtered = if tau_s > 0.0 {
            (filtered * tau_s + w * 1e-3) / (tau_s + 1e-3)
        } else {
            w
        };
        out.push_str(&format!(
            "{:.3},{:.6},{:.3},{:.3}\n",
            k as f64 * 1e-3,
            1.1 * tau + 0.02 + 0.005 * gauss(),
            round(th + 3e-4 * gauss(), 1e-3),
            round(filtered, 1e-3),
        ));
    }
    out
}

/// The rig's columns, as its CSV logs them.
const COLUMNS: &str = "t=time:s,torque=volts_torque:nm,theta=hub:rad,tip=tip:m";

/// `beam calibrate LOGS --params PARAMS --columns COLUMNS EXTRA...`.
fn calibrate(logs: &[&str], params: &str, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["calibrate"];
    args.extend(logs);
    args.extend(["--params", params, "--columns", COLUMNS]);
    args.extend(extra);
    common::beam(&args)
}

#[test]
fn the_default_calibration_finds_the_second_rigs_first_mode_on_each_step_and_on_both() {
    let dir = common::scratch("second-rig");
    let up = dir.join("up.csv");
    let down = dir.join("down.csv");
    std::fs::write(&up, rig_log(0.0, 0.1, 1)).unwrap();
    std::fs::write(&down, rig_log(0.1, 0.0, 2)).unwrap();
    let (t, guess) = (truth(), drawing());
    let params = dir.join("guess.toml");
    std::fs::write(
        &params,
        params_file::render(&guess, "the drawing's, 10 % thick"),
    )
    .unwrap();
    let want = common::first_clamped_hz(t);
    assert!(
        (common::first_clamped_hz(guess) / want - 1.0).abs() > 0.05,
        "the guess is off"
    );
    let (up, down, params) = (
        up.to_str().unwrap(),
        down.to_str().unwrap(),
        params.to_str().unwrap(),
    );
    for logs in [vec![up], vec![down], vec![up, down]] {
        let v = common::json(&calibrate(&logs, params, &["--json"]));
        let found = v["identified"]["clamped_hz"][0].as_f64().unwrap();
        let off = found / want - 1.0;
        eprintln!(
            "{logs:?}: first clamped mode {found:.4} Hz, truth {want:.4} Hz ({:+.2} %)",
            100.0 * off
        );
        assert!(off.abs() < 0.03, "{logs:?}: {found} Hz against {want} Hz");
    }
    // Held out: calibrated on the step up and the step down, two other steps replayed,
    // one each way: the tip within 15 % RMS (the hub prescribed) and the hub, driven open
    // loop by the logged torque, within 2 deg RMS. The torque's 20 mN m offset is read at
    // rest before the moves, and the friction's difference by direction is what the
    // balance cannot place either way once the offset is known; both are carried in the
    // parameter file. Calibrated on the step up alone, the step down drifted 3.4 deg (the
    // friction taken the same both ways); without the offset read at rest, 6.7 deg.
    let found = dir.join("both.toml");
    let out = calibrate(&[up, down], params, &["--out", found.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (name, from, to, seed) in [("up2", 0.1, 0.2, 5), ("down2", 0.2, 0.1, 6)] {
        let held = dir.join(format!("{name}.csv"));
        std::fs::write(&held, rig_log(from, to, seed)).unwrap();
        let what = format!("{name}, from up and down");
        common::assert_held_out(&what, "tip", &held, &found, COLUMNS);
    }
    let file = std::fs::read_to_string(&found).unwrap();
    let key = |k: &str| -> f64 {
        let prefix = format!("{k} = ");
        file.lines()
            .find_map(|l| l.strip_prefix(prefix.as_str()))
            .unwrap_or_else(|| panic!("{k} in the parameter file"))
            .trim()
            .parse()
            .unwrap()
    };
    let offset = key("torque_offset_nm");
    assert!((offset - 0.02).abs() < 0.002, "offset {offset} N m");
    // The friction's difference by direction: 8 mN m in the rig (28 up, 12 down).
    let asym = key("coulomb_asym_nm");
    assert!((asym - 0.008).abs() < 0.003, "coulomb_asym_nm {asym} N m");
}

#[test]
fn a_log_cut_inside_its_move_is_refused_naming_that() {
    // The step up's log from 0.1 s into its 0.3 s move: the hub already turns.
    let dir = common::scratch("second-rig-cut");
    let full = rig_log(0.0, 0.1, 3);
    let mut lines = full.lines();
    let mut cut = format!("{}\n", lines.next().unwrap());
    for l in lines {
        let t: f64 = l.split(',').next().unwrap().parse().unwrap();
        if t >= 2.1 {
            cut.push_str(l);
            cut.push('\n');
        }
    }
    let file = dir.join("cut.csv");
    std::fs::write(&file, cut).unwrap();
    let t = truth();
    let params = dir.join("truth.toml");
    std::fs::write(&params, params_file::render(&t, "the rig's")).unwrap();
    let out = calibrate(&[file.to_str().unwrap()], params.to_str().unwrap(), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    // Refused, and for that reason, not the tip mass's or the gauge's.
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("starts inside a move") && err.contains("--from"),
        "{err}"
    );
}

#[test]
fn the_logs_ringing_is_reported_and_holds_the_model_to_it() {
    let dir = common::scratch("second-rig-ringing");
    let up = dir.join("up.csv");
    std::fs::write(&up, rig_log(0.0, 0.1, 4)).unwrap();
    let (t, guess) = (truth(), drawing());
    let params = dir.join("guess.toml");
    std::fs::write(&params, params_file::render(&guess, "10 % thick")).unwrap();
    let run = |extra: &[&str]| {
        let mut extra = extra.to_vec();
        extra.push("--json");
        let (up, params) = (up.to_str().unwrap(), params.to_str().unwrap());
        common::json(&calibrate(&[up], params, &extra))
    };
    let hz = |v: &serde_json::Value, who: &str| v["ringing"][0][who]["hz"].as_f64().unwrap();
    // The default: the model rings where the log does, and both are in the summary.
    let v = run(&[]);
    let (log, model) = (hz(&v, "log"), hz(&v, "model"));
    eprintln!("default: log rings at {log:.4} Hz, the model at {model:.4} Hz");
    assert!((model / log - 1.0).abs() < 0.005, "{log} {model}");
    // The soft PD hold swings the hub with the beam: the log rings below the clamped mode,
    // which is why the model is compared ringing for ringing, on the same hub.
    assert!(log < 0.99 * common::first_clamped_hz(t), "{log}");
    let warns = |v: &serde_json::Value| {
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .take(3)
            .map(|w| w.as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert!(
        !warns(&v).iter().any(|w| w.contains("the model rings at")),
        "{:?}",
        warns(&v)
    );
    // The strip's material named: its handbook density is the reference, as
    // --known-density 7850 would make it; not both.
    let v = run(&["--material", "steel"]);
    assert_eq!(v["split"]["reference"], "density", "{v}");
    assert_eq!(v["identified"]["density_kg_m3"].as_f64(), Some(7850.0));
    // Whatever it says of the torque balance, it does not ask for the density it was given.
    let all = v["warnings"].to_string();
    assert!(!all.contains("give the density you know"), "{all}");
    let both = common::beam(&[
        "calibrate",
        up.to_str().unwrap(),
        "--material",
        "steel",
        "--known-density",
        "7800",
    ]);
    assert!(!both.status.success());
    // A lag the rig does not have, given: the fit moves the beam's frequency to use it, and
    // the ringing says so among the warnings shown.
    let v = run(&["--strain-delay", "0.056"]);
    let (log, model) = (hz(&v, "log"), hz(&v, "model"));
    eprintln!("with a 56 ms lag given: log {log:.4} Hz, model {model:.4} Hz");
    assert!(model / log - 1.0 > 0.01, "{log} {model}");
    assert!(
        warns(&v).iter().any(|w| w.contains("the model rings at")),
        "{:?}",
        warns(&v)
    );
}

#[test]
fn a_tip_sensor_behind_a_filter_keeps_the_first_mode_and_the_ringing() {
    // The tip read through a first-order filter of 56 ms (a camera's or an amplifier's):
    // its phase lag changes with frequency, which no single delay matches. The default
    // calibration must still find the first mode, and the model ring where the log does.
    let dir = common::scratch("second-rig-filter");
    let (t, guess) = (truth(), drawing());
    let params = dir.join("guess.toml");
    std::fs::write(&params, params_file::render(&guess, "10 % thick")).unwrap();
    let up = dir.join("up.csv");
    std::fs::write(&up, rig_log_filtered(0.0, 0.1, 4, 0.056)).unwrap();
    let v = common::json(&calibrate(
        &[up.to_str().unwrap()],
        params.to_str().unwrap(),
        &["--json"],
    ));
    let found = v["identified"]["clamped_hz"][0].as_f64().unwrap();
    let ring = &v["ringing"][0];
    let (log, model) = (
        ring["log"]["hz"].as_f64().unwrap(),
        ring["model"]["hz"].as_f64().unwrap(),
    );
    eprintln!(
        "tip behind 56 ms: first clamped mode {:+.2} %, rings: log {log:.4} Hz, model {model:.4} Hz",
        100.0 * (found / common::first_clamped_hz(t) - 1.0)
    );
    assert!(
        (found / common::first_clamped_hz(t) - 1.0).abs() < 0.03,
        "{found}"
    );
    assert!((model / log - 1.0).abs() < 0.005, "{log} {model}");
}
