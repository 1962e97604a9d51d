//! A stand-in for a teaching lab's rotary flexible link as its raw logs come: one 500 Hz log
//! holding a train of PD steps up and down, some after long rests and some after short ones
//! (0.15-0.3 s), with a root strain gauge, a 4096-count encoder, a torque derived from the
//! motor (5 % low, 15 mN m of offset, noise) and hub friction that drags more one way (40 mN m
//! turning up, 16 mN m down). Made here from the simulated plant under a hub PD, so its truth
//! is known. The default calibration must cut the log into its moves, find the first clamped
//! mode within 2 % on each step alone, and, calibrated on the whole log, predict the steps
//! of a second log held out within 2 deg of open-loop hub and 15 % of strain, up and down.

mod common;

use beam_sim::plant::{Plant, State};
use model_core::{Beam, BeamParams, ModalModel};

/// The rig: the aluminium link on a geared hub with friction that differs by direction.
fn truth() -> BeamParams {
    BeamParams {
        viscous_nms: 0.002,
        coulomb_nm: 0.028,
        coulomb_asym_nm: 0.012,
        ..BeamParams::aluminium()
    }
}

/// A log of the hub PD (the paper's Kp 20, Kd 1) commanded in steps: `steps` holds each
/// step's time and target, rad; `duration_s` long, logged at 500 Hz.
fn step_log(steps: &[(f64, f64)], duration_s: f64, seed: u64) -> String {
    let model = ModalModel::<3>::try_build(&Beam::try_build(truth()).unwrap()).unwrap();
    let plant = Plant::new(model);
    let h = plant.stable_step_s().min(1e-4);
    let per_sample = (2e-3 / h).ceil() as usize;
    let h = 2e-3 / per_sample as f64;
    let mut x = State::<3>::at_rest(0.0);
    let mut gauss = common::gauss(seed);
    let count = std::f64::consts::TAU / 4096.0;
    let mut out = String::from("t,tau_derived,encoder,gauge\n");
    let samples = (duration_s / 2e-3).round() as usize;
    for k in 0..samples {
        let t = k as f64 * 2e-3;
        let target = steps
            .iter()
            .rev()
            .find(|(at, _)| *at <= t)
            .map_or(0.0, |(_, to)| *to);
        // The drive's PD on the encoder's angle, at 500 Hz, held between samples.
        let measured = (x.theta / count).floor() * count;
        let tau = plant.saturate(20.0 * (target - measured) - 1.0 * x.omega);
        let strain = plant.outputs(&x).root_strain;
        out.push_str(&format!(
            "{t:.3},{:.6},{:.6},{:.4}\n",
            0.95 * tau + 0.015 + 0.002 * gauss(),
            measured,
            1e6 * strain + 0.5 * gauss(),
        ));
        for _ in 0..per_sample {
            x = plant.rk4_step(&x, tau, h);
        }
    }
    out
}

const COLUMNS: &str = "t=t:s,torque=tau_derived:nm,theta=encoder:rad,strain=gauge:ue";

#[test]
fn a_raw_train_of_steps_is_cut_calibrated_step_by_step_and_predicts_held_out_steps_both_ways() {
    let dir = common::scratch("step-train");
    // Long and short rests: 0.5 s before the first step, then 1.2 s, 0.25 s, 1.0 s, 0.15 s
    // after each step has (about) settled.
    let train = [
        (0.5, 0.3),
        (1.7, 0.0),
        (2.9, -0.3),
        (4.0, 0.0),
        (5.2, 0.3),
        (6.3, 0.0),
    ];
    let log = dir.join("train.csv");
    std::fs::write(&log, step_log(&train, 7.5, 1)).unwrap();
    // The drawing's parameters: the blade 8 % stiffer, no friction known.
    let t = truth();
    let guess = BeamParams {
        ei_nm2: 1.08 * t.ei_nm2,
        coulomb_nm: 0.0,
        coulomb_asym_nm: 0.0,
        viscous_nms: 0.0,
        ..t
    };
    let params = dir.join("guess.toml");
    std::fs::write(
        &params,
        beam_tools::io::params_file::render(&guess, "the drawing's"),
    )
    .unwrap();
    let want = common::first_clamped_hz(t);
    let (log, params) = (log.to_str().unwrap(), params.to_str().unwrap());
    // `beam calibrate` on the log with the drawing's parameters, and `extra`.
    let calibrate = |extra: &[&str]| {
        let mut args = vec!["calibrate", log, "--params", params, "--columns", COLUMNS];
        args.extend(extra);
        args.push("--json");
        common::json(&common::beam(&args))
    };
    // The whole log, calibrated as it comes: cut into its six moves.
    let found = dir.join("found.toml");
    let v = calibrate(&["--out", found.to_str().unwrap()]);
    let moves = v["logs"].as_array().unwrap();
    assert_eq!(moves.len(), train.len(), "{:?}", moves);
    let hz = v["identified"]["clamped_hz"][0].as_f64().unwrap();
    let i = &v["identified"];
    eprintln!(
        "the whole log: {} moves, first clamped mode {:+.2} %, friction {:.1} up / {:.1} down mN m (truth 40 / 16)",
        moves.len(),
        100.0 * (hz / want - 1.0),
        1e3 * (i["coulomb_nm"].as_f64().unwrap() + i["coulomb_asym_nm"].as_f64().unwrap()),
        1e3 * (i["coulomb_nm"].as_f64().unwrap() - i["coulomb_asym_nm"].as_f64().unwrap()),
    );
    assert!((hz / want - 1.0).abs() < 0.02, "{hz} Hz against {want}");
    // Each step alone, cut from the log by its times (the rest before it included).
    let windows: Vec<(f64, f64)> = moves
        .iter()
        .map(|m| {
            let name = m["log"].as_str().unwrap();
            let span = name.rsplit(", ").next().unwrap().trim_end_matches(" s)");
            let (a, b) = span.split_once("..").unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect();
    for (a, b) in &windows {
        let (from, to) = (format!("{a}"), format!("{b}"));
        let v = calibrate(&["--from", &from, "--to", &to]);
        let hz = v["identified"]["clamped_hz"][0].as_f64().unwrap();
        eprintln!(
            "the step {a:.2}..{b:.2} s alone: first clamped mode {:+.2} %",
            100.0 * (hz / want - 1.0)
        );
        assert!(
            (hz / want - 1.0).abs() < 0.02,
            "{a}..{b}: {hz} Hz against {want}"
        );
    }
    // Held out: two other steps, one each way, from rest, replayed with what the whole log
    // found.
    for (target, seed, what) in [(0.2, 2, "up 0.2 rad"), (-0.25, 3, "down 0.25 rad")] {
        let held = dir.join(format!("held-{seed}.csv"));
        std::fs::write(&held, step_log(&[(0.4, target)], 2.0, seed)).unwrap();
        common::assert_held_out(what, "strain", &held, &found, COLUMNS);
    }
}
