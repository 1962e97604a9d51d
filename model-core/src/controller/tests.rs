//! The controller against hand-built raw readings: modes, faults, commands, and properties
//! over any sequence of readings.

use super::*;
use crate::beam::{Beam, BeamParams};
use crate::law::{Law, PdGains, SmcGains, StrainSmcGains, Switching};
use crate::modal::ModalModel;
use proptest::prelude::*;

fn controller(law: Law) -> Controller<4> {
    let m = ModalModel::<2>::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap();
    let law = ControlLaw::try_build(law, &m).unwrap();
    let half_pi = core::f32::consts::FRAC_PI_2;
    Controller::try_build(
        ControllerSettings::new(crate::table::Instruments::DEFAULT),
        law,
        Spline::quintic(-half_pi, half_pi, 0.35).unwrap(),
    )
    .unwrap()
}

const SMC_GAINS: SmcGains = SmcGains {
    w: 30.0,
    a: 20.0,
    beta: 0.3,
    switching: Switching::Tanh,
};
const SMC: Law = Law::Smc(SMC_GAINS);

/// The raw counter of a hub exactly on the move's reference `ticks` ticks in, with a live
/// gauge's code at zero strain ([`live_code`]).
fn on_reference(c: &Controller<4>, ticks: u32) -> RawMeasurement {
    let s = c.settings();
    let theta = c.spline().eval(ticks as f32 * s.ts_s).pos;
    let count = ((theta - s.theta_home_rad) / s.encoder.rad_per_count() as f32).round();
    RawMeasurement {
        encoder_raw: (count as i64 as u32) & s.encoder.mask(),
        strain_root_code: live_code(ticks),
        ..Default::default()
    }
}

/// A live bridge's code at zero strain on tick `k`: a few hundred codes of noise (0.1 ue
/// on the 24-bit converter), so never the same code for long, as a converter that stopped
/// converting reads ([`GAUGE_FROZEN_TICKS`]).
fn live_code(k: u32) -> i32 {
    (k.wrapping_mul(2_654_435_761) >> 24) as i32 - 128
}

#[test]
fn idle_until_started_then_slews_then_holds() {
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    let out = c.step(&on_reference(&c, 0));
    assert_eq!((out.mode, out.torque_nm), (Mode::Idle, 0.0));
    c.start_move().unwrap();
    let out = c.step(&on_reference(&c, 0));
    assert_eq!(out.mode, Mode::Slewing);
    // On the reference at rest at the start: nothing to correct yet.
    assert_eq!(out.torque_nm, 0.0);
    for k in 1..=400 {
        let out = c.step(&on_reference(&c, k));
        assert!(out.faults.is_empty(), "tick {k}: {}", out.faults);
    }
    let out = c.step(&on_reference(&c, 400));
    assert_eq!(out.mode, Mode::Holding);
    // At the end point and at rest (the velocity filter has settled): no torque needed
    // beyond a count's worth of error.
    assert!(out.torque_nm.abs() < 0.01, "{}", out.torque_nm);
    assert_eq!(c.start_move(), Ok(()));
}

#[test]
fn a_hub_that_does_not_move_under_torque_trips_encoder_stuck() {
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    let still = |k: u32| RawMeasurement {
        strain_root_code: live_code(k),
        ..Default::default()
    };
    c.step(&still(0));
    c.start_move().unwrap();
    // The reference runs away from a hub that never moves; once PD's torque passes a
    // fifth of the limit, or the reference moves two counts a tick, STALL_TICKS ticks
    // without a count trip the fault.
    let s = *c.settings();
    let spline = c.spline().clone();
    let outs: Vec<TorqueCommand> = (1..=400).map(|k| c.step(&still(k))).collect();
    let k = outs
        .iter()
        .position(|o| o.mode == Mode::Fault)
        .expect("a hub that never moves must trip");
    assert_eq!(outs[k].faults, FaultFlags::ENCODER_STUCK);
    assert_eq!(outs[k].torque_nm, 0.0);
    // Tick j evaluates the reference at j ts (the start tick at 0).
    let two_counts = 2.0 * s.encoder.rad_per_count() as f32 / s.ts_s;
    let blind = |j: usize| {
        outs[j].torque_nm.abs() >= STALL_TORQUE_FRACTION * 10.0
            || spline.eval(j as f32 * s.ts_s).vel.abs() >= two_counts
    };
    let first = (0..k).find(|&j| blind(j)).unwrap();
    assert_eq!(k, first + STALL_TICKS as usize - 1);
    assert!((first..k).all(blind));
}

#[test]
fn faults_latch_with_torque_off_until_reset() {
    let mut c = controller(SMC);
    c.step(&RawMeasurement::default());
    c.start_move().unwrap();
    c.step(&RawMeasurement::default());
    let out = c.step(&RawMeasurement {
        amp_fault: true,
        ..Default::default()
    });
    assert_eq!((out.mode, out.torque_nm), (Mode::Fault, 0.0));
    assert!(out.faults.contains(FaultFlags::AMP_FAULT));
    // The fault input clearing does not clear the fault.
    let out = c.step(&RawMeasurement::default());
    assert_eq!((out.mode, out.torque_nm), (Mode::Fault, 0.0));
    assert_eq!(c.start_move(), Err(CommandError::Faulted));
    c.reset();
    assert_eq!(c.step(&RawMeasurement::default()).mode, Mode::Idle);
}

#[test]
fn the_next_move_is_swapped_in_between_moves_only() {
    let half_pi = core::f32::consts::FRAC_PI_2;
    let back = Spline::quintic(half_pi, -half_pi, 0.35).unwrap();
    let wrong = Spline::quintic(0.0, half_pi, 0.35).unwrap();
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    c.step(&on_reference(&c, 0));
    c.start_move().unwrap();
    c.step(&on_reference(&c, 0));
    assert_eq!(c.set_spline(back.clone()), Err(CommandError::Busy));
    for k in 1..=400 {
        c.step(&on_reference(&c, k));
    }
    assert_eq!(c.mode(), Mode::Holding);
    // The hub is at +90 deg: the way back starts there and runs.
    let at_end = on_reference(&c, 400);
    c.set_spline(back).unwrap();
    c.start_move().unwrap();
    assert_eq!(c.step(&at_end).mode, Mode::Slewing);
    for k in 1..=400 {
        c.step(&on_reference(&c, k));
    }
    assert_eq!(c.mode(), Mode::Holding);
    // A move that starts at 0 deg is refused at the next tick as a start mismatch.
    let home = on_reference(&c, 400);
    c.set_spline(wrong).unwrap();
    c.start_move().unwrap();
    let out = c.step(&home);
    assert_eq!(out.mode, Mode::Fault);
    assert!(out.faults.contains(FaultFlags::START_MISMATCH));
}

#[test]
fn a_torque_that_overflows_latches_non_finite_with_the_torque_off() {
    let mut c = controller(Law::Pd(PdGains { kp: 3e38, kd: 3e38 }));
    c.step(&on_reference(&c, 0));
    c.start_move().unwrap();
    c.step(&on_reference(&c, 0));
    // One count off the reference: 3e38 * 3.8e-4 is finite, the velocity term is not.
    let out = c.step(&RawMeasurement {
        encoder_raw: 5,
        ..Default::default()
    });
    assert_eq!((out.mode, out.torque_nm), (Mode::Fault, 0.0));
    assert!(
        out.faults.contains(FaultFlags::NON_FINITE),
        "{}",
        out.faults
    );
}

#[test]
fn each_bad_reading_names_its_fault() {
    let cases: [(RawMeasurement, FaultFlags); 4] = [
        (
            RawMeasurement {
                driver_fault: true,
                ..Default::default()
            },
            FaultFlags::DRIVER,
        ),
        (
            RawMeasurement {
                strain_root_code: i32::MAX,
                ..Default::default()
            },
            FaultFlags::ADC_RAIL,
        ),
        (
            RawMeasurement {
                encoder_raw: 5000,
                ..Default::default()
            },
            FaultFlags::ENCODER_JUMP,
        ),
        // 4000 microstrain is past the 3000 limit but inside the ADC's 5000 span.
        (
            RawMeasurement {
                strain_root_code: (4000e-6 / AdcSpec::DEFAULT.strain_per_code()) as i32,
                ..Default::default()
            },
            FaultFlags::OVER_STRAIN,
        ),
    ];
    for (raw, flag) in cases {
        let mut c = controller(SMC);
        c.step(&RawMeasurement::default());
        let out = c.step(&raw);
        assert_eq!(out.mode, Mode::Fault, "{flag}");
        assert!(out.faults.contains(flag), "{} lacks {flag}", out.faults);
    }
}

#[test]
fn a_move_started_away_from_its_start_is_refused() {
    let mut c = controller(SMC);
    c.step(&RawMeasurement::default());
    // Move the hub 100 counts per tick (within the speed limit) to 0.3 rad away.
    let mut raw = 0u32;
    for _ in 0..8 {
        raw += 100;
        c.step(&RawMeasurement {
            encoder_raw: raw,
            ..Default::default()
        });
    }
    c.start_move().unwrap();
    let out = c.step(&RawMeasurement {
        encoder_raw: raw,
        ..Default::default()
    });
    assert!(out.faults.contains(FaultFlags::START_MISMATCH));
    assert_eq!(out.torque_nm, 0.0);
}

#[test]
fn idle_averaging_removes_the_strain_offset() {
    let mut c = controller(SMC);
    for k in 0..100 {
        c.step(&RawMeasurement {
            strain_root_code: 1000 + (k % 2) * 2,
            ..Default::default()
        });
    }
    c.start_move().unwrap();
    let out = c.step(&RawMeasurement {
        strain_root_code: 1001,
        ..Default::default()
    });
    assert_eq!(out.strain, 0.0);
}

#[test]
fn bad_settings_are_named() {
    let m = ModalModel::<1>::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap();
    let law = ControlLaw::try_build(SMC, &m).unwrap();
    let spline = Spline::<2>::quintic(0.0, 1.0, 0.35).unwrap();
    let build = |s| Controller::try_build(s, law, spline.clone()).unwrap_err();
    let named = |e: ConfigError| match e {
        ConfigError::Param(p) => p.field,
    };
    assert_eq!(
        named(build(ControllerSettings {
            ts_s: 0.0,
            ..ControllerSettings::new(crate::table::Instruments::DEFAULT)
        })),
        "ts_s"
    );
    assert_eq!(
        named(build(ControllerSettings {
            max_strain: f32::NAN,
            ..ControllerSettings::new(crate::table::Instruments::DEFAULT)
        })),
        "max_strain"
    );
    assert_eq!(
        named(build(ControllerSettings {
            max_speed_rad_s: 1e6,
            ..ControllerSettings::new(crate::table::Instruments::DEFAULT)
        })),
        "max_speed_rad_s"
    );
}

proptest! {
    /// Whatever the sensors say, tick after tick, the torque is finite and within the
    /// limit, and torque is only applied while slewing or holding.
    #[test]
    fn step_is_total_and_bounded(
        law_pick in 0usize..4,
        starts in prop::collection::vec(any::<bool>(), 1..60),
        raws in prop::collection::vec((
            // Any counter value, or small steps (so the loop actually runs instead of
            // tripping the jump check at once).
            prop_oneof![any::<u32>(), 0u32..200, 65_400u32..65_536],
            // Any code, the 24-bit rails, and codes near zero.
            prop_oneof![any::<i32>(), Just(8_388_607), Just(-8_388_608), -5_000i32..5_000],
            any::<bool>(),
            any::<bool>(),
        ), 1..60),
    ) {
        // The last law overflows f32 on the first error: every torque it computes is
        // non-finite, which must latch NON_FINITE with the torque off.
        let laws = [
            Law::Pd(PdGains::BASELINE),
            SMC,
            Law::SmcStrain(StrainSmcGains { w: SMC_GAINS.w, a: SMC_GAINS.a, beta: SMC_GAINS.beta, c: -50.0, switching: SMC_GAINS.switching, model_terms: true }),
            Law::Pd(PdGains { kp: 3e38, kd: 3e38 }),
        ];
        let mut c = controller(laws[law_pick]);
        for (i, (enc, code, amp, drv)) in raws.into_iter().enumerate() {
            if starts[i % starts.len()] {
                let _ = c.start_move();
            }
            if i % 17 == 16 {
                c.reset();
            }
            let out = c.step(&RawMeasurement { encoder_raw: enc, strain_root_code: code, amp_fault: amp, driver_fault: drv });
            prop_assert!(out.torque_nm.is_finite() && out.torque_nm.abs() <= 10.0);
            if !matches!(out.mode, Mode::Slewing | Mode::Holding) {
                prop_assert_eq!(out.torque_nm, 0.0);
            }
            if out.mode == Mode::Fault {
                prop_assert!(!out.faults.is_empty());
            }
        }
    }
}

#[test]
fn a_hub_leaving_the_range_under_torque_latches_out_of_range_but_not_while_idle() {
    let s = ControllerSettings::new(crate::table::Instruments::DEFAULT);
    let raw_at = |theta: f32| {
        let count = ((theta - s.theta_home_rad) / s.encoder.rad_per_count() as f32).round();
        RawMeasurement {
            encoder_raw: (count as i64 as u32) & s.encoder.mask(),
            strain_root_code: live_code(theta.to_bits()),
            ..Default::default()
        }
    };
    // The move runs -90 to +90 deg; the hub is then pushed on (as by a load) in steps the
    // encoder accepts, up to 200 deg.
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    c.step(&on_reference(&c, 0));
    c.start_move().unwrap();
    for k in 0..=400 {
        c.step(&on_reference(&c, k));
    }
    assert_eq!(c.mode(), Mode::Holding);
    let limit = RANGE_RAD + RANGE_FAULT_MARGIN_RAD;
    let mut theta = core::f32::consts::FRAC_PI_2;
    while theta < 200f32.to_radians() {
        theta += 0.005;
        let out = c.step(&raw_at(theta));
        if theta < limit - 0.01 {
            assert!(
                out.faults.is_empty(),
                "{} deg: {}",
                theta.to_degrees(),
                out.faults
            );
        }
        if theta > limit + 0.01 {
            assert!(
                out.faults.contains(FaultFlags::OUT_OF_RANGE),
                "{}",
                out.faults
            );
            assert_eq!((out.mode, out.torque_nm), (Mode::Fault, 0.0));
        }
    }
    // Idle (torque off), a hub turned far out by hand is no fault.
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    let mut theta = 0.0f32;
    while theta < 400f32.to_radians() {
        theta += 0.005;
        assert!(c.step(&raw_at(theta)).faults.is_empty());
    }
}

#[test]
fn a_move_armed_counts_as_slewing_and_clearing_keeps_the_last_angle() {
    let mut c = controller(Law::Pd(PdGains::BASELINE));
    c.step(&on_reference(&c, 0));
    let theta = c.theta_rad();
    c.start_move().unwrap();
    // Before the next tick: slewing for every command, at the move's start.
    assert_eq!(c.mode(), Mode::Slewing);
    assert_eq!(c.snapshot().mode, Mode::Slewing);
    assert_eq!(c.move_elapsed_s(), 0.0);
    assert_eq!(c.start_move(), Err(CommandError::Busy));
    let rest = Spline::quintic(0.0, 0.0, 1.0).unwrap();
    assert_eq!(c.set_spline(rest), Err(CommandError::Busy));
    // Disabling drops the armed move.
    c.disable();
    assert_eq!(c.mode(), Mode::Idle);
    // A reset keeps the last measured angle (it is -90 deg here, not the zero).
    assert!(theta < -1.5);
    c.reset();
    assert_eq!(c.theta_rad(), theta);
    assert_eq!(c.snapshot().theta_rad, theta);
}

/// The estimate's finite check, by IEEE 754's rules: an infinity or a NaN in the hub rate,
/// the strain or its rate latches NON_FINITE; the largest, smallest and signed-zero finite
/// values do not.
#[test]
fn the_finite_check_flags_every_infinity_and_nan_and_nothing_finite() {
    let c = controller(SMC);
    // A reading with no other fault: mid-range code, no fault lines.
    let raw = RawMeasurement::default();
    let check = |omega: f32, strain: f32, strain_rate: f32| {
        let x = Estimate {
            theta: 0.0,
            omega,
            strain,
            strain_rate,
        };
        c.detect_faults(&raw, &x).contains(FaultFlags::NON_FINITE)
    };
    let finite = [
        0.0,
        -0.0,
        1.0,
        -3.5,
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        1e-45,
    ];
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -f32::NAN];
    for &v in &finite {
        // Strain within the over-strain limit, so that only the finite check can speak.
        assert!(
            !check(v, 0.0, v) && !check(0.0, v.clamp(-1e-3, 1e-3), 0.0),
            "{v}"
        );
    }
    for &b in &bad {
        for &v in &finite {
            assert!(
                check(b, 0.0, v) && check(v, b, 0.0) && check(0.0, 0.0, b),
                "{b} {v}"
            );
        }
    }
    // Two infinities of opposite sign do not cancel.
    assert!(check(f32::INFINITY, 0.0, f32::NEG_INFINITY));
}

proptest! {
    /// The idle codes' mean, in f32 without double precision, is within one f32 step of
    /// the exact quotient (a code of up to 32 bits, summed over up to 2^16 samples).
    #[test]
    fn the_mean_code_is_the_quotient_to_one_f32_step(
        mean in -(1i64 << 31)..(1i64 << 31),
        spread in 0i64..(1i64 << 16),
        n in 1u32..=MAX_ZERO_SAMPLES,
    ) {
        let sum = mean * n as i64 + spread % n as i64;
        let exact = sum as f64 / n as f64;
        let got = mean_code(sum, n) as f64;
        let step = f32::EPSILON as f64 * exact.abs().max(1.0);
        prop_assert!((got - exact).abs() <= step, "{sum} / {n}: {got} against {exact}");
    }
}

#[test]
fn the_mean_code_of_a_few_codes_is_exact() {
    assert_eq!(mean_code(-7, 2), -3.5);
    assert_eq!(mean_code(7, 2), 3.5);
    assert_eq!(mean_code(0, 5), 0.0);
    assert_eq!(mean_code(-1, 4), -0.25);
}

#[test]
fn before_its_first_tick_the_drive_reports_the_hub_at_home() {
    // The counter's origin is where it was powered up, the home angle (-90 deg here): a
    // status or a plan before any tick must see the hub there, not at 0.
    let c = controller(Law::Pd(PdGains::BASELINE));
    let home = c.settings().theta_home_rad;
    assert_eq!(home, -core::f32::consts::FRAC_PI_2);
    assert_eq!(c.snapshot().theta_rad, home);
    assert_eq!(c.theta_rad(), home);
    let mut c = c;
    let out = c.step(&RawMeasurement::default());
    assert_eq!(out.theta_rad, home);
}

/// A move on the reference for `ticks` ticks, the gauge live, then its code frozen.
fn frozen_mid_move(c: &mut Controller<4>, live_ticks: u32) -> Vec<TorqueCommand> {
    c.step(&on_reference(c, 0));
    c.start_move().unwrap();
    for k in 0..live_ticks {
        c.step(&on_reference(c, k));
    }
    let frozen = live_code(live_ticks - 1);
    (live_ticks..400)
        .map(|k| {
            c.step(&RawMeasurement {
                strain_root_code: frozen,
                ..on_reference(c, k)
            })
        })
        .collect()
}

#[test]
fn a_frozen_gauge_latches_gauge_and_the_drives_own_law_finishes_the_move() {
    let mut c = controller(SMC);
    let outs = frozen_mid_move(&mut c, 100);
    // The frozen code was read once live; its GAUGE_FROZEN_TICKS-th repeat latches.
    let k = outs
        .iter()
        .position(|o| !o.faults.is_empty())
        .expect("a frozen gauge must latch");
    assert_eq!(k + 1, GAUGE_FROZEN_TICKS as usize);
    assert_eq!(outs[k].faults, FaultFlags::GAUGE);
    // Not a stop: the move goes on, on the drive's own law, to its end and the hold.
    assert!(outs[k..].iter().all(|o| o.mode != Mode::Fault));
    assert_eq!(c.mode(), Mode::Holding);
    assert!(c.st.braking);
    assert!(outs[k..].iter().any(|o| o.torque_nm != 0.0));
    // Idle, the same code on end is a fault like any other: no torque to hand over.
    let mut c = controller(SMC);
    let outs: Vec<_> = (0..20)
        .map(|_| c.step(&RawMeasurement::default()))
        .collect();
    assert_eq!(outs[GAUGE_FROZEN_TICKS as usize - 1].mode, Mode::Idle);
    assert_eq!(outs[GAUGE_FROZEN_TICKS as usize].mode, Mode::Fault);
    assert_eq!(outs[GAUGE_FROZEN_TICKS as usize].faults, FaultFlags::GAUGE);
}

#[test]
fn a_converter_too_coarse_to_show_noise_is_not_watched_for_frozen_codes() {
    // 12 bits over +-5000 ue: 2.4 ue a code, more than the 0.6 ue of noise the designs assume,
    // so a live bridge may well read one code for long.
    let mut s = ControllerSettings::new(crate::table::Instruments::DEFAULT);
    s.adc.bits = 12;
    let mut c = controller(SMC);
    c = Controller::try_build(s, c.cfg.law, c.spline().clone()).unwrap();
    for _ in 0..1000 {
        assert_eq!(c.step(&RawMeasurement::default()).mode, Mode::Idle);
    }
}

#[test]
fn a_reading_past_the_trip_under_a_moving_hub_hands_the_move_to_the_drives_own_law() {
    // 4000 ue read 100 ticks into the move (a gauge at three times its gain reads a 1300 ue
    // beam so): latched, and the move finishes on the encoder rather than coasting.
    let over = (4000e-6 / AdcSpec::DEFAULT.strain_per_code()) as i32;
    let mut c = controller(SMC);
    c.step(&on_reference(&c, 0));
    c.start_move().unwrap();
    for k in 0..100 {
        c.step(&on_reference(&c, k));
    }
    let out = c.step(&RawMeasurement {
        strain_root_code: over,
        ..on_reference(&c, 100)
    });
    assert_eq!(out.faults, FaultFlags::OVER_STRAIN);
    assert_eq!(out.mode, Mode::Slewing);
    for k in 101..=400 {
        let out = c.step(&on_reference(&c, k));
        assert_eq!(out.faults, FaultFlags::OVER_STRAIN, "tick {k}");
    }
    assert_eq!(c.mode(), Mode::Holding);
    // An encoder fault on top is a stop.
    let out = c.step(&RawMeasurement {
        encoder_raw: 5000,
        ..on_reference(&c, 400)
    });
    assert_eq!((out.mode, out.torque_nm), (Mode::Fault, 0.0));
}
