//! Driver for the ADS1220, the 24-bit delta-sigma converter on the root strain bridge.
//!
//! Generic over [`SpiDevice`] (the bus plus chip select, so the bus can be shared) and an
//! [`InputPin`] for the converter's active-low DRDY line, so it runs on the board's SPI1 and,
//! under `cargo test`, against `embedded-hal-mock` transactions.
//!
//! The converter runs in continuous-conversion mode at 1000 samples/s, the control rate, so the
//! tick never starts or waits for a conversion: it polls DRDY and, when a result is ready,
//! clocks out three bytes (about 6 us at 4 MHz). The converter's clock is not the loop's, so a
//! tick now and then finds no new sample; it then reuses the last code and counts it as stale.
//! A converter that stops converting (unplugged, reset, stuck DRDY) shows up as a run of stale
//! ticks, which the drive turns into a driver fault instead of controlling on old data.

use embedded_hal::digital::InputPin;
use embedded_hal::spi::{Operation, SpiDevice};

/// The converter's SPI commands (datasheet section 8.5.3).
pub mod command {
    /// Reset the device to its power-on state.
    pub const RESET: u8 = 0x06;
    /// Start or restart conversions.
    pub const START: u8 = 0x08;
    /// Enter power-down mode.
    pub const POWERDOWN: u8 = 0x02;
    /// Read registers: `RREG | (first << 2) | (count - 1)`.
    pub const RREG: u8 = 0x20;
    /// Write registers: `WREG | (first << 2) | (count - 1)`.
    pub const WREG: u8 = 0x40;
}

/// Time the converter needs after RESET before it takes commands, ns (50 us + 32 t_CLK at
/// the internal 4.096 MHz clock is 57.8 us; rounded up).
pub const RESET_SETTLE_NS: u32 = 100_000;

/// The four configuration registers, written and verified by [`Ads1220::init`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Registers 0 to 3.
    pub registers: [u8; 4],
}

impl Config {
    /// A full strain bridge between AIN0 (+) and AIN1 (-), PGA gain 128; normal mode at 1000
    /// samples/s, continuous conversion; ratiometric reference from REFP0/REFN0 (the bridge's
    /// excitation, so supply drift cancels); no 50/60 Hz filter (it would cap the rate at
    /// 20 samples/s); low-side power switch closed while converting; no excitation currents;
    /// data-ready on the dedicated DRDY pin only.
    pub const BRIDGE_1KSPS: Config = Config {
        registers: [
            0b0000_1110, // MUX = AIN0/AIN1, GAIN = 128, PGA enabled
            0b1100_0100, // DR = 1000 SPS, MODE = normal, CM = continuous, TS off, BCS off
            0b0100_1000, // VREF = REFP0/REFN0, no FIR, PSW closed, IDAC off
            0b0000_0000, // IDACs off, DRDY only on its pin
        ],
    };
}

/// What went wrong talking to the converter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<S, P> {
    /// The SPI transaction failed.
    Spi(S),
    /// Reading the DRDY pin failed.
    DataReady(P),
    /// A configuration register read back differently from what was written: the converter
    /// is absent, miswired, or not an ADS1220.
    ConfigMismatch {
        /// Register number, 0 to 3.
        register: u8,
        /// The value written.
        wrote: u8,
        /// The value read back.
        read: u8,
    },
}

/// One poll's result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// The newest conversion result, sign-extended from 24 bits.
    pub code: i32,
    /// Consecutive polls that found no new conversion (0 when `code` is fresh).
    pub stale_polls: u16,
}

/// The converter on its bus, with the last result it gave.
#[derive(Debug)]
pub struct Ads1220<SPI, DRDY> {
    spi: SPI,
    drdy: DRDY,
    last: Sample,
}

impl<SPI: SpiDevice, DRDY: InputPin> Ads1220<SPI, DRDY> {
    /// Takes the bus and the DRDY pin; nothing is sent until [`Ads1220::init`].
    pub fn new(spi: SPI, drdy: DRDY) -> Self {
        Self {
            spi,
            drdy,
            last: Sample::default(),
        }
    }

    /// Resets the converter, writes `config`, reads it back and starts continuous conversion.
    pub fn init(&mut self, config: &Config) -> Result<(), Error<SPI::Error, DRDY::Error>> {
        self.spi
            .transaction(&mut [
                Operation::Write(&[command::RESET]),
                Operation::DelayNs(RESET_SETTLE_NS),
            ])
            .map_err(Error::Spi)?;
        let r = config.registers;
        self.spi
            .write(&[command::WREG | 3, r[0], r[1], r[2], r[3]])
            .map_err(Error::Spi)?;
        let mut back = [0u8; 4];
        self.spi
            .transaction(&mut [
                Operation::Write(&[command::RREG | 3]),
                Operation::Read(&mut back),
            ])
            .map_err(Error::Spi)?;
        for (register, (&wrote, &read)) in (0u8..).zip(r.iter().zip(back.iter())) {
            if wrote != read {
                return Err(Error::ConfigMismatch {
                    register,
                    wrote,
                    read,
                });
            }
        }
        self.spi.write(&[command::START]).map_err(Error::Spi)?;
        self.last = Sample::default();
        Ok(())
    }

    /// Reads the newest conversion if DRDY says one is ready, else returns the last one with
    /// its stale count raised. Never blocks.
    pub fn poll(&mut self) -> Result<Sample, Error<SPI::Error, DRDY::Error>> {
        if self.drdy.is_low().map_err(Error::DataReady)? {
            // In continuous mode the result is clocked out directly, without RDATA.
            let mut bytes = [0u8; 3];
            self.spi.read(&mut bytes).map_err(Error::Spi)?;
            self.last = Sample {
                code: code_from_bytes(bytes),
                stale_polls: 0,
            };
        } else {
            self.last.stale_polls = self.last.stale_polls.saturating_add(1);
        }
        Ok(self.last)
    }

    /// The last sample, without touching the bus.
    pub fn last(&self) -> Sample {
        self.last
    }

    /// Gives the bus and pin back.
    pub fn release(self) -> (SPI, DRDY) {
        (self.spi, self.drdy)
    }
}

impl<SPI: SpiDevice, DRDY: InputPin> crate::drive::StrainSensor for Ads1220<SPI, DRDY> {
    type Error = Error<SPI::Error, DRDY::Error>;

    fn poll(&mut self) -> Result<Sample, Self::Error> {
        Ads1220::poll(self)
    }

    fn last(&self) -> Sample {
        Ads1220::last(self)
    }
}

/// A 24-bit two's-complement result, MSB first, as an `i32`.
pub fn code_from_bytes(b: [u8; 3]) -> i32 {
    // Put the 24 bits at the top of an i32 and shift back: the shift extends the sign.
    i32::from_be_bytes([b[0], b[1], b[2], 0]) >> 8
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
    use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as Spi};

    fn init_transactions(readback: [u8; 4]) -> Vec<Spi<u8>> {
        let r = Config::BRIDGE_1KSPS.registers;
        let mut t = vec![
            Spi::transaction_start(),
            Spi::write(command::RESET),
            Spi::delay(RESET_SETTLE_NS),
            Spi::transaction_end(),
            Spi::transaction_start(),
            Spi::write_vec(vec![0x43, r[0], r[1], r[2], r[3]]),
            Spi::transaction_end(),
            Spi::transaction_start(),
            Spi::write(0x23),
            Spi::read_vec(readback.to_vec()),
            Spi::transaction_end(),
        ];
        if readback == r {
            t.extend([
                Spi::transaction_start(),
                Spi::write(command::START),
                Spi::transaction_end(),
            ]);
        }
        t
    }

    #[test]
    fn codes_are_sign_extended_24_bit() {
        assert_eq!(code_from_bytes([0x7F, 0xFF, 0xFF]), (1 << 23) - 1);
        assert_eq!(code_from_bytes([0x80, 0x00, 0x00]), -(1 << 23));
        assert_eq!(code_from_bytes([0xFF, 0xFF, 0xFF]), -1);
        assert_eq!(code_from_bytes([0x00, 0x01, 0x00]), 256);
    }

    #[test]
    fn init_resets_writes_verifies_and_starts() {
        let mut spi = SpiMock::new(&init_transactions(Config::BRIDGE_1KSPS.registers));
        let mut drdy = PinMock::new(&[]);
        let mut adc = Ads1220::new(spi.clone(), drdy.clone());
        adc.init(&Config::BRIDGE_1KSPS).unwrap();
        spi.done();
        drdy.done();
    }

    #[test]
    fn a_wrong_readback_names_the_register_and_does_not_start() {
        let mut back = Config::BRIDGE_1KSPS.registers;
        back[2] = 0xFF; // what an absent device on a pulled-up MISO reads
        let mut spi = SpiMock::new(&init_transactions(back));
        let mut drdy = PinMock::new(&[]);
        let mut adc = Ads1220::new(spi.clone(), drdy.clone());
        assert_eq!(
            adc.init(&Config::BRIDGE_1KSPS),
            Err(Error::ConfigMismatch {
                register: 2,
                wrote: 0x48,
                read: 0xFF
            })
        );
        spi.done();
        drdy.done();
    }

    #[test]
    fn polls_read_only_when_data_is_ready_and_count_stale_ticks() {
        let mut spi = SpiMock::new(&[
            Spi::transaction_start(),
            Spi::read_vec(vec![0xFF, 0xFE, 0x00]),
            Spi::transaction_end(),
            Spi::transaction_start(),
            Spi::read_vec(vec![0x00, 0x10, 0x00]),
            Spi::transaction_end(),
        ]);
        let mut drdy = PinMock::new(&[
            Pin::get(State::Low),
            Pin::get(State::High),
            Pin::get(State::High),
            Pin::get(State::Low),
        ]);
        let mut adc = Ads1220::new(spi.clone(), drdy.clone());
        let codes: Vec<Sample> = (0..4).map(|_| adc.poll().unwrap()).collect();
        assert_eq!(
            codes,
            [
                Sample {
                    code: -512,
                    stale_polls: 0
                },
                Sample {
                    code: -512,
                    stale_polls: 1
                },
                Sample {
                    code: -512,
                    stale_polls: 2
                },
                Sample {
                    code: 4096,
                    stale_polls: 0
                },
            ]
        );
        spi.done();
        drdy.done();
    }

    /// The SPI mock cannot fail a transfer, so a bus that always fails stands in for it.
    struct BrokenBus;
    #[derive(Debug, PartialEq)]
    struct BusError;
    impl embedded_hal::spi::Error for BusError {
        fn kind(&self) -> embedded_hal::spi::ErrorKind {
            embedded_hal::spi::ErrorKind::Overrun
        }
    }
    impl embedded_hal::spi::ErrorType for BrokenBus {
        type Error = BusError;
    }
    impl SpiDevice for BrokenBus {
        fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), BusError> {
            Err(BusError)
        }
    }

    #[test]
    fn bus_and_pin_errors_are_reported_not_swallowed() {
        let mut drdy = PinMock::new(&[Pin::get(State::Low)]);
        let mut adc = Ads1220::new(BrokenBus, drdy.clone());
        assert_eq!(adc.init(&Config::BRIDGE_1KSPS), Err(Error::Spi(BusError)));
        assert_eq!(adc.poll(), Err(Error::Spi(BusError)));
        drdy.done();

        let pin_error = embedded_hal_mock::eh1::MockError::Io(std::io::ErrorKind::Other);
        let mut drdy = PinMock::new(&[Pin::get(State::Low).with_error(pin_error.clone())]);
        let mut adc = Ads1220::new(BrokenBus, drdy.clone());
        assert!(matches!(adc.poll(), Err(Error::DataReady(_))));
        drdy.done();
    }
}
