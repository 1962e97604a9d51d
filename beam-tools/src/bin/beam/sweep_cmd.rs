//! `beam sweep`: Monte Carlo over parameter errors and payloads, the scheduled controller
//! against the PD baseline on the same beams; percentiles, a CSV per case and histograms.

use crate::{beam, named, PlantArgs};
use anyhow::{bail, Context};
use beam_tools::design::sweep::{percentiles, sweep, Case, SweepSpec};
use beam_tools::io::plot::{histograms, HistogramPanel};
use clap::Args;
use host_tests::metrics::Metrics;
use model_core::{Law, LawKind, PdGains};
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct SweepArgs {
    #[command(flatten)]
    plant: PlantArgs,
    /// Controller (gains from the compiled table at each case's payload).
    #[arg(long, value_parser = named::<LawKind>(), default_value = "smc")]
    controller: LawKind,
    /// Number of cases.
    #[arg(long, default_value_t = 1000)]
    cases: usize,
    /// Parameter error bound: EI, rho, Jm, friction and damping each within +-SPREAD.
    #[arg(long, default_value_t = 0.2)]
    spread: f64,
    /// Largest payload, kg (uniform from 0).
    #[arg(long, default_value_t = 0.05)]
    payload_max: f64,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Coulomb friction drawn from 0 to this, N m (0: the preset's, scaled with the viscous).
    #[arg(long, default_value_t = 0.0)]
    coulomb_max: f64,
    /// Move amplitudes, deg, taken in turn by the cases at their planned times (0.35 s *
    /// sqrt(deg / 180)), shaped by each law's table shaper [default: the paper's slew].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    moves: Vec<f64>,
    /// Plan each of --moves with model-core's planner at its shortest time, as a commanded
    /// drive does (instead of 0.35 s * sqrt(deg / 180)).
    #[arg(long, requires = "moves")]
    shortest: bool,
    /// Gains and shapers from this table (as `beam optimize --table` writes it) instead of
    /// the compiled one, for the controller and the peer.
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    /// Do not run the pd-ff peer (feedforward + PD with its table shaper) on each case.
    #[arg(long)]
    no_peer: bool,
    /// Write one row per case.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write histograms of the residual strain and hub error (.png or .svg).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

type Pick = fn(&Metrics) -> Option<f64>;
/// A metric's name and its (p50, p95, max).
type Summary = (&'static str, Option<(f64, f64, f64)>);
const SUMMARY: [(&str, Pick); 6] = [
    ("rms_root_strain_ue_0_4_0_6", |m| {
        m.rms_root_strain_ue_0_4_0_6
    }),
    ("err_deg_t0_6", |m| m.err_deg_t0_6),
    ("err_deg_t2_0", |m| m.err_deg_t2_0),
    ("settle_s", |m| m.settle_s),
    ("peak_torque_nm", |m| m.peak_torque_nm),
    ("max_root_strain_ue_after_move", |m| {
        m.max_root_strain_ue_after_move
    }),
];

pub fn run(a: &SweepArgs) -> anyhow::Result<()> {
    if a.plant.tip_mass.is_some() {
        bail!("--tip-mass does not apply to sweep: payloads are drawn up to --payload-max");
    }
    if !(a.spread.is_finite() && (0.0..0.9).contains(&a.spread)) {
        bail!("--spread {} must be in [0, 0.9)", a.spread);
    }
    if !(a.payload_max.is_finite() && (0.0..=1.0).contains(&a.payload_max)) {
        bail!("--payload-max {} must be in [0, 1] kg", a.payload_max);
    }
    if a.cases == 0 || a.cases > 1_000_000 {
        bail!("--cases {} must be 1..=1000000", a.cases);
    }
    if let Some(path) = &a.plot {
        beam_tools::io::plot::check_extension(path)?;
    }
    if !(a.coulomb_max.is_finite() && (0.0..=1.0).contains(&a.coulomb_max)) {
        bail!("--coulomb-max {} must be in [0, 1] N m", a.coulomb_max);
    }
    if a.moves
        .iter()
        .any(|m| !(m.is_finite() && *m > 0.0 && *m <= 720.0))
    {
        bail!("--moves must be amplitudes in (0, 720] deg");
    }
    let nominal = *beam(&a.plant)?.params();
    let kind = a.controller.name();
    let loaded = match &a.table {
        Some(path) => Some(beam_tools::design::table::gain_rows(
            &gain_table::load(path)?.rows,
        )),
        None => None,
    };
    let table = loaded.as_deref().unwrap_or(model_core::gains::GAIN_TABLE);
    if loaded.is_some() && !table.iter().any(|r| r.law.kind() == a.controller) {
        bail!(
            "{} has no {} row",
            a.table
                .as_ref()
                .map_or(String::new(), |p| p.display().to_string()),
            a.controller
        );
    }
    let tuned = |k: LawKind| {
        move |payload: f64| {
            let p = payload as f32;
            let law =
                model_core::gains::schedule(table, k, p).unwrap_or(host_tests::sim::hand_picked(k));
            (law, model_core::gains::schedule_shaper(table, k, p))
        }
    };
    let law_at = tuned(a.controller);
    let peer_at = tuned(LawKind::PdFf);
    let peer: Option<&(dyn Fn(f64) -> beam_tools::design::sweep::Tuned + Sync)> =
        (!a.no_peer && a.controller != LawKind::PdFf).then_some(&peer_at);
    let spec = SweepSpec {
        cases: a.cases,
        spread: a.spread,
        payload_max_kg: a.payload_max,
        seed: a.seed,
        coulomb_max_nm: a.coulomb_max,
        moves_deg: a.moves.clone(),
        shortest: a.shortest,
    };
    let started = Instant::now();
    let cases = with_modes!(
        a.plant.modes,
        sweep(&nominal, &spec, &law_at, Law::Pd(PdGains::BASELINE), peer)
    )?;
    let seconds = started.elapsed().as_secs_f64();
    if let Some(path) = &a.csv {
        beam_tools::io::files::write_atomically(path, |w| write_csv(&cases, w))
            .with_context(|| path.display().to_string())?;
    }
    if let Some(path) = &a.plot {
        let panels = [
            HistogramPanel {
                title: "RMS root strain 0.4..0.6 s",
                unit: "microstrain",
                controller: cases
                    .iter()
                    .filter_map(|c| c.controller.rms_root_strain_ue_0_4_0_6)
                    .collect(),
                baseline: cases
                    .iter()
                    .filter_map(|c| c.baseline.rms_root_strain_ue_0_4_0_6)
                    .collect(),
            },
            HistogramPanel {
                title: "Hub error at 0.6 s",
                unit: "deg",
                controller: cases
                    .iter()
                    .filter_map(|c| c.controller.err_deg_t0_6)
                    .collect(),
                baseline: cases
                    .iter()
                    .filter_map(|c| c.baseline.err_deg_t0_6)
                    .collect(),
            },
        ];
        let title = format!(
            "{} vs PD 20/1: {} cases, +-{:.0} % parameters, 0..{} kg",
            kind,
            a.cases,
            a.spread * 100.0,
            a.payload_max
        );
        beam_tools::io::files::plot_atomically(path, |tmp| {
            histograms(&title, (kind, "pd 20/1"), &panels, tmp)
        })?;
    }
    let breakdowns = |f: fn(&Case) -> &Metrics| {
        cases
            .iter()
            .filter(|c| f(c).breakdown_at_s.is_some())
            .count()
    };
    let (bc, bb) = (breakdowns(|c| &c.controller), breakdowns(|c| &c.baseline));
    let stats = |f: fn(&Case) -> &Metrics| {
        SUMMARY
            .iter()
            .map(|(name, pick)| (*name, percentiles(cases.iter().map(|c| pick(f(c))))))
            .collect::<Vec<_>>()
    };
    let (sc, sb) = (stats(|c| &c.controller), stats(|c| &c.baseline));
    let sp: Option<Vec<Summary>> = peer.is_some().then(|| {
        SUMMARY
            .iter()
            .map(|(name, pick)| {
                (
                    *name,
                    percentiles(cases.iter().map(|c| c.peer.as_ref().and_then(pick))),
                )
            })
            .collect()
    });
    let bp = cases
        .iter()
        .filter(|c| c.peer.as_ref().is_some_and(|m| m.breakdown_at_s.is_some()))
        .count();
    if a.json {
        let obj = |s: &[Summary]| {
            s.iter()
                .map(|(n, p)| {
                    (
                        n.to_string(),
                        p.map_or(
                            json!(null),
                            |(a, b, c)| json!({"p50": a, "p95": b, "max": c}),
                        ),
                    )
                })
                .collect::<serde_json::Map<_, _>>()
        };
        let mut v = json!({
            "controller": kind, "preset": a.plant.preset_label(), "modes": a.plant.modes,
            "cases": a.cases, "spread": a.spread, "payload_max_kg": a.payload_max, "seed": a.seed, "seconds": seconds,
            "breakdowns": bc, "baseline_breakdowns": bb, "metrics": obj(&sc), "baseline_metrics": obj(&sb),
        });
        if let (Some(sp), serde_json::Value::Object(o)) = (&sp, &mut v) {
            o.insert("peer".into(), json!("pd-ff"));
            o.insert("peer_breakdowns".into(), json!(bp));
            o.insert("peer_metrics".into(), serde_json::Value::Object(obj(sp)));
        }
        if let serde_json::Value::Object(o) = &mut v {
            if a.coulomb_max > 0.0 {
                o.insert("coulomb_max_nm".into(), json!(a.coulomb_max));
            }
            if !a.moves.is_empty() {
                o.insert("moves_deg".into(), json!(a.moves));
            }
        }
        println!("{v}");
        return Ok(());
    }
    println!(
        "{} cases in {seconds:.1} s: {kind} (gain table) vs PD 20/1, {} preset, {} mode(s), +-{:.0} % on EI, rho, Jm, friction, damping, payload 0..{} kg",
        a.cases,
        a.plant.preset_label(),
        a.plant.modes,
        a.spread * 100.0,
        a.payload_max
    );
    println!("  model breakdowns: {kind} {bc}, pd {bb} (metrics below are over the runs that stayed in range)");
    if sp.is_some() {
        println!("  pd-ff peer (its table shaper): {bp} breakdowns");
    }
    println!(
        "  {:32} {:>30} {:>30} {:>30}",
        "metric (p50 / p95 / max)",
        kind,
        "pd 20/1",
        if sp.is_some() { "pd-ff" } else { "" }
    );
    let fmt = |p: Option<(f64, f64, f64)>| {
        p.map_or("n/a".to_string(), |(a, b, c)| {
            format!("{a:.3} / {b:.3} / {c:.3}")
        })
    };
    for (i, ((name, c), (_, b))) in sc.iter().zip(&sb).enumerate() {
        let p = sp.as_ref().map_or(String::new(), |sp| fmt(sp[i].1));
        println!("  {name:32} {:>30} {:>30} {:>30}", fmt(*c), fmt(*b), p);
    }
    Ok(())
}

fn write_csv(cases: &[Case], w: &mut dyn Write) -> std::io::Result<()> {
    write!(
        w,
        "case,payload_kg,ei_scale,rho_scale,jm_scale,friction_scale,damping_scale,coulomb_nm,move_deg"
    )?;
    let with_peer = cases.iter().any(|c| c.peer.is_some());
    let columns: &[&str] = if with_peer {
        &["ctl", "pd", "peer"]
    } else {
        &["ctl", "pd"]
    };
    for who in columns {
        for (name, _) in SUMMARY {
            write!(w, ",{who}_{name}")?;
        }
        write!(w, ",{who}_breakdown_at_s")?;
    }
    writeln!(w)?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    let empty = Metrics::default();
    for (i, c) in cases.iter().enumerate() {
        let p = &c.perturbation;
        write!(
            w,
            "{i},{},{},{},{},{},{},{},{}",
            p.payload_kg,
            p.ei,
            p.rho,
            p.jm,
            p.friction,
            p.damping,
            opt(p.coulomb_nm),
            opt(p.move_deg)
        )?;
        let peer = c.peer.as_ref().unwrap_or(&empty);
        let runs = [&c.controller, &c.baseline, peer];
        for m in &runs[..columns.len()] {
            for (_, pick) in SUMMARY {
                write!(w, ",{}", opt(pick(m)))?;
            }
            write!(w, ",{}", opt(m.breakdown_at_s))?;
        }
        writeln!(w)?;
    }
    Ok(())
}
