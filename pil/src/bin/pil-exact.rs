//! The processor-in-the-loop drive of a table that asks for exact moves (`[drive]
//! exact_moves = true`): the same drive as the `pil` binary (`../drive.rs`), built with the
//! firmware's `exact` feature, whose observer laws plan their shortest moves to a target to
//! leave their reference beams at rest (model-core's `planner::exact`). Built by the PIL
//! tests from such a table:
//! `BEAM_GAIN_TABLE=T cargo build -p pil --bin pil-exact --features exact --release --target
//! thumbv7em-none-eabihf`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[path = "../drive.rs"]
mod drive;

/// On the host this binary is only type-checked; build it as above.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the PIL drive runs under QEMU: build it with `cargo build -p pil --bin pil-exact \
         --features exact --release --target thumbv7em-none-eabihf` from a table that asks \
         for exact moves"
    );
    std::process::exit(2);
}
