//! Simulated sensors: they turn the plant's true state into the raw readings the drive's
//! hardware gives, using the same [`EncoderSpec`] and [`AdcSpec`] the controller decodes with.
//!
//! The encoder is quantised to whole counts and seen through a wrapping hardware counter; the
//! strain bridge is an ADC code with an offset, seeded Gaussian noise, rounding and clipping
//! at the rails. Seeded, so every run is reproducible.

use model_core::{AdcSpec, EncoderSpec, Instruments, RawMeasurement};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// Configuration of the simulated sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorConfig {
    /// Encoder and counter.
    pub encoder: EncoderSpec,
    /// Strain ADC.
    pub adc: AdcSpec,
    /// The ADC code at zero strain (the bridge's offset).
    pub adc_offset_code: i32,
    /// Standard deviation of the strain noise (dimensionless strain).
    pub strain_noise_std: f64,
    /// Seed of the noise generator.
    pub seed: u64,
}

/// The simulated gauge's noise unless a run says otherwise, strain (standard deviation): a
/// bridge amplifier's floor, 0.5 ue.
pub const STRAIN_NOISE_STD: f64 = 0.5e-6;

impl SensorConfig {
    /// Sensors with `instruments` (a drive's table's, or a rig's): a bridge offset of 1234
    /// codes, [`STRAIN_NOISE_STD`] of strain noise, seed 1.
    pub fn reading(instruments: Instruments) -> Self {
        Self {
            encoder: instruments.encoder,
            adc: instruments.adc,
            adc_offset_code: 1234,
            strain_noise_std: STRAIN_NOISE_STD,
            seed: 1,
        }
    }

    /// The instruments these sensors are.
    pub fn instruments(&self) -> Instruments {
        Instruments {
            encoder: self.encoder,
            adc: self.adc,
        }
    }
}

/// The reference drive's instruments ([`Instruments::DEFAULT`], which a gain table's `[drive]`
/// starts from), read as [`SensorConfig::reading`] reads them. A tool simulating a drive
/// passes its table's ([`SensorConfig::reading`]).
impl Default for SensorConfig {
    fn default() -> Self {
        Self::reading(Instruments::DEFAULT)
    }
}

/// A sensor failure to inject ([`Sensors::inject`]): what goes wrong on a rig.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SensorFault {
    /// Both sensors read true.
    #[default]
    None,
    /// The gauge's code stays at its last reading (a converter that stopped updating).
    GaugeStuck,
    /// The gauge reads the converter's zero code (the bridge's excitation open).
    GaugeZero,
    /// The gauge reads the strain with the other sign (the bridge wired reversed).
    GaugeReversed,
    /// The gauge reads this many times the strain (a wrong gain resistor).
    GaugeGain(f64),
    /// The gauge reads this much strain too much (a drifting bridge), strain.
    GaugeBias(f64),
    /// The encoder's count stays at its last reading (a disconnected encoder).
    EncoderStuck,
    /// The encoder's count jumps by this many counts, once, and stays off by them (a
    /// slipped disc, a noise burst the counter took as counts).
    EncoderJump(i64),
}

/// The simulated sensor set.
#[derive(Clone, Debug)]
pub struct Sensors {
    cfg: SensorConfig,
    theta_home: f64,
    noise: Normal<f64>,
    rng: StdRng,
    fault: SensorFault,
    /// Counts the encoder is off by (jumps so far).
    count_offset: i64,
    /// The last readings (for the stuck faults).
    last: Option<(i64, i32)>,
}

impl Sensors {
    /// Sensors whose encoder counter reads zero at hub angle `theta_home`.
    pub fn new(cfg: SensorConfig, theta_home: f64) -> Self {
        let std = if cfg.strain_noise_std.is_finite() && cfg.strain_noise_std > 0.0 {
            cfg.strain_noise_std
        } else {
            0.0
        };
        Self {
            cfg,
            theta_home,
            noise: Normal::new(0.0, std)
                .unwrap_or(Normal::new(0.0, 0.0).expect("zero std is valid")),
            rng: StdRng::seed_from_u64(cfg.seed),
            fault: SensorFault::None,
            count_offset: 0,
            last: None,
        }
    }

    /// From the next reading on, the sensors fail as `fault` says (in place of any fault
    /// injected before; an encoder's jump stays). [`SensorFault::None`] heals them.
    pub fn inject(&mut self, fault: SensorFault) {
        if let SensorFault::EncoderJump(n) = fault {
            self.count_offset = self.count_offset.saturating_add(n);
        }
        self.fault = fault;
    }

    /// The encoder count (unwrapped, quantised toward minus infinity) at hub angle `theta`;
    /// a reversed encoder counts the same edges down.
    pub fn count(&self, theta: f64) -> i64 {
        let up = ((theta - self.theta_home) / self.cfg.encoder.rad_per_count()).floor() as i64;
        if self.cfg.encoder.reversed {
            -up
        } else {
            up
        }
    }

    /// The raw readings for hub angle `theta` and root strain `strain`, through any fault
    /// injected.
    pub fn read(&mut self, theta: f64, strain: f64, amp_fault: bool) -> RawMeasurement {
        let noisy = strain + self.noise.sample(&mut self.rng);
        let read_strain = match self.fault {
            SensorFault::GaugeReversed => -noisy,
            SensorFault::GaugeGain(k) => k * noisy,
            SensorFault::GaugeBias(b) => noisy + b,
            _ => noisy,
        };
        // A reversed bridge gives the same code magnitudes with the other sign.
        let up = (read_strain / self.cfg.adc.strain_per_code()).round();
        let up = if self.cfg.adc.reversed { -up } else { up };
        let code = up + self.cfg.adc_offset_code as f64;
        let code = code.clamp(
            self.cfg.adc.min_code() as f64,
            self.cfg.adc.max_code() as f64,
        ) as i32;
        let count = self.count(theta).saturating_add(self.count_offset);
        let (count, code) = match (self.fault, self.last) {
            (SensorFault::EncoderStuck, Some((last, _))) => (last, code),
            (SensorFault::GaugeStuck, Some((_, last))) => (count, last),
            (SensorFault::GaugeZero, _) => (count, 0),
            _ => (count, code),
        };
        self.last = Some((count, code));
        RawMeasurement {
            encoder_raw: (count as u64 & self.cfg.encoder.mask() as u64) as u32,
            strain_root_code: code,
            amp_fault,
            driver_fault: false,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SensorConfig {
        &self.cfg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoder_quantises_and_wraps_the_16_bit_counter() {
        let s = Sensors::new(SensorConfig::default(), 0.0);
        let per_rev = 16384.0;
        let step = 2.0 * std::f64::consts::PI / per_rev;
        assert_eq!(s.count(10.5 * step), 10);
        assert_eq!(s.count(-0.5 * step), -1);
        // Five revolutions = 81920 counts = 16384 modulo 65536.
        let mut s = s;
        let raw = s.read(5.0 * 2.0 * std::f64::consts::PI + 0.5 * step, 0.0, false);
        assert_eq!(raw.encoder_raw, 81920 % 65536);
    }

    #[test]
    fn adc_codes_clip_at_the_rails() {
        let cfg = SensorConfig {
            strain_noise_std: 0.0,
            ..Default::default()
        };
        let mut s = Sensors::new(cfg, 0.0);
        assert_eq!(s.read(0.0, 0.0, false).strain_root_code, 1234);
        assert_eq!(
            s.read(0.0, 1.0, false).strain_root_code,
            AdcSpec::DEFAULT.max_code()
        );
        assert_eq!(
            s.read(0.0, -1.0, false).strain_root_code,
            AdcSpec::DEFAULT.min_code()
        );
    }
}
