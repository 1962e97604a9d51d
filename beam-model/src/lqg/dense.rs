//! The dense algebra of the LQG design, on matrices of one fixed size ([`D`]) of which the
//! first `n` rows and columns are used: products, the Gauss-Jordan inverse, the matrix
//! exponential and the doubling algorithm for the discrete algebraic Riccati equation.
//! `f64`, no allocation; run once per design, never per tick.

// Dense matrix algebra reads best with its indices: `a[i][j]` as in the formulas.
#![allow(clippy::needless_range_loop)]

use crate::modal::MAX_MODES;

/// Working dimension: the states of a model of up to [`MAX_MODES`] modes, the integral, and
/// Van Loan's input column.
pub(super) const D: usize = 2 + 2 * MAX_MODES + 2;

/// A working matrix; a caller uses its first `n` rows and columns.
pub(super) type Mat = [[f64; D]; D];

/// The zero matrix.
pub(super) const ZERO: Mat = [[0.0; D]; D];

fn identity(n: usize) -> Mat {
    let mut a = ZERO;
    for (i, row) in a.iter_mut().enumerate().take(n) {
        row[i] = 1.0;
    }
    a
}

/// `a b` on the leading `n` by `n` blocks, for matrices of any one size (the design's
/// [`Mat`], the closed loop's larger one).
pub(super) fn mul<const S: usize>(a: &[[f64; S]; S], b: &[[f64; S]; S], n: usize) -> [[f64; S]; S] {
    let mut c = [[0.0; S]; S];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i][k];
            if aik == 0.0 {
                continue;
            }
            for j in 0..n {
                c[i][j] += aik * b[k][j];
            }
        }
    }
    c
}

fn add(a: &Mat, b: &Mat, n: usize) -> Mat {
    let mut c = *a;
    for i in 0..n {
        for j in 0..n {
            c[i][j] += b[i][j];
        }
    }
    c
}

pub(super) fn transpose(a: &Mat, n: usize) -> Mat {
    let mut t = ZERO;
    for i in 0..n {
        for j in 0..n {
            t[j][i] = a[i][j];
        }
    }
    t
}

fn norm1(a: &Mat, n: usize) -> f64 {
    (0..n)
        .map(|j| (0..n).map(|i| libm::fabs(a[i][j])).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Gauss-Jordan inverse with partial pivoting; `None` if singular.
pub(super) fn inverse(a: &Mat, n: usize) -> Option<Mat> {
    let mut m = *a;
    let mut inv = identity(n);
    for col in 0..n {
        let p =
            (col..n).max_by(|&i, &j| libm::fabs(m[i][col]).total_cmp(&libm::fabs(m[j][col])))?;
        if !(libm::fabs(m[p][col]) > 1e-300) {
            return None;
        }
        m.swap(col, p);
        inv.swap(col, p);
        let d = 1.0 / m[col][col];
        for j in 0..n {
            m[col][j] *= d;
            inv[col][j] *= d;
        }
        for i in 0..n {
            if i != col {
                let f = m[i][col];
                if f != 0.0 {
                    for j in 0..n {
                        m[i][j] -= f * m[col][j];
                        inv[i][j] -= f * inv[col][j];
                    }
                }
            }
        }
    }
    Some(inv)
}

/// `exp(a)` by scaling and squaring a degree-16 Taylor series.
pub(super) fn expm(a: &Mat, n: usize) -> Mat {
    let mut squarings = 0;
    let mut scale = 1.0;
    while norm1(a, n) * scale > 0.5 {
        scale *= 0.5;
        squarings += 1;
    }
    let mut s = ZERO;
    for i in 0..n {
        for j in 0..n {
            s[i][j] = a[i][j] * scale;
        }
    }
    let mut e = identity(n);
    let mut term = identity(n);
    for k in 1..=16 {
        term = mul(&term, &s, n);
        let f = 1.0 / k as f64;
        for row in term.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v *= f;
            }
        }
        e = add(&e, &term, n);
    }
    for _ in 0..squarings {
        e = mul(&e, &e, n);
    }
    e
}

/// The stabilising solution of `P = A'PA - A'PG(I + HG)^-1... ` in the doubling form: for
/// the DARE `X = A' X A - A' X B (R + B' X B)^-1 B' X A + Q`, with `g = B R^-1 B'` and
/// `h = Q`, returns X.
pub(super) fn dare(a: &Mat, g: &Mat, h: &Mat, n: usize) -> Option<Mat> {
    let (mut a, mut g, mut h) = (*a, *g, *h);
    let id = identity(n);
    for _ in 0..80 {
        // W = (I + G H)^-1
        let w = inverse(&add(&id, &mul(&g, &h, n), n), n)?;
        let wa = mul(&w, &a, n);
        let at = transpose(&a, n);
        let a_next = mul(&a, &wa, n);
        let g_next = add(&g, &mul(&mul(&a, &mul(&w, &g, n), n), &at, n), n);
        let h_next = add(&h, &mul(&mul(&at, &h, n), &wa, n), n);
        let change = norm1(&add(&h_next, &scaled(&h, -1.0, n), n), n);
        let size = norm1(&h_next, n);
        a = a_next;
        g = g_next;
        h = h_next;
        if !size.is_finite() {
            return None;
        }
        if change <= 1e-12 * size {
            return Some(h);
        }
    }
    None
}

fn scaled(a: &Mat, f: f64, n: usize) -> Mat {
    let mut c = *a;
    for row in c.iter_mut().take(n) {
        for v in row.iter_mut().take(n) {
            *v *= f;
        }
    }
    c
}
