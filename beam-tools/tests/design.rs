//! Gain design: the optimiser is deterministic and honours its constraints, and the shipped
//! gain table (loaded as the tools load it) does what the table claims on the plant.

mod common;

use beam_sim::metrics::{metrics, CostSpec};
use beam_sim::sim::{simulate, SimOptions, HAND_PICKED_SMC};
use beam_tools::design::optimize::{default_params, evaluate, optimize, Spec};
use model_core::{Beam, BeamParams, Law, LawKind, ModalModel, PdGains, Switching};

fn model(payload_kg: f64) -> ModalModel<3> {
    let params = BeamParams {
        tip_mass_kg: payload_kg,
        ..BeamParams::aluminium()
    };
    ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap()
}

fn spec(m: &ModalModel<3>, seed: u64) -> Spec {
    Spec {
        kind: LawKind::Smc,
        instruments: model_core::Instruments::DEFAULT,
        params: default_params(LawKind::Smc, m),
        switching: Switching::Tanh,
        model_terms: false,
        cost: CostSpec::default(),
        max_err_deg_0_6: Some(1.0),
        hold: Some((1.0, 0.5)),
        torque_fraction: 0.99,
        max_root_strain_ue: None,
        samples: 48,
        search: beam_tools::design::optimize::Search::Sampled,
        starts: 1,
        local_evals: 40,
        seed,
        warm_start: None,
        objective: beam_tools::design::optimize::Objective::Cost,
        load_hold: None,
        motion: beam_sim::sim::Motion::default(),
        scenarios: vec![],
        quantile: 0.95,
    }
}

#[test]
fn optimiser_is_deterministic_feasible_and_beats_the_hand_picked_gains() {
    let m = model(0.0);
    let s = spec(&m, 7);
    let a = optimize(&m, &s, &|_, _| {});
    let b = optimize(&m, &s, &|_, _| {});
    assert_eq!(a.best.gains, b.best.gains, "same seed, same design");
    assert!(a.best.feasible());
    // Its constraints hold on an independent, full-length run of the winner.
    let run = simulate(&m, a.best.law, &SimOptions::default()).unwrap();
    let r = metrics(&run);
    assert!(
        r.err_deg_t0_6.unwrap() <= 1.0 && r.peak_torque_nm.unwrap() < 9.9,
        "{r:?}"
    );
    // The hand-picked gains (a grid by eye) are feasible too; the optimiser must not do worse.
    let x = [
        HAND_PICKED_SMC.w as f64,
        HAND_PICKED_SMC.a as f64,
        HAND_PICKED_SMC.beta as f64,
    ];
    let hand = evaluate(&m, &s, &x);
    assert!(hand.feasible());
    assert!(
        a.best.cost < hand.cost,
        "optimised J {} vs hand-picked {}",
        a.best.cost,
        hand.cost
    );
}

#[test]
fn shipped_smc_gains_cut_residual_strain_tenfold_with_the_hub_on_target() {
    // The design goal: RMS root strain over 0.4..0.6 s at most a tenth of PD (20, 1)'s, with
    // the hub within 1 deg of the target at 0.6 s, on the default preset at no payload.
    let m = model(0.0);
    let smc = common::shipped()
        .law(LawKind::Smc, 0.0)
        .expect("the table has smc rows");
    let opts = SimOptions::default();
    let r = metrics(&simulate(&m, smc, &opts).unwrap());
    let pd = metrics(&simulate(&m, Law::Pd(PdGains::BASELINE), &opts).unwrap());
    let (rs, rp) = (
        r.rms_root_strain_ue_0_4_0_6.unwrap(),
        pd.rms_root_strain_ue_0_4_0_6.unwrap(),
    );
    assert!(rs <= rp / 10.0, "smc {rs} ue vs pd {rp} ue");
    assert!(r.err_deg_t0_6.unwrap() <= 1.0, "{r:?}");
    assert!(r.tip_settle_0_5deg_s.unwrap() < 1.0, "{r:?}");
}

#[test]
fn every_shipped_row_settles_its_payload_without_breakdown() {
    for row in common::shipped().rows {
        let m = model(row.payload_kg as f64);
        // Each row runs with the shaper it was designed with (none for smc and smc-strain).
        let opts = SimOptions {
            motion: beam_sim::sim::Motion {
                shaper: row.shaper,
                ..Default::default()
            },
            ..SimOptions::default()
        };
        let r = metrics(&simulate(&m, row.law, &opts).unwrap());
        assert!(
            r.breakdown_at_s.is_none(),
            "{} at {} kg",
            row.law.name(),
            row.payload_kg
        );
        assert!(
            r.err_deg_end_plus_0_25.unwrap() <= 1.0,
            "{} at {} kg: {r:?}",
            row.law.name(),
            row.payload_kg
        );
        assert!(
            r.err_deg_t2_0.unwrap() <= 0.5,
            "{} at {} kg: {r:?}",
            row.law.name(),
            row.payload_kg
        );
    }
}

#[test]
fn every_row_and_every_payload_between_rows_is_quiet_after_ten_seconds() {
    // A row that only looks settled in a short window can still be in a limit cycle (the
    // optimised smc-strain rows from 12.5 g sat at the torque limit after a few seconds).
    // Each row, and the midpoint between neighbouring rows (the drive interpolates there),
    // runs the paper's slew with its scheduled shaper for 10 s; over the last 0.5 s the root
    // strain RMS must be at most 5 ue and the torque RMS at most 0.5 N m.
    let mut payloads: Vec<(LawKind, f32)> = vec![];
    for w in common::shipped().rows.windows(2) {
        payloads.push((w[0].law.kind(), w[0].payload_kg));
        if w[0].law.kind() == w[1].law.kind() {
            payloads.push((w[0].law.kind(), (w[0].payload_kg + w[1].payload_kg) / 2.0));
        }
    }
    let last = common::shipped().rows.last().unwrap();
    payloads.push((last.law.kind(), last.payload_kg));
    let mut failed = vec![];
    for (kind, payload) in payloads {
        let law = common::shipped().law(kind, payload).unwrap();
        let shaper = common::shipped().shaper(kind, payload);
        let opts = SimOptions {
            duration_s: 10.0,
            motion: beam_sim::sim::Motion {
                shaper,
                ..Default::default()
            },
            ..SimOptions::default()
        };
        let run = simulate(&model(payload as f64), law, &opts).unwrap();
        assert!(run.breakdown.is_none(), "{kind} at {payload} kg");
        let tail: Vec<_> = run.samples.iter().filter(|s| s.t >= 9.5).collect();
        let rms = |f: &dyn Fn(&&beam_sim::sim::Sample) -> f64| {
            (tail.iter().map(|s| f(s).powi(2)).sum::<f64>() / tail.len() as f64).sqrt()
        };
        let (strain, torque) = (rms(&|s| s.root_strain * 1e6), rms(&|s| s.torque));
        let settle = beam_sim::metrics::metrics(&run).settle_s;
        eprintln!("{kind} at {payload} kg: {strain:.2} ue, {torque:.3} N m RMS at 9.5-10 s; settled {settle:?}");
        if strain > 5.0 || torque > 0.5 {
            failed.push(format!(
                "{kind} at {payload} kg: {strain:.1} ue, {torque:.2} N m"
            ));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

#[test]
fn the_settle_objective_scores_the_settle_time_and_does_not_lose_its_start() {
    use beam_sim::metrics::{metrics_with, SettleSpec};
    use beam_tools::design::optimize::{Objective, SETTLE_RUN_S};
    let m = model(0.0);
    let start = beam_sim::sim::HAND_PICKED_LQG;
    let x0 = [start.kp, start.kd, start.ki, start.kq, start.sigma].map(|v| v as f64);
    // The paper's slew with the shipped lqg row's shaper (unshaped, the law saturates).
    let motion = beam_sim::sim::Motion {
        shaper: common::shipped().shaper(LawKind::Lqg, 0.0),
        ..Default::default()
    };
    let s = Spec {
        motion,
        kind: LawKind::Lqg,
        instruments: model_core::Instruments::DEFAULT,
        params: default_params(LawKind::Lqg, &m),
        objective: Objective::Settle(SettleSpec::default()),
        max_err_deg_0_6: None,
        hold: None,
        samples: 8,
        search: beam_tools::design::optimize::Search::Sampled,
        local_evals: 12,
        warm_start: Some(x0.to_vec()),
        ..spec(&m, 3)
    };
    // The score of a gain set is the settle time of its run, as the metrics compute it.
    let start_eval = evaluate(&m, &s, &x0);
    let run = simulate(
        &m,
        Law::Lqg(start),
        &SimOptions {
            duration_s: SETTLE_RUN_S,
            motion,
            sensors: beam_sim::sensors::SensorConfig {
                seed: s.seed,
                ..Default::default()
            },
            ..SimOptions::default()
        },
    )
    .unwrap();
    let settle = metrics_with(&run, &SettleSpec::default()).settle_s.unwrap();
    assert_eq!(start_eval.cost, settle);
    assert!(start_eval.feasible(), "{start_eval:?}");
    // A search that starts there ends no worse.
    let best = optimize(&m, &s, &|_, _| {}).best;
    assert!(
        best.feasible() && best.cost <= settle,
        "{best:?} against {settle} s"
    );
}

#[test]
fn every_smc_i_row_switches_hard_enough_to_hold_the_stated_load() {
    // The disturbance bound the rows are designed for: 0.5 N m at rest. The sliding mode
    // holds a load below Jc A (Jc = Jeff / (1 - c gamma), the blended output's inertia).
    const LOAD_NM: f64 = 0.5;
    let mut rows = 0;
    for row in common::shipped().rows {
        let Some(g) = row.law.gains::<model_core::SmcIGains>() else {
            continue;
        };
        rows += 1;
        let m = model(row.payload_kg as f64);
        let jc = m.jeff / (1.0 - g.c as f64 * model_core::law::strain_coupling(&m) as f64);
        assert!(
            jc * g.a as f64 >= LOAD_NM,
            "smc-i at {} kg: Jc A = {} N m",
            row.payload_kg,
            jc * g.a as f64
        );
    }
    assert!(rows > 0, "the table has smc-i rows");
}

#[test]
fn optimize_writes_no_row_that_never_settles_and_says_when_pd_settles_sooner() {
    let dir = common::scratch("optimize-settle");
    // `beam optimize --params docs/PARAMS --controller smc --table TABLE`.
    let optimize = |params: &str, table: &std::path::Path| {
        let params = format!("{}/../docs/{params}", env!("CARGO_MANIFEST_DIR"));
        common::beam(&[
            "optimize",
            "--params",
            &params,
            "--controller",
            "smc",
            "--table",
            table.to_str().unwrap(),
        ])
    };
    // The lab link (docs/lab-link/truth.toml): a light hub and a lightly damped blade with a
    // tip mass. No smc row found on it settles the paper's slew within the run (the hub
    // within 0.05 deg and the root strain within 5 ue for good): it is shown, not written.
    let table = dir.join("lab.toml");
    let out = optimize("lab-link/truth.toml", &table);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("not written") && err.contains("never settle"),
        "{err}"
    );
    assert!(!table.exists(), "a table was written");
    // docs/truth.toml: the row settles, later than PD 20/1, and the report says so.
    let table = dir.join("truth.toml");
    let out = optimize("truth.toml", &table);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(table.exists());
    assert!(text.contains("settle later than PD 20/1"), "{text}");
}

#[test]
fn a_root_strain_bound_holds_on_the_design_and_refuses_one_the_move_cannot_meet() {
    // The paper's slew: the unconstrained design's peak root strain over the run.
    let m = model(0.0);
    // The peak root strain (ue) and torque (N m) of a law's run, and its hub's error from
    // its final angle at 0.6 s and 1 s (deg): what the spec bounds.
    let peaks = |law| {
        let run = simulate(&m, law, &SimOptions::default()).unwrap();
        let peak =
            |f: fn(&beam_sim::sim::Sample) -> f64| run.samples.iter().map(f).fold(0.0, f64::max);
        let err_at = |t: f64| {
            let s = run.samples.iter().find(|s| s.t >= t - 1e-9).unwrap();
            (s.theta - run.theta_final).abs().to_degrees()
        };
        (
            peak(|s| 1e6 * s.root_strain.abs()),
            peak(|s| s.torque.abs()),
            err_at(0.6),
            err_at(1.0),
        )
    };
    let peak_ue = |law| peaks(law).0;
    let free = optimize(&m, &spec(&m, 7), &|_, _| {});
    let free_peak = peak_ue(free.best.law);
    let bounded = |bound: f64| {
        optimize(
            &m,
            &Spec {
                max_root_strain_ue: Some(bound),
                ..spec(&m, 7)
            },
            &|_, _| {},
        )
    };
    // A bound just above it: a feasible design that keeps to it on an independent run (the
    // search's path changes, as candidates past the bound rank as infeasible).
    let loose = bounded(1.05 * free_peak);
    assert!(loose.best.feasible());
    assert!(peak_ue(loose.best.law) <= 1.05 * free_peak);
    // Half of it: the move itself bends the beam more than that under any gains the search
    // tries (the least it found was about 1000 ue, measured 2026-11-26), so no design is
    // feasible, and the violation says by how much.
    let tight = bounded(0.5 * free_peak);
    let tight_peak = peak_ue(tight.best.law);
    eprintln!(
        "peak root strain: free {free_peak:.0} ue; bounded at {:.0}: best {tight_peak:.0} ue, violation {:.3}",
        0.5 * free_peak,
        tight.best.violation
    );
    assert!(!tight.best.feasible());
    // The violation is the largest of the spec's bounds' (the torque's and the hub's error
    // at 0.6 s and at 1 s too: the search may trade strain for them), as an independent run
    // measures them.
    let (_, torque, err_06, err_1) = peaks(tight.best.law);
    let s = spec(&m, 7);
    let limit = m.beam.params().torque_limit_nm;
    let (max_06, (_, max_1)) = (s.max_err_deg_0_6.unwrap(), s.hold.unwrap());
    let expected = [
        tight_peak / (0.5 * free_peak) - 1.0,
        torque / (s.torque_fraction * limit) - 1.0,
        err_06 / max_06 - 1.0,
        err_1 / max_1 - 1.0,
    ]
    .into_iter()
    .fold(f64::MIN, f64::max);
    assert!(
        (tight.best.violation - expected).abs() < 1e-6,
        "{} against {expected}",
        tight.best.violation
    );
}
