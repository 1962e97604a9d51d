//! The assumed-modes model of the beam (docs/design.md, section 2), for 1 to 4 clamped-free modes.
//!
//! Mode shapes are the cantilever's, `phi_i(x) = cosh kx - cos kx - s_i (sinh kx - sin kx)`,
//! normalised so that `int_0^L phi_i phi_j dx = L delta_ij`. Every matrix is an integral over
//! the beam, evaluated once by composite Gauss-Legendre quadrature in `f64` (the cosh/sinh
//! cancellation of mode 4 costs five digits, which `f32` could not afford). The model is
//! configuration: built once by [`ModalModel::try_build`], then only read.

use crate::beam::Beam;
use crate::linalg::{self, Mat};
use core::f64::consts::PI;
use core::fmt;

/// Roots b_i of `cos b cosh b = -1`, the clamped-free eigenvalues (docs/design.md, section 2).
pub const MODE_ROOTS: [f64; 4] = [1.875_104_07, 4.694_091_13, 7.854_757_44, 10.995_540_73];

/// Most modes supported.
pub const MAX_MODES: usize = MODE_ROOTS.len();

/// Gauss-Legendre points per panel and panels over the beam: enough that the matrices are
/// exact to about 1e-13 relative for mode 4 (checked by the orthonormality test).
const GL_POINTS: usize = 8;
const PANELS: usize = 32;

/// One clamped-free mode shape on a beam of length `length_m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeShape {
    k: f64,
    s: f64,
}

impl ModeShape {
    /// Mode `i` (0-based) of a beam of length `length_m`; `i` must be below [`MAX_MODES`].
    pub fn new(i: usize, length_m: f64) -> Self {
        let b = refined_root(MODE_ROOTS[i.min(MAX_MODES - 1)]);
        let s = (libm::sinh(b) - libm::sin(b)) / (libm::cosh(b) + libm::cos(b));
        Self { k: b / length_m, s }
    }

    /// phi(x).
    pub fn phi(&self, x: f64) -> f64 {
        let kx = self.k * x;
        libm::cosh(kx) - libm::cos(kx) - self.s * (libm::sinh(kx) - libm::sin(kx))
    }

    /// phi'(x).
    pub fn dphi(&self, x: f64) -> f64 {
        let kx = self.k * x;
        self.k * (libm::sinh(kx) + libm::sin(kx) - self.s * (libm::cosh(kx) - libm::cos(kx)))
    }

    /// phi''(x), the curvature per unit modal coordinate.
    pub fn ddphi(&self, x: f64) -> f64 {
        let kx = self.k * x;
        self.k
            * self.k
            * (libm::cosh(kx) + libm::cos(kx) - self.s * (libm::sinh(kx) + libm::sin(kx)))
    }

    /// The wavenumber k = b / L.
    pub fn wavenumber(&self) -> f64 {
        self.k
    }
}

/// Polishes a tabulated root of `cos b cosh b + 1 = 0` to full `f64` precision by Newton's
/// method: the nine printed digits would otherwise limit orthonormality to about 1e-9.
fn refined_root(mut b: f64) -> f64 {
    for _ in 0..8 {
        let f = libm::cos(b) * libm::cosh(b) + 1.0;
        let df = libm::cos(b) * libm::sinh(b) - libm::sin(b) * libm::cosh(b);
        b -= f / df;
    }
    b
}

/// Nodes and weights of the `P`-point Gauss-Legendre rule on [-1, 1], by Newton's method on
/// the Legendre polynomial (so no table of constants can carry a typo).
fn gauss_legendre<const P: usize>() -> ([f64; P], [f64; P]) {
    let mut x = [0.0; P];
    let mut w = [0.0; P];
    for i in 0..P {
        let mut z = libm::cos(PI * (i as f64 + 0.75) / (P as f64 + 0.5));
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for n in 2..=P {
                let p2 = ((2 * n - 1) as f64 * z * p1 - (n - 1) as f64 * p0) / n as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = P as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if libm::fabs(dz) < 1e-16 {
                break;
            }
        }
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

/// `int_0^L f(x) dx` by composite Gauss-Legendre.
#[cfg(test)]
fn integrate<F: FnMut(f64) -> f64>(length_m: f64, mut f: F) -> f64 {
    let mut sum = 0.0;
    let panel = for_each_point(&gauss_legendre::<GL_POINTS>(), length_m, |w, x| {
        sum += w * f(x)
    });
    panel * sum
}

/// Calls `f(w, x)` at each point `x` of the composite Gauss-Legendre rule `rule` (nodes and
/// weights on [-1, 1]) over [0, L], in order, with its weight `w`; returns the factor that
/// turns `sum(w f(x))` into the integral (half a panel's length).
fn for_each_point<F: FnMut(f64, f64)>(
    (nodes, weights): &([f64; GL_POINTS], [f64; GL_POINTS]),
    length_m: f64,
    mut f: F,
) -> f64 {
    let h = length_m / PANELS as f64;
    for p in 0..PANELS {
        let mid = (p as f64 + 0.5) * h;
        for (z, w) in nodes.iter().zip(weights) {
            f(*w, mid + 0.5 * h * z);
        }
    }
    0.5 * h
}

/// The modal model with `N` flexible modes: matrices of docs/design.md, section 2 and derived data.
///
/// Build with [`ModalModel::try_build`]; fields are public for reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalModel<const N: usize> {
    /// The beam this model describes.
    pub beam: Beam,
    /// The mode shapes.
    pub shapes: [ModeShape; N],
    /// Mass per unit length rho, kg/m.
    pub rho_kg_m: f64,
    /// Rigid hub-plus-beam inertia Mtt, kg m^2.
    pub mtt: f64,
    /// Rigid-flexible coupling h_i, kg m.
    pub h: [f64; N],
    /// Modal mass matrix Mqq, kg.
    pub mqq: Mat<N>,
    /// Inverse of Mqq.
    pub mqq_inv: Mat<N>,
    /// Modal stiffness matrix Kqq, N/m.
    pub kqq: Mat<N>,
    /// Foreshortening matrix G (negative semidefinite), kg.
    pub g: Mat<N>,
    /// S = Mqq + 2 G, the matrix of the centrifugal and Coriolis terms, kg.
    pub s: Mat<N>,
    /// Modal damping Cq = diag(2 zeta omega_i Mqq_ii), N s/m.
    pub cq: Mat<N>,
    /// Effective hub inertia Jeff = Mtt - h' Mqq^-1 h (the Schur complement), kg m^2.
    pub jeff: f64,
    /// Flexible frequencies with the hub clamped, Hz, ascending.
    pub clamped_hz: [f64; N],
    /// Flexible frequencies of the linearised system with the hub free (rigid mode dropped), Hz.
    pub pinned_hz: [f64; N],
    /// Root strain per modal coordinate, (t/2) phi_i''(x_root).
    pub root_strain_coef: [f64; N],
    /// Mid-span strain per modal coordinate, (t/2) phi_i''(x_mid).
    pub mid_strain_coef: [f64; N],
    /// Tip deflection per modal coordinate, phi_i(L).
    pub tip_coef: [f64; N],
}

impl<const N: usize> ModalModel<N> {
    /// Computes every matrix for `beam` with `N` modes (1 to 4).
    pub fn try_build(beam: &Beam) -> Result<Self, ModelError> {
        if N == 0 || N > MAX_MODES {
            return Err(ModelError::UnsupportedModeCount(N));
        }
        let p = *beam.params();
        let (l, r, mt) = (p.length_m, p.hub_radius_m, p.tip_mass_kg);
        let rho = p.rho_kg_m();
        let shapes: [ModeShape; N] = core::array::from_fn(|i| ModeShape::new(i, l));

        let mtt =
            p.jm_kgm2 + rho * (l * l * l / 3.0 + r * l * l + r * r * l) + mt * (r + l) * (r + l);
        // Every integral below in one pass over the quadrature's points, each shape evaluated
        // once a point (`integrate`, term for term and in its order: the same sums to the
        // bit, for a quarter of the hyperbolic and trigonometric functions).
        let rule = gauss_legendre::<GL_POINTS>();
        let mut sum_h = [0.0; N];
        let (mut sum_m, mut sum_k, mut sum_g) = (
            linalg::zeros::<N>(),
            linalg::zeros::<N>(),
            linalg::zeros::<N>(),
        );
        let panel = for_each_point(&rule, l, |w, x| {
            let phi: [f64; N] = core::array::from_fn(|i| shapes[i].phi(x));
            let dphi: [f64; N] = core::array::from_fn(|i| shapes[i].dphi(x));
            let ddphi: [f64; N] = core::array::from_fn(|i| shapes[i].ddphi(x));
            // G_ij = int rho_bar (r+x) g_ij(x) dx with g_ij(x) = -1/2 int_0^x phi_i' phi_j'.
            // Swapping the order of integration leaves one integral:
            // G_ij = -1/2 int_0^L phi_i' phi_j' [rho (r (L-x) + (L^2-x^2)/2) + Mt (r+L)] dx.
            let arm = rho * (r * (l - x) + 0.5 * (l * l - x * x)) + mt * (r + l);
            for i in 0..N {
                sum_h[i] += w * (rho * (r + x) * phi[i]);
                for j in 0..=i {
                    sum_m[i][j] += w * (rho * phi[i] * phi[j]);
                    sum_k[i][j] += w * (ddphi[i] * ddphi[j]);
                    sum_g[i][j] += w * (dphi[i] * dphi[j] * arm);
                }
            }
        });
        let h: [f64; N] =
            core::array::from_fn(|i| panel * sum_h[i] + mt * (r + l) * shapes[i].phi(l));
        let mut mqq = linalg::zeros::<N>();
        let mut kqq = linalg::zeros::<N>();
        let mut g = linalg::zeros::<N>();
        for i in 0..N {
            for j in 0..=i {
                let (a, b) = (shapes[i], shapes[j]);
                let m = panel * sum_m[i][j] + mt * a.phi(l) * b.phi(l);
                let k = p.ei_nm2 * (panel * sum_k[i][j]);
                let gij = -0.5 * (panel * sum_g[i][j]);
                mqq[i][j] = m;
                mqq[j][i] = m;
                kqq[i][j] = k;
                kqq[j][i] = k;
                g[i][j] = gij;
                g[j][i] = gij;
            }
        }
        let mut s = mqq;
        for i in 0..N {
            for j in 0..N {
                s[i][j] += 2.0 * g[i][j];
            }
        }
        let mqq_inv = linalg::spd_inverse(&mqq).ok_or(ModelError::NotPositiveDefinite("Mqq"))?;
        let jeff = mtt - linalg::quad(&h, &mqq_inv, &h);
        if !(jeff > 0.0) {
            return Err(ModelError::NotPositiveDefinite("the hub-beam mass matrix"));
        }
        let to_hz = |lambda: [f64; N]| lambda.map(|l| libm::sqrt(l.max(0.0)) / (2.0 * PI));
        let clamped_hz = to_hz(
            linalg::generalized_eigenvalues(&kqq, &mqq)
                .ok_or(ModelError::NotPositiveDefinite("Mqq"))?,
        );
        // Hub free: theta'' = -h'q''/Mtt condenses the rigid coordinate into Mqq - h h'/Mtt.
        let mut m_pinned = mqq;
        for i in 0..N {
            for j in 0..N {
                m_pinned[i][j] -= h[i] * h[j] / mtt;
            }
        }
        let pinned_hz = to_hz(
            linalg::generalized_eigenvalues(&kqq, &m_pinned)
                .ok_or(ModelError::NotPositiveDefinite("Mqq - h h'/Mtt"))?,
        );
        let mut cq = linalg::zeros::<N>();
        for i in 0..N {
            cq[i][i] = 2.0 * p.damping_ratio * (2.0 * PI * clamped_hz[i]) * mqq[i][i];
        }
        let half_t = 0.5 * p.thickness_m;
        Ok(Self {
            beam: *beam,
            shapes,
            rho_kg_m: rho,
            mtt,
            h,
            mqq,
            mqq_inv,
            kqq,
            g,
            s,
            cq,
            jeff,
            clamped_hz,
            pinned_hz,
            root_strain_coef: shapes.map(|m| half_t * m.ddphi(p.root_gauge_m)),
            mid_strain_coef: shapes.map(|m| half_t * m.ddphi(p.mid_gauge_m)),
            tip_coef: shapes.map(|m| m.phi(l)),
        })
    }

    /// Analytic clamped frequency of mode `i` without tip mass: b_i^2/(2 pi L^2) sqrt(EI/rho).
    pub fn analytic_clamped_hz(&self, i: usize) -> f64 {
        let p = self.beam.params();
        let b = MODE_ROOTS[i];
        b * b / (2.0 * PI * p.length_m * p.length_m) * libm::sqrt(p.ei_nm2 / self.rho_kg_m)
    }
}

/// Why a model could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// The mode count must be 1 to 4.
    UnsupportedModeCount(usize),
    /// A mass matrix came out singular or indefinite (cannot happen for valid parameters).
    NotPositiveDefinite(&'static str),
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::UnsupportedModeCount(n) => {
                write!(
                    f,
                    "{n} modes requested: the model supports 1 to {MAX_MODES}"
                )
            }
            ModelError::NotPositiveDefinite(what) => write!(f, "{what} is not positive definite"),
        }
    }
}

impl core::error::Error for ModelError {}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::beam::{BeamParams, Preset};

    fn isclose(a: f64, b: f64, rtol: f64, atol: f64) -> bool {
        (a - b).abs() <= atol + rtol * b.abs()
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        // An 8-point rule is exact to degree 15: int_0^1 x^15 = 1/16.
        let v = integrate(1.0, |x| x.powi(15));
        assert!(isclose(v, 1.0 / 16.0, 1e-14, 0.0));
        assert!(isclose(integrate(PI, libm::sin), 2.0, 1e-13, 0.0));
    }

    /// `M`, `K`, `G` and `h` as each integral alone gives them, by [`integrate`]: what the
    /// model's one pass over the points must equal.
    fn by_integral<const N: usize>(p: &BeamParams) -> (Mat<N>, Mat<N>, Mat<N>, [f64; N]) {
        let (l, r, mt) = (p.length_m, p.hub_radius_m, p.tip_mass_kg);
        let rho = p.rho_kg_m();
        let shapes: [ModeShape; N] = core::array::from_fn(|i| ModeShape::new(i, l));
        let h = core::array::from_fn(|i| {
            let si = shapes[i];
            integrate(l, |x| rho * (r + x) * si.phi(x)) + mt * (r + l) * si.phi(l)
        });
        let (mut m, mut k, mut g) = (linalg::zeros(), linalg::zeros(), linalg::zeros());
        for i in 0..N {
            for j in 0..N {
                let (a, b) = (shapes[i], shapes[j]);
                m[i][j] = integrate(l, |x| rho * a.phi(x) * b.phi(x)) + mt * a.phi(l) * b.phi(l);
                k[i][j] = p.ei_nm2 * integrate(l, |x| a.ddphi(x) * b.ddphi(x));
                g[i][j] = -0.5
                    * integrate(l, |x| {
                        a.dphi(x)
                            * b.dphi(x)
                            * (rho * (r * (l - x) + 0.5 * (l * l - x * x)) + mt * (r + l))
                    });
            }
        }
        (m, k, g, h)
    }

    fn assembled_as_each_integral<const N: usize>(p: BeamParams) {
        let model = ModalModel::<N>::try_build(&Beam::try_build(p).unwrap()).unwrap();
        let (m, k, g, h) = by_integral::<N>(&p);
        // Bit for bit (the lower triangle is what the pass sums; the upper is its mirror).
        for i in 0..N {
            for j in 0..=i {
                assert_eq!(model.mqq[i][j].to_bits(), m[i][j].to_bits(), "M {i}{j}");
                assert_eq!(model.kqq[i][j].to_bits(), k[i][j].to_bits(), "K {i}{j}");
                assert_eq!(model.g[i][j].to_bits(), g[i][j].to_bits(), "G {i}{j}");
            }
            assert_eq!(model.h[i].to_bits(), h[i].to_bits(), "h {i}");
        }
    }

    #[test]
    fn the_one_pass_assembly_is_each_integral_to_the_bit() {
        for &preset in Preset::ALL {
            let base = BeamParams::preset(preset);
            for p in [
                base,
                BeamParams {
                    tip_mass_kg: 0.05,
                    hub_radius_m: 0.03,
                    ..base
                },
            ] {
                assembled_as_each_integral::<1>(p);
                assembled_as_each_integral::<2>(p);
                assembled_as_each_integral::<3>(p);
                assembled_as_each_integral::<4>(p);
            }
        }
    }

    #[test]
    fn mode_shapes_are_orthonormal_and_satisfy_the_boundary_conditions() {
        let l = 0.4842;
        for i in 0..MAX_MODES {
            let a = ModeShape::new(i, l);
            // Clamped root: phi(0) = phi'(0) = 0. Free tip: phi''(L) = phi'''(L) = 0 (the
            // curvature at the tip vanishes relative to its root value).
            assert!(a.phi(0.0).abs() < 1e-12 && a.dphi(0.0).abs() < 1e-12);
            assert!(a.ddphi(l).abs() < 1e-6 * a.ddphi(0.0).abs(), "mode {i}");
            for j in 0..MAX_MODES {
                let b = ModeShape::new(j, l);
                let m = integrate(l, |x| a.phi(x) * b.phi(x));
                let expect = if i == j { l } else { 0.0 };
                assert!(
                    isclose(m, expect, 1e-10, 1e-10 * l),
                    "int phi{i} phi{j} = {m}"
                );
            }
        }
    }

    #[test]
    fn clamped_frequencies_match_euler_bernoulli() {
        for &preset in Preset::ALL {
            let beam = Beam::try_build(BeamParams::preset(preset)).unwrap();
            let m = ModalModel::<4>::try_build(&beam).unwrap();
            for i in 0..4 {
                let f = m.analytic_clamped_hz(i);
                // The printed roots carry nine digits.
                assert!(
                    isclose(m.clamped_hz[i], f, 1e-8, 0.0),
                    "{preset:?} mode {i}: {} vs {f}",
                    m.clamped_hz[i]
                );
            }
        }
        // A textbook number: the aluminium strip's first cantilever mode, 3.516/(2 pi L^2)
        // sqrt(EI/rho) with EI 1.709 and rho 0.3238 is about 5.5 Hz.
        let beam = Beam::try_build(BeamParams::aluminium()).unwrap();
        let m = ModalModel::<1>::try_build(&beam).unwrap();
        assert!((m.clamped_hz[0] - 5.48).abs() < 0.05, "{}", m.clamped_hz[0]);
    }

    #[test]
    fn stiffness_is_diagonal_and_foreshortening_negative_semidefinite() {
        let beam = Beam::try_build(BeamParams::aluminium()).unwrap();
        let m = ModalModel::<4>::try_build(&beam).unwrap();
        let p = beam.params();
        for i in 0..4 {
            // Kqq_ii = EI k_i^4 L for the unit-normalised shapes.
            let k = m.shapes[i].wavenumber();
            assert!(isclose(MODE_ROOTS[i] / p.length_m, k, 1e-8, 0.0));
            assert!(isclose(
                m.kqq[i][i],
                p.ei_nm2 * k.powi(4) * p.length_m,
                1e-10,
                0.0
            ));
            for j in 0..4 {
                if i != j {
                    assert!(m.kqq[i][j].abs() < 1e-8 * m.kqq[i][i]);
                }
            }
        }
        // -G is positive definite: its eigenvalues are all > 0.
        let neg_g = m.g.map(|row| row.map(|v| -v));
        let ev = linalg::sym_eigenvalues(&neg_g);
        assert!(ev[0] > 0.0, "{ev:?}");
    }

    #[test]
    fn with_hub_free_the_first_mode_rises_to_about_9_8_hz() {
        // docs/design.md, section 2: with the aluminium EI the first hub-free mode is near 9.8 Hz.
        let beam = Beam::try_build(BeamParams::aluminium()).unwrap();
        let m = ModalModel::<4>::try_build(&beam).unwrap();
        assert!((m.pinned_hz[0] - 9.8).abs() < 0.3, "{:?}", m.pinned_hz);
        for i in 0..4 {
            assert!(m.pinned_hz[i] > m.clamped_hz[i]);
        }
        assert!(m.jeff > 0.0 && m.jeff < m.mtt);
    }

    #[test]
    fn tip_mass_lowers_the_frequencies_and_raises_the_inertia() {
        let bare = Beam::try_build(BeamParams::aluminium()).unwrap();
        let loaded = Beam::try_build(BeamParams {
            tip_mass_kg: 0.05,
            ..BeamParams::aluminium()
        })
        .unwrap();
        let a = ModalModel::<3>::try_build(&bare).unwrap();
        let b = ModalModel::<3>::try_build(&loaded).unwrap();
        assert!(b.clamped_hz[0] < a.clamped_hz[0]);
        assert!(b.mtt > a.mtt);
        // Rigid-body fact: the tip mass adds Mt (r+L)^2 to Mtt.
        let p = bare.params();
        assert!(isclose(
            b.mtt - a.mtt,
            0.05 * (p.hub_radius_m + p.length_m).powi(2),
            1e-12,
            0.0
        ));
    }

    #[test]
    fn mode_count_is_checked() {
        let beam = Beam::try_build(BeamParams::table1()).unwrap();
        assert_eq!(
            ModalModel::<5>::try_build(&beam).unwrap_err(),
            ModelError::UnsupportedModeCount(5)
        );
        assert_eq!(
            ModalModel::<0>::try_build(&beam).unwrap_err(),
            ModelError::UnsupportedModeCount(0)
        );
    }
}
