//! The operator's two buttons, START and CLEAR FAULT, turned into drive commands.
//!
//! The buttons are polled once per tick (a GPIO read, no interrupt and no waiting) and
//! debounced by time: a press counts once it has read pressed for [`DEBOUNCE_TICKS`]
//! consecutive ticks, and fires once per press. START runs the move of the compiled-in
//! sequence that begins nearest the hub (out from -90 deg, back from +90 deg); the controller
//! still refuses, with a start-mismatch fault, a hub that is not within tolerance of it.

use crate::drive::Command;
use embedded_hal::digital::InputPin;
use model_core::Spline;

/// Ticks a button must read pressed before it counts (20 ms at 1 kHz).
pub const DEBOUNCE_TICKS: u16 = 20;

/// One active-low button with its debounce state.
#[derive(Debug)]
struct Button<P> {
    pin: P,
    pressed_ticks: u16,
}

impl<P: InputPin> Button<P> {
    /// True on the tick the press becomes valid. An unreadable pin reads as released.
    fn pressed(&mut self) -> bool {
        if self.pin.is_low().unwrap_or(false) {
            self.pressed_ticks = self.pressed_ticks.saturating_add(1);
        } else {
            self.pressed_ticks = 0;
        }
        self.pressed_ticks == DEBOUNCE_TICKS
    }
}

/// The buttons and the move sequence they step through.
#[derive(Debug)]
pub struct Operator<const K: usize, const M: usize, S, C> {
    start: Button<S>,
    clear: Button<C>,
    moves: [Spline<K>; M],
}

impl<const K: usize, const M: usize, S: InputPin, C: InputPin> Operator<K, M, S, C> {
    /// The START and CLEAR FAULT buttons (active low) and the moves START chooses from.
    pub fn new(start: S, clear: C, moves: [Spline<K>; M]) -> Self {
        Self {
            start: Button {
                pin: start,
                pressed_ticks: 0,
            },
            clear: Button {
                pin: clear,
                pressed_ticks: 0,
            },
            moves,
        }
    }

    /// Reads the buttons once; `theta_rad` is the hub angle this tick. CLEAR FAULT wins if
    /// both become valid on the same tick.
    pub fn poll(&mut self, theta_rad: f32) -> Option<Command<K>> {
        let start = self.start.pressed();
        if self.clear.pressed() {
            return Some(Command::ClearFault);
        }
        if start {
            return self.nearest(theta_rad).cloned().map(Command::Move);
        }
        None
    }

    /// The move whose start is nearest `theta_rad`.
    fn nearest(&self, theta_rad: f32) -> Option<&Spline<K>> {
        crate::config::nearest(&self.moves, theta_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction};

    fn moves() -> [Spline<2>; 2] {
        let h = core::f32::consts::FRAC_PI_2;
        [
            Spline::quintic(-h, h, 0.35).unwrap(),
            Spline::quintic(h, -h, 0.35).unwrap(),
        ]
    }

    fn pin(states: &[State]) -> Mock {
        Mock::new(
            &states
                .iter()
                .map(|s| Transaction::get(*s))
                .collect::<Vec<_>>(),
        )
    }

    #[test]
    fn a_press_fires_once_after_the_debounce_time_and_bounces_do_not() {
        use State::{High, Low};
        // A bounce (3 ticks low), then a held press of 30 ticks, then release.
        let mut start_states = vec![Low, Low, Low, High];
        start_states.extend([Low; 30]);
        start_states.push(High);
        let n = start_states.len();
        let mut start = pin(&start_states);
        let mut clear = pin(&vec![High; n]);
        let mut op = Operator::new(start.clone(), clear.clone(), moves());
        let fired: Vec<usize> = (0..n)
            .filter(|_| op.poll(-core::f32::consts::FRAC_PI_2).is_some())
            .collect();
        assert_eq!(fired, [4 + DEBOUNCE_TICKS as usize - 1]);
        start.done();
        clear.done();
    }

    #[test]
    fn start_picks_the_move_beginning_nearest_the_hub() {
        let h = core::f32::consts::FRAC_PI_2;
        let op = Operator::new(pin(&[]), pin(&[]), moves());
        assert_eq!(op.nearest(-h + 0.01).unwrap().end(), h);
        assert_eq!(op.nearest(h - 0.3).unwrap().end(), -h);
        assert!(op.nearest(f32::NAN).is_none());
        let Operator {
            mut start,
            mut clear,
            ..
        } = op;
        start.pin.done();
        clear.pin.done();
    }

    #[test]
    fn clear_fault_wins_over_start() {
        let n = DEBOUNCE_TICKS as usize;
        let mut start = pin(&vec![State::Low; n]);
        let mut clear = pin(&vec![State::Low; n]);
        let mut op = Operator::new(start.clone(), clear.clone(), moves());
        let last = (0..n).map(|_| op.poll(0.0)).last().unwrap();
        assert_eq!(last, Some(Command::ClearFault));
        start.done();
        clear.done();
    }
}
