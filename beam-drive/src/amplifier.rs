//! The motor amplifier as a torque actuator: PWM duty for the magnitude, a direction pin for
//! the sign, an enable pin that must be high for any current to flow, and the amplifier's
//! own /FAULT output (active low, open drain).
//!
//! The amplifier is a current (torque) mode drive: its current set-point is proportional to
//! the PWM duty, so torque = duty * full-scale torque. That one scaling lives in
//! [`TorqueScale`]; nothing else in the firmware converts torque to duty. Generic over
//! `embedded-hal` 1.0's [`SetDutyCycle`], [`OutputPin`] and [`InputPin`], so the board passes
//! its timer channel and GPIOs and the host tests pass mocks; the drive sees it as an
//! [`Actuator`](crate::drive::Actuator).

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::pwm::SetDutyCycle;
use model_core::{Mode, TorqueCommand};

/// Torque at 100 % duty, the amplifier's full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueScale {
    /// N m at full duty; positive and finite.
    pub full_scale_nm: f32,
}

/// The duty and direction for one torque.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Drive {
    /// Duty in counts of the PWM's `max_duty`.
    pub duty: u16,
    /// True for positive torque.
    pub positive: bool,
}

impl TorqueScale {
    /// The duty (in `max_duty` counts, rounded to nearest) and direction for `torque_nm`.
    /// Torques past full scale saturate; a non-finite torque gives zero duty.
    pub fn duty(&self, torque_nm: f32, max_duty: u16) -> Drive {
        let fraction = if torque_nm.is_finite() && self.full_scale_nm > 0.0 {
            let f = libm::fabsf(torque_nm) / self.full_scale_nm;
            // A comparison, not `min`: that is a library call on the Cortex-M4F.
            if f > 1.0 {
                1.0
            } else {
                f
            }
        } else {
            0.0
        };
        Drive {
            // Round half up by adding 0.5 and truncating: the same result as `roundf`
            // except within an ulp of a half, without its library call on the tick. The sum
            // is within [0.5, 65535.5] (`fraction` is within [0, 1], `max_duty` a u16), so it
            // truncates into a u16 as it is: through `u32`, one saturating VCVT on the
            // Cortex-M4F, without the compares a saturating cast to `u16` adds.
            duty: (fraction * max_duty as f32 + 0.5) as u32 as u16,
            positive: torque_nm >= 0.0,
        }
    }
}

/// Which of the amplifier's signals failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<P, D, E> {
    /// Setting the PWM duty failed.
    Pwm(P),
    /// Setting the direction pin failed.
    Direction(D),
    /// Setting the enable pin failed.
    Enable(E),
}

/// The amplifier's three inputs and its fault output. `REVERSED`: positive torque needs the
/// direction pin low (the table's `[drive]` `torque_reversed`); a constant, so the tick
/// does no more work for it.
#[derive(Debug)]
pub struct Amplifier<PWM, DIR, EN, FLT, const REVERSED: bool = false> {
    pwm: PWM,
    dir: DIR,
    en: EN,
    fault: FLT,
    scale: TorqueScale,
}

/// The error type of an [`Amplifier`] over these pins.
pub type AmpError<PWM, DIR, EN> = Error<
    <PWM as embedded_hal::pwm::ErrorType>::Error,
    <DIR as embedded_hal::digital::ErrorType>::Error,
    <EN as embedded_hal::digital::ErrorType>::Error,
>;

impl<PWM: SetDutyCycle, DIR: OutputPin, EN: OutputPin, FLT: InputPin, const REVERSED: bool>
    Amplifier<PWM, DIR, EN, FLT, REVERSED>
{
    /// Takes the signals and puts the amplifier in its safe state (disabled, zero duty).
    pub fn new(
        pwm: PWM,
        dir: DIR,
        en: EN,
        fault: FLT,
        scale: TorqueScale,
    ) -> Result<Self, AmpError<PWM, DIR, EN>> {
        let mut amp = Self {
            pwm,
            dir,
            en,
            fault,
            scale,
        };
        amp.disable()?;
        Ok(amp)
    }

    /// Enable low first (the amplifier stops at once), then zero duty.
    pub fn disable(&mut self) -> Result<(), AmpError<PWM, DIR, EN>> {
        let en = self.en.set_low().map_err(Error::Enable);
        let pwm = self.pwm.set_duty_cycle(0).map_err(Error::Pwm);
        en.and(pwm)
    }

    /// Applies one tick's command: torque while slewing or holding, disabled otherwise.
    pub fn apply(&mut self, cmd: &TorqueCommand) -> Result<(), AmpError<PWM, DIR, EN>> {
        if !matches!(cmd.mode, Mode::Slewing | Mode::Holding) {
            return self.disable();
        }
        let d = self.scale.duty(cmd.torque_nm, self.pwm.max_duty_cycle());
        // Direction before duty, duty before enable: no instant drives the old duty the
        // new way round.
        self.dir
            .set_state((d.positive != REVERSED).into())
            .map_err(Error::Direction)?;
        self.pwm.set_duty_cycle(d.duty).map_err(Error::Pwm)?;
        self.en.set_high().map_err(Error::Enable)
    }

    /// The amplifier reports a fault. Its /FAULT output is active low and open drain, so a
    /// broken wire or an unreadable pin reads as a fault too.
    pub fn faulted(&mut self) -> bool {
        self.fault.is_high().map(|high| !high).unwrap_or(true)
    }

    /// The torque scaling.
    pub fn scale(&self) -> TorqueScale {
        self.scale
    }
}

impl<PWM: SetDutyCycle, DIR: OutputPin, EN: OutputPin, FLT: InputPin, const REVERSED: bool>
    crate::drive::Actuator for Amplifier<PWM, DIR, EN, FLT, REVERSED>
{
    type Error = AmpError<PWM, DIR, EN>;

    fn apply(&mut self, cmd: &TorqueCommand) -> Result<(), Self::Error> {
        Amplifier::apply(self, cmd)
    }

    fn disable(&mut self) -> Result<(), Self::Error> {
        Amplifier::disable(self)
    }

    fn faulted(&mut self) -> bool {
        Amplifier::faulted(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
    use embedded_hal_mock::eh1::pwm::{Mock as PwmMock, Transaction as Pwm};
    use embedded_hal_mock::eh1::MockError;
    use model_core::FaultFlags;

    const SCALE: TorqueScale = TorqueScale {
        full_scale_nm: 10.0,
    };

    /// A released /FAULT line (these tests drive the outputs).
    fn released() -> crate::fakes::Line<'static> {
        crate::fakes::Line(Box::leak(Box::default()))
    }

    #[test]
    fn the_fault_line_is_active_low_and_an_unreadable_line_is_a_fault() {
        let bench = crate::fakes::Bench::new();
        let mut amp = Amplifier::<_, _, _, _, false>::new(
            crate::fakes::Pwm(&bench),
            crate::fakes::Direction(&bench),
            crate::fakes::Enable(&bench),
            crate::fakes::Line(&bench),
            SCALE,
        )
        .unwrap();
        assert!(!amp.faulted());
        bench.amp_fault.set(true);
        assert!(amp.faulted());
        bench.amp_fault.set(false);
        bench.inputs_broken.set(true);
        assert!(amp.faulted());
    }

    fn command(mode: Mode, torque_nm: f32) -> TorqueCommand {
        TorqueCommand {
            torque_nm,
            mode,
            ..Default::default()
        }
    }

    #[test]
    fn duty_is_proportional_saturates_and_rejects_non_finite() {
        let d = |t| SCALE.duty(t, 4200);
        assert_eq!(
            d(5.0),
            Drive {
                duty: 2100,
                positive: true
            }
        );
        assert_eq!(
            d(-2.5),
            Drive {
                duty: 1050,
                positive: false
            }
        );
        assert_eq!(d(25.0).duty, 4200);
        assert_eq!(
            d(-25.0),
            Drive {
                duty: 4200,
                positive: false
            }
        );
        assert_eq!(d(f32::NAN).duty, 0);
        assert_eq!(d(f32::INFINITY).duty, 0);
        // One LSB of duty is 10/4200 N m; half of one rounds up.
        assert_eq!(d(10.0 / 4200.0 * 0.5).duty, 1);
        // The widest timer: full scale and past it are its top count, not a wrap to 0.
        for t in [10.0, 25.0, -25.0, f32::MAX] {
            assert_eq!(SCALE.duty(t, u16::MAX).duty, u16::MAX);
        }
        assert_eq!(SCALE.duty(0.0, u16::MAX).duty, 0);
    }

    /// Starts disabled, then each torque sets direction, duty and enable in that order, and
    /// a fault disables: the pin's level is the torque's sign, the other way when `REVERSED`.
    fn direction_duty_then_enable<const REVERSED: bool>() {
        let level = |positive: bool| {
            if positive != REVERSED {
                State::High
            } else {
                State::Low
            }
        };
        let mut pwm = PwmMock::new(&[
            Pwm::set_duty_cycle(0),
            Pwm::max_duty_cycle(4200),
            Pwm::set_duty_cycle(1260),
            Pwm::max_duty_cycle(4200),
            Pwm::set_duty_cycle(4200),
            Pwm::set_duty_cycle(0),
        ]);
        let mut dir = PinMock::new(&[Pin::set(level(false)), Pin::set(level(true))]);
        let mut en = PinMock::new(&[
            Pin::set(State::Low),
            Pin::set(State::High),
            Pin::set(State::High),
            Pin::set(State::Low),
        ]);
        let mut amp = Amplifier::<_, _, _, _, REVERSED>::new(
            pwm.clone(),
            dir.clone(),
            en.clone(),
            released(),
            SCALE,
        )
        .unwrap();
        amp.apply(&command(Mode::Slewing, -3.0)).unwrap();
        amp.apply(&command(Mode::Holding, 12.0)).unwrap();
        amp.apply(&TorqueCommand {
            faults: FaultFlags::AMP_FAULT,
            ..command(Mode::Fault, 0.0)
        })
        .unwrap();
        pwm.done();
        dir.done();
        en.done();
    }

    #[test]
    fn new_starts_disabled_and_torque_sets_direction_duty_then_enable() {
        direction_duty_then_enable::<false>();
    }

    #[test]
    fn a_reversed_amplifier_sets_the_direction_pin_the_other_way() {
        direction_duty_then_enable::<true>();
    }

    #[test]
    fn idle_never_enables_even_with_a_torque() {
        let mut pwm = PwmMock::new(&[Pwm::set_duty_cycle(0), Pwm::set_duty_cycle(0)]);
        let mut dir = PinMock::new(&[]);
        let mut en = PinMock::new(&[Pin::set(State::Low), Pin::set(State::Low)]);
        let mut amp = Amplifier::<_, _, _, _, false>::new(
            pwm.clone(),
            dir.clone(),
            en.clone(),
            released(),
            SCALE,
        )
        .unwrap();
        amp.apply(&command(Mode::Idle, 3.0)).unwrap();
        pwm.done();
        dir.done();
        en.done();
    }

    #[test]
    fn a_failing_enable_pin_still_zeroes_the_duty_and_is_reported() {
        let err = MockError::Io(std::io::ErrorKind::Other);
        let mut pwm = PwmMock::new(&[Pwm::set_duty_cycle(0)]);
        let mut dir = PinMock::new(&[]);
        let mut en = PinMock::new(&[Pin::set(State::Low).with_error(err.clone())]);
        let result = Amplifier::<_, _, _, _, false>::new(
            pwm.clone(),
            dir.clone(),
            en.clone(),
            released(),
            SCALE,
        );
        assert!(matches!(result, Err(Error::Enable(_))));
        pwm.done();
        dir.done();
        en.done();
    }
}
