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
//! [`beam_drive::drive::Drive::tick`]), poll the buttons, feed the watchdog, queue telemetry.
//! Nothing in it blocks, allocates or logs. A full queue drops the sample (the tick numbers
//! in the log show the gap), never the tick.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use crate::board::{self, Board, BoardDrive, BoardOperator};
    use beam_drive::drive::Telemetry;
    use beam_drive::link::Link;
    use beam_wire::command::{Outcome, Record, Refusal, Reply};
    use heapless::spsc::{Consumer, Producer, Queue};
    use stm32f4xx_hal::pac::Interrupt;
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::serial::{Rx1, RxISR, Tx1, TxISR, TxListen};
    use stm32f4xx_hal::timer::{CounterHz, Flag};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    /// Telemetry samples buffered between the tick and `idle` (one slot stays empty).
    const TELEMETRY_SLOTS: usize = 64;
    /// The link's transmit ring, bytes (about 25 record frames).
    const LINK_TX: usize = 1024;
    /// How far ahead of the tick a stop is cut, s: room for planning it in `idle` (it is
    /// planned again from a fresh snapshot if the move has passed this point meanwhile).
    const STOP_LEAD_S: f32 = 0.005;

    #[shared]
    struct Shared {
        /// Owned by the tick (the highest priority, so its lock costs nothing); `idle` locks
        /// it only to copy a snapshot and to swap in a prepared move (microseconds).
        drive: BoardDrive,
        link: Link<LINK_TX>,
    }

    #[local]
    struct Local {
        operator: BoardOperator,
        loop_timer: CounterHz<stm32f4xx_hal::pac::TIM2>,
        watchdog: IndependentWatchdog,
        link_tx: Tx1,
        link_rx: Rx1,
        commander: firmware::BoardCommander,
        telemetry_in: Producer<'static, Telemetry, TELEMETRY_SLOTS>,
        telemetry_out: Consumer<'static, Telemetry, TELEMETRY_SLOTS>,
    }

    #[init(local = [queue: Queue<Telemetry, TELEMETRY_SLOTS> = Queue::new()])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let board = match board::init(cx.device, cx.core) {
            Ok(b) => b,
            Err(e) => crate::halt(e),
        };
        if !board.crystal {
            defmt::error!("the crystal did not start: on the internal oscillator, torque refused (clock fault)");
        }
        defmt::info!(
            "drive up: {} Hz loop, gains `{}` at {} kg, commands at {} baud",
            board::LOOP_HZ,
            firmware::CONTROLLER.name(),
            firmware::PAYLOAD_KG,
            beam_drive::link::BAUD
        );
        let Board {
            drive,
            operator,
            loop_timer,
            watchdog,
            link_tx,
            link_rx,
            commander,
            crystal: _,
        } = board;
        let (telemetry_in, telemetry_out) = cx.local.queue.split();
        (
            Shared {
                drive,
                link: Link::new(),
            },
            Local {
                operator,
                loop_timer,
                watchdog,
                link_tx,
                link_rx,
                commander,
                telemetry_in,
                telemetry_out,
            },
        )
    }

    #[task(binds = TIM2, priority = 3, shared = [drive], local = [operator, loop_timer, watchdog, telemetry_in])]
    fn tick(mut cx: tick::Context) {
        cx.local.loop_timer.clear_flags(Flag::Update);
        let operator = cx.local.operator;
        let t = cx.shared.drive.lock(|drive| {
            let t = drive.tick_in::<{ firmware::LAWS }>();
            if let Some(command) = operator.poll(t.theta_rad) {
                // A refused command (busy, faulted) changes nothing; the telemetry shows why.
                let _ = drive.command(command);
            }
            t
        });
        cx.local.watchdog.feed();
        let _ = cx.local.telemetry_in.enqueue(t);
    }

    /// The link's bytes, both ways, below the tick and above `idle`.
    #[task(binds = USART1, priority = 2, shared = [link], local = [link_tx, link_rx])]
    fn link_bytes(mut cx: link_bytes::Context) {
        let (rx, tx) = (cx.local.link_rx, cx.local.link_tx);
        cx.shared.link.lock(|link| {
            while rx.is_rx_not_empty() {
                match rx.read() {
                    Ok(b) => link.receive_byte(b),
                    // Overrun, noise, framing: the frame it was in fails its CRC.
                    Err(_) => link.receive_byte(0),
                }
            }
            board::clear_link_overrun();
            while tx.is_tx_empty() {
                match link.next_tx_byte() {
                    Some(b) => {
                        let _ = tx.write(b);
                    }
                    None => break,
                }
            }
            if link.tx_pending() > 0 {
                tx.listen();
            } else {
                tx.unlisten();
            }
        });
    }

    /// Telemetry to defmt and, when streaming, to the link; commands prepared here (the
    /// planning) and swapped into the drive under a short lock.
    #[idle(shared = [drive, link], local = [telemetry_out, commander])]
    fn idle(mut cx: idle::Context) -> ! {
        let commander = cx.local.commander;
        loop {
            if let Some(t) = cx.local.telemetry_out.dequeue() {
                t.log();
                let every = commander.stream_every() as u32;
                if every > 0 && t.tick % every == 0 {
                    let record = Record {
                        tick: t.tick,
                        torque_nm: t.torque_nm,
                        theta_rad: t.theta_rad,
                        theta_ref_rad: t.theta_ref_rad,
                        strain: t.strain,
                        mode: t.mode as u8,
                        faults: t.faults.0,
                        dropped: 0,
                    };
                    cx.shared.link.lock(|link| link.record(&record));
                    rtic::pend(Interrupt::USART1);
                }
            }
            let Some(request) = cx.shared.link.lock(|link| link.next_request()) else {
                continue;
            };
            let mut outcome = Err(Refusal::Busy);
            // A stop is cut a little ahead of the tick; if planning took longer than that,
            // it is planned again from a fresh snapshot.
            for _ in 0..3 {
                let mut snap = cx.shared.drive.lock(|drive| drive.snapshot());
                snap.move_elapsed_s += STOP_LEAD_S;
                outcome = commander
                    .prepare(&request.command, &snap)
                    .and_then(|action| {
                        cx.shared.drive.lock(|drive| drive.apply(commander, action))
                    });
                if outcome != Err(Refusal::Busy) {
                    break;
                }
            }
            let reply = Reply {
                seq: request.seq,
                outcome: outcome.unwrap_or_else(Outcome::Refused),
            };
            cx.shared.link.lock(|link| link.reply(&reply));
            rtic::pend(Interrupt::USART1);
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

/// Torque off first, then the report, then a system reset request. Interrupts are masked, so
/// the tick (which feeds the watchdog) no longer runs whichever context panicked (the tick,
/// the link's interrupt or `idle`): should the reset request not take, the watchdog resets
/// the MCU. Either way it comes back idle with torque off. (QEMU models the reset request,
/// not the watchdog.)
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    board::safe_state();
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        // The location only: formatting the message would link core::fmt's float printing
        // (about 10 KiB) for a path that should never run.
        match info.location() {
            Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
            None => defmt::error!("panic"),
        }
    }
    cortex_m::peripheral::SCB::sys_reset();
}

/// As the panic handler: torque off, then where it happened.
#[cfg(target_os = "none")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board::safe_state();
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    }
    cortex_m::peripheral::SCB::sys_reset();
}

#[cfg(target_os = "none")]
use defmt_rtt as _;

/// On the host this crate is only type-checked; the firmware is built with `cargo fw`.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the firmware runs on thumbv7em-none-eabihf: build it with `cargo fw`");
    std::process::exit(2);
}
