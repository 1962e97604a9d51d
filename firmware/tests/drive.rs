//! The drive's tick against fake hardware: a wrapping 16-bit encoder counter, a bridge
//! converter that can stop or fail, an amplifier whose pins record what they were told.
//!
//! These check the firmware's glue (what reaches `step`, what reaches the pins), not the
//! control law, which model-core and beam-sim cover.

use beam_drive::ads1220::{code_from_bytes, Ads1220};
use beam_drive::amplifier::{Amplifier, TorqueScale};
use beam_drive::config::MOVE_KNOTS;
use beam_drive::drive::{Command, Drive, Telemetry, MAX_STALE_TICKS};
use beam_drive::fakes::{Bench, Bus, Counter, DataReady, Direction, Enable, Line, Pwm, MAX_DUTY};
use firmware::{build_controller, sequence};
use model_core::{CommandError, FaultFlags, Mode};

type TestDrive = Drive<
    MOVE_KNOTS,
    Counter<'static>,
    Ads1220<Bus<'static>, DataReady<'static>>,
    Amplifier<Pwm<'static>, Direction<'static>, Enable<'static>, Line<'static>>,
>;

/// A drive on a fresh bench (leaked: each test's bench lives as long as the test process).
fn drive() -> (TestDrive, &'static Bench) {
    let b: &'static Bench = Box::leak(Box::default());
    b.converting.set(true);
    // A live bridge: its code moves with its noise every conversion.
    b.noisy.set(true);
    let adc = Ads1220::new(Bus(b), DataReady(b));
    let amp = Amplifier::<_, _, _, _, false>::new(
        Pwm(b),
        Direction(b),
        Enable(b),
        Line(b),
        TorqueScale {
            full_scale_nm: 10.0,
        },
    )
    .unwrap();
    (
        Drive::new(build_controller().unwrap(), Counter(b), adc, amp),
        b,
    )
}

fn run(d: &mut TestDrive, ticks: usize) -> Telemetry {
    (0..ticks).map(|_| d.tick()).last().unwrap()
}

#[test]
fn powers_up_idle_with_the_amplifier_off() {
    let (mut d, b) = drive();
    let t = run(&mut d, 50);
    assert_eq!((t.mode, t.torque_nm, t.tick), (Mode::Idle, 0.0, 49));
    assert!(!b.en_high.get());
    assert_eq!(b.duty.get(), 0);
}

#[test]
fn a_move_enables_the_amplifier_and_the_duty_follows_the_torque() {
    let (mut d, b) = drive();
    run(&mut d, 10);
    let [out, _] = sequence().unwrap();
    d.command(Command::Move(out)).unwrap();
    // The hub is held at the start (the counter does not move): the reference runs away
    // from it and the controller pushes, positive, within the first few ticks (and before
    // the stall watch, STALL_TICKS without a count, takes it for a blocked hub).
    let mut pushed = false;
    for _ in 0..model_core::controller::STALL_TICKS {
        let t = d.tick();
        assert_eq!(t.mode, Mode::Slewing);
        assert!(b.en_high.get());
        let expected = (t.torque_nm.abs() / 10.0 * MAX_DUTY as f32).round() as u16;
        assert_eq!(b.duty.get(), expected);
        if t.torque_nm > 0.1 {
            pushed = true;
            assert!(b.dir_high.get());
        }
    }
    assert!(pushed);
}

#[test]
fn the_encoder_wraps_through_zero_without_a_jump() {
    let (mut d, b) = drive();
    // Turn backwards from 0 through the 16-bit wrap, 40 counts a tick (0.9 deg/ms, well
    // under the 50 rad/s limit), for 100 ticks: 4000 counts back. The first tick's count is
    // the home position.
    run(&mut d, 1);
    for _ in 0..100 {
        b.encoder_raw
            .set(b.encoder_raw.get().wrapping_sub(40) & 0xFFFF);
        let t = d.tick();
        assert_eq!(t.faults, FaultFlags::default());
    }
    let t = run(&mut d, 1);
    let rad_per_count = std::f32::consts::TAU / 16384.0;
    let expected = -std::f32::consts::FRAC_PI_2 - 4000.0 * rad_per_count;
    assert!(
        (t.theta_rad - expected).abs() < 1e-5,
        "{} vs {expected}",
        t.theta_rad
    );
    assert_eq!(t.encoder_raw, 65536 - 4000);
}

#[test]
fn a_converter_that_stops_latches_a_driver_fault_and_only_clear_fault_clears_it() {
    let (mut d, b) = drive();
    run(&mut d, 10);
    let [out, _] = sequence().unwrap();
    d.command(Command::Move(out.clone())).unwrap();
    run(&mut d, 5);
    assert!(b.en_high.get());
    b.converting.set(false);
    // The tolerated misses pass, the next one trips.
    for i in 1..=MAX_STALE_TICKS + 1 {
        let t = d.tick();
        let tripped = i > MAX_STALE_TICKS;
        assert_eq!(t.mode == Mode::Fault, tripped, "stale tick {i}");
    }
    assert!(d.controller().faults().contains(FaultFlags::DRIVER));
    assert!(!b.en_high.get());
    assert_eq!(b.duty.get(), 0);
    // Data coming back does not clear it; a move is refused; clear-fault does.
    b.converting.set(true);
    assert_eq!(run(&mut d, 20).mode, Mode::Fault);
    assert_eq!(
        d.command(Command::Move(out.clone())),
        Err(CommandError::Faulted)
    );
    d.command(Command::ClearFault).unwrap();
    assert_eq!(run(&mut d, 1).mode, Mode::Idle);
}

#[test]
fn a_bus_error_latches_a_driver_fault_at_once() {
    let (mut d, b) = drive();
    run(&mut d, 10);
    b.bus_broken.set(true);
    let t = run(&mut d, 1);
    assert_eq!(t.mode, Mode::Fault);
    assert!(t.faults.contains(FaultFlags::DRIVER));
}

#[test]
fn the_amplifier_fault_line_turns_the_torque_off_in_the_same_tick() {
    let (mut d, b) = slewing();
    b.amp_fault.set(true);
    let t = run(&mut d, 1);
    assert_eq!((t.mode, t.torque_nm), (Mode::Fault, 0.0));
    assert!(t.faults.contains(FaultFlags::AMP_FAULT));
    assert!(!b.en_high.get());
}

#[test]
fn an_amplifier_pin_that_cannot_be_set_latches_a_driver_fault_with_the_torque_off() {
    let (mut d, b) = slewing();
    b.outputs_broken.set(true);
    // The failing write is found after `step`: the torque is reported as zero at once, and
    // the next tick latches the fault.
    let t = run(&mut d, 1);
    assert_eq!((t.mode, t.torque_nm), (Mode::Slewing, 0.0));
    // A transient failure still latches: with the pins back, the fault stays until cleared
    // and the amplifier is disabled.
    b.outputs_broken.set(false);
    let t = run(&mut d, 1);
    assert_eq!(t.mode, Mode::Fault);
    assert!(t.faults.contains(FaultFlags::DRIVER), "{:?}", t.faults);
    assert!(!b.en_high.get());
}

#[test]
fn the_strain_code_reaches_the_controller_sign_extended() {
    let (mut d, b) = drive();
    b.noisy.set(false);
    b.strain_code.set(-1234);
    let t = run(&mut d, 1);
    assert_eq!(t.strain_code, -1234);
    assert_eq!(code_from_bytes([0xFF, 0xFB, 0x2E]), -1234);
}

/// A drive in the middle of its compiled-in move, the amplifier enabled.
fn slewing() -> (TestDrive, &'static Bench) {
    let (mut d, b) = drive();
    run(&mut d, 10);
    let [out, _] = sequence().unwrap();
    d.command(Command::Move(out)).unwrap();
    run(&mut d, 30);
    assert!(b.en_high.get());
    assert_eq!(d.controller().mode(), Mode::Slewing);
    (d, b)
}

#[test]
fn a_bus_error_mid_move_disables_the_amplifier_in_the_same_tick() {
    let (mut d, b) = slewing();
    b.bus_broken.set(true);
    let t = run(&mut d, 1);
    assert_eq!((t.mode, t.torque_nm), (Mode::Fault, 0.0));
    assert!(t.faults.contains(FaultFlags::DRIVER));
    assert!(!b.en_high.get());
    assert_eq!(b.duty.get(), 0);
}

#[test]
fn a_bridge_at_either_rail_mid_move_latches_adc_rail_and_the_drives_own_law_drives_on() {
    // The ADS1220's 24-bit codes run from -2^23 to 2^23 - 1; a code at either end is a
    // saturated or disconnected bridge. The fault latches in the tick; the move goes on, on
    // the drive's own law (encoder only), with the amplifier on.
    for rail in [-(1 << 23), (1 << 23) - 1] {
        let (mut d, b) = slewing();
        b.strain_code.set(rail);
        let t = run(&mut d, 1);
        assert_eq!(t.mode, Mode::Slewing, "code {rail}");
        assert!(
            t.faults.contains(FaultFlags::ADC_RAIL),
            "code {rail}: {:?}",
            t.faults
        );
        assert!(b.en_high.get());
        // And stays so (for a few ticks: this bench's hub does not follow the move, which
        // the stall watch would take for a stuck encoder after STALL_TICKS).
        let t = run(&mut d, 5);
        assert!(t.faults.contains(FaultFlags::ADC_RAIL), "{:?}", t.faults);
        assert!(t.mode != Mode::Fault && t.torque_nm.abs() <= 10.0);
    }
}

#[test]
fn a_faulted_drive_keeps_the_amplifier_off_until_cleared_and_moved_again() {
    let (mut d, b) = slewing();
    b.amp_fault.set(true);
    run(&mut d, 1);
    b.amp_fault.set(false);
    // Faulted: however the hub and the bridge read, no tick enables the amplifier or sets a
    // duty, and a move is refused.
    for k in 0..200u32 {
        b.encoder_raw
            .set((b.encoder_raw.get() + 3 * (k % 5)) & 0xFFFF);
        let t = d.tick();
        assert_eq!((t.mode, t.torque_nm), (Mode::Fault, 0.0));
        assert!(!b.en_high.get());
        assert_eq!(b.duty.get(), 0);
    }
    let [out, _] = sequence().unwrap();
    assert_eq!(d.command(Command::Move(out)), Err(CommandError::Faulted));
    // Cleared: idle, still off.
    d.command(Command::ClearFault).unwrap();
    let t = run(&mut d, 5);
    assert_eq!((t.mode, t.torque_nm), (Mode::Idle, 0.0));
    assert!(!b.en_high.get());
}
