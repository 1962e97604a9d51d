//! Small dense least squares: the normal equations of a few unknowns, solved by Gauss-Jordan
//! elimination (the problems here have at most a handful of columns and thousands of rows).

/// The inverse of a small symmetric positive-definite matrix by Gauss-Jordan elimination with
/// partial pivoting; `None` if it is singular (to working precision).
pub fn invert(mut a: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let scale = (0..n).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    for c in 0..n {
        let pivot = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[pivot][c].abs() <= 1e-14 * scale {
            return None;
        }
        a.swap(c, pivot);
        inv.swap(c, pivot);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..n {
            if r != c {
                let f = a[r][c];
                for j in 0..n {
                    a[r][j] -= f * a[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    Some(inv)
}

/// The solution of `a x = b` for a small square `a`; `None` if `a` is singular.
pub fn solve(a: Vec<Vec<f64>>, b: Vec<f64>) -> Option<Vec<f64>> {
    let inv = invert(a)?;
    Some(
        inv.iter()
            .map(|r| r.iter().zip(&b).map(|(x, y)| x * y).sum())
            .collect(),
    )
}

/// Linear least squares `y ~ X c` accumulated row by row.
#[derive(Clone, Debug, Default)]
pub struct Normal {
    xtx: Vec<Vec<f64>>,
    xty: Vec<f64>,
    yty: f64,
    rows: usize,
}

/// A least-squares fit.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// The coefficients.
    pub coef: Vec<f64>,
    /// `(X'X)^-1`: times the residual variance, the coefficients' covariance for independent
    /// residuals.
    pub xtx_inv: Vec<Vec<f64>>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Rows fitted.
    pub rows: usize,
}

impl Normal {
    /// An empty problem with `cols` unknowns.
    pub fn new(cols: usize) -> Self {
        Self {
            xtx: vec![vec![0.0; cols]; cols],
            xty: vec![0.0; cols],
            yty: 0.0,
            rows: 0,
        }
    }

    /// Adds the row `x . c = y`.
    pub fn add(&mut self, x: &[f64], y: f64) {
        for (i, xi) in x.iter().enumerate() {
            for (j, xj) in x.iter().enumerate() {
                self.xtx[i][j] += xi * xj;
            }
            self.xty[i] += xi * y;
        }
        self.yty += y * y;
        self.rows += 1;
    }

    /// The fit; `None` if the columns are dependent.
    pub fn solve(&self) -> Option<Fit> {
        let xtx_inv = invert(self.xtx.clone())?;
        let coef: Vec<f64> = xtx_inv
            .iter()
            .map(|r| r.iter().zip(&self.xty).map(|(a, b)| a * b).sum())
            .collect();
        let explained: f64 = coef.iter().zip(&self.xty).map(|(c, b)| c * b).sum();
        Some(Fit {
            coef,
            xtx_inv,
            rss: (self.yty - explained).max(0.0),
            rows: self.rows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_line_and_its_textbook_standard_errors() {
        // y = 2 + 3x at x = 0..4, residuals +-1 alternating: the slope's standard error is
        // s / sqrt(Sxx) with s^2 = RSS / (n - 2), here Sxx = 10.
        let mut n = Normal::new(2);
        let r = [1.0, -1.0, 1.0, -1.0, 1.0];
        for (k, e) in r.iter().enumerate() {
            let x = k as f64;
            n.add(&[1.0, x], 2.0 + 3.0 * x + e);
        }
        let f = n.solve().unwrap();
        let s2 = f.rss / 3.0;
        // Least squares on these residuals: mean 0.2 moves the intercept; the slope sees
        // sum (x - 2) e = 0.
        assert!((f.coef[1] - 3.0).abs() < 1e-12, "{f:?}");
        assert!((f.coef[0] - 2.2).abs() < 1e-12, "{f:?}");
        assert!((f.rss - (5.0 - 5.0 * 0.04)).abs() < 1e-12, "{f:?}");
        assert!(((s2 * f.xtx_inv[1][1]).sqrt() - (s2 / 10.0).sqrt()).abs() < 1e-12);
        assert!(Normal::new(2).solve().is_none());
    }
}
