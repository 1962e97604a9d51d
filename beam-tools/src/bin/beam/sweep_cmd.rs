//! `beam sweep`: Monte Carlo over parameter errors and payloads, the scheduled controller
//! against the PD baseline on the same beams; percentiles, a CSV per case and histograms.

use crate::{beam, damping_range, named, PlantArgs, SensorArgs, SettleArgs};
use anyhow::{bail, Context};
use beam_sim::metrics::Metrics;
use beam_sim::sim::Known;
use beam_tools::design::sweep::{
    sweep, trace_case, Case, KnownParams, LawSummary, SweepSpec, SUMMARY,
};
use beam_tools::io::plot::{histograms, HistogramPanel};
use clap::{Args, ValueEnum};
use model_core::{BeamParams, Law, LawKind, PdGains};
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct SweepArgs {
    #[command(flatten)]
    plant: PlantArgs,
    #[command(flatten)]
    settle: SettleArgs,
    /// Simulated time of each case from the move command, s: a case not settled by then
    /// counts as never settled.
    #[arg(long, default_value_t = beam_tools::design::sweep::DEFAULT_DURATION_S)]
    duration: f64,
    /// Controller (gains from the gain table at each case's payload).
    #[arg(long, value_parser = named::<LawKind>(), default_value = "smc")]
    controller: LawKind,
    /// Number of cases.
    #[arg(long, default_value_t = 1000)]
    cases: usize,
    /// Parameter error bound: EI, rho, Jm, friction and damping each within +-SPREAD.
    #[arg(long, default_value_t = 0.2)]
    spread: f64,
    /// The modal damping ratio drawn log-uniformly from LO to HI (for instance 0.005,0.02:
    /// 0.5 to 2 %, half the beams below 1 %) instead of the preset's within +-SPREAD.
    #[arg(long, value_name = "LO,HI", value_parser = damping_range)]
    damping_ratio: Option<(f64, f64)>,
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
    /// With --shortest and an observer law: plan each move to leave the law's reference
    /// beam at rest, a bang-coast-bang move shaped on it by Newton's method (docs/design.md,
    /// section 3), instead of the shaped quintic. Better on beams within about 10 % of the
    /// model (a calibrated drive), not over the default spread.
    #[arg(long, requires = "shortest")]
    exact: bool,
    /// Each of --moves in this time, s (shaped and stretched by the law's shaper, as `beam
    /// simulate --time S`), instead of 0.35 s * sqrt(deg / 180): how the settle time depends
    /// on the move's length.
    #[arg(
        long,
        value_name = "S",
        requires = "moves",
        conflicts_with = "shortest"
    )]
    move_time: Option<f64>,
    /// Gains, shapers and instruments from this table (as `beam optimize --table` writes
    /// it), for the controller and the peer [default: $BEAM_GAIN_TABLE, else the
    /// repository's gains.toml].
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    /// Do not run the pd-ff peer (feedforward + PD with its table shaper) on each case.
    #[arg(long)]
    no_peer: bool,
    /// Feed an observer law (lqg, smc-modal) the beam's true state instead of its
    /// observer's estimate: what the law would do with perfect knowledge of the state, to
    /// see what the observer costs (refused for the other laws; PD 20/1 and the peer read
    /// the instruments as always).
    #[arg(long)]
    true_state: bool,
    #[command(flatten)]
    sensors: SensorArgs,
    /// Build each case's drive on the drawn beam instead of the nominal one (the laws'
    /// designs, the planner's inertia; the shapers' frequencies scaled by the drawn beam's
    /// first hub-free frequency against the nominal's): what identifying each beam could at
    /// most give. The PD baseline and the peer get the same drive.
    #[arg(long, conflicts_with = "drive_knows")]
    drive_knows_beam: bool,
    /// Build only these parts of each case's drive on the drawn beam, the rest on the nominal
    /// one: `observer` (an observer law's model of the beam), `kalman` (its Kalman gain),
    /// `regulator` (the feedback's gains, and the plant numbers every law scales its gains
    /// by), `reference` (the reference beam and feedforward, the planner's inertia and the
    /// shapers' frequencies). Comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "PART")]
    drive_knows: Vec<DrivePart>,
    /// With --drive-knows-beam or --drive-knows: build those parts on a beam with only these
    /// of the drawn beam's parameters, the rest nominal (default: all of them):
    /// `stiffness` (EI / density as drawn, at the nominal density: what the observer laws'
    /// identifier finds), `ei`, `density`, `hub` (Jm), `damping`, `friction` (viscous and
    /// Coulomb). Comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "PARAM")]
    drive_knows_params: Vec<BeamParam>,
    /// Write one row per case.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write histograms of the residual strain and hub error (.png or .svg).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Run only case N of this sweep (the same beam, payload, move and sensor noise as in
    /// the whole sweep; 0-based, the CSV's `case`), the controller alone, and report its
    /// draw and the metrics of `beam simulate`: to see why a case is slow.
    #[arg(long, value_name = "N", conflicts_with_all = ["csv", "plot"])]
    case: Option<usize>,
    /// With --case: write that run's trace (the columns of `beam simulate --csv`).
    #[arg(long, value_name = "FILE", requires = "case")]
    trace: Option<PathBuf>,
}

pub fn run(a: &SweepArgs) -> anyhow::Result<()> {
    check(a)?;
    if a.exact && !a.controller.has_observer() {
        bail!(
            "--exact plans on an observer law's reference beam; {} has none (use lqg or smc-modal)",
            a.controller.name()
        );
    }
    if a.true_state && !a.controller.has_observer() {
        bail!(
            "--true-state feeds an observer law's state; {} has no observer (use lqg or smc-modal)",
            a.controller.name()
        );
    }
    let nominal = *beam(&a.plant)?.params();
    let table = load_table(a)?;
    let tuned = |k: LawKind| {
        move |payload: f64| {
            let p = payload as f32;
            let law = table
                .and_then(|t| t.law(k, p))
                .unwrap_or(model_core::Law::start(k));
            let shaper = table.map_or(model_core::Shaper::NONE, |t| t.shaper(k, p));
            (law, shaper)
        }
    };
    let law_at = tuned(a.controller);
    let peer_at = tuned(LawKind::PdFf);
    let peer: Option<&(dyn Fn(f64) -> beam_tools::design::sweep::Tuned + Sync)> =
        (!a.no_peer && a.controller != LawKind::PdFf).then_some(&peer_at);
    let spec = SweepSpec {
        cases: a.cases,
        spread: a.spread,
        damping_ratio: a.damping_ratio,
        payload_max_kg: a.payload_max,
        seed: a.seed,
        coulomb_max_nm: a.coulomb_max,
        moves_deg: a.moves.clone(),
        shortest: a.shortest,
        // As the drive whose table asks for them plans its law's shortest moves.
        exact: a.exact || table.is_some_and(|t| t.drive.exact_moves && t.drive.law == a.controller),
        move_time_s: a.move_time,
        duration_s: a.duration,
        settle: a.settle.spec()?,
        instruments: a
            .sensors
            .instruments(table.map_or(model_core::Instruments::DEFAULT, |t| t.drive.instruments))?,
        strain_noise_std: a.sensors.strain_noise_std()?,
        true_state: a.true_state,
        drive_knows: a.known(),
        known_params: a.known_params(),
    };
    if let Some(index) = a.case {
        return run_case(a, &nominal, &spec, &law_at, index);
    }
    let started = Instant::now();
    let cases = with_modes!(
        a.plant.modes,
        sweep(&nominal, &spec, &law_at, Law::Pd(PdGains::BASELINE), peer)
    )?;
    let seconds = started.elapsed().as_secs_f64();
    write_files(a, &nominal, &cases)?;
    let controller = LawSummary::of(&cases, |c| Some(&c.controller));
    let baseline = LawSummary::of(&cases, |c| Some(&c.baseline));
    let peer = peer
        .is_some()
        .then(|| LawSummary::of(&cases, |c| c.peer.as_ref()));
    if a.json {
        print_json(a, &spec, seconds, &controller, &baseline, peer.as_ref());
    } else {
        print_text(a, &spec, seconds, &controller, &baseline, peer.as_ref());
    }
    Ok(())
}

/// `--case N`: case N alone, its draw and metrics, and its trace with `--trace`.
fn run_case(
    a: &SweepArgs,
    nominal: &BeamParams,
    spec: &SweepSpec,
    law_at: &(dyn Fn(f64) -> beam_tools::design::sweep::Tuned + Sync),
    index: usize,
) -> anyhow::Result<()> {
    let (p, run) = with_modes!(a.plant.modes, trace_case(nominal, spec, law_at, index))?;
    if let Some(path) = &a.trace {
        beam_tools::io::files::write_atomically(path, |w| {
            beam_tools::io::files::write_trace_csv(&run, w)
        })
        .with_context(|| path.display().to_string())?;
    }
    let law = law_at(p.payload_kg).0;
    let mut o = crate::run_json(
        &run,
        &law,
        &a.plant.preset_label(),
        a.plant.modes,
        &spec.settle,
    )?;
    let draw = json!({
        "payload_kg": p.payload_kg, "ei_scale": p.ei, "rho_scale": p.rho, "jm_scale": p.jm,
        "friction_scale": p.friction, "damping_scale": p.damping_scale(nominal),
        "damping_ratio": p.apply(nominal).damping_ratio, "coulomb_nm": p.coulomb_nm,
        "move_deg": p.move_deg,
    });
    if a.json {
        o.insert("case".into(), json!(index));
        o.insert("draw".into(), draw);
        println!("{}", serde_json::Value::Object(o));
    } else {
        let settled = run_settle(&o);
        println!(
            "case {index} of the sweep (seed {}): {}",
            a.seed,
            serde_json::to_string(&draw)?
        );
        println!(
            "  {}: settled {settled}, move end T = {:.3} s",
            a.controller.name(),
            run.move_end_s
        );
        if let Some(path) = &a.trace {
            println!("  trace written to {}", path.display());
        }
    }
    Ok(())
}

/// The settle time of a run's JSON, as text.
fn run_settle(o: &serde_json::Map<String, serde_json::Value>) -> String {
    match o.get("settle_s").and_then(|v| v.as_f64()) {
        Some(s) => format!("at {s:.3} s from the move command"),
        None => "never within the run".to_string(),
    }
}

/// The arguments' ranges, checked before anything runs.
fn check(a: &SweepArgs) -> anyhow::Result<()> {
    if a.plant.tip_mass.is_some() {
        bail!("--tip-mass does not apply to sweep: payloads are drawn up to --payload-max");
    }
    if !a.drive_knows_params.is_empty() && a.known() == Known::NONE {
        bail!("--drive-knows-params says which parameters the parts in --drive-knows (or --drive-knows-beam) are built with: give one of those");
    }
    if !(a.spread.is_finite() && (0.0..0.9).contains(&a.spread)) {
        bail!("--spread {} must be in [0, 0.9)", a.spread);
    }
    if !(a.payload_max.is_finite() && (0.0..=1.0).contains(&a.payload_max)) {
        bail!("--payload-max {} must be in [0, 1] kg", a.payload_max);
    }
    if !(a.duration.is_finite() && a.duration > 0.0 && a.duration <= 600.0) {
        bail!(
            "--duration {} must be a number of seconds in (0, 600]",
            a.duration
        );
    }
    a.settle.spec()?;
    if a.cases == 0 || a.cases > 1_000_000 {
        bail!("--cases {} must be 1..=1000000", a.cases);
    }
    if let Some(n) = a.case.filter(|&n| n >= a.cases) {
        bail!(
            "--case {n} is not a case of a {}-case sweep (0 to {}, as the CSV numbers them)",
            a.cases,
            a.cases - 1
        );
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
    if a.move_time
        .is_some_and(|t| !(t.is_finite() && t > 0.0 && t <= 10.0))
    {
        bail!("--move-time must be in (0, 10] s");
    }
    Ok(())
}

/// The gain table (`--table`, or the default one); a table given must have rows of the
/// controller.
fn load_table(a: &SweepArgs) -> anyhow::Result<Option<&'static model_core::DriveTable<'static>>> {
    let table = beam_tools::io::table_file::table_or_default(a.table.as_deref())?;
    if let (Some(path), Some(t)) = (&a.table, table) {
        if !t.rows.iter().any(|r| r.law.kind() == a.controller) {
            bail!("{} has no {} row", path.display(), a.controller);
        }
    }
    Ok(table)
}

/// `--csv` (a row per case) and `--plot` (histograms against the baseline).
fn write_files(a: &SweepArgs, nominal: &BeamParams, cases: &[Case]) -> anyhow::Result<()> {
    if let Some(path) = &a.csv {
        beam_tools::io::files::write_atomically(path, |w| write_csv(nominal, cases, w))
            .with_context(|| path.display().to_string())?;
    }
    let Some(path) = &a.plot else {
        return Ok(());
    };
    // Finite values only: a run that never settled has no place on the axis (the text
    // report counts them).
    let panel = |title, unit, pick: fn(&Metrics) -> Option<f64>| HistogramPanel {
        title,
        unit,
        controller: cases
            .iter()
            .filter_map(|c| pick(&c.controller))
            .filter(|v| v.is_finite())
            .collect(),
        baseline: cases
            .iter()
            .filter_map(|c| pick(&c.baseline))
            .filter(|v| v.is_finite())
            .collect(),
    };
    let panels = [
        panel("Settle time from the move command", "s", |m| m.settle_s),
        panel("RMS root strain T+0.05..T+0.25 s", "microstrain", |m| {
            m.rms_root_strain_ue_end_plus_0_05_0_25
        }),
    ];
    let kind = a.controller.name();
    let damping = a.damping_ratio.map_or(String::new(), |(lo, hi)| {
        format!(", damping {}-{} %", lo * 100.0, hi * 100.0)
    });
    let title = format!(
        "{} vs PD 20/1: {} cases, +-{:.0} % parameters{damping}, 0..{} kg",
        kind,
        a.cases,
        a.spread * 100.0,
        a.payload_max
    );
    beam_tools::io::files::plot_atomically(path, |tmp| {
        histograms(&title, (kind, "pd 20/1"), &panels, tmp)
    })?;
    Ok(())
}

fn print_json(
    a: &SweepArgs,
    spec: &SweepSpec,
    seconds: f64,
    controller: &LawSummary,
    baseline: &LawSummary,
    peer: Option<&LawSummary>,
) {
    let obj = |s: &LawSummary| {
        s.metrics
            .iter()
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
    let mut o = serde_json::Map::new();
    let mut put = |k: &str, v: serde_json::Value| {
        o.insert(k.into(), v);
    };
    put("controller", json!(a.controller.name()));
    put("preset", json!(a.plant.preset_label()));
    put("modes", json!(a.plant.modes));
    put("cases", json!(a.cases));
    put("spread", json!(a.spread));
    put(
        "damping_ratio",
        json!(a.damping_ratio.map(|(lo, hi)| [lo, hi])),
    );
    put("payload_max_kg", json!(a.payload_max));
    put("seed", json!(a.seed));
    put("seconds", json!(seconds));
    put("duration_s", json!(a.duration));
    put("settle_band", json!(a.settle.spec().ok()));
    put(
        "encoder_counts_per_rev",
        json!(spec.instruments.encoder.counts_per_rev),
    );
    put("gauge_noise_ue", json!(spec.strain_noise_std * 1e6));
    put("breakdowns", json!(controller.breakdowns));
    put("unsettled", json!(controller.unsettled));
    put("faulted", json!(controller.faulted));
    put("baseline_breakdowns", json!(baseline.breakdowns));
    put("baseline_unsettled", json!(baseline.unsettled));
    put("metrics", json!(obj(controller)));
    put("baseline_metrics", json!(obj(baseline)));
    if let Some(p) = peer {
        put("peer", json!("pd-ff"));
        put("peer_breakdowns", json!(p.breakdowns));
        put("peer_unsettled", json!(p.unsettled));
        put("peer_metrics", json!(obj(p)));
    }
    if a.coulomb_max > 0.0 {
        put("coulomb_max_nm", json!(a.coulomb_max));
    }
    let known = a.known();
    if known != Known::NONE {
        put(
            "drive_knows",
            json!({"observer": known.observer, "kalman": known.kalman, "regulator": known.regulator, "reference": known.reference}),
        );
        if !a.drive_knows_params.is_empty() {
            put("drive_knows_params", json!(spelled(&a.drive_knows_params)));
        }
    }
    if !a.moves.is_empty() {
        put("moves_deg", json!(a.moves));
    }
    println!("{}", serde_json::Value::Object(o));
}

fn print_text(
    a: &SweepArgs,
    spec: &SweepSpec,
    seconds: f64,
    controller: &LawSummary,
    baseline: &LawSummary,
    peer: Option<&LawSummary>,
) {
    let kind = a.controller.name();
    let damping = a.damping_ratio.map_or("damping".to_string(), |(lo, hi)| {
        format!(
            "damping ratio {}-{} % (log-uniform)",
            lo * 100.0,
            hi * 100.0
        )
    });
    println!(
        "{} cases in {seconds:.1} s: {kind} (gain table) vs PD 20/1, {} preset, {} mode(s), +-{:.0} % on EI, rho, Jm, friction, {damping}, payload 0..{} kg",
        a.cases,
        a.plant.preset_label(),
        a.plant.modes,
        a.spread * 100.0,
        a.payload_max
    );
    let beam = if a.drive_knows_params.is_empty() {
        "its drawn beam".to_string()
    } else {
        format!(
            "a beam with only the drawn {} (--drive-knows-params)",
            spelled(&a.drive_knows_params).join(", ")
        )
    };
    println!(
        "  sensors: encoder {} counts/rev, gauge noise {} ue RMS",
        spec.instruments.encoder.counts_per_rev,
        spec.strain_noise_std * 1e6
    );
    if a.drive_knows_beam {
        println!("  each drive built on {beam} (--drive-knows-beam)");
    } else if !a.drive_knows.is_empty() {
        println!(
            "  each drive's {} built on {beam}, the rest on the nominal (--drive-knows)",
            spelled(&a.drive_knows).join(", ")
        );
    }
    println!(
        "  model breakdowns: {kind} {}, pd {} (metrics below are over the runs that stayed in range)",
        controller.breakdowns, baseline.breakdowns
    );
    println!(
        "  not settled within the {} s run (hub {} deg, root strain {} ue): {kind} {}, pd {}",
        a.duration,
        a.settle.settle_hub_deg,
        a.settle.settle_strain_ue,
        controller.unsettled,
        baseline.unsettled
    );
    println!(
        "  faults latched (a sensor, the strain trip; breakdowns included): {kind} {}, pd {}",
        controller.faulted, baseline.faulted
    );
    if let Some(p) = peer {
        println!(
            "  pd-ff peer (its table shaper): {} breakdowns, {} not settled",
            p.breakdowns, p.unsettled
        );
    }
    println!("  settle_s counts from the move command; T is when each move's reference ends");
    println!(
        "  {:32} {:>30} {:>30} {:>30}",
        "metric (p50 / p95 / max)",
        kind,
        "pd 20/1",
        if peer.is_some() { "pd-ff" } else { "" }
    );
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:.3}")
        } else {
            "never".to_string()
        }
    };
    let fmt = |p: Option<(f64, f64, f64)>| {
        p.map_or("n/a".to_string(), |(a, b, c)| {
            format!("{} / {} / {}", num(a), num(b), num(c))
        })
    };
    for (i, ((name, c), (_, b))) in controller.metrics.iter().zip(&baseline.metrics).enumerate() {
        let p = peer.map_or(String::new(), |p| fmt(p.metrics[i].1));
        println!("  {name:32} {:>30} {:>30} {:>30}", fmt(*c), fmt(*b), p);
    }
}

/// `damping_scale` is the damping ratio drawn over the nominal's, also when it was drawn from
/// `--damping-ratio`.
fn write_csv(nominal: &BeamParams, cases: &[Case], w: &mut dyn Write) -> std::io::Result<()> {
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
    // Empty for none; a run that never settled writes `inf`.
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
            p.damping_scale(nominal),
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

/// A part of the drive that `--drive-knows` builds on the drawn beam.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum DrivePart {
    Observer,
    Kalman,
    Regulator,
    Reference,
}

/// A parameter of the drawn beam a drive can be built with (`--drive-knows-params`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum BeamParam {
    Stiffness,
    Ei,
    Density,
    Hub,
    Damping,
    Friction,
}

/// The values as the command line spells them (`--drive-knows`, `--drive-knows-params`).
fn spelled<T: ValueEnum>(values: &[T]) -> Vec<String> {
    values
        .iter()
        .filter_map(|v| v.to_possible_value())
        .map(|v| v.get_name().to_string())
        .collect()
}

impl SweepArgs {
    /// The drawn beam's parameters the known parts are built with (all by default).
    fn known_params(&self) -> KnownParams {
        if self.drive_knows_params.is_empty() {
            return KnownParams::ALL;
        }
        let has = |p| self.drive_knows_params.contains(&p);
        KnownParams {
            stiffness: has(BeamParam::Stiffness),
            ei: has(BeamParam::Ei),
            density: has(BeamParam::Density),
            hub: has(BeamParam::Hub),
            damping: has(BeamParam::Damping),
            friction: has(BeamParam::Friction),
        }
    }

    /// The parts of the drive built on the drawn beam.
    fn known(&self) -> Known {
        if self.drive_knows_beam {
            return Known::ALL;
        }
        let has = |part| self.drive_knows.contains(&part);
        Known {
            observer: has(DrivePart::Observer),
            kalman: has(DrivePart::Kalman),
            regulator: has(DrivePart::Regulator),
            reference: has(DrivePart::Reference),
        }
    }
}
