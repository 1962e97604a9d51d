//! The processor-in-the-loop drive: the firmware's own `Drive::tick`, gain table and fault
//! handling, with the STM32F4 peripherals replaced by frames from the host's simulated plant.
//!
//! Runs on QEMU's `netduinoplus2` (an emulated STM32F405). Each tick the host writes one
//! [`SensorFrame`](beam_wire::SensorFrame) to semihosting stdin; the drive hands its
//! encoder count, strain code and fault line to the same generic drivers the board uses, over
//! the fake bus and pins of `beam_drive::fakes` (the ADS1220 driver clocks the code out of a
//! stand-in SPI bus with DRDY always ready), runs
//! `Drive::tick`, and writes one [`CommandFrame`](beam_wire::CommandFrame) back on
//! stdout. The tick is bracketed by `insn_mark_start` / `insn_mark_end` for the
//! instruction-count plugin, and its telemetry goes out through defmt, here a logger on
//! semihosting stderr. No clocks are configured: QEMU has no RCC model, and lockstep with
//! the host replaces the timer.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod drive;

/// On the host this binary is only type-checked; build it with `cargo pil-fw`.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the PIL drive runs under QEMU: build it with `cargo pil-fw`, run it with `beam pil`"
    );
    std::process::exit(2);
}
