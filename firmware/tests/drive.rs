//! The drive's tick against fake hardware: a wrapping 16-bit encoder counter, a bridge
//! converter that can stop or fail, an amplifier whose pins record what they were told.
//!
//! These check the firmware's glue (what reaches `step`, what reaches the pins), not the
//! control law, which model-core and host-tests cover.

use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use embedded_hal::spi::{ErrorType as SpiErrorType, Operation, SpiDevice};
use firmware::ads1220::{code_from_bytes, Ads1220};
use firmware::amplifier::{Amplifier, TorqueScale};
use firmware::config::{build_controller, sequence, MOVE_KNOTS};
use firmware::drive::{Command, Drive, QuadratureCounter, Telemetry, MAX_STALE_TICKS};
use model_core::{CommandError, FaultFlags, Mode};
use std::cell::Cell;
use std::convert::Infallible;
use std::rc::Rc;

/// Everything the fakes share with the test.
#[derive(Default)]
struct Bench {
    counter: Cell<u16>,
    code: Cell<i32>,
    converting: Cell<bool>,
    spi_broken: Cell<bool>,
    amp_fault_low: Cell<bool>,
    duty: Cell<u16>,
    dir_high: Cell<bool>,
    en_high: Cell<bool>,
}

struct Counter(Rc<Bench>);
impl QuadratureCounter for Counter {
    fn count(&mut self) -> u32 {
        self.0.counter.get() as u32
    }
}

struct Bus(Rc<Bench>);
#[derive(Debug)]
struct BusError;
impl embedded_hal::spi::Error for BusError {
    fn kind(&self) -> embedded_hal::spi::ErrorKind {
        embedded_hal::spi::ErrorKind::Other
    }
}
impl SpiErrorType for Bus {
    type Error = BusError;
}
impl SpiDevice for Bus {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), BusError> {
        if self.0.spi_broken.get() {
            return Err(BusError);
        }
        for op in ops {
            if let Operation::Read(buf) = op {
                let b = self.0.code.get().to_be_bytes();
                buf.copy_from_slice(&b[1..4]);
            }
        }
        Ok(())
    }
}

/// DRDY: low (data ready) while the converter converts.
struct DataReady(Rc<Bench>);
impl PinErrorType for DataReady {
    type Error = Infallible;
}
impl InputPin for DataReady {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.converting.get())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.converting.get())
    }
}

struct FaultLine(Rc<Bench>);
impl PinErrorType for FaultLine {
    type Error = Infallible;
}
impl InputPin for FaultLine {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.amp_fault_low.get())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.amp_fault_low.get())
    }
}

struct Pwm(Rc<Bench>);
impl PwmErrorType for Pwm {
    type Error = Infallible;
}
impl SetDutyCycle for Pwm {
    fn max_duty_cycle(&self) -> u16 {
        8400
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0.duty.set(duty);
        Ok(())
    }
}

struct Out(Rc<Bench>, fn(&Bench) -> &Cell<bool>);
impl PinErrorType for Out {
    type Error = Infallible;
}
impl OutputPin for Out {
    fn set_low(&mut self) -> Result<(), Infallible> {
        (self.1)(&self.0).set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        (self.1)(&self.0).set(true);
        Ok(())
    }
}

type TestDrive = Drive<MOVE_KNOTS, Counter, Bus, DataReady, Pwm, Out, Out, FaultLine>;

fn drive() -> (TestDrive, Rc<Bench>) {
    let b = Rc::new(Bench::default());
    b.converting.set(true);
    // Fault line released (pulled high), amplifier enabled as soon as something tries.
    let adc = Ads1220::new(Bus(b.clone()), DataReady(b.clone()));
    let amp = Amplifier::new(
        Pwm(b.clone()),
        Out(b.clone(), |b| &b.dir_high),
        Out(b.clone(), |b| &b.en_high),
        TorqueScale {
            full_scale_nm: 10.0,
        },
    )
    .unwrap();
    let d = Drive::new(
        build_controller().unwrap(),
        Counter(b.clone()),
        adc,
        amp,
        FaultLine(b.clone()),
    );
    (d, b)
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
    // from it and the controller pushes, positive, within the first few ticks.
    let mut pushed = false;
    for _ in 0..50 {
        let t = d.tick();
        assert_eq!(t.mode, Mode::Slewing);
        assert!(b.en_high.get());
        let expected = (t.torque_nm.abs() / 10.0 * 8400.0).round() as u16;
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
        b.counter.set(b.counter.get().wrapping_sub(40));
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
    b.spi_broken.set(true);
    let t = run(&mut d, 1);
    assert_eq!(t.mode, Mode::Fault);
    assert!(t.faults.contains(FaultFlags::DRIVER));
}

#[test]
fn the_amplifier_fault_line_turns_the_torque_off_in_the_same_tick() {
    let (mut d, b) = drive();
    run(&mut d, 10);
    let [out, _] = sequence().unwrap();
    d.command(Command::Move(out)).unwrap();
    run(&mut d, 30);
    assert!(b.en_high.get());
    b.amp_fault_low.set(true);
    let t = run(&mut d, 1);
    assert_eq!((t.mode, t.torque_nm), (Mode::Fault, 0.0));
    assert!(t.faults.contains(FaultFlags::AMP_FAULT));
    assert!(!b.en_high.get());
}

#[test]
fn the_strain_code_reaches_the_controller_sign_extended() {
    let (mut d, b) = drive();
    b.code.set(-1234);
    let t = run(&mut d, 1);
    assert_eq!(t.strain_code, -1234);
    assert_eq!(code_from_bytes([0xFF, 0xFB, 0x2E]), -1234);
}

/// The fuzz corpus's seed frames were written by an independent Python encoder
/// (`zlib.crc32`, hand-rolled COBS and postcard varints): the Rust decoder must read them,
/// which pins the wire format to its description rather than to itself.
#[test]
fn frames_from_an_independent_encoder_decode() {
    use beam_wire::{decode, DriveMessage, FrameReader, HostMessage, SensorFrame};
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/seeds/pil_frame/");
    let read = |name: &str| std::fs::read(format!("{dir}{name}")).unwrap();
    let frames = |bytes: Vec<u8>| {
        let mut r = FrameReader::new();
        bytes
            .into_iter()
            .filter_map(|b| r.push(b).map(|f| f.unwrap().to_vec()))
            .collect::<Vec<_>>()
    };
    let host: Vec<HostMessage> = frames(read("setup_sensors_stop"))
        .into_iter()
        .map(|mut f| decode(&mut f).unwrap())
        .collect();
    assert_eq!(
        host,
        [
            HostMessage::Setup {
                controller: model_core::LawKind::Smc,
                payload_kg: 0.0
            },
            HostMessage::Sensors(SensorFrame {
                seq: 0,
                encoder_raw: 0,
                strain_code: 1234,
                amp_fault: false,
                start: false
            }),
            HostMessage::Sensors(SensorFrame {
                seq: 1,
                encoder_raw: 65535,
                strain_code: -8_388_608,
                amp_fault: true,
                start: true
            }),
            HostMessage::Stop,
        ]
    );
    let mut cmd = frames(read("command")).remove(0);
    match decode::<DriveMessage>(&mut cmd).unwrap() {
        DriveMessage::Command(c) => {
            assert_eq!((c.seq, c.torque_nm, c.mode, c.faults), (7, 1.5, 1, 0));
            assert_eq!(c.theta_rad, -1.5707964);
        }
        other => panic!("{other:?}"),
    }
}
