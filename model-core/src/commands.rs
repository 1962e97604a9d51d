//! The drive's command handler: what a [`Request`] of the wire protocol does to a running
//! [`Controller`], once, for the firmware and for the host alike (docs/design.md, section 10).
//!
//! It runs outside the 1 kHz tick, between ticks (the board calls it from its lower-priority
//! link task, and the tick only ever sees a finished, validated spline or law swapped in
//! whole). Moves are planned by [`crate::planner`] from the hub's last measured angle with
//! the drive's limits; gains and the shaper come from the compiled gain table, scheduled on
//! the payload. The policy for a command that arrives mid-move is to refuse it
//! ([`Refusal::Busy`]), except `Stop`, `Disable`, `Status` and `Stream`: nothing queues.
//!
//! A command's effect is decided when it is answered: a move answered `Moving` is the
//! running move for every later command, though it starts on the next tick (`Stop` cuts it
//! at its start, a second move or a payload is `Busy`). A move starts from rest
//! ([`Refusal::HubMoving`] while the hub turns faster than
//! [`crate::controller::REST_RAD_S`]); `Stop` with no move running but the hub turning (the
//! torque was off) brakes it, so that a hub that coasted out of the range can be stopped and
//! then moved back into it.

use crate::controller::{Controller, Mode, Snapshot};
use crate::error::{CommandError, PlanError};
use crate::law::{ControlLaw, LawKind, LawSet, ALL_LAWS};
use crate::planner::{
    plan_brake, plan_stop, plan_through, Limits, Plan, Waypoint, SHAPED_PLAN_KNOTS,
};
use crate::plant::Plant;
use crate::shaper::Shaper;
use crate::table::DriveTable;
pub use crate::table::SetupError;
pub use beam_wire::command::{Command, Outcome, Refusal, Reply, Request, Status};

/// The controller a commanded drive runs: its moves are planned, shaped moves.
pub type CommandedController = Controller<SHAPED_PLAN_KNOTS>;

/// What the handler keeps between commands: the drive's table, the law, and what is
/// scheduled for the present payload; in a build that holds the laws `LAWS` ([`LawSet`]: the
/// board's holds its own alone, [`Commander`] every law).
#[derive(Clone, Debug, PartialEq)]
pub struct CommanderIn<'t, const LAWS: LawSet> {
    table: &'t DriveTable<'t>,
    kind: LawKind,
    payload_kg: f32,
    limits: Limits,
    shaper: Shaper,
    stream_every: u16,
    /// The move running or last run, with its base (a stop cuts the base).
    current: Option<Plan>,
}

/// The command handler of a build that holds every law (the host's, the PIL drive's).
pub type Commander<'t> = CommanderIn<'t, ALL_LAWS>;

impl<'t, const LAWS: LawSet> CommanderIn<'t, LAWS> {
    /// The handler for `kind` on `table`'s drive carrying `payload_kg`, with the law to build
    /// the controller with. An observer law (lqg, smc-modal) needs the `observer` feature and
    /// the table's designs; without them it is refused.
    pub fn try_new(
        table: &'t DriveTable<'t>,
        kind: LawKind,
        payload_kg: f32,
    ) -> Result<(Self, ControlLaw), SetupError> {
        let (law, shaper, limits) = table.configure::<LAWS>(kind, payload_kg)?;
        let me = Self {
            table,
            kind,
            payload_kg,
            limits,
            shaper,
            stream_every: 0,
            current: None,
        };
        Ok((me, law))
    }

    /// The plant the drive is built for.
    pub fn plant(&self) -> &'t Plant {
        self.table.plant
    }

    /// The drive's configuration.
    pub fn table(&self) -> &'t DriveTable<'t> {
        self.table
    }

    /// The planner's limits for the present payload.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The shaper every move is planned with.
    pub fn shaper(&self) -> &Shaper {
        &self.shaper
    }

    /// The payload the gains are scheduled for, kg.
    pub fn payload_kg(&self) -> f32 {
        self.payload_kg
    }

    /// Telemetry decimation, ticks per record (0: off).
    pub fn stream_every(&self) -> u16 {
        self.stream_every
    }

    /// Carries out `req` on `ctl` and answers it. Changes nothing unless the reply says so.
    /// The same as [`Commander::prepare`] on a snapshot of `ctl` followed at once by
    /// [`Commander::apply`].
    pub fn handle(&mut self, ctl: &mut CommandedController, req: &Request) -> Reply {
        let outcome = self
            .prepare(&req.command, &ctl.snapshot())
            .and_then(|action| self.apply(action, ctl));
        Reply {
            seq: req.seq,
            outcome: outcome.unwrap_or_else(Outcome::Refused),
        }
    }

    /// The slow half of a command, which needs no access to the running controller: the
    /// planning, the scheduling and the checks, from `snap` (a board runs it in its link
    /// task while the tick goes on). A stop is cut at `snap.move_elapsed_s`; a caller that
    /// applies it later passes a snapshot taken that much ahead (see [`Action::Stop`]).
    pub fn prepare(&self, command: &Command, snap: &Snapshot) -> Result<Action, Refusal> {
        let ready = match snap.mode {
            Mode::Fault => Err(Refusal::Faulted),
            // A gauge fault leaves the drive holding on its own law: no new move until the
            // fault is cleared.
            _ if !snap.faults.is_empty() => Err(Refusal::Faulted),
            Mode::Slewing => Err(Refusal::Busy),
            Mode::Idle | Mode::Holding => Ok(()),
        };
        match command {
            Command::MoveTo { to_rad, time_s } => {
                ready?;
                let target = [Waypoint {
                    rad: *to_rad,
                    at_s: None,
                }];
                self.plan(snap, &target, *time_s)
            }
            Command::MoveThrough { waypoints, time_s } => {
                ready?;
                let mut points = [Waypoint {
                    rad: 0.0,
                    at_s: None,
                }; crate::planner::MAX_WAYPOINTS];
                for (p, w) in points.iter_mut().zip(waypoints.iter()) {
                    *p = Waypoint {
                        rad: w.rad,
                        at_s: w.at_s,
                    };
                }
                // (`get`: no bounds-check panic; the wire holds at most MAX_WAYPOINTS.)
                let points = points.get(..waypoints.len()).unwrap_or(&[]);
                self.plan(snap, points, *time_s)
            }
            Command::SetPayload { kg } => {
                ready?;
                let (law, shaper, limits) =
                    self.table
                        .configure::<LAWS>(self.kind, *kg)
                        .map_err(|e| match e {
                            SetupError::NoGains => Refusal::NoGains,
                            SetupError::Payload | SetupError::Gains(_) => Refusal::BadArgument,
                        })?;
                Ok(Action::SetPayload(Schedule {
                    payload_kg: *kg,
                    law,
                    shaper,
                    limits,
                }))
            }
            Command::Stop => {
                // Refused while the hub turns only in Fault (whose torque stays off until
                // `clear`): a move of this handler's is cut on its own plan, anything else (a
                // hub coasting with the torque off, a hold that lost its hub, a move the
                // handler has no plan for, one whose cut cannot be planned) is braked by the
                // drive's brake. (A button's move started after a commanded one is taken for
                // that one here, and `apply` refuses the cut `NotMoving`.)
                if snap.mode == Mode::Fault {
                    return Err(Refusal::Faulted);
                }
                let brake = || {
                    plan_brake(snap.theta_rad, snap.omega_rad_s, &self.limits)
                        .map(Action::Brake)
                        .map_err(plan_refusal)
                };
                if snap.mode != Mode::Slewing {
                    if at_rest(snap).is_ok() {
                        return Err(Refusal::NotMoving);
                    }
                    return brake();
                }
                let Some(current) = self.current.as_ref() else {
                    return brake();
                };
                // The next tick evaluates the move at the elapsed time (it has counted this
                // tick).
                match plan_stop(current, snap.move_elapsed_s, &self.limits) {
                    Ok(stopped) => Ok(Action::Stop {
                        plan: stopped,
                        cut_s: snap.move_elapsed_s,
                    }),
                    Err(_) => brake(),
                }
            }
            Command::Disable => Ok(Action::Disable),
            Command::ClearFault => Ok(Action::ClearFault),
            Command::Status => Ok(Action::Status),
            Command::Stream { every } => Ok(Action::Stream(*every)),
        }
    }

    /// The quick half: swaps what [`Commander::prepare`] made into `ctl`, whole (a board
    /// runs it with the tick held off for the copy, microseconds). Rechecks the state, which
    /// may have moved on since the snapshot: a move that ended or a fault latched refuses
    /// what no longer fits, and a stop whose cut time has passed is [`Refusal::Busy`] (take a
    /// new snapshot further ahead and prepare again).
    pub fn apply(
        &mut self,
        action: Action,
        ctl: &mut CommandedController,
    ) -> Result<Outcome, Refusal> {
        match action {
            Action::Start(plan) => {
                // Checked before anything is swapped, so a refusal changes nothing.
                match ctl.mode() {
                    Mode::Fault => return Err(Refusal::Faulted),
                    Mode::Slewing => return Err(Refusal::Busy),
                    Mode::Idle | Mode::Holding => {}
                }
                let duration_s = plan.shaped.duration_s();
                ctl.set_spline(plan.shaped.clone()).map_err(refusal)?;
                ctl.start_move().map_err(refusal)?;
                self.current = Some(plan);
                Ok(Outcome::Moving { duration_s })
            }
            Action::Stop { plan, cut_s } => {
                // Only the move this handler started can be stopped by cutting its base (a
                // move started otherwise, by a button, has no base here).
                let running_ours = self
                    .current
                    .as_ref()
                    .is_some_and(|c| ctl.spline() == &c.shaped);
                if ctl.mode() != Mode::Slewing || !running_ours {
                    return Err(Refusal::NotMoving);
                }
                if ctl.move_elapsed_s() > cut_s {
                    return Err(Refusal::Busy);
                }
                let duration_s = plan.shaped.duration_s();
                ctl.replace_move(plan.shaped.clone()).map_err(refusal)?;
                self.current = Some(plan);
                Ok(Outcome::Moving { duration_s })
            }
            Action::Brake(plan) => {
                let duration_s = plan.shaped.duration_s();
                ctl.start_brake(plan.shaped.clone()).map_err(refusal)?;
                self.current = Some(plan);
                Ok(Outcome::Moving { duration_s })
            }
            Action::SetPayload(s) => {
                ctl.set_law(s.law).map_err(refusal)?;
                (self.payload_kg, self.shaper, self.limits) = (s.payload_kg, s.shaper, s.limits);
                Ok(Outcome::Done)
            }
            Action::Disable => {
                ctl.disable();
                Ok(Outcome::Done)
            }
            Action::ClearFault => {
                // (A gauge fault latches in Holding or Slewing: cleared all the same, to Idle.)
                if ctl.mode() == Mode::Fault || !ctl.faults().is_empty() {
                    ctl.reset();
                }
                Ok(Outcome::Done)
            }
            Action::Status => Ok(Outcome::Status(self.status(ctl))),
            Action::Stream(every) => {
                self.stream_every = every;
                Ok(Outcome::Done)
            }
        }
    }

    /// Plans the move from the hub's last measured angle, with the hub at rest.
    fn plan(
        &self,
        snap: &Snapshot,
        waypoints: &[Waypoint],
        time_s: Option<f32>,
    ) -> Result<Action, Refusal> {
        at_rest(snap)?;
        start(plan_through(
            snap.theta_rad,
            waypoints,
            time_s,
            &self.shaper,
            &self.limits,
        ))
    }

    /// The drive's state.
    pub fn status(&self, ctl: &CommandedController) -> Status {
        Status {
            mode: ctl.mode() as u8,
            faults: ctl.faults().0,
            theta_rad: ctl.theta_rad(),
            omega_rad_s: ctl.omega_rad_s(),
            strain: ctl.strain(),
            move_elapsed_s: ctl.move_elapsed_s(),
            move_duration_s: ctl.spline().duration_s(),
            payload_kg: self.payload_kg,
            law: Some(self.kind),
            stream_every: self.stream_every,
            ticks: ctl.uptime_ticks(),
        }
    }
}

/// A command made ready to swap in: the output of [`Commander::prepare`].
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Start this move.
    Start(Plan),
    /// Replace the running move by this stop, cut at `cut_s` into the move; only while
    /// the move has not passed it.
    Stop {
        /// The stopped move.
        plan: Plan,
        /// Where it leaves the running move, s since the move started.
        cut_s: f32,
    },
    /// Brake the hub along this plan, in place of whatever runs
    /// ([`Controller::start_brake`]): it starts where its first tick finds the hub.
    Brake(Plan),
    /// Use these gains, shaper and limits.
    SetPayload(Schedule),
    /// Torque off.
    Disable,
    /// Clear latched faults.
    ClearFault,
    /// Report.
    Status,
    /// Set the telemetry decimation.
    Stream(u16),
}

/// What is scheduled for a payload.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// The payload, kg.
    pub payload_kg: f32,
    /// Its law.
    pub law: ControlLaw,
    /// Its shaper.
    pub shaper: Shaper,
    /// Its planner limits.
    pub limits: Limits,
}

/// A move starts from rest: refused while the hub turns faster than
/// [`crate::controller::REST_RAD_S`] (after `Disable`, a hub may coast for seconds).
fn at_rest(snap: &Snapshot) -> Result<(), Refusal> {
    if libm::fabsf(snap.omega_rad_s) > crate::controller::REST_RAD_S {
        return Err(Refusal::HubMoving);
    }
    Ok(())
}

/// A plan to start, or the refusal its planning error means.
fn start(plan: Result<Plan, PlanError>) -> Result<Action, Refusal> {
    plan.map(Action::Start).map_err(plan_refusal)
}

fn plan_refusal(e: PlanError) -> Refusal {
    match e {
        PlanError::TooFast { needs_s } => Refusal::TooFast { needs_s },
        PlanError::OutOfRange { rad, .. } => Refusal::OutOfRange { rad },
        PlanError::TooLong { max_s } => Refusal::TooLong { max_s },
        PlanError::NoWaypoints
        | PlanError::TooManyWaypoints { .. }
        | PlanError::NonFinite
        | PlanError::MixedTimes
        | PlanError::TimesNotIncreasing
        | PlanError::BadLimits
        | PlanError::Unplannable
        | PlanError::Spline(_)
        | PlanError::Shaper(_) => Refusal::BadArgument,
    }
}

fn refusal(e: CommandError) -> Refusal {
    match e {
        CommandError::Faulted => Refusal::Faulted,
        CommandError::Busy => Refusal::Busy,
        CommandError::NotMoving => Refusal::NotMoving,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::RawMeasurement;
    use crate::spline::Spline;

    fn drive() -> (Commander<'static>, CommandedController) {
        let rows = crate::table::tests::rows(LawKind::PdFf, &[0.0, 0.05]);
        let table = crate::table::tests::table(rows);
        let (commander, law) = Commander::try_new(table, LawKind::PdFf, 0.0).unwrap();
        let rest = Spline::try_build(&[(0.0, 0.0), (1.0, 0.0)]).unwrap();
        let ctl = Controller::try_build(table.settings(0.0), law, rest).unwrap();
        (commander, ctl)
    }

    #[test]
    fn an_action_prepared_earlier_is_refused_whole_when_the_state_has_moved_on() {
        let (mut c, mut ctl) = drive();
        let raw = RawMeasurement::default();
        ctl.step(&raw);
        // A move prepared while idle, applied after a fault latched: refused, nothing swapped.
        let go = Command::MoveTo {
            to_rad: 0.5,
            time_s: None,
        };
        let action = c.prepare(&go, &ctl.snapshot()).unwrap();
        let faulted = RawMeasurement {
            amp_fault: true,
            ..raw
        };
        ctl.step(&faulted);
        let before = (c.clone(), ctl.clone());
        assert_eq!(c.apply(action, &mut ctl), Err(Refusal::Faulted));
        assert!(before == (c.clone(), ctl.clone()));
        ctl.reset();
        ctl.step(&raw);
        // A stop prepared for a time the move has already passed: refused, nothing swapped.
        let action = c.prepare(&go, &ctl.snapshot()).unwrap();
        assert!(matches!(
            c.apply(action, &mut ctl),
            Ok(Outcome::Moving { .. })
        ));
        for _ in 0..20 {
            ctl.step(&raw);
        }
        let stop = c.prepare(&Command::Stop, &ctl.snapshot()).unwrap();
        for _ in 0..3 {
            ctl.step(&raw);
        }
        let before = (c.clone(), ctl.clone());
        assert_eq!(c.apply(stop, &mut ctl), Err(Refusal::Busy));
        assert!(before == (c.clone(), ctl.clone()));
        // Prepared again from a fresh snapshot, it applies.
        let stop = c.prepare(&Command::Stop, &ctl.snapshot()).unwrap();
        assert!(matches!(
            c.apply(stop, &mut ctl),
            Ok(Outcome::Moving { .. })
        ));
    }

    #[test]
    fn a_payload_is_scheduled_on_the_model_built_with_it_and_refused_past_the_table() {
        let (c, ctl) = drive();
        let snap = ctl.snapshot();
        let plant = c.plant();
        let heaviest = plant.max_payload_kg();
        for kg in [0.6 * heaviest, heaviest] {
            let Ok(Action::SetPayload(s)) = c.prepare(&Command::SetPayload { kg }, &snap) else {
                panic!("{kg} kg refused")
            };
            // The planner's inertia is the model's Mtt with the payload at the tip: the
            // table's plant's beam, its model built here, not read from the table's plant.
            let beam = crate::beam::Beam::try_build(plant.params_with(kg as f64)).unwrap();
            let model = crate::modal::ModalModel::<3>::try_build(&beam).unwrap();
            let rel = (s.limits.inertia_kgm2 as f64 - model.mtt).abs() / model.mtt;
            assert!(rel < 1e-6, "{kg} kg: inertia off by {rel:e}");
        }
        for kg in [heaviest + 1e-3, -1e-3, f32::NAN, f32::INFINITY] {
            assert_eq!(
                c.prepare(&Command::SetPayload { kg }, &snap),
                Err(Refusal::BadArgument),
                "{kg} kg"
            );
        }
    }
}
