//! Small fixed-size dense linear algebra for the modal model (N <= 4 modes).
//!
//! Only what the model needs: a Cholesky factorisation, solves, and the symmetric (generalised)
//! eigenproblem by cyclic Jacobi rotations. Sizes are const generics so nothing allocates; the
//! routines return `None` instead of panicking when a matrix is not positive definite.

// Index loops read like the textbook formulas they implement.
#![allow(clippy::needless_range_loop)]

/// A square `N x N` matrix, row-major.
pub type Mat<const N: usize> = [[f64; N]; N];

/// The zero matrix.
pub const fn zeros<const N: usize>() -> Mat<N> {
    [[0.0; N]; N]
}

/// `a * x` for a square matrix and a vector.
pub fn mat_vec<const N: usize>(a: &Mat<N>, x: &[f64; N]) -> [f64; N] {
    let mut y = [0.0; N];
    for (yi, row) in y.iter_mut().zip(a) {
        *yi = row.iter().zip(x).map(|(r, x)| r * x).sum();
    }
    y
}

/// Dot product.
pub fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// The quadratic form `x' a y`.
pub fn quad<const N: usize>(x: &[f64; N], a: &Mat<N>, y: &[f64; N]) -> f64 {
    dot(x, &mat_vec(a, y))
}

/// Lower-triangular Cholesky factor `l` with `a = l l'`; `None` unless `a` is symmetric
/// positive definite (to rounding).
pub fn cholesky<const N: usize>(a: &Mat<N>) -> Option<Mat<N>> {
    let mut l = zeros::<N>();
    for i in 0..N {
        for j in 0..=i {
            let mut sum = a[i][j];
            for k in 0..j {
                sum -= l[i][k] * l[j][k];
            }
            if i == j {
                if !(sum > 0.0) || !sum.is_finite() {
                    return None;
                }
                l[i][i] = libm::sqrt(sum);
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    Some(l)
}

/// Solves `l y = b` for lower-triangular `l`.
pub fn forward_sub<const N: usize>(l: &Mat<N>, b: &[f64; N]) -> [f64; N] {
    let mut y = [0.0; N];
    for i in 0..N {
        let s: f64 = (0..i).map(|k| l[i][k] * y[k]).sum();
        y[i] = (b[i] - s) / l[i][i];
    }
    y
}

/// Solves `l' x = y` for lower-triangular `l`.
pub fn back_sub_t<const N: usize>(l: &Mat<N>, y: &[f64; N]) -> [f64; N] {
    let mut x = [0.0; N];
    for i in (0..N).rev() {
        let s: f64 = (i + 1..N).map(|k| l[k][i] * x[k]).sum();
        x[i] = (y[i] - s) / l[i][i];
    }
    x
}

/// Solves `a x = b` given the Cholesky factor `l` of `a`.
pub fn chol_solve<const N: usize>(l: &Mat<N>, b: &[f64; N]) -> [f64; N] {
    back_sub_t(l, &forward_sub(l, b))
}

/// Inverse of a symmetric positive definite matrix, `None` if it is not.
pub fn spd_inverse<const N: usize>(a: &Mat<N>) -> Option<Mat<N>> {
    let l = cholesky(a)?;
    let mut inv = zeros::<N>();
    for j in 0..N {
        let mut e = [0.0; N];
        e[j] = 1.0;
        let col = chol_solve(&l, &e);
        for i in 0..N {
            inv[i][j] = col[i];
        }
    }
    Some(inv)
}

/// Eigenvalues of a symmetric matrix by cyclic Jacobi rotations, sorted ascending.
pub fn sym_eigenvalues<const N: usize>(a: &Mat<N>) -> [f64; N] {
    let mut m = *a;
    for _sweep in 0..64 {
        let off: f64 = (0..N)
            .flat_map(|i| (0..N).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| m[i][j] * m[i][j])
            .sum();
        let scale: f64 = (0..N).map(|i| m[i][i] * m[i][i]).sum();
        if off <= 1e-30 * scale || off == 0.0 {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if m[p][q] == 0.0 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = libm::copysign(1.0, theta)
                    / (libm::fabs(theta) + libm::sqrt(theta * theta + 1.0));
                let c = 1.0 / libm::sqrt(t * t + 1.0);
                let s = t * c;
                for k in 0..N {
                    let (mkp, mkq) = (m[k][p], m[k][q]);
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..N {
                    let (mpk, mqk) = (m[p][k], m[q][k]);
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
            }
        }
    }
    let mut ev = [0.0; N];
    for (i, e) in ev.iter_mut().enumerate() {
        *e = m[i][i];
    }
    insertion_sort(&mut ev);
    ev
}

/// Eigenvalues `lambda` of the symmetric-definite pencil `k v = lambda m v`, ascending;
/// `None` if `m` is not positive definite.
pub fn generalized_eigenvalues<const N: usize>(k: &Mat<N>, m: &Mat<N>) -> Option<[f64; N]> {
    let l = cholesky(m)?;
    // c = l^-1 k l^-T, built column by column.
    let mut tmp = zeros::<N>(); // l^-1 k
    for j in 0..N {
        let col: [f64; N] = core::array::from_fn(|i| k[i][j]);
        let y = forward_sub(&l, &col);
        for i in 0..N {
            tmp[i][j] = y[i];
        }
    }
    let mut c = zeros::<N>(); // (l^-1 (l^-1 k)')' = l^-1 k l^-T since k is symmetric
    for i in 0..N {
        let y = forward_sub(&l, &tmp[i]);
        for j in 0..N {
            c[j][i] = y[j];
        }
    }
    // Symmetrise against rounding before the Jacobi sweep.
    for i in 0..N {
        for j in 0..i {
            let avg = 0.5 * (c[i][j] + c[j][i]);
            c[i][j] = avg;
            c[j][i] = avg;
        }
    }
    Some(sym_eigenvalues(&c))
}

/// Sorts a few numbers in place, ascending by `total_cmp` (NaN last). The library's sort
/// would do, but its pattern-defeating quicksort is about 8 KiB of flash on the drive for
/// lists of at most 30 elements, where insertion sort is as fast.
pub fn insertion_sort<T: TotalOrder>(v: &mut [T]) {
    for i in 1..v.len() {
        let mut j = i;
        while j > 0 && v[j - 1].total_after(&v[j]) {
            v.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// The floats [`insertion_sort`] sorts: `f64` (the model's eigenvalues) and `f32` (the
/// drive's shaper breaks), each by its `total_cmp`.
pub trait TotalOrder: Copy {
    /// `self` comes after `other` in IEEE 754's total order.
    fn total_after(&self, other: &Self) -> bool;
}

impl TotalOrder for f64 {
    fn total_after(&self, other: &Self) -> bool {
        self.total_cmp(other).is_gt()
    }
}

impl TotalOrder for f32 {
    fn total_after(&self, other: &Self) -> bool {
        self.total_cmp(other).is_gt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_reconstructs_and_rejects_indefinite() {
        let a = [[4.0, 2.0, 0.4], [2.0, 5.0, 1.0], [0.4, 1.0, 3.0]];
        let l = cholesky(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3).map(|k| l[i][k] * l[j][k]).sum();
                assert!((r - a[i][j]).abs() < 1e-12);
            }
        }
        assert!(cholesky(&[[1.0, 2.0], [2.0, 1.0]]).is_none());
        let inv = spd_inverse(&a).unwrap();
        let x = mat_vec(&inv, &[1.0, 2.0, 3.0]);
        let b = mat_vec(&a, &x);
        assert!(
            (b[0] - 1.0).abs() < 1e-12 && (b[1] - 2.0).abs() < 1e-12 && (b[2] - 3.0).abs() < 1e-12
        );
    }

    #[test]
    fn eigenvalues_match_closed_form() {
        // [[2,1],[1,2]] has eigenvalues 1 and 3.
        let ev = sym_eigenvalues(&[[2.0, 1.0], [1.0, 2.0]]);
        assert!((ev[0] - 1.0).abs() < 1e-12 && (ev[1] - 3.0).abs() < 1e-12);
        // Pencil k = diag(2, 12), m = diag(1, 3): eigenvalues 2 and 4.
        let ev =
            generalized_eigenvalues(&[[2.0, 0.0], [0.0, 12.0]], &[[1.0, 0.0], [0.0, 3.0]]).unwrap();
        assert!((ev[0] - 2.0).abs() < 1e-12 && (ev[1] - 4.0).abs() < 1e-12);
    }
}
