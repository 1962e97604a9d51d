//! A stand-in for a second teaching rig, as a new user meets it: a steel strip whose first
//! clamped mode is near 1.7 Hz, logged at 1 kHz with the hub angle rounded to 1 mrad, a tip
//! sensor in place of a strain gauge (rounded to 1 mm), and a torque derived from the
//! motor's voltage (10 % high, 20 mN m of offset, noise); each log a 0.1 rad step, up or
//! down, after seconds at rest. The starting parameters have the strip 10 % thick (its
//! thickness is known to +-10 %). Before, the default `beam calibrate` refused every one of
//! these (a negative density from the torque balance, the offset taken for the move's
//! start); the first clamped mode must now come out within 3 % of the truth on each log
//! and on both, and a step held out must be predicted.

mod common;

use beam_tools::io::params_file;
use model_core::{Beam, BeamParams, ModalModel};

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
        coulomb_nm: 0.02,
        tip_mass_kg: 0.0,
        damping_ratio: 0.01,
        root_gauge_m: 0.0,
        mid_gauge_m: 0.31,
        ..BeamParams::aluminium()
    }
}

fn clamped_hz(p: BeamParams) -> f64 {
    ModalModel::<3>::try_build(&Beam::try_build(p).unwrap())
        .unwrap()
        .clamped_hz[0]
}

/// The rig's log of a PD step from `from` to `to` rad in 0.3 s: 2 s at rest, then 5 s.
fn rig_log(from: f32, to: f32, seed: u64) -> String {
    let csv = common::pd_move_csv(truth(), from, to, 0.3, 5.0);
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (torque, theta, tip) = (col("torque_nm"), col("theta_true_rad"), col("w_tip_m"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // Deterministic noise: a linear congruential generator's uniform draws, summed in
    // threes (near-Gaussian), of unit variance.
    let mut x = seed;
    let mut gauss = move || {
        (0..3)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .sum::<f64>()
            * 2.0
    };
    let round = |v: f64, q: f64| (v / q).round() * q;
    let mut out = String::from("time,volts_torque,hub,tip\n");
    let rest = 2000;
    for k in 0..rest + rows.len() {
        let r = &rows[k.saturating_sub(rest)];
        // At rest before the move the PD holds the hub with no torque.
        let tau = if k < rest { 0.0 } else { r[torque] };
        let (th, w) = if k < rest {
            (from as f64, 0.0)
        } else {
            (r[theta], r[tip])
        };
        out.push_str(&format!(
            "{:.3},{:.6},{:.3},{:.3}\n",
            k as f64 * 1e-3,
            1.1 * tau + 0.02 + 0.005 * gauss(),
            round(th + 3e-4 * gauss(), 1e-3),
            round(w, 1e-3),
        ));
    }
    out
}

#[test]
fn the_default_calibration_finds_the_second_rigs_first_mode_on_each_step_and_on_both() {
    let dir = common::scratch("second-rig");
    let up = dir.join("up.csv");
    let down = dir.join("down.csv");
    std::fs::write(&up, rig_log(0.0, 0.1, 1)).unwrap();
    std::fs::write(&down, rig_log(0.1, 0.0, 2)).unwrap();
    // The drawing's parameters: the strip 10 % thick (EI +33 %, mass +10 %).
    let t = truth();
    let thick = 1.1 * t.thickness_m;
    let guess = BeamParams {
        thickness_m: thick,
        ei_nm2: 200e9 * t.width_m * thick * thick * thick / 12.0,
        ..t
    };
    let params = dir.join("guess.toml");
    std::fs::write(
        &params,
        params_file::render(&guess, "the drawing's, 10 % thick"),
    )
    .unwrap();
    let want = clamped_hz(t);
    assert!(
        (clamped_hz(guess) / want - 1.0).abs() > 0.05,
        "the guess is off"
    );
    let (up, down, params) = (
        up.to_str().unwrap(),
        down.to_str().unwrap(),
        params.to_str().unwrap(),
    );
    for logs in [vec![up], vec![down], vec![up, down]] {
        let mut args = vec!["calibrate"];
        args.extend(&logs);
        args.extend([
            "--params",
            params,
            "--columns",
            "t=time:s,torque=volts_torque:nm,theta=hub:rad,tip=tip:m",
            "--json",
        ]);
        let v = common::json(&common::beam(&args));
        let found = v["identified"]["clamped_hz"][0].as_f64().unwrap();
        let off = found / want - 1.0;
        eprintln!(
            "{logs:?}: first clamped mode {found:.4} Hz, truth {want:.4} Hz ({:+.2} %)",
            100.0 * off
        );
        assert!(off.abs() < 0.03, "{logs:?}: {found} Hz against {want} Hz");
    }
    // Held out: calibrated on the step up, the step down replayed: the tip within 15 % RMS
    // (the hub prescribed) and the hub, driven open loop by the logged torque, within 2 deg
    // RMS. The torque's 20 mN m offset is read at rest before the move and carried in the
    // parameter file; without it the open-loop hub drifted 6.7 deg.
    let found = dir.join("up.toml");
    let columns = "t=time:s,torque=volts_torque:nm,theta=hub:rad,tip=tip:m";
    let out = common::beam(&[
        "calibrate",
        up,
        "--params",
        params,
        "--columns",
        columns,
        "--out",
        found.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r = common::json(&common::beam(&[
        "replay",
        down,
        "--params",
        found.to_str().unwrap(),
        "--columns",
        columns,
        "--json",
    ]));
    let (tip, hub) = (
        r["beam_rel_err"].as_f64().unwrap(),
        r["hub_rms_err_deg"].as_f64().unwrap(),
    );
    eprintln!(
        "held out (down, from up): tip {:.1} % RMS, open-loop hub {hub:.1} deg RMS",
        100.0 * tip
    );
    assert!(tip < 0.15, "tip {tip}");
    assert!(hub < 2.0, "open-loop hub {hub} deg");
    let file = std::fs::read_to_string(&found).unwrap();
    let offset: f64 = file
        .lines()
        .find_map(|l| l.strip_prefix("torque_offset_nm = "))
        .expect("the offset in the parameter file")
        .trim()
        .parse()
        .unwrap();
    assert!((offset - 0.02).abs() < 0.002, "offset {offset} N m");
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
    let out = common::beam(&[
        "calibrate",
        file.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--columns",
        "t=time:s,torque=volts_torque:nm,theta=hub:rad,tip=tip:m",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    // Refused, and for that reason, not the tip mass's or the gauge's.
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("starts inside a move") && err.contains("--from"),
        "{err}"
    );
}
