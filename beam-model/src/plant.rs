//! The plant a drive is built for, reduced to what its control laws and its move planner read.
//!
//! The assumed-modes model ([`crate::modal`]) is integrated in `f64` with transcendental
//! functions: cheap on a host, about 10 KiB of soft-float code on a Cortex-M4F. A drive never
//! needs the whole model, only a few numbers of it at the payload it carries: the rigid and
//! effective inertias, how a hub acceleration shows in the root strain, and (for the strain
//! law's model terms) the first columns of the modal matrices. [`PlantPoint`] holds those
//! numbers for one payload; [`Plant`] holds them with no payload and what a payload changes,
//! over the payload range a gain table covers. The build computes it on the host from the
//! table's `[plant]` and compiles it in, so the drive builds nothing at start-up, and a
//! payload set at run time costs a few dozen multiplications.
//!
//! Both are `f32`, the drive's own precision: rounded once from the `f64` model, and updated
//! for a payload in `f32`, so the drive links no software floating point for them.

use crate::beam::BeamParams;
use crate::linalg;
use crate::modal::{ModalModel, MAX_MODES};

/// `a . b`, summed in order.
fn dot(a: &[f32; MAX_MODES], b: &[f32; MAX_MODES]) -> f32 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// The plant at one payload: what the laws and the planner read of the modal model, in
/// `f32` (they fold it into their own constants once). Vectors run over the model's modes
/// and are zero past them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantPoint {
    /// The payload (tip mass) these numbers are for, kg.
    pub payload_kg: f32,
    /// The drive's torque limit, N m.
    pub torque_limit_nm: f32,
    /// Viscous hub friction, N m s/rad.
    pub viscous_nms: f32,
    /// Coulomb hub friction, N m.
    pub coulomb_nm: f32,
    /// Rigid hub-plus-beam inertia Mtt, kg m^2.
    pub mtt: f32,
    /// Effective hub inertia with the beam free to flex, `Mtt - h' Mqq^-1 h`, kg m^2.
    pub jeff: f32,
    /// Root strain per unit modal coordinate, e_i.
    pub root_strain_coef: [f32; MAX_MODES],
    /// `Mqq^-1 h`.
    pub minv_h: [f32; MAX_MODES],
    /// `Mqq^-1 e` (Mqq is symmetric: also `e' Mqq^-1`).
    pub minv_e: [f32; MAX_MODES],
    /// First column of the modal stiffness Kqq, N/m.
    pub kqq_col0: [f32; MAX_MODES],
    /// First column of the modal damping Cq, N s/m.
    pub cq_col0: [f32; MAX_MODES],
    /// First column of `S = Mqq + 2 G`, kg.
    pub s_col0: [f32; MAX_MODES],
    /// The root strain per unit hub acceleration with the beam bent statically under it,
    /// `e' Kqq^-1 h`, strain per rad/s^2: what a move planned at an acceleration bends the
    /// beam by when it follows slowly (model-core's planner holds its shortest moves to a
    /// strain budget with it).
    pub strain_per_acc: f32,
}

impl PlantPoint {
    /// The numbers of `model`, at the payload it was built with.
    pub fn of<const N: usize>(model: &ModalModel<N>) -> Self {
        let p = model.beam.params();
        let pad = |v: [f64; N]| -> [f32; MAX_MODES] {
            core::array::from_fn(|i| if i < N { v[i] as f32 } else { 0.0 })
        };
        let col0 = |a: &linalg::Mat<N>| pad(core::array::from_fn(|j| a[j][0]));
        Self {
            payload_kg: p.tip_mass_kg as f32,
            torque_limit_nm: p.torque_limit_nm as f32,
            viscous_nms: p.viscous_nms as f32,
            coulomb_nm: p.coulomb_nm as f32,
            mtt: model.mtt as f32,
            jeff: model.jeff as f32,
            root_strain_coef: pad(model.root_strain_coef),
            minv_h: pad(linalg::mat_vec(&model.mqq_inv, &model.h)),
            minv_e: pad(linalg::mat_vec(&model.mqq_inv, &model.root_strain_coef)),
            kqq_col0: col0(&model.kqq),
            cq_col0: col0(&model.cq),
            s_col0: col0(&model.s),
            strain_per_acc: static_strain(model, &model.h) as f32,
        }
    }

    /// gamma = e' Mqq^-1 h: how much a hub acceleration shows in the root strain of the held
    /// beam.
    pub fn strain_coupling(&self) -> f32 {
        dot(&self.root_strain_coef, &self.minv_h)
    }

    /// Smallest admissible `1 - c gamma` of a strain blend `y = theta + c eps_root`: the
    /// blended output's input gain relative to the hub's. Below it the surface's control
    /// direction nearly vanishes (or flips).
    pub const MIN_BLEND_RATIO: f32 = 0.2;

    /// `1 - c gamma` for the strain blend `c` (rad per unit strain), if at least
    /// [`Self::MIN_BLEND_RATIO`]: the one rule for a blend, which the gain table's build and
    /// the laws both apply.
    pub fn blend_ratio(&self, c: f32) -> Option<f32> {
        let ratio = 1.0 - c * self.strain_coupling();
        (ratio >= Self::MIN_BLEND_RATIO).then_some(ratio)
    }
}

/// `e' Kqq^-1 v`: the root strain of the beam bent statically by the modal load `v` per unit
/// hub acceleration (`h` for the beam's own inertia, `(r + L) u` for a tip mass). 0 for a
/// stiffness that is not positive definite (which no model that builds has).
pub(crate) fn static_strain<const N: usize>(model: &ModalModel<N>, v: &[f64; N]) -> f64 {
    linalg::cholesky(&model.kqq).map_or(0.0, |l| {
        linalg::dot(&model.root_strain_coef, &linalg::chol_solve(&l, v))
    })
}

impl<const N: usize> From<&ModalModel<N>> for PlantPoint {
    fn from(model: &ModalModel<N>) -> Self {
        Self::of(model)
    }
}

/// The plant a drive is built for: the beam without payload, the model's mode count, the
/// model's numbers at no payload, and what the payload changes.
///
/// A tip mass `p` enters the model as a rank-one term: `Mqq(p) = Mqq + p u u'` with
/// `u_i = phi_i(L)`, `h(p) = h + p (r + L) u`, `Mtt(p) = Mtt + p (r + L)^2`, and `S` affinely.
/// So [`Plant::at`] computes the plant at any payload exactly (to `f32` rounding), with no integral and no
/// matrix factorisation: by the Sherman-Morrison formula, with `w = Mqq^-1 u`,
/// `Mqq(p)^-1 x = Mqq^-1 x - k w (w'x)` and `k = p / (1 + p u'w)`, and so
/// `Jeff(p) = Jeff + p (r + L - w'h)^2 / (1 + p u'w)`. Only the first clamped
/// frequency (which sets the first mode's damping term) is an eigenvalue; it is tabulated
/// and `1/f^2` interpolated between grid points (exact for one mode, where `1/f^2` is affine
/// in the payload).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plant {
    /// The beam, its tip mass zero (the payload is the drive's setting).
    pub params: BeamParams,
    /// Flexible modes of the model.
    pub modes: usize,
    /// The plant at no payload.
    pub base: PlantPoint,
    /// The payload's arm, hub radius plus beam length, m.
    pub arm_m: f32,
    /// The beam's damping ratio (the first mode's damping term is rebuilt from it).
    pub damping_ratio: f32,
    /// The coupling `h` at no payload.
    pub h: [f32; MAX_MODES],
    /// The mode shapes at the tip, `u_i = phi_i(L)`.
    pub tip_shape: [f32; MAX_MODES],
    /// `w = Mqq^-1 u` at no payload.
    pub tip_minv: [f32; MAX_MODES],
    /// How the first column of `S` grows with the payload, per kg.
    pub s_col0_per_kg: [f32; MAX_MODES],
    /// `Mqq[0][0]` at no payload, kg.
    pub mqq00: f32,
    /// How [`PlantPoint::strain_per_acc`] grows with the payload, per kg: `(r + L) e' Kqq^-1
    /// u` (the tip mass's inertial load, `h` being affine in the payload and `Kqq` not
    /// changing with it).
    pub strain_per_acc_per_kg: f32,
    /// The first clamped frequency, Hz, at payloads (kg) from 0 to the heaviest the drive
    /// accepts (the table's heaviest row), sorted.
    pub first_hz: &'static [(f32, f32)],
}

impl Plant {
    /// The plant of the beam `params` (its tip mass zero), from its modal models with no
    /// payload (`m0`) and with 1 kg at the tip (`m1`, for the slope of `S`, which is affine
    /// in the payload), and its first clamped frequency at payloads from 0 up (`first_hz`,
    /// sorted: the payloads the plant covers).
    pub fn from_models<const N: usize>(
        params: BeamParams,
        m0: &ModalModel<N>,
        m1: &ModalModel<N>,
        first_hz: &'static [(f32, f32)],
    ) -> Plant {
        let pad = |v: &[f64; N]| -> [f32; MAX_MODES] {
            core::array::from_fn(|i| if i < N { v[i] as f32 } else { 0.0 })
        };
        Plant {
            params,
            modes: N,
            base: PlantPoint::of(m0),
            arm_m: (params.hub_radius_m + params.length_m) as f32,
            damping_ratio: params.damping_ratio as f32,
            h: pad(&m0.h),
            tip_shape: pad(&m0.tip_coef),
            tip_minv: pad(&linalg::mat_vec(&m0.mqq_inv, &m0.tip_coef)),
            s_col0_per_kg: pad(&core::array::from_fn(|i| m1.s[i][0] - m0.s[i][0])),
            mqq00: m0.mqq[0][0] as f32,
            strain_per_acc_per_kg: ((params.hub_radius_m + params.length_m)
                * static_strain(m0, &m0.tip_coef)) as f32,
            first_hz,
        }
    }

    /// The heaviest payload the plant covers, kg: the end of its frequency table.
    pub fn max_payload_kg(&self) -> f32 {
        self.first_hz.last().map_or(0.0, |&(p, _)| p)
    }

    /// The plant at `payload_kg` (see [`Plant`]); `None` outside 0 to
    /// [`Plant::max_payload_kg`] (or NaN).
    pub fn at(&self, payload_kg: f32) -> Option<PlantPoint> {
        let p = payload_kg;
        if !(p >= 0.0 && p <= self.max_payload_kg()) {
            return None;
        }
        if p == 0.0 {
            return Some(self.base);
        }
        let b = &self.base;
        let u = &self.tip_shape;
        let arm = self.arm_m;
        let mtt = b.mtt + p * arm * arm;
        let h: [f32; MAX_MODES] = core::array::from_fn(|i| self.h[i] + p * arm * u[i]);
        // Sherman-Morrison (see [`Plant`]); Mqq^-1 h(p) = Mqq^-1 h + p (r + L) w.
        let w = &self.tip_minv;
        let d = 1.0 + p * dot(u, w);
        let k = p / d;
        let (wh, we) = (dot(w, &h), dot(w, &b.root_strain_coef));
        // Jeff(p) = Mtt(p) - h(p)' Mqq(p)^-1 h(p) expands to Jeff + p (r + L - w'h)^2 / d:
        // the same number without the cancellation of the difference (Mtt is about six
        // times Jeff, which would cost f32 nearly three bits).
        let lever = arm - dot(w, &self.h);
        let minv_h: [f32; MAX_MODES] =
            core::array::from_fn(|i| b.minv_h[i] + p * arm * w[i] - k * w[i] * wh);
        let f1 = self.first_hz_at(p)?;
        let mut cq_col0 = [0.0; MAX_MODES];
        let mqq00 = self.mqq00 + p * u[0] * u[0];
        cq_col0[0] = 2.0 * self.damping_ratio * (2.0 * core::f32::consts::PI * f1) * mqq00;
        Some(PlantPoint {
            payload_kg: p,
            mtt,
            jeff: b.jeff + p * lever * lever / d,
            minv_h,
            minv_e: core::array::from_fn(|i| b.minv_e[i] - k * w[i] * we),
            cq_col0,
            s_col0: core::array::from_fn(|i| b.s_col0[i] + p * self.s_col0_per_kg[i]),
            strain_per_acc: b.strain_per_acc + p * self.strain_per_acc_per_kg,
            ..*b
        })
    }

    /// The first clamped frequency at payload `p` (kg), Hz: `1/f^2` interpolated on the
    /// table; `None` outside it.
    pub fn first_hz_at(&self, p: f32) -> Option<f32> {
        let mut below = self.first_hz.first()?;
        for above in self.first_hz {
            if p == above.0 {
                return Some(above.1);
            }
            if p < above.0 {
                let f = (p - below.0) / (above.0 - below.0);
                let (a, b) = (1.0 / (below.1 * below.1), 1.0 / (above.1 * above.1));
                return Some(crate::sqrt::sqrtf(1.0 / (a + (b - a) * f)));
            }
            below = above;
        }
        None
    }

    /// The beam with `payload_kg` at its tip.
    pub fn params_with(&self, payload_kg: f64) -> BeamParams {
        BeamParams {
            tip_mass_kg: payload_kg,
            ..self.params
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::{Beam, BeamParams};

    /// The root strain of the clamped beam under a steady hub acceleration of 1 rad/s^2,
    /// from its root moment ([`BeamParams::static_root_strain_per_acc`]).
    fn exact_strain_per_acc(p: &BeamParams) -> f64 {
        p.static_root_strain_per_acc()
    }

    fn model<const N: usize>(payload_kg: f64) -> ModalModel<N> {
        let params = BeamParams {
            tip_mass_kg: payload_kg,
            ..BeamParams::aluminium()
        };
        ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap()
    }

    /// [`PlantPoint::strain_per_acc`] against the beam's statics, with two to four modes, at
    /// the shipped table's payloads.
    #[test]
    fn the_static_strain_per_acceleration_is_the_root_moments() {
        for payload in [0.0, 0.025, 0.05] {
            let exact = exact_strain_per_acc(model::<2>(payload).beam.params());
            let found = [
                PlantPoint::of(&model::<2>(payload)).strain_per_acc,
                PlantPoint::of(&model::<3>(payload)).strain_per_acc,
                PlantPoint::of(&model::<4>(payload)).strain_per_acc,
            ]
            .map(|s| (s as f64).abs() / exact);
            // Two modes fall short by what they leave out (1-2.6 %, more with the payload,
            // whose load the two cantilever shapes follow worst); three and four come
            // within 1 % either side (the strain is a second derivative of the shapes, so
            // it converges from both sides), and four closer than two.
            let off = found.map(|f| (f - 1.0).abs());
            assert!(found[0] < 1.0 && off[0] < 0.03, "{payload} kg: {found:?}");
            assert!(off[1] < 0.01 && off[2] < 0.01, "{payload} kg: {found:?}");
            assert!(off[2] < off[0], "{payload} kg: {found:?}");
        }
    }

    /// What a design on two modes expects the modes it leaves out to bend the root by
    /// ([`crate::lqg::OmittedStrain`]) is what they bend by in the whole model's own statics:
    /// the four-mode beam held at a steady hub acceleration while it spins, `(Kqq - w^2 S) q
    /// = -h a` solved on all its modes, read at the root by its third and fourth. The
    /// expectation leaves out the modes' own share of the centrifugal load, `w^2 S_oo q_o`
    /// (and its pull back on the first two): to first order a part `w^2 S_jj / K_jj` of their
    /// bending, 2.3 % at 20 rad/s; the test allows half as much again, and 0.5 %. With no
    /// modes past the design's there is nothing to expect.
    #[test]
    fn the_modes_left_out_bend_as_the_whole_model_does_statically() {
        for payload in [0.0, 0.025, 0.05] {
            let four = model::<4>(payload);
            let omitted = crate::lqg::OmittedStrain::of(&four);
            for (acc, w) in [(100.0, 0.0), (100.0, 15.0), (-40.0, 20.0)] {
                let k: linalg::Mat<4> = core::array::from_fn(|i| {
                    core::array::from_fn(|j| four.kqq[i][j] - w * w * four.s[i][j])
                });
                let load = four.h.map(|h| -h * acc);
                let q = linalg::chol_solve(&linalg::cholesky(&k).unwrap(), &load);
                let beyond: f64 = (2..4).map(|i| four.root_strain_coef[i] * q[i]).sum();
                let expected = omitted.per_acc * acc
                    + w * w * (omitted.per_spin[0] * q[0] + omitted.per_spin[1] * q[1]);
                let left_out = (2..4)
                    .map(|j| (w * w * four.s[j][j] / four.kqq[j][j]).abs())
                    .fold(0.0, f64::max);
                assert!(
                    (expected / beyond - 1.0).abs() < 0.005 + 1.5 * left_out,
                    "{payload} kg, {acc} rad/s^2 at {w} rad/s: expected {expected}, bent {beyond}"
                );
            }
            assert_eq!(
                crate::lqg::OmittedStrain::of(&model::<2>(payload)),
                Default::default()
            );
        }
    }
}
