//! The STM32F405RG motor drive: every concrete HAL type, pin and clock is named here and
//! nowhere else (stabilizer's `hardware` pattern). The rest of the firmware sees embedded-hal
//! traits through [`beam_drive::drive::Drive`].
//!
//! Pin map (an ODrive-style layout: the encoder on TIM3 as on its M0 connector):
//!
//! | signal                  | pin       | peripheral                        |
//! |-------------------------|-----------|-----------------------------------|
//! | hub encoder A/B         | PB4, PB5  | TIM3 encoder mode, 16-bit         |
//! | bridge ADC SCK/MISO/MOSI| PA5-PA7   | SPI1, mode 1, 4 MHz               |
//! | bridge ADC /CS, /DRDY   | PA4, PA3  | GPIO out, GPIO in                 |
//! | amplifier PWM           | PA8       | TIM1 CH1, 20 kHz                  |
//! | amplifier DIR, ENABLE   | PB12, PB13| GPIO out                          |
//! | amplifier /FAULT        | PB14      | GPIO in, pull-up (open drain)     |
//! | START, CLEAR FAULT      | PC0, PC1  | GPIO in, pull-up (active low)     |
//! | 1 kHz loop tick         | -         | TIM2 update interrupt             |

use beam_drive::ads1220::{self, Ads1220};
use beam_drive::amplifier::Amplifier;
use beam_drive::config::{BuildError, MOVE_KNOTS};
use beam_drive::drive::{Drive, QuadratureCounter};
use beam_drive::operator::Operator;
use embedded_hal::pwm::SetDutyCycle;
use embedded_hal_bus::spi::ExclusiveDevice;
use stm32f4xx_hal::{
    gpio::Alternate,
    gpio::{Input, Output, Pin, PinState, PushPull},
    pac,
    prelude::*,
    qei::Qei,
    rcc::Config,
    rcc::{BusTimerClock, Rcc},
    serial::{self, Rx1, Tx1},
    spi::{self, Spi},
    timer::{CounterHz, Event, SysDelay, Timer},
    watchdog::IndependentWatchdog,
};

/// The board's crystal, Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// How many times the start-up reads the crystal's ready flag before it gives up on it:
/// some 30 ms on the internal oscillator the MCU starts on (16 MHz, a few cycles a read),
/// ten times the 2 ms a crystal of this kind takes to start.
const HSE_READY_POLLS: u32 = 100_000;
pub use beam_drive::config::{PWM_HZ, SYSCLK_HZ};
/// Control loop rate, Hz (model-core's `DEFAULT_TS_S` is its period).
pub use model_core::LOOP_HZ;
/// Bridge ADC SPI clock, Hz (the ADS1220 allows up to 6.6 MHz).
pub const ADC_SPI_HZ: u32 = 4_000_000;
/// Watchdog timeout, ms: ten missed ticks reset the MCU.
pub const WATCHDOG_MS: u32 = 10;
/// GPIOB pin of the amplifier's enable line; the panic path drives it through the registers.
const ENABLE_PIN: u8 = 13;

/// The hub encoder counter.
pub struct Encoder(Qei<pac::TIM3>);
impl QuadratureCounter for Encoder {
    fn count(&mut self) -> u32 {
        use stm32f4xx_hal::hal_02::Qei as _;
        self.0.count() as u32
    }
}

/// The bridge ADC's bus: SPI1 with its chip select.
pub type AdcBus = ExclusiveDevice<Spi<pac::SPI1>, Pin<'A', 4, Output<PushPull>>, SysDelay>;
/// The bridge ADC's data-ready line.
pub type AdcReady = Pin<'A', 3, Input>;
/// The amplifier's PWM input: TIM1's channel 1 on PA8 ([`TorquePwm::new`]).
pub type PwmPin = Pin<'A', 8, Alternate<1>>;
/// The amplifier's direction input.
pub type Direction = Pin<'B', 12, Output<PushPull>>;
/// The amplifier's enable input.
pub type Enable = Pin<'B', ENABLE_PIN, Output<PushPull>>;
/// The amplifier's fault output.
pub type AmpFault = Pin<'B', 14, Input>;
/// The bridge ADC on this board.
pub type BoardAdc = Ads1220<AdcBus, AdcReady>;
/// The amplifier on this board.
pub type BoardAmplifier =
    Amplifier<TorquePwm, Direction, Enable, AmpFault, { firmware::TORQUE_REVERSED }>;
/// The drive on this board.
pub type BoardDrive = Drive<MOVE_KNOTS, Encoder, BoardAdc, BoardAmplifier>;
/// The operator's buttons.
pub type BoardOperator = Operator<MOVE_KNOTS, 2, Pin<'C', 0, Input>, Pin<'C', 1, Input>>;

/// What the loop owns.
pub struct Board {
    /// Sensors, controller, amplifier.
    pub drive: BoardDrive,
    /// START and CLEAR FAULT.
    pub operator: BoardOperator,
    /// The timer whose update interrupt is the tick.
    pub loop_timer: CounterHz<pac::TIM2>,
    /// Fed once per tick.
    pub watchdog: IndependentWatchdog,
    /// The command link's USART1 (PA9 TX, PA10 RX) at `beam_drive::link::BAUD`.
    pub link_tx: Tx1,
    /// See `link_tx`.
    pub link_rx: Rx1,
    /// The command handler, with the compiled-in law and payload.
    pub commander: firmware::BoardCommander,
    /// The crystal started and the MCU runs at `SYSCLK_HZ` from it. If not, it runs on its
    /// internal oscillator at 16 MHz, and the drive has the clock fault latched.
    pub crystal: bool,
}

/// Why the board did not come up. The amplifier is never enabled in any of these cases.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub enum BringUpError {
    /// The compiled-in configuration.
    Config(BuildError),
    /// The command link's USART could not be configured.
    Link,
    /// The loop timer refused the rate.
    LoopTimer,
    /// The amplifier's pins (infallible on this MCU; kept for completeness).
    Amplifier,
}

/// Clocks, pins, peripherals; the amplifier disabled; the watchdog and the tick started.
/// A bridge ADC that does not answer does not stop bring-up: the drive comes up with a
/// driver fault latched, visible in telemetry; CLEAR FAULT cannot clear it for long, since an
/// unconfigured converter never signals data and the stale-data check trips again.
pub fn init(dp: pac::Peripherals, cp: cortex_m::Peripherals) -> Result<Board, BringUpError> {
    // A dead or missing crystal must not hang the board before it can say so (the HAL waits
    // for it for ever): on the internal oscillator, without the PLL (whose lock is waited for
    // too), the drive comes up, answers, and refuses torque with the clock fault latched.
    // QEMU's STM32F405 has no clock controller at all, and takes this path.
    let crystal = crystal_starts(&dp.RCC);
    let clocks = if crystal {
        Config::hse(HSE_HZ.Hz())
            .sysclk(SYSCLK_HZ.Hz())
            .pclk1(42.MHz())
            .pclk2(84.MHz())
    } else {
        Config::hsi()
    };
    let mut rcc = dp.RCC.freeze(clocks);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let gpioc = dp.GPIOC.split(&mut rcc);

    // The amplifier first, so that it is held disabled before anything else runs.
    let enable: Enable = gpiob.pb13.into_push_pull_output_in_state(PinState::Low);
    let direction: Direction = gpiob.pb12.into_push_pull_output();
    let pwm = TorquePwm::new(dp.TIM1, gpioa.pa8.into_alternate(), &mut rcc);
    let fault: AmpFault = gpiob.pb14.into_pull_up_input();
    let amp = Amplifier::new(pwm, direction, enable, fault, firmware::TORQUE_SCALE)
        .map_err(|_| BringUpError::Amplifier)?;

    // PB4 comes out of reset as the JTAG NJTRST (AF0); SWD does not need it.
    let encoder = Encoder(Qei::new(
        dp.TIM3,
        (gpiob.pb4.into_input(), gpiob.pb5),
        &mut rcc,
    ));

    let spi_bus = Spi::new(
        dp.SPI1,
        (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
        spi::Mode {
            polarity: spi::Polarity::IdleLow,
            phase: spi::Phase::CaptureOnSecondTransition,
        },
        ADC_SPI_HZ.Hz(),
        &mut rcc,
    );
    let cs = gpioa.pa4.into_push_pull_output_in_state(PinState::High);
    let delay = cp.SYST.delay(&rcc.clocks);
    let bus: AdcBus = match ExclusiveDevice::new(spi_bus, cs, delay) {
        Ok(bus) => bus,
        Err(never) => match never {},
    };
    let mut adc = Ads1220::new(bus, gpioa.pa3.into_floating_input());
    let adc_ok = adc.init(&ads1220::Config::BRIDGE_1KSPS);
    if let Err(e) = adc_ok {
        let what = match e {
            ads1220::Error::Spi(_) => "SPI error",
            ads1220::Error::DataReady(_) => "DRDY pin error",
            ads1220::Error::ConfigMismatch { .. } => "configuration read back wrong",
        };
        defmt::error!("bridge ADC: {=str}", what);
    }

    let controller = firmware::build_controller().map_err(BringUpError::Config)?;
    let sequence = firmware::sequence().map_err(BringUpError::Config)?;
    let mut drive = Drive::new(controller, encoder, adc, amp);
    if adc_ok.is_err() {
        drive.report_driver_failure();
    }
    if !crystal {
        drive.report_clock_failure();
    }
    let operator = Operator::new(
        gpioc.pc0.into_pull_up_input(),
        gpioc.pc1.into_pull_up_input(),
        sequence,
    );

    // The command link: USART1 on APB2 (84 MHz), interrupt-driven.
    let link = dp
        .USART1
        .serial(
            (gpioa.pa9, gpioa.pa10),
            serial::Config::default().baudrate(beam_drive::link::BAUD.bps()),
            &mut rcc,
        )
        .map_err(|_| BringUpError::Link)?;
    let (link_tx, mut link_rx) = link.split();
    link_rx.listen();
    let (commander, _) = firmware::BoardCommander::try_new(
        &firmware::TABLE,
        firmware::CONTROLLER,
        firmware::PAYLOAD_KG,
    )
    .map_err(|e| BringUpError::Config(BuildError::Setup(e)))?;

    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    // Halting in the debugger must not reset the drive.
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());

    let mut loop_timer = dp.TIM2.counter_hz(&mut rcc);
    loop_timer
        .start(LOOP_HZ.Hz())
        .map_err(|_| BringUpError::LoopTimer)?;
    loop_timer.listen(Event::Update);

    Ok(Board {
        drive,
        operator,
        loop_timer,
        watchdog,
        link_tx,
        link_rx,
        commander,
        crystal,
    })
}

/// The amplifier's PWM input: TIM1's channel 1 on PA8, edge-aligned at [`PWM_HZ`], the duty
/// in counts of the period (embedded-hal's [`SetDutyCycle`]).
///
/// Written over the registers rather than taken from the HAL's `pwm_hz`, which sets the
/// same registers but unwraps the `Result` of its auto-reload write: that one unwrap linked
/// `core::fmt`'s string and `Debug` formatting into the board, 976 B of flash for a message
/// no one reads (the panic handler prints the location only).
pub struct TorquePwm {
    tim: pac::TIM1,
    _pin: PwmPin,
}

impl TorquePwm {
    /// TIM1 clocked and reset, counting at [`PWM_HZ`] from the bus clock `rcc` set up, its
    /// channel 1 in PWM mode 1 with the duty zero, the output enabled (the main output at
    /// the first update, as the HAL's `pwm_hz` leaves it).
    pub fn new(tim: pac::TIM1, pin: PwmPin, rcc: &mut Rcc) -> Self {
        // Clock on and reset, as the HAL's timers do.
        let tim = Timer::new(tim, rcc).release();
        // The prescaler and period for the rate, as the HAL computes them: on the board's
        // 168 MHz the prescaler is 0 and the period `PWM_PERIOD_COUNTS`.
        let ticks = (pac::TIM1::timer_clock(&rcc.clocks).raw() / PWM_HZ).max(2);
        let psc = (ticks - 1) / (1 << 16);
        let arr = (ticks / (psc + 1) - 1).clamp(1, u16::MAX as u32) as u16;
        tim.cr1().modify(|_, w| w.arpe().set_bit());
        tim.psc().write(|w| w.psc().set(psc as u16));
        tim.arr().write(|w| w.arr().set(arr));
        tim.ccr1().write(|w| w.ccr().set(0));
        tim.ccmr1_output()
            .modify(|_, w| w.oc1pe().set_bit().oc1m().pwm_mode1());
        // Load the prescaler and the period now, without an update interrupt.
        tim.cr1().modify(|_, w| w.urs().set_bit());
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().modify(|_, w| w.urs().clear_bit());
        tim.ccer().modify(|_, w| w.cc1e().set_bit());
        tim.bdtr().modify(|_, w| w.aoe().set_bit());
        tim.cr1().modify(|_, w| w.cen().set_bit());
        Self { tim, _pin: pin }
    }
}

impl embedded_hal::pwm::ErrorType for TorquePwm {
    type Error = core::convert::Infallible;
}

impl SetDutyCycle for TorquePwm {
    fn max_duty_cycle(&self) -> u16 {
        (self.tim.arr().read().arr().bits()).wrapping_add(1)
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Self::Error> {
        self.tim.ccr1().write(|w| w.ccr().set(duty));
        Ok(())
    }
}

/// Turns the crystal oscillator on and waits for it a bounded time ([`HSE_READY_POLLS`]);
/// true if it is ready. If not, it is turned off again, and the MCU stays on its internal
/// oscillator.
fn crystal_starts(rcc: &pac::RCC) -> bool {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    for _ in 0..HSE_READY_POLLS {
        if rcc.cr().read().hserdy().bit_is_set() {
            return true;
        }
    }
    rcc.cr().modify(|_, w| w.hseon().clear_bit());
    false
}

/// Torque off through the registers, whatever state the HAL objects are in: enable low,
/// duty zero, TIM1's main output off. For the panic and HardFault handlers, where the
/// owners of these peripherals can no longer be trusted or reached.
pub fn safe_state() {
    // SAFETY: single writes to a set/reset register and to TIM1's compare and break
    // registers. They race with nothing: the handlers that call this never return, and a
    // tick that preempts them writes the same safe values (the controller is faulted or its
    // state is being abandoned).
    unsafe {
        let gpiob = &*pac::GPIOB::ptr();
        gpiob
            .bsrr()
            .write(|w| w.bits(1 << (16 + ENABLE_PIN as u32)));
        let tim1 = &*pac::TIM1::ptr();
        tim1.ccr1().write(|w| w.bits(0));
        tim1.bdtr().modify(|_, w| w.moe().clear_bit());
    }
}

/// Clears a USART1 overrun whose byte is gone: ORE set with RXNE clear (a byte arrived while
/// the last was unread, and that one has since been read). ORE raises the receive interrupt
/// too, and with nothing to read the link's handler would return straight into it for ever:
/// idle, where commands are answered, would never run again while the tick kept feeding the
/// watchdog. Reading the data register after the status register clears it; with RXNE clear
/// there is no byte to lose. For the link's interrupt, which owns the receiver.
pub fn clear_link_overrun() {
    // SAFETY: reads of USART1's status and data registers. The data register is read only
    // when the status says there is no received byte in it, from the interrupt that owns the
    // receiver (nothing else reads it).
    unsafe {
        let usart = &*pac::USART1::ptr();
        let sr = usart.sr().read();
        if sr.ore().bit_is_set() && sr.rxne().bit_is_clear() {
            let _ = usart.dr().read();
        }
    }
}
