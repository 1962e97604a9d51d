//! The PIL drive itself, shared by the two PIL binaries (`pil`, and `pil-observer` with the
//! observer laws): see `main.rs`.

use beam_drive::ads1220::Ads1220;
use beam_drive::amplifier::Amplifier;
use beam_drive::config::{
    build_commanded_in, build_controller_in, nearest, sequence_for, MOVE_KNOTS, SLEW_FROM_RAD,
};
use beam_drive::drive::{Command, Drive};
use beam_drive::fakes::{Bench, Bus, Counter, DataReady, Direction, Enable, Line, Pwm};
use beam_wire::{
    decode, encode, CommandFrame, DriveError, DriveMessage, FrameReader, HostMessage, LawKind,
    SensorFrame, MAX_FRAME,
};
use core::cell::UnsafeCell;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use semihosting::io::{Read, Write};
// The PAC's interrupt vector table, which cortex-m-rt's `device` feature expects.
use stm32f4xx_hal as _;

/// Instruction-count markers (counted by `beam-tools/qemu-plugin`): different bodies, so the
/// linker cannot fold them into one address.
#[no_mangle]
#[inline(never)]
pub extern "C" fn insn_mark_start() {
    core::hint::black_box(1u32);
}

/// See [`insn_mark_start`].
#[no_mangle]
#[inline(never)]
pub extern "C" fn insn_mark_end() {
    core::hint::black_box(2u32);
}

struct Link {
    stdin: semihosting::io::Stdin,
    stdout: semihosting::io::Stdout,
    reader: FrameReader,
}

impl Link {
    fn receive(&mut self) -> Result<HostMessage, DriveError> {
        let mut byte = [0u8; 1];
        loop {
            let n = self.stdin.read(&mut byte).map_err(|_| DriveError::Io)?;
            if n == 0 {
                return Err(DriveError::EndOfInput);
            }
            if let Some(frame) = self.reader.push(byte[0]) {
                let frame = frame.map_err(DriveError::Frame)?;
                return decode(frame).map_err(DriveError::Frame);
            }
        }
    }

    fn send(&mut self, msg: &DriveMessage) -> Result<(), DriveError> {
        let mut buf = [0u8; MAX_FRAME + 1];
        let frame = encode(msg, &mut buf).map_err(DriveError::Frame)?;
        self.stdout.write_all(frame).map_err(|_| DriveError::Io)
    }
}

fn run(link: &mut Link) -> Result<(), DriveError> {
    match link.receive()? {
        HostMessage::Setup {
            controller,
            payload_kg,
        } => run_sequence(link, controller, payload_kg),
        HostMessage::SetupCommanded {
            controller,
            payload_kg,
            home_rad,
        } => run_commanded(link, controller, payload_kg, home_rad),
        _ => Err(DriveError::Unexpected),
    }
}

/// The amplifier on the bench's fake pins.
/// The drive on the bench's fakes: the counter, the ADS1220 on the fake bus, the
/// amplifier on the fake pins. The sensor frame is copied into the bench before each
/// tick (a new conversion every tick, as the host's sensor model gives one); the
/// amplifier's outputs go nowhere, the torque travels back in the command frame.
#[allow(clippy::type_complexity)] // the fakes' types, named once here
fn bench_drive(
    controller: model_core::Controller<MOVE_KNOTS>,
    bench: &Bench,
) -> Result<
    Drive<
        MOVE_KNOTS,
        Counter<'_>,
        Ads1220<Bus<'_>, DataReady<'_>>,
        Amplifier<Pwm<'_>, Direction<'_>, Enable<'_>, Line<'_>, { firmware::TORQUE_REVERSED }>,
    >,
    DriveError,
> {
    let amp = Amplifier::new(
        Pwm(bench),
        Direction(bench),
        Enable(bench),
        Line(bench),
        firmware::TORQUE_SCALE,
    )
    .map_err(|_| DriveError::Config)?;
    Ok(Drive::new(
        controller,
        Counter(bench),
        Ads1220::new(Bus(bench), DataReady(bench)),
        amp,
    ))
}

/// Copies one sensor frame into the bench, after checking its sequence number.
fn load(bench: &Bench, sensors: &SensorFrame, expected: u32) -> Result<(), DriveError> {
    if sensors.seq != expected {
        return Err(DriveError::Sequence {
            expected,
            got: sensors.seq,
        });
    }
    bench.encoder_raw.set(sensors.encoder_raw);
    bench.strain_code.set(sensors.strain_code);
    bench.amp_fault.set(sensors.amp_fault);
    Ok(())
}

/// One counted tick, its telemetry logged and its command frame sent.
fn tick_and_send<const K: usize, Q, S, A>(
    link: &mut Link,
    drive: &mut Drive<K, Q, S, A>,
    seq: u32,
) -> Result<f32, DriveError>
where
    Q: beam_drive::drive::QuadratureCounter,
    S: beam_drive::drive::StrainSensor,
    A: beam_drive::drive::Actuator,
{
    insn_mark_start();
    let t = drive.tick_in::<{ firmware::LAWS }>();
    insn_mark_end();
    t.log();
    link.send(&DriveMessage::Command(CommandFrame {
        seq,
        torque_nm: t.torque_nm,
        theta_rad: t.theta_rad,
        strain: t.strain,
        mode: t.mode as u8,
        faults: t.faults.0,
    }))?;
    Ok(t.theta_rad)
}

/// The compiled-in move sequence, started by the START flag of the sensor frames.
fn run_sequence(link: &mut Link, kind: LawKind, payload_kg: f32) -> Result<(), DriveError> {
    let controller =
        build_controller_in::<{ firmware::LAWS }>(&firmware::ALL_LAWS, kind, payload_kg)
            .map_err(|_| DriveError::Config)?;
    let moves =
        sequence_for(&firmware::ALL_LAWS, kind, payload_kg).map_err(|_| DriveError::Config)?;
    let bench = Bench::new();
    let mut drive = bench_drive(controller, &bench)?;
    link.send(&DriveMessage::Ready)?;
    let mut expected = 0u32;
    let mut theta = SLEW_FROM_RAD;
    loop {
        let sensors = match link.receive()? {
            HostMessage::Sensors(s) => s,
            HostMessage::Stop => return Ok(()),
            HostMessage::Setup { .. }
            | HostMessage::SetupCommanded { .. }
            | HostMessage::Command(_) => return Err(DriveError::Unexpected),
        };
        load(&bench, &sensors, expected)?;
        if sensors.start {
            if let Some(m) = nearest(&moves, theta) {
                // Refused (faulted, busy): the command frame's mode and faults say so.
                let _ = drive.command(Command::Move(m.clone()));
            }
        }
        theta = tick_and_send(link, &mut drive, sensors.seq)?;
        expected = expected.wrapping_add(1);
    }
}

/// A drive that takes commands: each is carried out by model-core's handler between
/// ticks and answered at once; moves are planned on the drive.
fn run_commanded(
    link: &mut Link,
    kind: LawKind,
    payload_kg: f32,
    home_rad: f32,
) -> Result<(), DriveError> {
    let (controller, mut commander) =
        build_commanded_in::<{ firmware::LAWS }>(&firmware::ALL_LAWS, kind, payload_kg, home_rad)
            .map_err(|_| DriveError::Config)?;
    let bench = Bench::new();
    let mut drive = bench_drive(controller, &bench)?;
    link.send(&DriveMessage::Ready)?;
    let mut expected = 0u32;
    loop {
        match link.receive()? {
            HostMessage::Sensors(s) => {
                load(&bench, &s, expected)?;
                tick_and_send(link, &mut drive, s.seq)?;
                expected = expected.wrapping_add(1);
            }
            HostMessage::Command(request) => {
                let reply = drive.handle(&mut commander, &request);
                link.send(&DriveMessage::Reply(reply))?;
            }
            HostMessage::Stop => return Ok(()),
            HostMessage::Setup { .. } | HostMessage::SetupCommanded { .. } => {
                return Err(DriveError::Unexpected)
            }
        }
    }
}

#[entry]
fn main() -> ! {
    let (Ok(stdin), Ok(stdout)) = (semihosting::io::stdin(), semihosting::io::stdout()) else {
        semihosting::process::exit(4)
    };
    let mut link = Link {
        stdin,
        stdout,
        reader: FrameReader::new(),
    };
    match run(&mut link) {
        Ok(()) => semihosting::process::exit(0),
        Err(e) => {
            defmt::error!("pil: {}", e);
            // Best effort: the host may already be gone.
            let _ = link.send(&DriveMessage::Error(e));
            semihosting::process::exit(3)
        }
    }
}

/// defmt frames go to semihosting stderr, one write per log call.
#[defmt::global_logger]
struct StderrLogger;

struct LogState {
    taken: bool,
    encoder: defmt::Encoder,
    buf: [u8; 256],
    len: usize,
}

struct LogCell(UnsafeCell<LogState>);
// SAFETY: the PIL drive is single-threaded with no interrupts; `taken` rejects re-entry.
unsafe impl Sync for LogCell {}

static LOG: LogCell = LogCell(UnsafeCell::new(LogState {
    taken: false,
    encoder: defmt::Encoder::new(),
    buf: [0; 256],
    len: 0,
}));

impl LogState {
    /// Runs one encoder step with the frame buffer as its output.
    fn encode(&mut self, step: impl FnOnce(&mut defmt::Encoder, &mut dyn FnMut(&[u8]))) {
        let LogState {
            encoder, buf, len, ..
        } = self;
        let mut sink = |bytes: &[u8]| {
            for &b in bytes {
                if *len < buf.len() {
                    buf[*len] = b;
                    *len += 1;
                }
            }
        };
        step(encoder, &mut sink);
    }
}

// SAFETY: defmt calls acquire, then write and flush, then release, from one context, and
// the PIL drive has no interrupts; a nested acquire (a log inside a log) is dropped.
unsafe impl defmt::Logger for StderrLogger {
    fn acquire() {
        let state = unsafe { &mut *LOG.0.get() };
        if state.taken {
            return;
        }
        state.taken = true;
        state.len = 0;
        state.encode(|e, sink| e.start_frame(sink));
    }

    unsafe fn flush() {}

    unsafe fn release() {
        let state = unsafe { &mut *LOG.0.get() };
        state.encode(|e, sink| e.end_frame(sink));
        if let Ok(mut e) = semihosting::io::stderr() {
            let _ = e.write_all(&state.buf[..state.len]);
        }
        state.taken = false;
    }

    unsafe fn write(bytes: &[u8]) {
        let state = unsafe { &mut *LOG.0.get() };
        state.encode(|e, sink| e.write(bytes, sink));
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    semihosting::process::exit(101)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    semihosting::process::exit(102)
}
