//! Dense-band LU without pivoting, for the nonsymmetric effective matrices of moving frames.

use crate::error::{Error, Result};

/// A pivot at most this fraction of its row's largest entry (before elimination) counts as
/// singular: a few hundred ulps, i.e. what is left when elimination cancels the row.
pub const PIVOT_TOL: f64 = 1e-13;

/// Dense-band LU factorization without pivoting, for the nonsymmetric effective matrices of
/// rotating links (the Coriolis term `2 phidot rho A int N^T S N` and the `phiddot` part of
/// `M_IC` are skew-symmetric). Refactorized in place with no allocation, `O(n b^2)` for
/// half-bandwidth `b`, so cost grows linearly with the element count of a chain.
///
/// Without pivoting the factorization exists whenever the symmetric part of the matrix is
/// positive definite (every leading principal minor is then nonzero), which holds for Newmark
/// effective matrices `M/(beta dt^2) + gamma/(beta dt) C + K` at the steps of interest; a pivot that
/// is not finite, or that elimination has cancelled to [`PIVOT_TOL`] of its own row's largest
/// entry, is reported as [`Error::Singular`] instead of being divided by. The test is per row:
/// the unknowns of a mechanism differ in unit and scale (a slider's mass against the rotary
/// inertia of a 60 um beam element, 1e13 apart), so a pivot is small only against its own row.
#[derive(Debug, Clone)]
pub struct BandLu {
    n: usize,
    b: usize,
    /// Row-major band: entry (i, j) at `i * (2b + 1) + (j + b - i)`, for `|i - j| <= b`.
    a: Vec<f64>,
    /// Largest magnitude in each row before elimination (the pivot test's scale).
    row_scale: Vec<f64>,
    /// Numeric factorizations done.
    pub factorizations: u64,
}

impl BandLu {
    /// An `n x n` zero matrix of half-bandwidth `b`.
    pub fn new(n: usize, b: usize) -> Self {
        BandLu {
            n,
            b,
            a: vec![0.0; n * (2 * b + 1)],
            row_scale: vec![0.0; n],
            factorizations: 0,
        }
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Half-bandwidth.
    pub fn bandwidth(&self) -> usize {
        self.b
    }

    /// Sets every entry to zero (before assembling a new matrix).
    pub fn clear(&mut self) {
        self.a.fill(0.0);
    }

    /// Adds `v` to entry (i, j). Panics in debug builds if `|i - j| > b` (an assembly bug, not
    /// user input: the bandwidth is computed from the same connectivity).
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        debug_assert!(i.abs_diff(j) <= self.b && i < self.n && j < self.n);
        let w = 2 * self.b + 1;
        self.a[i * w + j + self.b - i] += v;
    }

    /// Entry (i, j) (zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if i.abs_diff(j) > self.b {
            return 0.0;
        }
        self.a[i * (2 * self.b + 1) + j + self.b - i]
    }

    /// Factorizes the assembled matrix in place (L unit lower, U upper). `what` names the
    /// matrix in the error.
    pub fn factorize(&mut self, what: &str) -> Result<()> {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        for (i, row) in self.a.chunks_exact(w).enumerate() {
            self.row_scale[i] = row.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        }
        for k in 0..n {
            let piv = self.a[k * w + b];
            if !piv.is_finite() || piv.abs() <= PIVOT_TOL * self.row_scale[k] {
                return Err(Error::Singular {
                    what: if piv.is_finite() {
                        what.to_string()
                    } else {
                        format!("{what} (non-finite entries)")
                    },
                    index: k,
                    dof: String::new(),
                });
            }
            let last = (k + b).min(n - 1);
            for i in k + 1..=last {
                let ik = i * w + k + b - i;
                let l = self.a[ik] / piv;
                self.a[ik] = l;
                if l != 0.0 {
                    let (ri, rk) = (i * w + b - i, k * w + b - k);
                    for j in k + 1..=last {
                        self.a[ri + j] -= l * self.a[rk + j];
                    }
                }
            }
        }
        self.factorizations += 1;
        Ok(())
    }

    /// Solves `A x = rhs` in place with the factorization.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        for i in 0..n {
            let lo = i.saturating_sub(b);
            let row = i * w + b - i;
            let mut s = x[i];
            for j in lo..i {
                s -= self.a[row + j] * x[j];
            }
            x[i] = s;
        }
        for i in (0..n).rev() {
            let hi = (i + b).min(n - 1);
            let row = i * w + b - i;
            let mut s = x[i];
            for j in i + 1..=hi {
                s -= self.a[row + j] * x[j];
            }
            x[i] = s / self.a[row + i];
        }
    }
}

#[cfg(test)]
mod band_lu_tests {
    use super::BandLu;

    /// A nonsymmetric band matrix with positive definite symmetric part: LU solve reproduces a
    /// known solution to rounding.
    #[test]
    fn solves_nonsymmetric_band() {
        let (n, b) = (40, 4);
        let mut m = BandLu::new(n, b);
        let mut dense = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in i.saturating_sub(b)..=(i + b).min(n - 1) {
                let v = if i == j {
                    10.0 + i as f64 * 0.1
                } else {
                    ((i * 7 + j * 3) % 5) as f64 * 0.3 - 0.6 + (j as f64 - i as f64) * 0.05
                };
                m.add(i, j, v);
                dense[i][j] = v;
            }
        }
        let x_true: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x: Vec<f64> = (0..n).map(|i| (0..n).map(|j| dense[i][j] * x_true[j]).sum()).collect();
        m.factorize("test").unwrap();
        m.solve_in_place(&mut x);
        for i in 0..n {
            assert!((x[i] - x_true[i]).abs() < 1e-13, "{i}: {} vs {}", x[i], x_true[i]);
        }
    }

    /// Rows of very different scale (a slider's mass beside the rotary inertia of a tiny beam
    /// element, 1e13 apart) factorize: each pivot is judged against its own row.
    #[test]
    fn rows_of_different_scale_factorize() {
        let mut m = BandLu::new(3, 1);
        m.add(0, 0, 7.6e-2);
        m.add(1, 1, 4.1e-15);
        m.add(1, 2, 1.0e-16);
        m.add(2, 1, 1.0e-16);
        m.add(2, 2, 5.0e-15);
        m.factorize("M").unwrap();
        let mut x = vec![7.6e-2, 4.2e-15, 5.1e-15];
        m.solve_in_place(&mut x);
        for v in x {
            assert!((v - 1.0).abs() < 1e-14, "{v}");
        }
    }

    /// A row that elimination cancels (row 1 = row 0 up to 1e-15) is singular at that row.
    #[test]
    fn a_cancelled_row_is_singular_at_its_index() {
        let mut m = BandLu::new(2, 1);
        m.add(0, 0, 1.0);
        m.add(0, 1, 2.0);
        m.add(1, 0, 1.0);
        m.add(1, 1, 2.0 + 1e-15);
        match m.factorize("K") {
            Err(crate::error::Error::Singular { index, .. }) => assert_eq!(index, 1),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn zero_pivot_is_an_error() {
        let mut m = BandLu::new(3, 1);
        m.add(0, 0, 1.0);
        m.add(2, 2, 1.0);
        assert!(m.factorize("K").is_err());
    }
}
