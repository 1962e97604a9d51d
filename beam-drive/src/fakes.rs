//! Stand-in hardware for the drive: an encoder counter, the bridge converter's SPI bus and
//! data-ready line, the amplifier's PWM, direction, enable and fault lines, all reading and
//! writing one shared [`Bench`].
//!
//! The real drivers ([`Ads1220`](crate::ads1220::Ads1220),
//! [`Amplifier`](crate::amplifier::Amplifier)) run on top of these, so what is faked is only
//! the wire: the host tests of [`Drive`](crate::drive::Drive) set the bench's fields to make
//! a converter stop or a bus fail, and the PIL drive under QEMU copies each sensor frame into
//! the bench before its tick. `no_std`, no allocation: the bench is a set of `Cell`s borrowed
//! by every fake.

use core::cell::Cell;
use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use embedded_hal::spi::{ErrorType as SpiErrorType, Operation, SpiDevice};

/// The PWM's full-scale count: TIM1's period on the board.
pub const MAX_DUTY: u16 = crate::config::PWM_PERIOD_COUNTS;

/// What the fakes read and record.
#[derive(Debug, Default)]
pub struct Bench {
    /// The encoder counter's raw value.
    pub encoder_raw: Cell<u32>,
    /// The converter's result, clocked out as 24 bits.
    pub strain_code: Cell<i32>,
    /// Each read adds a live bridge's noise to `strain_code` (a few hundred codes, never
    /// at a rail): a converter that reads one code on end has stopped converting, and the
    /// controller says so (`FaultFlags::GAUGE`).
    pub noisy: Cell<bool>,
    /// Reads so far (the noise's sequence).
    reads: Cell<u32>,
    /// The converter has a result ready every poll (DRDY low); false: it stopped.
    pub converting: Cell<bool>,
    /// Every SPI transaction fails.
    pub bus_broken: Cell<bool>,
    /// The amplifier asserts /FAULT.
    pub amp_fault: Cell<bool>,
    /// Every input pin read (DRDY, /FAULT) fails.
    pub inputs_broken: Cell<bool>,
    /// Every output write (PWM, direction, enable) fails.
    pub outputs_broken: Cell<bool>,
    /// The last duty written.
    pub duty: Cell<u16>,
    /// The direction pin is high.
    pub dir_high: Cell<bool>,
    /// The enable pin is high.
    pub en_high: Cell<bool>,
}

impl Bench {
    /// A converter that converts, nothing broken, outputs low.
    pub const fn new() -> Self {
        Bench {
            encoder_raw: Cell::new(0),
            strain_code: Cell::new(0),
            noisy: Cell::new(false),
            reads: Cell::new(0),
            converting: Cell::new(true),
            bus_broken: Cell::new(false),
            amp_fault: Cell::new(false),
            inputs_broken: Cell::new(false),
            outputs_broken: Cell::new(false),
            duty: Cell::new(0),
            dir_high: Cell::new(false),
            en_high: Cell::new(false),
        }
    }
}

impl Bench {
    /// The code the converter clocks out on this read.
    fn code(&self) -> i32 {
        let code = self.strain_code.get();
        let (low, high) = (-(1 << 23), (1 << 23) - 1);
        if !self.noisy.get() || code <= low || code >= high {
            return code;
        }
        let n = self.reads.get().wrapping_add(1);
        self.reads.set(n);
        (code + bridge_noise(n)).clamp(low + 1, high - 1)
    }
}

/// A live bridge's noise on its `n`-th conversion, codes: a spread of -128..=127 (0.08 ue
/// on the shipped converter) in no short cycle, so that no two conversions in a row are
/// likely to read one code (what a stopped converter does).
pub const fn bridge_noise(n: u32) -> i32 {
    (n.wrapping_mul(2_654_435_761) >> 24) as i32 - 128
}

/// A failure of a fake bus or pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Broken;

impl embedded_hal::spi::Error for Broken {
    fn kind(&self) -> embedded_hal::spi::ErrorKind {
        embedded_hal::spi::ErrorKind::Other
    }
}

impl embedded_hal::digital::Error for Broken {
    fn kind(&self) -> embedded_hal::digital::ErrorKind {
        embedded_hal::digital::ErrorKind::Other
    }
}

impl embedded_hal::pwm::Error for Broken {
    fn kind(&self) -> embedded_hal::pwm::ErrorKind {
        embedded_hal::pwm::ErrorKind::Other
    }
}

/// The encoder counter.
pub struct Counter<'a>(pub &'a Bench);

impl crate::drive::QuadratureCounter for Counter<'_> {
    fn count(&mut self) -> u32 {
        self.0.encoder_raw.get()
    }
}

/// The converter's SPI bus: every read clocks out the bench's code, MSB first.
pub struct Bus<'a>(pub &'a Bench);

impl SpiErrorType for Bus<'_> {
    type Error = Broken;
}

impl SpiDevice for Bus<'_> {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), Broken> {
        if self.0.bus_broken.get() {
            return Err(Broken);
        }
        let [_, b2, b1, b0] = self.0.code().to_be_bytes();
        for op in ops {
            if let Operation::Read(buf) = op {
                for (dst, src) in buf.iter_mut().zip([b2, b1, b0]) {
                    *dst = src;
                }
            }
        }
        Ok(())
    }
}

/// An input pin of the bench: the converter's DRDY (low while converting) or the
/// amplifier's /FAULT (low while faulted).
pub struct Line<'a>(pub &'a Bench);

/// The converter's data-ready line.
pub struct DataReady<'a>(pub &'a Bench);

impl PinErrorType for DataReady<'_> {
    type Error = Broken;
}

impl InputPin for DataReady<'_> {
    fn is_high(&mut self) -> Result<bool, Broken> {
        self.is_low().map(|low| !low)
    }

    fn is_low(&mut self) -> Result<bool, Broken> {
        if self.0.inputs_broken.get() {
            return Err(Broken);
        }
        Ok(self.0.converting.get())
    }
}

impl PinErrorType for Line<'_> {
    type Error = Broken;
}

impl InputPin for Line<'_> {
    fn is_high(&mut self) -> Result<bool, Broken> {
        self.is_low().map(|low| !low)
    }

    fn is_low(&mut self) -> Result<bool, Broken> {
        if self.0.inputs_broken.get() {
            return Err(Broken);
        }
        Ok(self.0.amp_fault.get())
    }
}

/// The amplifier's PWM input.
pub struct Pwm<'a>(pub &'a Bench);

impl PwmErrorType for Pwm<'_> {
    type Error = Broken;
}

impl SetDutyCycle for Pwm<'_> {
    fn max_duty_cycle(&self) -> u16 {
        MAX_DUTY
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Broken> {
        if self.0.outputs_broken.get() {
            return Err(Broken);
        }
        self.0.duty.set(duty);
        Ok(())
    }
}

/// Defines an output pin recording its level in one field of the bench.
macro_rules! output_pin {
    ($(#[$doc:meta])* $name:ident, $field:ident) => {
        $(#[$doc])*
        pub struct $name<'a>(pub &'a Bench);

        impl PinErrorType for $name<'_> {
            type Error = Broken;
        }

        impl OutputPin for $name<'_> {
            fn set_low(&mut self) -> Result<(), Broken> {
                self.set(false)
            }

            fn set_high(&mut self) -> Result<(), Broken> {
                self.set(true)
            }
        }

        impl $name<'_> {
            fn set(&mut self, high: bool) -> Result<(), Broken> {
                if self.0.outputs_broken.get() {
                    return Err(Broken);
                }
                self.0.$field.set(high);
                Ok(())
            }
        }
    };
}

output_pin!(
    /// The amplifier's direction input.
    Direction,
    dir_high
);
output_pin!(
    /// The amplifier's enable input.
    Enable,
    en_high
);
