//! Unit and sign mistakes in a log are named for what they are: a log of a simulated PD
//! slew, read right and then as a user might misread it.

mod common;

use beam_tools::identify::calibrate::{read_log, Log};
use beam_tools::identify::units::{unit_mistake, UnitMistake};
use model_core::BeamParams;

/// A PD move of `deg` in `time_s` on `params`, 1 s, as its CSV log reads back.
fn log_of(params: BeamParams, deg: f32, time_s: f32) -> Log {
    read_log(&csv_of(params, deg, time_s), "slew.csv").unwrap()
}

/// The CSV log of [`log_of`]'s move.
fn csv_of(params: BeamParams, deg: f32, time_s: f32) -> String {
    common::pd_move_csv(params, 0.0, deg.to_radians(), time_s, 1.0)
}

fn scaled(log: &Log, f: impl Fn(&mut Log)) -> Log {
    let mut l = log.clone();
    f(&mut l);
    l
}

#[test]
fn a_log_read_right_has_no_unit_mistake_whatever_its_move() {
    let al = BeamParams::aluminium();
    for (deg, time_s) in [(180.0, 0.35), (30.0, 0.5), (6.0, 0.3), (-90.0, 0.4)] {
        let log = log_of(al, deg, time_s);
        assert_eq!(unit_mistake(&log, &al), None, "{deg} deg in {time_s} s");
    }
}

#[test]
fn each_misread_unit_or_sign_is_named() {
    let al = BeamParams::aluminium();
    let log = log_of(al, 90.0, 0.4);
    let deg_per_rad = 180.0 / std::f64::consts::PI;
    let ratio = |l: &Log| match unit_mistake(l, &al) {
        Some(UnitMistake::TorqueAngleScale { ratio }) => ratio,
        other => panic!("{other:?}"),
    };
    // Degrees read as radians: the hub seems to turn 57 times as far.
    let r = ratio(&scaled(&log, |l| {
        l.theta.iter_mut().for_each(|x| *x *= deg_per_rad)
    }));
    assert!((19.0..170.0).contains(&r), "{r}");
    // Radians read as degrees.
    let r = ratio(&scaled(&log, |l| {
        l.theta.iter_mut().for_each(|x| *x /= deg_per_rad)
    }));
    assert!((1.0 / 170.0..1.0 / 19.0).contains(&r), "{r}");
    // N m read as mN m, and mN m as N m.
    let r = ratio(&scaled(&log, |l| {
        l.torque.iter_mut().for_each(|x| *x *= 1e-3)
    }));
    assert!((300.0..3000.0).contains(&r), "{r}");
    let r = ratio(&scaled(&log, |l| {
        l.torque.iter_mut().for_each(|x| *x *= 1e3)
    }));
    assert!((1.0 / 3000.0..1.0 / 300.0).contains(&r), "{r}");
    // The torque with the other sign.
    let flipped = scaled(&log, |l| l.torque.iter_mut().for_each(|x| *x = -*x));
    assert!(
        matches!(unit_mistake(&flipped, &al), Some(UnitMistake::TorqueSign { correlation }) if correlation < -0.2),
        "{:?}",
        unit_mistake(&flipped, &al)
    );
    // Seconds read as milliseconds, and milliseconds as seconds.
    for f in [1e-3, 1e3] {
        let l = scaled(&log, |l| l.t.iter_mut().for_each(|x| *x *= f));
        assert!(
            matches!(
                unit_mistake(&l, &al),
                Some(UnitMistake::SamplePeriod { .. })
            ),
            "{f}"
        );
    }
    // Microstrain read as strain.
    let l = scaled(&log, |l| l.beam_signal.iter_mut().for_each(|x| *x *= 1e6));
    assert!(matches!(
        unit_mistake(&l, &al),
        Some(UnitMistake::BeamSignal { .. })
    ));
    // Each says what to map.
    let text = unit_mistake(
        &scaled(&log, |l| l.theta.iter_mut().for_each(|x| *x *= deg_per_rad)),
        &al,
    )
    .unwrap()
    .to_string();
    assert!(text.contains("theta=COLUMN:deg"), "{text}");
}

#[test]
fn calibrate_refuses_a_misread_column_naming_the_unit() {
    // The angle column, in radians, mapped as degrees: refused before any fit, by its name.
    let dir = common::scratch("units");
    let file = dir.join("slew.csv");
    std::fs::write(&file, csv_of(BeamParams::aluminium(), 90.0, 0.4)).unwrap();
    let out = common::beam(&[
        "calibrate",
        file.to_str().unwrap(),
        "--columns",
        "theta=theta_rad:deg",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("radians read as degrees") && err.contains("theta=COLUMN:rad"),
        "{err}"
    );
}
