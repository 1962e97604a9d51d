//! One tick of the drive, over generic sensors and actuator: read encoder, strain and the
//! actuator's fault line, call model-core's `step`, write the torque, return telemetry
//! (docs/design.md, section 8).
//!
//! This is the whole of the firmware's per-tick work apart from the board's timer flag and
//! watchdog. It is generic over three roles, each a small trait: a [`QuadratureCounter`], a
//! [`StrainSensor`] (the ADS1220 driver) and an [`Actuator`] (the amplifier driver), so the
//! same code runs on the STM32F405 board, in the PIL drive and in host tests (both over
//! [`crate::fakes`]). It never blocks, allocates or panics: every driver error becomes a
//! latched [`model_core::FaultFlags::DRIVER`] fault and the actuator is disabled.

pub use crate::ads1220::Sample;
use model_core::law::{LawSet, ALL_LAWS};
use model_core::{
    CommandError, Controller, FaultFlags, Mode, RawMeasurement, Spline, TorqueCommand,
};

/// A hardware quadrature counter. embedded-hal 1.0 has no encoder trait, so this is the one
/// the drive needs: the raw counter value, which wraps at the counter's width.
pub trait QuadratureCounter {
    /// The counter now.
    fn count(&mut self) -> u32;
}

/// The strain bridge's converter, polled once per tick.
pub trait StrainSensor {
    /// A bus or pin failure.
    type Error;
    /// The newest sample, or the last one with its stale count raised when no new conversion
    /// is ready. Never blocks.
    fn poll(&mut self) -> Result<Sample, Self::Error>;
    /// The last sample, without touching the hardware.
    fn last(&self) -> Sample;
}

/// The torque actuator: the motor amplifier.
pub trait Actuator {
    /// A signal that could not be set.
    type Error;
    /// Applies one tick's command: its torque while slewing or holding, disabled otherwise.
    fn apply(&mut self, cmd: &TorqueCommand) -> Result<(), Self::Error>;
    /// Removes the torque at once.
    fn disable(&mut self) -> Result<(), Self::Error>;
    /// The actuator reports a fault (a line that cannot be read counts as one).
    fn faulted(&mut self) -> bool;
}

/// Consecutive ticks without a new strain conversion before the data counts as lost. At
/// 1000 samples/s against a 1 kHz loop a miss is normal now and then, two in a row are rare,
/// and five (5 ms without strain, a tenth of the first mode's period) is a converter that
/// stopped.
pub const MAX_STALE_TICKS: u16 = 5;

/// A command from the operator, applied between ticks.
#[derive(Clone, Debug, PartialEq)]
pub enum Command<const K: usize> {
    /// Run this move (it must start where the hub is).
    Move(Spline<K>),
    /// Clear latched faults; the drive returns to idle with torque off.
    ClearFault,
}

/// What one tick did, for the telemetry queue.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Telemetry {
    /// Tick number since power-on (the time is `tick * ts`).
    pub tick: u32,
    /// The raw encoder counter.
    pub encoder_raw: u32,
    /// The strain converter's code.
    pub strain_code: i32,
    /// Torque commanded, N m.
    pub torque_nm: f32,
    /// Hub angle, rad.
    pub theta_rad: f32,
    /// Reference angle, rad.
    pub theta_ref_rad: f32,
    /// Root strain, offset removed.
    pub strain: f32,
    /// Controller mode.
    pub mode: Mode,
    /// Latched faults.
    pub faults: FaultFlags,
}

#[cfg(target_os = "none")]
impl Telemetry {
    /// Writes the sample to defmt in the fixed `tlm` format that `beam telemetry` turns into
    /// the CSV `beam calibrate` reads: tick, encoder count, strain code, torque, angle,
    /// reference, strain, mode (0 idle, 1 slewing, 2 holding, 3 fault), fault bits.
    pub fn log(&self) {
        defmt::info!(
            "tlm {=u32} {=u32} {=i32} {=f32} {=f32} {=f32} {=f32} {=u8} {=u16}",
            self.tick,
            self.encoder_raw,
            self.strain_code,
            self.torque_nm,
            self.theta_rad,
            self.theta_ref_rad,
            self.strain,
            self.mode as u8,
            self.faults.0
        );
    }
}

/// The controller with its sensors and actuator.
pub struct Drive<const K: usize, Q, S, A> {
    controller: Controller<K>,
    encoder: Q,
    strain: S,
    actuator: A,
    /// A driver failed on the previous tick (reported to `step` on this one).
    driver_failed: bool,
    /// The board runs on a clock it cannot drive on ([`Drive::report_clock_failure`]).
    clock_failed: bool,
}

impl<const K: usize, Q, S, A> Drive<K, Q, S, A>
where
    Q: QuadratureCounter,
    S: StrainSensor,
    A: Actuator,
{
    /// Puts the parts together. The strain sensor must already be initialised and the
    /// actuator disabled (as [`Amplifier::new`](crate::amplifier::Amplifier::new) leaves
    /// it); the controller starts idle.
    pub fn new(controller: Controller<K>, encoder: Q, strain: S, actuator: A) -> Self {
        Self {
            controller,
            encoder,
            strain,
            actuator,
            driver_failed: false,
            clock_failed: false,
        }
    }

    /// One control tick. Never blocks or panics.
    #[inline(always)] // the call is to `tick_in`, as the board's is
    pub fn tick(&mut self) -> Telemetry {
        self.tick_in::<ALL_LAWS>()
    }

    /// [`Drive::tick`] in a build that holds the laws `LAWS` only (the board's, whose
    /// controller's law was built in that set): no other law's arm in the dispatch.
    pub fn tick_in<const LAWS: LawSet>(&mut self) -> Telemetry {
        let encoder_raw = self.encoder.count();
        let (sample, adc_ok) = match self.strain.poll() {
            Ok(s) => (s, s.stale_polls <= MAX_STALE_TICKS),
            Err(_) => (self.strain.last(), false),
        };
        let amp_fault = self.actuator.faulted();
        let raw = RawMeasurement {
            encoder_raw,
            strain_root_code: sample.code,
            amp_fault,
            driver_fault: self.driver_failed || !adc_ok,
        };
        if self.clock_failed {
            // Every tick: `clear` cannot bring the torque back on a bad clock.
            self.controller.latch(FaultFlags::CLOCK);
        }
        let cmd = self.controller.step_in::<LAWS>(&raw);
        self.driver_failed = self.actuator.apply(&cmd).is_err();
        if self.driver_failed {
            // Best effort: whichever signal still works turns the torque off, and the next
            // tick latches the driver fault.
            let _ = self.actuator.disable();
        }
        Telemetry {
            // The controller counts its ticks (from 1 after the first): this one's number.
            tick: self.controller.uptime_ticks().wrapping_sub(1),
            encoder_raw,
            strain_code: sample.code,
            torque_nm: if self.driver_failed {
                0.0
            } else {
                cmd.torque_nm
            },
            theta_rad: cmd.theta_rad,
            theta_ref_rad: cmd.theta_ref_rad,
            strain: cmd.strain,
            mode: cmd.mode,
            faults: cmd.faults,
        }
    }

    /// Applies an operator command; it takes effect at the next tick.
    pub fn command(&mut self, cmd: Command<K>) -> Result<(), CommandError> {
        match cmd {
            Command::Move(spline) => {
                self.controller.set_spline(spline)?;
                self.controller.start_move()
            }
            Command::ClearFault => {
                self.controller.reset();
                self.driver_failed = false;
                Ok(())
            }
        }
    }

    /// Latches a driver fault at the next tick: for failures found outside the tick, such as
    /// a converter that did not configure at start-up.
    pub fn report_driver_failure(&mut self) {
        self.driver_failed = true;
    }

    /// Latches the clock fault from the next tick on, for good: the board's crystal did not
    /// start and it runs on its internal oscillator (see the firmware's clock start-up). The
    /// drive answers commands and reports, and never drives.
    pub fn report_clock_failure(&mut self) {
        self.clock_failed = true;
    }

    /// The controller (mode, faults, settings).
    pub fn controller(&self) -> &Controller<K> {
        &self.controller
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u32 {
        self.controller.uptime_ticks()
    }

    /// The last strain sample.
    pub fn last_strain(&self) -> Sample {
        self.strain.last()
    }
}

impl<Q, S, A> Drive<{ model_core::planner::SHAPED_PLAN_KNOTS }, Q, S, A>
where
    Q: QuadratureCounter,
    S: StrainSensor,
    A: Actuator,
{
    /// Carries out a command of the wire protocol through `commander` (between ticks; it
    /// takes effect at the next one). Clearing a fault also clears a driver failure.
    pub fn handle<const LAWS: LawSet>(
        &mut self,
        commander: &mut model_core::commands::CommanderIn<'_, LAWS>,
        request: &beam_wire::command::Request,
    ) -> beam_wire::command::Reply {
        let reply = commander.handle(&mut self.controller, request);
        if request.command == beam_wire::command::Command::ClearFault {
            self.driver_failed = false;
        }
        reply
    }

    /// What a command needs to know of the controller ([`Controller::snapshot`]).
    pub fn snapshot(&self) -> model_core::Snapshot {
        self.controller.snapshot()
    }

    /// Swaps in an action prepared outside the tick
    /// ([`Commander::prepare`](model_core::commands::Commander::prepare)), whole.
    pub fn apply<const LAWS: LawSet>(
        &mut self,
        commander: &mut model_core::commands::CommanderIn<'_, LAWS>,
        action: model_core::commands::Action,
    ) -> Result<beam_wire::command::Outcome, beam_wire::command::Refusal> {
        let clear = action == model_core::commands::Action::ClearFault;
        let outcome = commander.apply(action, &mut self.controller);
        if clear {
            self.driver_failed = false;
            // A bad clock is not cleared: the next status says so, not just the next tick.
            if self.clock_failed {
                self.controller.latch(FaultFlags::CLOCK);
            }
        }
        outcome
    }
}
