//! What the integration tests share: the `beam` binary as a user runs it, and the
//! repository's shipped gain table, loaded at run time as the host tools load a table.
// Each test file uses some of these.
#![allow(dead_code)]

use model_core::DriveTable;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The shipped `gains.toml`, loaded once.
pub fn shipped() -> &'static DriveTable<'static> {
    static TABLE: OnceLock<&'static DriveTable<'static>> = OnceLock::new();
    TABLE.get_or_init(|| {
        gain_table::open(&shipped_path())
            .expect("the shipped gain table loads")
            .leak()
    })
}

/// The shipped `gains.toml`.
pub fn shipped_path() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml")
}

/// The shipped table with its `[drive]` running smc-modal and asking for exact moves
/// (`exact_moves = true`), written to `path`: what a calibrated drive's table says.
pub fn write_exact_moves_table(path: &std::path::Path) {
    let shipped = std::fs::read_to_string(shipped_path()).unwrap();
    let text = shipped.replacen(
        "law = \"smc\"\n",
        "law = \"smc-modal\"\nexact_moves = true\n",
        1,
    );
    assert_ne!(text, shipped, "the shipped table's [drive] runs smc");
    std::fs::write(path, text).unwrap();
}

/// `beam ARGS`, with no `BEAM_GAIN_TABLE` from the caller's environment (the default table is
/// the repository's).
pub fn beam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_beam"))
        .args(args)
        .env_remove("BEAM_GAIN_TABLE")
        .output()
        .expect("run beam")
}

/// The one JSON object a successful run prints.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

/// A fresh scratch directory of this test process.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("beam-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Whether `qemu-system-arm` is installed. A test that needs it returns early when it is not,
/// loudly; where `BEAM_REQUIRE_QEMU` is set (CI) a missing QEMU fails instead.
pub fn qemu_present() -> bool {
    let found = Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        assert!(
            std::env::var_os("BEAM_REQUIRE_QEMU").is_none(),
            "BEAM_REQUIRE_QEMU is set but qemu-system-arm is not installed"
        );
        eprintln!(
            "\n\n!!!!!!!! SKIPPED: qemu-system-arm is not installed; the emulated-firmware \
             tests did not run (apt-get install qemu-system-arm) !!!!!!!!\n"
        );
    }
    found
}

/// The CSV log (`write_trace_csv`'s columns) of a PD move of a 3-mode model of `params`
/// from `from_rad` to `to_rad` in `time_s`, simulated for `duration_s`: the logs the
/// calibration tests take apart.
pub fn pd_move_csv(
    params: model_core::BeamParams,
    from_rad: f32,
    to_rad: f32,
    time_s: f32,
    duration_s: f64,
) -> String {
    use beam_sim::sim::{simulate, Motion, SimOptions};
    let beam = model_core::Beam::try_build(params).expect("the test's beam builds");
    let model = model_core::ModalModel::<3>::try_build(&beam).expect("its model builds");
    let run = simulate(
        &model,
        model_core::Law::Pd(model_core::PdGains::BASELINE),
        &SimOptions {
            duration_s,
            motion: Motion {
                from_rad,
                to_rad,
                time_s,
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .expect("the move simulates");
    let mut csv = Vec::new();
    beam_tools::io::files::write_trace_csv(&run, &mut csv).expect("writes to memory");
    String::from_utf8(csv).expect("the CSV is text")
}

/// The first clamped mode of a 3-mode model of `params`, Hz.
pub fn first_clamped_hz(params: model_core::BeamParams) -> f64 {
    let beam = model_core::Beam::try_build(params).expect("the test's beam builds");
    model_core::ModalModel::<3>::try_build(&beam)
        .expect("its model builds")
        .clamped_hz[0]
}

/// Deterministic noise of unit variance for the stand-in logs: a linear congruential
/// generator's uniform draws, summed in threes (near-Gaussian).
pub fn gauss(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed;
    move || {
        (0..3)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .sum::<f64>()
            * 2.0
    }
}

/// `beam replay LOG --params PARAMS --columns COLUMNS`: the beam signal's RMS error as a
/// fraction of its RMS (hub prescribed), and the open-loop hub's RMS error, deg.
pub fn replay_errors(log: &std::path::Path, params: &std::path::Path, columns: &str) -> (f64, f64) {
    let r = json(&beam(&[
        "replay",
        log.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--columns",
        columns,
        "--json",
    ]));
    (
        r["beam_rel_err"].as_f64().unwrap(),
        r["hub_rms_err_deg"].as_f64().unwrap(),
    )
}

/// Holds a held-out log to the calibration's goals: replayed on `params`, the beam signal
/// (`signal`: "tip", "strain") within 15 % RMS with the hub prescribed, and the hub, driven
/// open loop by the logged torque, within 2 deg RMS. `what` names the case.
pub fn assert_held_out(
    what: &str,
    signal: &str,
    log: &std::path::Path,
    params: &std::path::Path,
    columns: &str,
) {
    let (beam, hub) = replay_errors(log, params, columns);
    eprintln!(
        "held out, {what}: {signal} {:.1} % RMS, open-loop hub {hub:.2} deg RMS",
        100.0 * beam
    );
    assert!(beam < 0.15, "{what}: {signal} {beam}");
    assert!(hub < 2.0, "{what}: open-loop hub {hub} deg");
}
