//! The square root, as the drive's FPU takes it.

/// `sqrt(x)`, correctly rounded (IEEE 754's square root, which every implementation must
/// round the same way): on a hard-float ARM target the FPU's `vsqrt.f32`, one instruction;
/// elsewhere libm's. libm has no ARM path and links a software root there (0.5 KB with its
/// table), for the planner's and the plant's few roots. Both give the same bits for every
/// input but NaN's payload, so the drive and the host still agree to the bit.
#[inline]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let root: u32;
        // SAFETY: FPU instructions on registers only: `s0` is saved to the stack and restored
        // around them, and the value goes in and out through core registers (Rust names no
        // FPU register class on this target without the unstable `vfp2` feature). No memory
        // Rust can see is read or written; the hard-float ABI guarantees the FPU is there
        // and enabled.
        #[allow(unsafe_code)]
        unsafe {
            core::arch::asm!(
                "vpush {{s0}}",
                "vmov s0, {x}",
                "vsqrt.f32 s0, s0",
                "vmov {root}, s0",
                "vpop {{s0}}",
                x = in(reg) x.to_bits(),
                root = lateout(reg) root,
                options(pure, nomem, preserves_flags)
            );
        }
        f32::from_bits(root)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

#[cfg(test)]
mod tests {
    use super::sqrtf;

    /// On the host this is libm's root, against `f64`'s root rounded once: exact squares,
    /// the ends of the range and the planner's usual magnitudes. The FPU's root is not run
    /// here; the PIL runs check it, through the planner's moves, as torques bit-identical
    /// to the host's.
    #[test]
    fn the_root_is_correctly_rounded() {
        for x in [
            0.0f32, 1.0, 4.0, 2.0, 0.5, 1e-30, 3.4e38, 1.17e-38, 1e-45, 123.456, 0.0272,
        ] {
            assert_eq!(sqrtf(x), (x as f64).sqrt() as f32, "{x}");
        }
        assert!(sqrtf(-1.0).is_nan());
    }
}
