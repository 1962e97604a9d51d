//! The processor-in-the-loop drive with the observer laws (lqg, smc-modal) as well: the same
//! drive as the `pil` binary (`../drive.rs`), built with the firmware's `observer` feature by
//! `cargo pil-fw-observer`. Its own binary, so that the `pil` binary stays the board's build
//! of the other laws (the observer feature changes how their tick is inlined, and so its
//! instruction count) and the board's flash has no room for the observer laws.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[path = "../drive.rs"]
mod drive;

/// On the host this binary is only type-checked; build it with `cargo pil-fw-observer`.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the PIL drive runs under QEMU: build it with `cargo pil-fw-observer`, run it with \
         `beam pil --controller lqg`"
    );
    std::process::exit(2);
}
