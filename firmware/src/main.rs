//! Motor-drive firmware for the STM32F405RG: the board, the 1 kHz loop and the fault handlers.
//!
//! Scheduling is RTIC 2. The tick is a hardware task bound to TIM2's update interrupt at the
//! highest priority; telemetry goes through a lock-free single-producer single-consumer queue
//! to `idle`, the lowest priority, which writes it to defmt over RTT. RTIC rather than a
//! hand-rolled critical-section mutex because its resources are checked at compile time: the
//! tick owns the drive outright (no lock, no `RefCell`, no `Option` to unwrap on the hot path)
//! and the queue halves get their `'static` lifetime without `unsafe`.
//!
//! Each tick: clear the timer flag, read sensors, `step`, write torque (all in
//! [`firmware::drive::Drive::tick`]), poll the buttons, feed the watchdog, queue telemetry.
//! Nothing in it blocks, allocates or logs. A full queue drops the sample (the tick numbers
//! in the log show the gap), never the tick.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use crate::board::{self, Board};
    use firmware::drive::Telemetry;
    use heapless::spsc::{Consumer, Producer, Queue};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::timer::Flag;

    /// Telemetry samples buffered between the tick and `idle` (one slot stays empty).
    const TELEMETRY_SLOTS: usize = 64;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        board: Board,
        telemetry_in: Producer<'static, Telemetry, TELEMETRY_SLOTS>,
        telemetry_out: Consumer<'static, Telemetry, TELEMETRY_SLOTS>,
    }

    #[init(local = [queue: Queue<Telemetry, TELEMETRY_SLOTS> = Queue::new()])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let board = match board::init(cx.device, cx.core) {
            Ok(b) => b,
            Err(e) => crate::halt(e),
        };
        defmt::info!(
            "drive up: {} Hz loop, gains `{}` at {} kg",
            board::LOOP_HZ,
            firmware::config::CONTROLLER.name(),
            firmware::config::PAYLOAD_KG
        );
        let (telemetry_in, telemetry_out) = cx.local.queue.split();
        (
            Shared {},
            Local {
                board,
                telemetry_in,
                telemetry_out,
            },
        )
    }

    #[task(binds = TIM2, priority = 2, local = [board, telemetry_in])]
    fn tick(cx: tick::Context) {
        let b = cx.local.board;
        b.loop_timer.clear_flags(Flag::Update);
        let t = b.drive.tick();
        if let Some(command) = b.operator.poll(t.theta_rad) {
            // A refused command (busy, faulted) changes nothing; the telemetry shows why.
            let _ = b.drive.command(command);
        }
        b.watchdog.feed();
        let _ = cx.local.telemetry_in.enqueue(t);
    }

    #[idle(local = [telemetry_out])]
    fn idle(cx: idle::Context) -> ! {
        loop {
            if let Some(t) = cx.local.telemetry_out.dequeue() {
                t.log();
            }
        }
    }
}

/// Bring-up failed: torque stays off, the reason goes out once, and the drive waits (the
/// watchdog is not running yet, so it waits for a power cycle, not a reset loop).
#[cfg(target_os = "none")]
fn halt(e: board::BringUpError) -> ! {
    board::safe_state();
    defmt::error!("bring-up failed: {}", e);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Set by the first panic: a panic while reporting one (a re-entered logger) must not recurse.
#[cfg(target_os = "none")]
static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// Torque off first, then the report. The watchdog, no longer fed, then resets the MCU,
/// which comes back idle with torque off.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    board::safe_state();
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        // The location only: formatting the message would link core::fmt's float printing
        // (about 10 KiB) for a path that should never run.
        match info.location() {
            Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
            None => defmt::error!("panic"),
        }
    }
    loop {
        core::hint::spin_loop();
    }
}

/// As the panic handler: torque off, then where it happened.
#[cfg(target_os = "none")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board::safe_state();
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    }
    loop {
        core::hint::spin_loop();
    }
}

#[cfg(target_os = "none")]
use defmt_rtt as _;

/// On the host this crate is only type-checked; the firmware is built with `cargo fw`.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the firmware runs on thumbv7em-none-eabihf: build it with `cargo fw`");
    std::process::exit(2);
}
