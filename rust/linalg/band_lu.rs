//! Dense-band LU without pivoting, for the nonsymmetric effective matrices of moving frames.

use crate::error::{Error, Result};

/// Dense-band LU factorization without pivoting, for the nonsymmetric effective matrices of
/// rotating links (the Coriolis term `2 phidot rho A int N^T S N` and the `phiddot` part of
/// `M_IC` are skew-symmetric). Refactorized in place with no allocation, `O(n b^2)` for
/// half-bandwidth `b`, so cost grows linearly with the element count of a chain.
///
/// Without pivoting the factorization exists whenever the symmetric part of the matrix is
/// positive definite (every leading principal minor is then nonzero), which holds for Newmark
/// effective matrices `M/(beta dt^2) + gamma/(beta dt) C + K` at the steps of interest; a pivot that
/// is not finite or is rounding noise is reported as [`Error::Singular`] (with the pivot's
/// index; the caller names the unknown) instead of being divided by.
///
/// A pivot `u_kk = a_kk - sum_j l_kj u_jk` is judged against what was subtracted to form it, not
/// against the largest diagonal entry of the whole matrix: it is noise when
/// `|u_kk| <= 8 (b + 1) eps (|a_kk| + sum_j |l_kj u_jk|)` (the rounding error of a sum of `b + 1`
/// terms, with a margin of 8). Rows of very different scale (the rotation of a 60 um element has
/// a mass ~1e-15 kg m^2 next to a slider of 0.08 kg; a translation's stiffness grows like
/// `1/l^3` with the element length `l`) then do not pass for singular, while a row that is a
/// combination of earlier ones to working precision (a massless unknown: zero row, zero pivot)
/// still does. The test is invariant under a diagonal scaling of the unknowns.
#[derive(Debug, Clone)]
pub struct BandLu {
    n: usize,
    b: usize,
    /// Row-major band: entry (i, j) at `i * (2b + 1) + (j + b - i)`, for `|i - j| <= b`.
    a: Vec<f64>,
    /// Scratch of [`Self::factorize`]: per row, `|a_kk| + sum_j |l_kj u_jk|` (the magnitude the
    /// pivot is formed from).
    pivot_scale: Vec<f64>,
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
            pivot_scale: vec![0.0; n],
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
        // rounding of a pivot formed from up to b + 1 terms, with a margin of 8
        let noise = 8.0 * (b + 1) as f64 * f64::EPSILON;
        for (i, s) in self.pivot_scale.iter_mut().enumerate() {
            *s = self.a[i * w + b].abs();
        }
        for k in 0..n {
            let piv = self.a[k * w + b];
            if !piv.is_finite() || piv.abs() <= noise * self.pivot_scale[k] {
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
                    self.pivot_scale[i] += (l * self.a[rk + i]).abs();
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

    /// The pivot test is relative to each row's own magnitude: a matrix and its diagonal
    /// scaling `D A D` with `D` from 1 down to 2^-30 (unknowns whose squared units differ by
    /// 1e18, like the rotation of a 60 um beam element next to a slider's travel; the old test
    /// against 1e-14 of the largest diagonal entry refused it) both factorize, and with powers of
    /// two the scaled solve is the unscaled one to the bit; a singular matrix (a row the sum of
    /// two earlier ones) stays singular under a scaling, at that row.
    #[test]
    fn pivot_test_is_invariant_under_diagonal_scaling() {
        let (n, b) = (30, 3);
        let d: Vec<f64> = (0..n).map(|i| 2f64.powi(-3 * (i % 11) as i32)).collect();
        let entry = |i: usize, j: usize| -> f64 {
            if i == j {
                8.0
            } else {
                1.0 / (1.0 + (i + 2 * j) as f64 % 3.0) - 0.2 * (i as f64 - j as f64).signum()
            }
        };
        let (mut plain, mut scaled) = (BandLu::new(n, b), BandLu::new(n, b));
        for i in 0..n {
            for j in i.saturating_sub(b)..=(i + b).min(n - 1) {
                plain.add(i, j, entry(i, j));
                scaled.add(i, j, d[i] * entry(i, j) * d[j]);
            }
        }
        let rhs: Vec<f64> = (0..n).map(|i| 2.0 + (i as f64 * 0.7).cos()).collect();
        // A x = rhs and (D A D) z = D rhs: z = D^-1 x
        let mut x = rhs.clone();
        let mut z: Vec<f64> = rhs.iter().zip(&d).map(|(r, d)| r * d).collect();
        plain.factorize("plain").unwrap();
        scaled.factorize("scaled").unwrap();
        plain.solve_in_place(&mut x);
        scaled.solve_in_place(&mut z);
        for i in 0..n {
            assert_eq!(z[i] * d[i], x[i], "{i}");
        }
        // singular: row 2 = row 0 + row 1 (tridiagonal), scaled
        let rows = [[2.0, -1.0, 0.0], [-1.0, 3.0, -1.0], [1.0, 2.0, -1.0]];
        let s = [1.0, 1e-6, 1e-9];
        let mut m = BandLu::new(3, 2);
        for i in 0..3 {
            for j in 0..3 {
                m.add(i, j, s[i] * rows[i][j] * s[j]);
            }
        }
        match m.factorize("K") {
            Err(crate::error::Error::Singular { index, .. }) => assert_eq!(index, 2),
            r => panic!("expected a singular pivot at 2, got {r:?}"),
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
