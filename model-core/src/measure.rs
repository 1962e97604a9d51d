//! From raw sensor readings to angle, velocity and strain.
//!
//! Hardware encoder counters are narrow (16 bits on most STM32 timers) and wrap; the
//! [`CounterExtender`] unwraps them into a 64-bit count one tick at a time, so the angle never
//! jumps at a wrap and never loses precision the way an ever-growing float would. Velocity is
//! the backward difference of the count through a first-order low-pass ([`LowPass`]); strain is
//! an ADC code minus its offset times a gain ([`AdcSpec`]). The same specs describe the host's
//! simulated sensors, so what the loop sees is the same in firmware and simulation.

use core::f32::consts::PI;

/// An incremental encoder and the width of the hardware counter that counts it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EncoderSpec {
    /// Counts per revolution after quadrature decoding.
    pub counts_per_rev: u32,
    /// Width of the hardware counter, bits (1 to 32).
    pub counter_bits: u8,
    /// The counter counts down as the hub turns positive (an encoder wired or mounted the
    /// other way round). Applied as a negative scale when the controller is built, so the
    /// tick does no more work for it.
    pub reversed: bool,
}

impl EncoderSpec {
    /// 16384 counts per revolution (a 4096-line encoder in x4 mode) on a 16-bit timer.
    pub const DEFAULT: EncoderSpec = EncoderSpec {
        counts_per_rev: 16384,
        counter_bits: 16,
        reversed: false,
    };

    /// Radians per count (the encoder's resolution, positive).
    pub fn rad_per_count(&self) -> f64 {
        2.0 * core::f64::consts::PI / self.counts_per_rev as f64
    }

    /// The fastest hub speed, rad/s, a controller reading the counter every `ts_s` accepts
    /// as its physical limit (`ControllerSettings::max_speed_rad_s`): a change is taken
    /// modulo the counter's width ([`CounterExtender::update`]), so the most counts a tick
    /// at that speed, rounded up, must stay below `2^(bits-1) - 1`.
    pub fn max_rate_rad_s(&self, ts_s: f64) -> f64 {
        let half = 1u64 << (self.counter_bits.clamp(2, 32) - 1);
        (half - 2) as f64 * self.rad_per_count() / ts_s
    }

    /// Radians of hub angle per count up: [`EncoderSpec::rad_per_count`], negative when
    /// [`reversed`](EncoderSpec::reversed).
    pub fn signed_rad_per_count(&self) -> f64 {
        signed(self.rad_per_count(), self.reversed)
    }

    /// Radians of hub angle per count up, as the 62-bit fixed-point number
    /// [`angle_rad`] uses where a count is too far out for `f32`: `2 pi / counts_per_rev`
    /// from `2 pi` to 128 bits, in integer arithmetic (no double precision, which the
    /// Cortex-M4F does in software), negative when [`reversed`](EncoderSpec::reversed).
    pub fn fixed_rad_per_count(&self) -> FixedRate {
        // 2 pi 2^125, rounded (pi's first 128 bits, C90FDAA2 2168C234 C4C6628B 80DC1CD1).
        const TAU_Q125: u128 = 0xc90f_daa2_2168_c234_c4c6_628b_80dc_1cd1;
        let d = u64::from(self.counts_per_rev.max(1));
        // Long division by 32-bit limbs: each partial quotient fits 32 bits.
        let (mut q, mut r) = (0u128, 0u64);
        for limb in (0..4).rev() {
            let cur = (r << 32) | u64::from((TAU_Q125 >> (32 * limb)) as u32);
            q |= u128::from(cur / d) << (32 * limb);
            r = cur % d;
        }
        // 63 significant bits at most: q is at least 2 pi 2^93 (a u32 divisor), so the
        // shift is at least 32.
        let shift = (128 - q.leading_zeros()).saturating_sub(63);
        let mantissa = (q >> shift) as i64;
        FixedRate {
            mantissa: if self.reversed { -mantissa } else { mantissa },
            exp: 125 - shift,
        }
    }

    /// The counter's modulus minus one, as a mask.
    pub fn mask(&self) -> u32 {
        if self.counter_bits >= 32 {
            u32::MAX
        } else {
            (1u32 << self.counter_bits) - 1
        }
    }

    /// The counter's width as [`CounterExtender::update_in`] uses it.
    pub fn width(&self) -> CounterWidth {
        CounterWidth {
            mask: self.mask(),
            shift: 32 - self.counter_bits.clamp(1, 32) as u32,
        }
    }
}

/// A counter's width, for [`CounterExtender::update_in`]: see [`EncoderSpec::width`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CounterWidth {
    /// [`EncoderSpec::mask`].
    pub mask: u32,
    /// 32 less the counter's bits: the shifts that sign-extend a change.
    pub shift: u32,
}

/// The least hub-angle noise an observer is designed to assume, rad: the reference
/// encoder's quantisation ([`EncoderSpec::DEFAULT`], 2 pi / 16384 / sqrt(12); a test checks
/// it), the encoder the observer laws' margins on beams off their model were measured with.
/// A finer encoder is read as finely, but the observer does not lean on it harder: designed
/// on 2^20 counts' own quantisation, it followed the encoder so closely that on soft, dense
/// beams carrying 30-50 g (EI 0.8, density 1.06-1.18 times the model's) smc-modal's 180 deg
/// moves rang on without end, past 2200 ue: 3 to 7 of 200 beams on each of three seeds,
/// with faults latched on 5 to 7 (the README's sweep)
/// (docs/design.md, section 4b, "What the observer costs, by sensor and by mode"). With the
/// floor none did, and the p95 stayed within 0.01 s of the reference encoder's.
pub const ANGLE_NOISE_FLOOR_RAD: f64 = 1.107_055_276_021_861_5e-4;

/// How a drive reads its hub and its beam: the encoder and the root strain converter. The
/// loop decodes with them, the simulated sensors quantise with them, and the observer laws
/// are designed on their noise (`Instruments::noise`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Instruments {
    /// The hub encoder.
    pub encoder: EncoderSpec,
    /// The root strain converter.
    pub adc: AdcSpec,
}

impl Instruments {
    /// A 16 384-count encoder on a 16-bit counter and a 24-bit bridge converter spanning
    /// +-5000 ue ([`EncoderSpec::DEFAULT`], [`AdcSpec::DEFAULT`]): the reference drive's,
    /// which a gain table's `[drive]` starts from.
    pub const DEFAULT: Instruments = Instruments {
        encoder: EncoderSpec::DEFAULT,
        adc: AdcSpec::DEFAULT,
    };

    /// The noise an observer assumes on these instruments: the encoder's quantisation (step /
    /// sqrt(12)), at least [`ANGLE_NOISE_FLOOR_RAD`], and the root gauge's, at least
    /// [`ASSUMED_STRAIN_NOISE`](crate::law::ASSUMED_STRAIN_NOISE) (a bridge amplifier's floor,
    /// above a fine converter's quantisation).
    pub fn noise(&self) -> beam_model::lqg::SensorNoise {
        let quantum = |step: f64| step / libm::sqrt(12.0);
        beam_model::lqg::SensorNoise {
            theta_rad: quantum(self.encoder.rad_per_count()).max(ANGLE_NOISE_FLOOR_RAD),
            encoder_step_rad: self.encoder.signed_rad_per_count(),
            strain: quantum(self.adc.strain_per_code()).max(crate::law::ASSUMED_STRAIN_NOISE),
        }
    }
}

/// A bipolar strain-gauge ADC: signed codes, full scale in strain.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdcSpec {
    /// Resolution, bits (2 to 32): codes span `-2^(bits-1) ..= 2^(bits-1) - 1`.
    pub bits: u8,
    /// Strain at positive full scale (dimensionless, 5000e-6 = 5000 microstrain).
    pub full_scale_strain: f64,
    /// Positive strain reads as negative codes (the bridge or its amplifier wired the other
    /// way round); applied as a negative scale when the controller is built.
    pub reversed: bool,
}

impl AdcSpec {
    /// A 24-bit bridge converter (ADS1220 class) spanning +-5000 microstrain.
    pub const DEFAULT: AdcSpec = AdcSpec {
        bits: 24,
        full_scale_strain: 5000e-6,
        reversed: false,
    };

    /// Most negative code (the lower rail).
    pub fn min_code(&self) -> i32 {
        (-(1i64 << (self.bits.clamp(2, 32) - 1))) as i32
    }

    /// Most positive code (the upper rail).
    pub fn max_code(&self) -> i32 {
        ((1i64 << (self.bits.clamp(2, 32) - 1)) - 1) as i32
    }

    /// Strain per code.
    pub fn strain_per_code(&self) -> f64 {
        self.full_scale_strain / (1i64 << (self.bits.clamp(2, 32) - 1)) as f64
    }

    /// Strain per code up: [`AdcSpec::strain_per_code`], negative when
    /// [`reversed`](AdcSpec::reversed).
    pub fn signed_strain_per_code(&self) -> f64 {
        signed(self.strain_per_code(), self.reversed)
    }

    /// True when `code` sits at either rail: a saturated or disconnected bridge.
    pub fn at_rail(&self, code: i32) -> bool {
        code <= self.min_code() || code >= self.max_code()
    }
}

/// `-x` for a reversed sensor, else `x` (a sign flip, not a soft-float multiply on the M4F).
fn signed(x: f64, reversed: bool) -> f64 {
    if reversed {
        -x
    } else {
        x
    }
}

/// Unwraps a wrapping hardware counter into a 64-bit count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CounterExtender {
    last_raw: u32,
    count: i64,
    primed: bool,
}

impl CounterExtender {
    /// Takes the next raw counter value (only its low `counter_bits` matter) and returns the
    /// extended count and the signed change since the previous call. The first call sets the
    /// origin: count 0, change 0. A change is taken modulo the counter width into
    /// `-2^(bits-1) .. 2^(bits-1)`, so the counter must not move half its range in one tick.
    pub fn update(&mut self, raw: u32, spec: &EncoderSpec) -> (i64, i64) {
        self.update_in(raw, spec.width())
    }

    /// [`CounterExtender::update`] with the counter's width worked out beforehand (once,
    /// not on every tick).
    #[inline(always)]
    pub fn update_in(&mut self, raw: u32, width: CounterWidth) -> (i64, i64) {
        let raw = raw & width.mask;
        if !self.primed {
            self.primed = true;
            self.last_raw = raw;
            return (self.count, 0);
        }
        // Sign-extend the wrapped difference from the counter's width to 32 bits (at most
        // 32), then to 64. In 32 bits: the Cortex-M4 has no 64-bit shifts by a variable
        // amount.
        let diff = raw.wrapping_sub(self.last_raw) & width.mask;
        let delta = (((diff << width.shift) as i32) >> width.shift) as i64;
        self.last_raw = raw;
        self.count = self.count.wrapping_add(delta);
        (self.count, delta)
    }

    /// The extended count so far.
    pub fn count(&self) -> i64 {
        self.count
    }
}

/// Counts within this distance of home convert to `f32` exactly (2^24).
pub const EXACT_F32_COUNTS: i64 = 1 << 24;

/// A fixed-point number, `mantissa * 2^-exp`: an encoder's radians per count to 62 bits
/// ([`EncoderSpec::fixed_rad_per_count`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FixedRate {
    /// Signed, below 2^63 in magnitude.
    pub mantissa: i64,
    /// The power of two it is divided by (60 to 93 for a `u32` count per revolution).
    pub exp: u32,
}

impl FixedRate {
    /// The nearest `f32` (to the 62 bits held).
    pub fn to_f32(self) -> f32 {
        libm::scalbnf(self.mantissa as f32, -(self.exp as i32))
    }
}

/// The hub angle of an extended count, `home + count * rad_per_count`.
///
/// Computed from the integer count every tick and never accumulated, so no error builds up
/// however long the drive runs. Within [`EXACT_F32_COUNTS`] of home (1024 revolutions at
/// 16384 counts/rev) this is `f32` arithmetic on an exactly converted count, the fast path the
/// slew always takes. Further out, where `count as f32` would round away whole counts, the
/// sum is formed exactly in 128-bit integers at the rate's fixed point (`rate`, the same
/// number as `rad_per_count` to 62 bits) and rounded to `f32` once, so the angle is the
/// nearest `f32` to the true value for any count an `i64` holds (for a home within 2^31 rad).
#[inline]
pub fn angle_rad(count: i64, home_rad: f32, rad_per_count: f32, rate: FixedRate) -> f32 {
    if count.unsigned_abs() < EXACT_F32_COUNTS as u64 {
        // Within 2^24 the count fits an i32, whose conversion is one FPU instruction on the
        // Cortex-M4F (an i64's is a library call); both are exact here.
        home_rad + (count as i32) as f32 * rad_per_count
    } else {
        far_angle_rad(count, home_rad, rate)
    }
}

/// [`angle_rad`] past [`EXACT_F32_COUNTS`]: `count * mantissa + home 2^exp` in `i128`
/// (below 2^126 plus the home's share), converted to `f32` with one rounding and scaled by
/// `2^-exp` exactly.
#[inline(never)]
fn far_angle_rad(count: i64, home_rad: f32, rate: FixedRate) -> f32 {
    let exp = rate.exp as i32;
    // The home as `m 2^e` with an integer m of at most 24 bits (`frexpf`'s fraction, in
    // [0.5, 1), times 2^24 is exact).
    let (fraction, e) = libm::frexpf(home_rad);
    // (Through an i32, which holds it: `f32 as i128` is a library routine on the drive.)
    let (m, e) = (i128::from(libm::scalbnf(fraction, 24) as i32), e - 24);
    // At the rate's fixed point; bits below it are dropped (a home is a few radians, whose
    // last bit is far above 2^-60). Up to 2^100 it leaves the sum below 2^127 (a home within
    // 2^31 rad for any encoder); past that the sum is left to f32.
    let at = e + exp;
    let home_fixed = match at {
        0.. if at <= 100 => m << at,
        0.. => return home_rad + count as f32 * rate.to_f32(),
        _ => m >> (-at).min(127),
    };
    let sum = i128::from(count) * i128::from(rate.mantissa) + home_fixed;
    scaled_f32(sum, exp)
}

/// `sum 2^-exp` as the nearest `f32`: `libm::scalbnf(sum as f32, -exp)` without the drive's
/// 128-bit conversion routine (0.25 KB). The top 63 bits of the magnitude, with a sticky bit
/// for any below them, round to the same `f32` (the rounding falls 39 bits above the sticky
/// bit, which only breaks what would otherwise be a tie), and are scaled back with the fixed
/// point's exponent in one step.
fn scaled_f32(sum: i128, exp: i32) -> f32 {
    let magnitude = sum.unsigned_abs();
    let shift = (128 - magnitude.leading_zeros()).saturating_sub(63);
    let below = magnitude & ((1u128 << shift) - 1);
    let top = (magnitude >> shift) as i64 | i64::from(below != 0);
    let top = if sum < 0 { -(top as f32) } else { top as f32 };
    libm::scalbnf(top, shift as i32 - exp)
}

/// First-order low-pass coefficient: `y += alpha (x - y)` with `alpha = 1 - exp(-2 pi fc Ts)`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LowPass {
    /// The smoothing coefficient in (0, 1].
    pub alpha: f32,
}

impl LowPass {
    /// The default velocity filter cutoff, Hz.
    pub const DEFAULT_CUTOFF_HZ: f32 = 200.0;

    /// The filter with cutoff `fc_hz` sampled every `ts_s`; `None` unless both are positive
    /// and finite.
    pub fn from_cutoff(fc_hz: f32, ts_s: f32) -> Option<LowPass> {
        if !(fc_hz > 0.0 && ts_s > 0.0 && fc_hz.is_finite() && ts_s.is_finite()) {
            return None;
        }
        Some(LowPass {
            alpha: 1.0 - libm::expf(-2.0 * PI * fc_hz * ts_s),
        })
    }

    /// One filter update of `state` toward `x`; returns the new output.
    #[inline]
    pub fn process(&self, state: &mut f32, x: f32) -> f32 {
        *state += self.alpha * (x - *state);
        *state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_observer_assumes_no_finer_angle_than_the_reference_encoder_resolves() {
        let step = |counts_per_rev| Instruments {
            encoder: EncoderSpec {
                counts_per_rev,
                ..EncoderSpec::DEFAULT
            },
            ..Instruments::DEFAULT
        };
        // Uniform quantisation of a 16384th of a turn: its standard deviation.
        let reference = 2.0 * core::f64::consts::PI / 16384.0 / libm::sqrt(12.0);
        assert!((ANGLE_NOISE_FLOOR_RAD - reference).abs() < 1e-12 * reference);
        assert_eq!(step(16384).noise().theta_rad, reference);
        // A coarser encoder is assumed as coarse as it is; a finer one no finer than that.
        assert_eq!(step(4096).noise().theta_rad, 4.0 * reference);
        assert_eq!(step(1 << 20).noise().theta_rad, ANGLE_NOISE_FLOOR_RAD);
        // Its reading is still taken as finely as it comes: the count's interval.
        assert_eq!(
            step(1 << 20).noise().encoder_step_rad,
            2.0 * core::f64::consts::PI / f64::from(1u32 << 20)
        );
    }

    #[test]
    fn low_pass_has_the_documented_coefficient_and_dc_gain() {
        let lp = LowPass::from_cutoff(200.0, 1e-3).unwrap();
        assert!((lp.alpha - (1.0 - (-0.4 * core::f32::consts::PI).exp())).abs() < 1e-6);
        let mut y = 0.0;
        for _ in 0..100 {
            lp.process(&mut y, 3.0);
        }
        assert!((y - 3.0).abs() < 1e-5);
        assert!(LowPass::from_cutoff(0.0, 1e-3).is_none());
        assert!(LowPass::from_cutoff(f32::NAN, 1e-3).is_none());
    }

    /// A week of continuous rotation at the encoder-jump limit (130 counts a tick, 49.9 rad/s)
    /// on the 16-bit counter, then all the way back: the 64-bit count is exact throughout,
    /// the angle is the nearest f32 to the true angle wherever the hub is (checked against
    /// whole revolutions plus the remainder, computed apart from the code under test), and
    /// back at home the angle is exactly home again: nothing accumulates.
    #[test]
    fn a_week_at_full_speed_keeps_the_count_and_the_angle_exact() {
        let spec = EncoderSpec::DEFAULT;
        let (rpc, rate) = (spec.rad_per_count(), spec.fixed_rad_per_count());
        let rpc32 = rate.to_f32();
        assert_eq!(rpc32, rpc as f32);
        let home = -core::f32::consts::FRAC_PI_2;
        const STEP: u32 = 130;
        const TICKS: u64 = 7 * 24 * 3600 * 1000;
        let check = |count: i64| {
            let revs = count.div_euclid(spec.counts_per_rev as i64) as f64;
            let rem = count.rem_euclid(spec.counts_per_rev as i64) as f64;
            let truth = home as f64 + revs * core::f64::consts::TAU + rem * rpc;
            let got = angle_rad(count, home, rpc32, rate) as f64;
            let ulp = (truth.abs() as f32).to_bits();
            let ulp = (f32::from_bits(ulp + 1) - f32::from_bits(ulp)) as f64;
            assert!(
                (got - truth).abs() <= 0.5 * ulp * (1.0 + 1e-6),
                "count {count}: {got} vs {truth}"
            );
        };
        for dir in [1i64, -1] {
            let mut ext = CounterExtender::default();
            let mut raw: u32 = if dir > 0 {
                0
            } else {
                (TICKS as u32).wrapping_mul(STEP)
            };
            let start = if dir > 0 {
                0
            } else {
                (TICKS * STEP as u64) as i64
            };
            ext.update(raw, &spec);
            let mut count = start;
            for k in 1..=TICKS {
                raw = if dir > 0 {
                    raw.wrapping_add(STEP)
                } else {
                    raw.wrapping_sub(STEP)
                };
                let (c, delta) = ext.update(raw, &spec);
                count += dir * STEP as i64;
                assert!(
                    delta == dir * STEP as i64 && c == count - start,
                    "tick {k}: count {c} delta {delta}"
                );
                if k % 10_000_000 == 0 {
                    check(count);
                }
            }
            check(count);
            if dir < 0 {
                assert_eq!(count, 0);
                assert_eq!(angle_rad(count, home, rpc32, rate), home);
            } else {
                assert_eq!(count, (TICKS * STEP as u64) as i64);
            }
        }
    }

    /// The fixed-point rate is 2 pi / counts to 62 bits, for encoders from one count a
    /// revolution to a 32-bit count, either way round: against the rate from 2 pi in f64
    /// (53 bits: their difference is f64's rounding, under 2^-52 of it).
    #[test]
    fn the_fixed_rate_is_two_pi_over_the_counts() {
        for cpr in [1u32, 3, 1000, 4096, 16384, 100_000, 1 << 20, u32::MAX] {
            for reversed in [false, true] {
                let spec = EncoderSpec {
                    counts_per_rev: cpr,
                    counter_bits: 16,
                    reversed,
                };
                let rate = spec.fixed_rad_per_count();
                assert!(rate.mantissa.unsigned_abs() >= 1 << 62, "{cpr}: {rate:?}");
                let got = rate.mantissa as f64 * (-(rate.exp as f64)).exp2();
                let want = spec.signed_rad_per_count();
                assert!((got - want).abs() <= want.abs() * 2.0f64.powi(-52), "{cpr}");
                assert_eq!(rate.to_f32(), want as f32, "{cpr}");
            }
        }
    }

    /// Far out, the angle is the nearest f32 to `home + count 2 pi / counts`, whatever the
    /// home's sign and size (up to a few revolutions) and for counts to i64's ends: against
    /// whole revolutions plus the remainder, in f64, for counts where f64 holds that sum to
    /// far better than an f32 step.
    #[test]
    fn far_out_the_angle_is_the_nearest_f32() {
        let spec = EncoderSpec::DEFAULT;
        let (rpc, rate) = (spec.rad_per_count(), spec.fixed_rad_per_count());
        let cpr = spec.counts_per_rev as i64;
        for home in [0.0f32, -1.5707964, 3.0, -20.0, 1e-30, 7.0e-3] {
            for count in [
                1i64 << 24,
                -(1 << 24) - 7,
                123_456_789_012,
                -98_765_432_109_876,
            ] {
                let revs = count.div_euclid(cpr) as f64;
                let rem = count.rem_euclid(cpr) as f64;
                let truth = home as f64 + revs * core::f64::consts::TAU + rem * rpc;
                let got = angle_rad(count, home, rate.to_f32(), rate) as f64;
                let step = (truth.abs() as f32).to_bits();
                let step = (f32::from_bits(step + 1) - f32::from_bits(step)) as f64;
                assert!(
                    (got - truth).abs() <= 0.5 * step * (1.0 + 1e-6),
                    "home {home} count {count}: {got} vs {truth}"
                );
            }
        }
        // At i64's ends the angle is finite and has the count's sign.
        for count in [i64::MAX, i64::MIN] {
            let a = angle_rad(count, 1.0, rate.to_f32(), rate);
            assert!(a.is_finite() && (a > 0.0) == (count > 0), "{count}: {a}");
        }
    }

    proptest! {
        /// The far angle's conversion is the one rounding of `sum as f32`, scaled: for sums
        /// of every size below 2^127 (ties included: a low bit set far below the top) and
        /// the fixed points the encoder rates use.
        #[test]
        fn the_far_sum_rounds_as_one_conversion(
            bits in 0u32..127,
            mantissa in any::<u128>(),
            tie in any::<bool>(),
            negative in any::<bool>(),
            exp in 60i32..94,
        ) {
            let mut magnitude = (mantissa >> (128 - bits.max(1))) | (1u128 << bits);
            if tie && bits > 30 {
                // Exactly halfway between two f32s, then a hair above it.
                magnitude = (magnitude >> (bits - 23)) << (bits - 23) | (1u128 << (bits - 24));
                magnitude |= mantissa & 1;
            }
            let sum = if negative { -(magnitude as i128) } else { magnitude as i128 };
            prop_assert_eq!(
                scaled_f32(sum, exp).to_bits(),
                libm::scalbnf(sum as f32, -exp).to_bits()
            );
        }
    }

    #[test]
    fn adc_rails_and_scale() {
        let a = AdcSpec::DEFAULT;
        assert_eq!((a.min_code(), a.max_code()), (-8_388_608, 8_388_607));
        assert!(a.at_rail(a.max_code()) && a.at_rail(a.min_code()) && !a.at_rail(0));
        assert!((a.strain_per_code() * 8_388_608.0 - 5000e-6).abs() < 1e-15);
        let a32 = AdcSpec { bits: 32, ..a };
        assert_eq!((a32.min_code(), a32.max_code()), (i32::MIN, i32::MAX));
    }

    proptest! {
        /// Any walk of per-tick steps smaller than half the counter range is recovered
        /// exactly from the wrapped counter, whatever the width and start value.
        #[test]
        fn extension_recovers_the_true_count(
            bits in 2u8..=32,
            start in any::<u32>(),
            steps in prop::collection::vec(any::<i64>(), 1..300),
        ) {
            let spec = EncoderSpec { counts_per_rev: 1000, counter_bits: bits, reversed: false };
            let half = 1i64 << (bits - 1);
            let mut ext = CounterExtender::default();
            let mut truth: i64 = start as i64;
            let raw = |c: i64| (c as u64 & spec.mask() as u64) as u32;
            ext.update(raw(truth), &spec);
            for s in steps {
                let step = s.rem_euclid(2 * half - 1) - (half - 1); // |step| < half
                truth += step;
                let (count, delta) = ext.update(raw(truth), &spec);
                prop_assert_eq!(delta, step);
                prop_assert_eq!(count, truth - start as i64);
            }
        }
    }

    #[test]
    fn sixteen_bit_counter_wraps_both_ways() {
        let spec = EncoderSpec::DEFAULT;
        let mut ext = CounterExtender::default();
        ext.update(65_530, &spec);
        assert_eq!(ext.update(4, &spec), (10, 10));
        // 4 -> 65534 is six counts backwards through zero.
        assert_eq!(ext.update(65_534, &spec), (4, -6));
    }
}
