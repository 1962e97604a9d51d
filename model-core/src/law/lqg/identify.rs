//! The observer laws' identifier (model-core's `identify` feature; docs/identification.md):
//! the beam's stiffness against the model's, fitted to the root gauge in each move's first
//! [`IDENTIFY_TICKS`], and what the observer and the feedback take from it
//! ([`Adaptation`]). Its tick runs inside the observer's (`super::observe`).

use super::{dot2, ObserverState};
use crate::law::Estimate;
use beam_model::lqg::{LqgDesign, DESIGN_MODES, MAX_STATES};

/// What the identifier found of the beam this move ([`Identifier`]), as the observer and the
/// feedback take it, and the identifier's own state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Adaptation {
    /// The identifier's beam and its fit, while the move's first [`IDENTIFY_TICKS`] run.
    pub identifier: Identifier,
    /// The beam's stiffness against the model's, less 1: moving to what the identifier
    /// found for this move (0 until it has). The observer's prediction scales the modes'
    /// restoring force by `1 + stiffness`.
    pub stiffness: f32,
    /// The beam's compliance against the model's, less 1, likewise: the feedback's
    /// reference bends the beam by `1 + compliance` times the reference beam (below
    /// [`COMPLIANCE_FADE_STRAIN`]).
    pub compliance: f32,
    /// The moving regulator's share the feedback carries this move: the design's
    /// [`LqgDesign::k_move`] from the move's start (set when it is armed,
    /// [`Adaptation::start`]), then, once the identifier has finished, that share on the
    /// compliance found, `k_move + compliance k_move_compliance`, for a law whose
    /// reference bends by it.
    pub k_move: [f32; MAX_STATES],
    /// [`LqgDesign::k_move_filter`] likewise.
    pub k_move_filter: f32,
}

impl Adaptation {
    /// Nothing identified yet, the moving regulator the design's: the state a move starts
    /// from. Set when the move is armed, off the tick (`crate::law::LawState::restart`).
    pub fn start(d: &LqgDesign) -> Self {
        Self {
            k_move: d.k_move,
            k_move_filter: d.k_move_filter,
            // A design that does not identify (`LqgDesign::id_a` zero) starts with its
            // identifier done: the tick asks only whether it has run its ticks.
            identifier: Identifier {
                ticks: if d.id_a[0] == 0.0 { IDENTIFY_TICKS } else { 0 },
                ..Identifier::default()
            },
            ..Self::default()
        }
    }
}

/// The identifier's state ([`LqgDesign::id_a`]): the clamped modes `z = q + G theta`
/// and their change per tick `v = ts z'` at the model's stiffness, their sensitivity to
/// the beam's compliance `lambda` (`s`, `sv`, the same for `d q / d lambda`), and the
/// least-squares sums of the gauge's reading against them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identifier {
    /// `G = Mqq^-1 h`, m per rad ([`clamped_coupling`]).
    pub g: [f32; DESIGN_MODES],
    /// `z`, m.
    pub z: [f32; DESIGN_MODES],
    /// `ts z'`, m.
    pub v: [f32; DESIGN_MODES],
    /// `d z / d lambda`, m.
    pub s: [f32; DESIGN_MODES],
    /// `ts d z' / d lambda`, m.
    pub sv: [f32; DESIGN_MODES],
    /// The hub's angle last tick, rad.
    pub theta: f32,
    /// Sum of the gauge's misfit times the strain's sensitivity.
    pub sum_misfit: f32,
    /// Sum of the strain's sensitivity squared.
    pub sum_sensitivity: f32,
    /// Ticks run ([`IDENTIFY_TICKS`] from the move's start for a design that does not
    /// identify, [`Adaptation::start`]).
    pub ticks: u32,
    /// The compliance found, less 1 ([`Adaptation::compliance`] moves to it).
    pub compliance: f32,
    /// The stiffness found, less 1 ([`Adaptation::stiffness`] moves to it).
    pub stiffness: f32,
}

/// How much of the way to what the identifier found the observer's stiffness and the
/// feedback's reference move each tick, while the reference moves: over about 20 ms. Taken
/// at once, the reference's change was a step of up to 6 N m in the torque (to the 10 N m
/// limit on 57 of 200 beams at 180 deg), and the observer's bent soft beams further
/// (1934-2024 ue at 180 deg over seven sets of 200 beams, against 1895-1964 ramped).
pub const COMPLIANCE_BLEND_PER_TICK: f32 = 0.05;

/// The root strain of the observer's estimate over which the feedback's reference stops
/// bending with the compliance found, strain: wholly below the first, not at all above the
/// second. A soft beam let bend as far as it would on the model's move passed the 2000 ue
/// bound at 180 deg (2100-2210 ue over seven sets of 200 beams); held to the model's
/// reference past 1900 ue it stays within 1895-1964 (docs/identification.md).
pub const COMPLIANCE_FADE_STRAIN: [f32; 2] = [1.5e-3, 1.9e-3];

/// How long the identifier runs from the start of a move, ticks (0.1 s at 1 kHz): long
/// enough for the gauge to see the beam bend under the move's first acceleration, short
/// enough that the hub has not yet turned fast enough to stiffen it.
pub const IDENTIFY_TICKS: u32 = 100;

/// The least sum of the squared sensitivity of the root strain to the compliance over the
/// identifier's ticks (strain^2) that it fits on; below it, the move runs on the model. A
/// strain the fit does not model, coherent with the sensitivity, moves the compliance by at
/// most its RMS times `sqrt(IDENTIFY_TICKS / sum)` (Cauchy-Schwarz): here 16 % for 5 ue, the
/// settle band's beam still ringing. The planner's shortest moves of 5 deg and more sum
/// more than 3e-7 (4e-6 to 2e-5 from 15 deg on the model's beam, 3e-7 to 1e-6 at 15 deg
/// with 50 g on a beam a third stiffer, which, run on the model, rang at 5 N m in the
/// hold); a 20 rad move, or 90 deg over 2 s, start too gently (1e-8 to 5e-8), and their
/// fits read the model's own beam 3-9 % off, a 20 rad move after a brake 30 % (which the
/// loop did not survive at 20 rad/s).
pub const MIN_FIT_SENSITIVITY: f32 = 1e-7;

/// The stiffness the identifier may find against the model's, as a factor: the beams the
/// drive is designed for (EI and density each within 20 %, so their ratio within 2/3 to 3/2).
/// A fit outside it (a gauge reading wrong) is held to it.
pub const IDENTIFY_RANGE: [f32; 2] = [
    beam_model::lqg::IDENTIFY_STIFFNESS[0] as f32,
    beam_model::lqg::IDENTIFY_STIFFNESS[1] as f32,
];

/// The one Gauss-Newton step's bias ([`identify`]): it reads a beam whose stiffness is `1 +
/// d` times the model's as about `1 + d + IDENTIFY_STEP_BIAS d^2`, stiffer than it is
/// whichever way the beam is off (the strain's dependence on the compliance curves, and one
/// step from the model follows its slope there). Measured on the sweep's beams without
/// payloads (`EI / rho` 0.69-1.35; 200 beams at 45 and 180 deg, each on the quintic and the
/// exact move, docs/identification.md): the step read them 2.2-3.7 % stiff on average, and
/// 4-7 % at the spread's edges; less 0.5 d^2, 0.5-1.9 % (0.8-3.4 % at the soft edge, and
/// from 0.6 % soft to 1.1 % stiff at the stiff one).
pub const IDENTIFY_STEP_BIAS: f32 = 0.5;

/// The stiffest step the correction takes ([`IDENTIFY_STEP_BIAS`]): where `k - 0.5 (k -
/// 1)^2` peaks, at [`IDENTIFY_RANGE`]'s top, 3/2. A step read stiffer is held there, so that
/// the correction never turns a stiffer reading into a softer beam.
pub const IDENTIFY_STEP_MAX: f32 = 2.0;

/// A stiffness found within this of the model's is taken for the model's: the fit's own
/// error. On the model's beam it finds 0.991-1.003, and 0.4-1.5 % high on beams 20 % off it
/// once its bias is taken off (`cargo test -p beam-sim --test observer identifies`); a
/// correction of a fraction of a percent moved the model's own 90 deg settle from 0.36 to
/// 0.40-0.44 s, as its strain crossed the 5 ue band a second-mode period later.
pub const IDENTIFY_DEAD_BAND: f32 = 0.02;

/// The factor on the reference beam's bending the feedback holds the beam to: `1 +
/// compliance` while the estimate's root strain is below [`COMPLIANCE_FADE_STRAIN`], fading
/// to 1 across it. 1 without `IDENTIFY`.
#[inline(always)]
pub(super) fn softer<const IDENTIFY: bool>(state: &ObserverState) -> f32 {
    if !IDENTIFY {
        return 1.0;
    }
    let bent = libm::fabsf(state.strain_estimate);
    let [from, to] = COMPLIANCE_FADE_STRAIN;
    let fade = if bent <= from {
        1.0
    } else if bent >= to {
        0.0
    } else {
        (to - bent) * (1.0 / (COMPLIANCE_FADE_STRAIN[1] - COMPLIANCE_FADE_STRAIN[0]))
    };
    1.0 + fade * state.adaptation.compliance
}

/// The factor on the modes' restoring force in the observer's prediction: `1 + stiffness`,
/// 1 without `IDENTIFY`.
#[inline(always)]
pub(super) fn stiffer<const IDENTIFY: bool>(state: &ObserverState) -> f32 {
    if IDENTIFY {
        1.0 + state.adaptation.stiffness
    } else {
        1.0
    }
}

/// A moving tick of the identification: the identifier's tick ([`identify`]), and the
/// observer's stiffness and the feedback's compliance moved towards what it found, over
/// [`COMPLIANCE_BLEND_PER_TICK`] (a step in either is a step in the torque). Nothing without
/// `IDENTIFY`.
#[inline(always)]
pub(super) fn adapt<const IDENTIFY: bool, const BEND: bool>(
    d: &LqgDesign,
    x: &Estimate,
    state: &mut ObserverState,
    omitted: f32,
) {
    if !IDENTIFY {
        return;
    }
    let a = &mut state.adaptation;
    let id = &mut a.identifier;
    // The identifier finished before this tick (the ticks that run it, the first of a
    // move's and the fit's among them, are the observer laws' most costly).
    let finished = id.ticks >= IDENTIFY_TICKS;
    if let Some([stiffness, compliance]) = identify(d, x, id, omitted) {
        id.stiffness = stiffness;
        id.compliance = compliance;
    }
    // Until the identifier has finished (by the tick before this one) there is nothing to
    // move to; its ticks, the law's most costly, skip the blend.
    if !finished {
        return;
    }
    a.stiffness += COMPLIANCE_BLEND_PER_TICK * (id.stiffness - a.stiffness);
    // Only a law whose reference bends by it (`observe`'s `BEND`) reads the compliance.
    if BEND {
        a.compliance += COMPLIANCE_BLEND_PER_TICK * (id.compliance - a.compliance);
        // The moving regulator follows the compliance.
        let c = a.compliance;
        unrolled!(i in [0 1 2 3 4 5] => {
            a.k_move[i] = d.k_move[i] + c * d.k_move_compliance[i];
        });
        a.k_move_filter = d.k_move_filter + c * d.k_move_filter_compliance;
    }
}

/// `G = Mqq^-1 h`, how far the hub's angle moves the clamped modes' coordinates, m per rad,
/// from the reference beam's numbers (a design carries no more for it): the hub-free modes'
/// `P h = Mf^-1 h` from the input column's modes, `-ts^2/2 P h` to second order in the
/// tick, `h = -Mtt ref_hub`, and `Mqq = Mf + h h' / Mtt` inverted by Sherman and Morrison:
/// `G = P h Mtt / (Mtt + h' P h)`.
#[inline(never)]
pub fn clamped_coupling(d: &LqgDesign) -> [f32; DESIGN_MODES] {
    const K: f32 = -2.0 / (crate::DEFAULT_TS_S * crate::DEFAULT_TS_S);
    let ph = [K * d.ref_bd[0], K * d.ref_bd[1]];
    let h = [-d.mtt * d.ref_hub[0], -d.mtt * d.ref_hub[1]];
    let f = d.mtt / (d.mtt + dot2(-0.0, &h, &ph));
    [f * ph[0], f * ph[1]]
}

/// One tick of the identifier ([`LqgDesign::id_a`]) at the start of a move: the clamped
/// modes driven by the measured hub angle, their sensitivity to the beam's compliance
/// `lambda`, and the least-squares sums of the gauge against them. On the move's
/// [`IDENTIFY_TICKS`]th tick, one Gauss-Newton step from the model, `lambda = 1 + sum(misfit
/// sensitivity) / sum(sensitivity^2)`: returns the stiffness `1 / lambda` less the step's
/// bias ([`IDENTIFY_STEP_BIAS`]) and the compliance, its inverse, each less 1, the stiffness
/// within [`IDENTIFY_RANGE`]. `None` on every other tick, and for a design that does not
/// identify.
#[inline(always)]
fn identify(d: &LqgDesign, x: &Estimate, id: &mut Identifier, omitted: f32) -> Option<[f32; 2]> {
    // (A design that does not identify starts with its ticks run, `Adaptation::start`.)
    if id.ticks >= IDENTIFY_TICKS {
        return None;
    }
    let theta = x.theta;
    if id.ticks == 0 {
        // From rest: the modes unbent, their sensitivity nil, the hub not yet turned. A step
        // from there adds nothing to the sums and leaves the identifier's beam as it is, so
        // this tick takes none (its products would be the worst tick's, with the coupling's).
        id.g = clamped_coupling(d);
        id.z = [id.g[0] * theta, id.g[1] * theta];
        id.theta = theta;
        id.ticks = 1;
        return None;
    }
    let g = id.g;
    let q = [id.z[0] - g[0] * theta, id.z[1] - g[1] * theta];
    let sensitivity = dot2(-0.0, &d.strain_coef, &id.s);
    id.sum_misfit += (x.strain - omitted - dot2(-0.0, &d.strain_coef, &q)) * sensitivity;
    id.sum_sensitivity += sensitivity * sensitivity;
    id.ticks += 1;
    if id.ticks >= IDENTIFY_TICKS {
        // The fit, with no step of the identifier's beam after it (nothing reads it): the
        // step's products would be the worst tick's.
        return fitted(id);
    }
    // z'' = -Mqq^-1 (Kqq q / lambda + Cq q'), and its derivative at lambda = 1 (the
    // damping's dependence on the stiffness left out), semi-implicit. `ts q' = ts z' - G
    // turn`, the hub's turn over the tick read from the encoder.
    let (a, c) = (&d.id_a, &d.id_c);
    let turn = theta - id.theta;
    id.theta = theta;
    let (aq, as_) = (
        [a[0] * q[0] + a[1] * q[1], a[2] * q[0] + a[3] * q[1]],
        [
            a[0] * id.s[0] + a[1] * id.s[1],
            a[2] * id.s[0] + a[3] * id.s[1],
        ],
    );
    unrolled!(i in [0 1] => {
        id.v[i] -= aq[i] + c[i] * (id.v[i] - g[i] * turn);
        id.sv[i] += aq[i] - as_[i] - c[i] * id.sv[i];
        id.z[i] += id.v[i];
        id.s[i] += id.sv[i];
    });
    None
}

/// The identifier's Gauss-Newton step on its sums ([`identify`]), on its last tick: the
/// stiffness and the compliance, each less 1; `None` if the move's start bent the beam too
/// little to fit ([`MIN_FIT_SENSITIVITY`]).
#[inline(always)]
fn fitted(id: &Identifier) -> Option<[f32; 2]> {
    if !(id.sum_sensitivity >= MIN_FIT_SENSITIVITY) {
        return None;
    }
    let lambda = 1.0 + id.sum_misfit / id.sum_sensitivity;
    let lo = IDENTIFY_RANGE[0];
    // The step's stiffness, then less its bias: held within [lo, IDENTIFY_STEP_MAX], where
    // the correction rises with it, to at most the range's top.
    let stiffness = if lambda.is_nan() {
        1.0
    } else if lambda * IDENTIFY_STEP_MAX <= 1.0 {
        IDENTIFY_STEP_MAX
    } else {
        let k = 1.0 / lambda;
        if k < lo {
            lo
        } else {
            k
        }
    };
    let off = stiffness - 1.0;
    let stiffness = stiffness - IDENTIFY_STEP_BIAS * off * off;
    let stiffness = if stiffness < lo { lo } else { stiffness };
    let stiffness = if libm::fabsf(stiffness - 1.0) < IDENTIFY_DEAD_BAND {
        1.0
    } else {
        stiffness
    };
    Some([stiffness - 1.0, 1.0 / stiffness - 1.0])
}
