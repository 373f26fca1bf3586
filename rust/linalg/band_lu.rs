//! Dense-band LU without pivoting, for the nonsymmetric effective matrices of moving frames.

use crate::error::{Error, Result};

/// The storage position of entry `(i, j)` of an `n x n` band of half-bandwidth `b` stored row by
/// row, `2b + 1` entries a row: `i (2b + 1) + (j + b - i)`. Panics outside the band (an assembly
/// bug, not user input: the bandwidth is computed from the same connectivity).
#[inline]
pub(super) fn band_position(n: usize, b: usize, i: usize, j: usize) -> usize {
    assert!(i.abs_diff(j) <= b && i < n && j < n, "entry outside the band");
    i * (2 * b + 1) + j + b - i
}

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
    /// `1 / u_jj`.
    inv_diag: Vec<f64>,
    /// The factors' columns, contiguous for the fixed-bandwidth substitutions (copied from `a`
    /// after each factorization, [`Self::copy_columns`]): `lcols[j b + t] = L[j + 1 + t, j]`,
    /// `ucols[j b + t] = U[j - b + t, j]`. In `a` a column's entries are `2b` apart, and the
    /// solves' loads of them could not be vector loads.
    lcols: Vec<f64>,
    ucols: Vec<f64>,
    /// Numeric factorizations done.
    pub factorizations: u64,
    /// Whether [`Self::solve_in_place`] runs its AVX2 build (the CPU has AVX2 and FMA; the
    /// same operations in the same order as the baseline's, so the same bits).
    avx2: bool,
}

impl BandLu {
    /// An `n x n` zero matrix of half-bandwidth `b`.
    pub fn new(n: usize, b: usize) -> Self {
        BandLu {
            n,
            b,
            a: vec![0.0; n * (2 * b + 1)],
            pivot_scale: vec![0.0; n],
            inv_diag: vec![0.0; n],
            lcols: vec![0.0; n * b],
            ucols: vec![0.0; n * b],
            factorizations: 0,
            avx2: super::ldlt::avx2_fma_available(),
        }
    }

    /// Runs [`Self::solve_in_place`] in its AVX2 build where `on` and the CPU has AVX2 and FMA
    /// (the default where it has), else in the baseline's: the same bits either way (the tests
    /// compare the two).
    pub fn set_avx2(&mut self, on: bool) {
        self.avx2 = on && super::ldlt::avx2_fma_available();
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

    /// The storage position of entry `(i, j)` (`|i - j| <= b`), for [`Self::add_at`]: callers
    /// that add into the same entries at every assembly compute it once.
    #[inline]
    pub fn position(&self, i: usize, j: usize) -> usize {
        band_position(self.n, self.b, i, j)
    }

    /// Adds `v` at a position from [`Self::position`].
    #[inline]
    pub fn add_at(&mut self, pos: usize, v: f64) {
        self.a[pos] += v;
    }

    /// Entry (i, j) (zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if i.abs_diff(j) > self.b {
            return 0.0;
        }
        self.a[band_position(self.n, self.b, i, j)]
    }

    /// Factorizes the assembled matrix in place (L unit lower, U upper). `what` names the
    /// matrix in the error.
    pub fn factorize(&mut self, what: &str) -> Result<()> {
        self.factorize_with(what, false)
    }

    /// [`Self::factorize`], with `general` the elimination for any half-bandwidth throughout
    /// (the tests compare the two).
    fn factorize_with(&mut self, what: &str, general: bool) -> Result<()> {
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
            match if general { 0 } else { b } {
                1 => self.eliminate::<1>(k),
                2 => self.eliminate::<2>(k),
                3 => self.eliminate::<3>(k),
                4 => self.eliminate::<4>(k),
                5 => self.eliminate::<5>(k),
                6 => self.eliminate::<6>(k),
                7 => self.eliminate::<7>(k),
                8 => self.eliminate::<8>(k),
                _ => self.eliminate_general(k),
            }
        }
        self.invert_pivots();
        self.copy_columns();
        self.factorizations += 1;
        Ok(())
    }

    /// Eliminates column `k` below the pivot (rows `k+1..=min(k+b, n-1)`), accumulating each
    /// row's pivot scale; for `b == B` with the full band below `k` the row length is fixed at
    /// compile time (the same operations in the same order as [`Self::eliminate_general`]).
    #[inline]
    fn eliminate<const B: usize>(&mut self, k: usize) {
        let n = self.n;
        if k + B >= n {
            return self.eliminate_general(k);
        }
        let w = 2 * B + 1;
        let piv = self.a[k * w + B];
        let (head, tail) = self.a.split_at_mut((k + 1) * w);
        let urow: &[f64; B] = head[k * w + B + 1..k * w + B + 1 + B].try_into().expect("band row");
        for d in 1..=B {
            // row k + d: its column k at offset B - d of the row, the next B columns after it
            let ik = (d - 1) * w + B - d;
            let l = tail[ik] / piv;
            tail[ik] = l;
            if l != 0.0 {
                self.pivot_scale[k + d] += (l * urow[d - 1]).abs();
                let row: &mut [f64; B] = (&mut tail[ik + 1..ik + 1 + B]).try_into().expect("band row");
                for t in 0..B {
                    row[t] -= l * urow[t];
                }
            }
        }
    }

    /// [`Self::eliminate`] for any half-bandwidth and near the end of the band.
    fn eliminate_general(&mut self, k: usize) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let piv = self.a[k * w + b];
        let last = (k + b).min(n - 1);
        // row k's entries right of the pivot (columns k+1..=last), read-only below
        let (head, tail) = self.a.split_at_mut((k + 1) * w);
        let urow = &head[k * w + b + 1..k * w + b + 1 + (last - k)];
        for i in k + 1..=last {
            // row i starts at (i - k - 1) w in `tail`; its column j at offset j + b - i
            let ri = (i - k - 1) * w;
            let ik = ri + k + b - i;
            let l = tail[ik] / piv;
            tail[ik] = l;
            if l != 0.0 {
                self.pivot_scale[i] += (l * urow[i - k - 1]).abs();
                let row = &mut tail[ik + 1..ik + 1 + (last - k)];
                for (x, &u) in row.iter_mut().zip(urow) {
                    *x -= l * u;
                }
            }
        }
    }

    /// The pivots' reciprocals into [`Self::inv_diag`] (the substitutions multiply by them).
    fn invert_pivots(&mut self) {
        let w = 2 * self.b + 1;
        for (j, d) in self.inv_diag.iter_mut().enumerate() {
            *d = 1.0 / self.a[j * w + self.b];
        }
    }

    /// The factors' columns the fixed-bandwidth solves read ([`Self::solve_fixed`]: L's columns
    /// `0..n`, zero past the last row, and U's columns `b..n`) into [`Self::lcols`] and
    /// [`Self::ucols`].
    fn copy_columns(&mut self) {
        match self.b {
            1 => self.copy_columns_fixed::<1>(),
            2 => self.copy_columns_fixed::<2>(),
            3 => self.copy_columns_fixed::<3>(),
            4 => self.copy_columns_fixed::<4>(),
            5 => self.copy_columns_fixed::<5>(),
            6 => self.copy_columns_fixed::<6>(),
            7 => self.copy_columns_fixed::<7>(),
            8 => self.copy_columns_fixed::<8>(),
            _ => {}
        }
    }

    fn copy_columns_fixed<const B: usize>(&mut self) {
        let n = self.n;
        if n <= B {
            return;
        }
        let w = 2 * B + 1;
        let a = &self.a[..n * w];
        for j in 0..n - B {
            let l: &mut [f64; B] = (&mut self.lcols[j * B..j * B + B]).try_into().expect("band column");
            for t in 0..B {
                l[t] = a[(j + 1 + t) * w + B - 1 - t];
            }
        }
        for j in n - B..n {
            for t in 0..B {
                let i = j + 1 + t;
                self.lcols[j * B + t] = if i < n { a[i * w + j + B - i] } else { 0.0 };
            }
        }
        for j in B..n {
            let u: &mut [f64; B] = (&mut self.ucols[j * B..j * B + B]).try_into().expect("band column");
            for t in 0..B {
                u[t] = a[(j - B + t) * w + 2 * B - t];
            }
        }
    }

    /// Solves `A x = rhs` in place with the factorization.
    ///
    /// By columns: once `x_j` is final its multiples are subtracted from the next `b` entries
    /// (forward) or the previous `b` (backward), so each entry's dependency on the one before is
    /// a single multiply-subtract (the row form's chain of `b` subtractions and a division per
    /// entry is what bounds a small system's solve). Half-bandwidths 1 to 8 take a variant with
    /// the column length fixed at compile time.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
            return unsafe { self.solve_in_place_avx2(x) };
        }
        self.solve_in_place_body(x)
    }

    /// [`Self::solve_in_place`] compiled with AVX2 enabled (its window in registers twice as
    /// wide as the baseline's).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn solve_in_place_avx2(&self, x: &mut [f64]) {
        self.solve_in_place_body(x)
    }

    #[inline(always)]
    fn solve_in_place_body(&self, x: &mut [f64]) {
        match self.b {
            1 => self.solve_fixed::<1>(x),
            2 => self.solve_fixed::<2>(x),
            3 => self.solve_fixed::<3>(x),
            4 => self.solve_fixed::<4>(x),
            5 => self.solve_fixed::<5>(x),
            6 => self.solve_fixed::<6>(x),
            7 => self.solve_fixed::<7>(x),
            8 => self.solve_fixed::<8>(x),
            _ => self.solve_columns(x),
        }
    }

    /// [`Self::solve_in_place`] for `b == B` and `n > B`: the `B` entries that column `j`
    /// updates are carried in a window (registers) from one column to the next; the operations
    /// and their order are those of [`Self::solve_columns`].
    #[inline(always)]
    fn solve_fixed<const B: usize>(&self, x: &mut [f64]) {
        let n = self.n;
        debug_assert_eq!(self.b, B);
        if n <= B {
            return self.solve_columns(x);
        }
        let w = 2 * B + 1;
        let a = &self.a[..n * w];
        let x = &mut x[..n];
        // forward: window = x[j+1..=j+B], column j of L from `lcols`
        let mut win = [0.0; B];
        win.copy_from_slice(&x[1..=B]);
        let mut xj = x[0];
        let lcols = &self.lcols[..n * B];
        for j in 0..n - 1 {
            // L[j+1+t, j], contiguous; zero past the last row (the window's entries there,
            // rows >= n, are never written back)
            let l: &[f64; B] = lcols[j * B..j * B + B].try_into().expect("band column");
            let next = if j + B + 1 < n { x[j + B + 1] } else { 0.0 };
            let mut out = [0.0; B];
            for t in 0..B {
                out[t] = win[t] - l[t] * xj;
            }
            x[j + 1] = out[0];
            win[..B - 1].copy_from_slice(&out[1..]);
            win[B - 1] = next;
            xj = out[0];
        }
        // backward: U[j-B+t, j] from `ucols` down to column B, from `a` below it; the window
        // holds x[j-B..j] (rows above the pivot) and `cur` the pivot's row, in registers, so
        // the chain from one column to the next does not go through memory
        let ucols = &self.ucols[..n * B];
        let mut win = [0.0; B];
        win.copy_from_slice(&x[n - 1 - B..n - 1]);
        let mut cur = x[n - 1];
        for j in (B..n).rev() {
            let xj = cur * self.inv_diag[j];
            x[j] = xj;
            // U[j-B+t, j], contiguous
            let u: &[f64; B] = ucols[j * B..j * B + B].try_into().expect("band column");
            let mut out = [0.0; B];
            for t in 0..B {
                out[t] = win[t] - u[t] * xj;
            }
            cur = out[B - 1];
            if j > B {
                win[1..].copy_from_slice(&out[..B - 1]);
                win[0] = x[j - 1 - B];
            } else {
                x[..B].copy_from_slice(&out);
            }
        }
        for j in (0..B).rev() {
            let xj = x[j] * self.inv_diag[j];
            x[j] = xj;
            for i in 0..j {
                x[i] -= a[i * w + j + B - i] * xj;
            }
        }
    }

    /// [`Self::solve_in_place`] for any half-bandwidth.
    pub fn solve_columns(&self, x: &mut [f64]) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let x = &mut x[..n];
        for j in 0..n {
            let xj = x[j];
            for i in j + 1..(j + b + 1).min(n) {
                x[i] -= self.a[i * w + j + b - i] * xj;
            }
        }
        for j in (0..n).rev() {
            let xj = x[j] * self.inv_diag[j];
            x[j] = xj;
            for i in j.saturating_sub(b)..j {
                x[i] -= self.a[i * w + j + b - i] * xj;
            }
        }
    }

    /// Solves two right-hand sides at once (`x` and `y`, each of length n), each with the same
    /// operations as [`Self::solve_in_place`] (so each result is bitwise that of a single
    /// solve): the two substitutions' dependency chains interleave.
    pub fn solve_pair_in_place(&self, x: &mut [f64], y: &mut [f64]) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let (x, y) = (&mut x[..n], &mut y[..n]);
        for j in 0..n {
            let (xj, yj) = (x[j], y[j]);
            for i in j + 1..(j + b + 1).min(n) {
                let l = self.a[i * w + j + b - i];
                x[i] -= l * xj;
                y[i] -= l * yj;
            }
        }
        for j in (0..n).rev() {
            let (xj, yj) = (x[j] * self.inv_diag[j], y[j] * self.inv_diag[j]);
            x[j] = xj;
            y[j] = yj;
            for i in j.saturating_sub(b)..j {
                let u = self.a[i * w + j + b - i];
                x[i] -= u * xj;
                y[i] -= u * yj;
            }
        }
    }

    /// The row-oriented substitutions (with divisions by the pivots): the tests' reference.
    #[cfg(test)]
    fn solve_rows(&self, x: &mut [f64]) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        for i in 0..n {
            let lo = i.saturating_sub(b);
            let row = i * w + b - i;
            let mut s = x[i];
            for (&l, &xj) in self.a[row + lo..row + i].iter().zip(&x[lo..i]) {
                s -= l * xj;
            }
            x[i] = s;
        }
        for i in (0..n).rev() {
            let hi = (i + b).min(n - 1);
            let row = i * w + b - i;
            let mut s = x[i];
            for (&u, &xj) in self.a[row + i + 1..=row + hi].iter().zip(&x[i + 1..=hi]) {
                s -= u * xj;
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
    /// The fixed-bandwidth solves give bitwise the general one's result, for every bandwidth
    /// they cover and near both ends of the band.
    #[test]
    fn fixed_bandwidth_factors_and_solves_equal_the_general_ones_and_the_row_form() {
        for b in 1..=9 {
            for n in [1, b, b + 1, 3 * b + 2] {
                let mut m = BandLu::new(n, b);
                for i in 0..n {
                    for j in i.saturating_sub(b)..=(i + b).min(n - 1) {
                        let v = if i == j {
                            6.0 + 0.1 * i as f64
                        } else {
                            0.3 * ((i * 5 + j * 3) % 7) as f64 - 0.9
                        };
                        m.add(i, j, v);
                    }
                }
                let mut g = m.clone();
                m.factorize("test").unwrap();
                g.factorize_with("test", true).unwrap();
                assert_eq!(m.a, g.a, "factors, b {b}, n {n}");
                let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.91).sin() + 0.2).collect();
                let (mut x, mut z) = (rhs.clone(), rhs);
                let (mut p, mut q) = (x.clone(), x.clone());
                let mut r = x.clone();
                let mut y = x.clone();
                m.solve_in_place(&mut x);
                m.solve_columns(&mut z);
                assert_eq!(x, z, "b {b}, n {n}");
                // the baseline build of the solve (the default is AVX2 where the CPU has it)
                let mut base = m.clone();
                base.set_avx2(false);
                base.solve_in_place(&mut y);
                assert_eq!(
                    y.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "baseline, b {b}, n {n}"
                );
                m.solve_pair_in_place(&mut p, &mut q);
                assert_eq!(p, x, "pair, b {b}, n {n}");
                assert_eq!(q, x, "pair, b {b}, n {n}");
                // the row form with divisions agrees to rounding
                m.solve_rows(&mut r);
                for (a, c) in r.iter().zip(&x) {
                    assert!((a - c).abs() <= 1e-13 * a.abs().max(1.0), "b {b}, n {n}: {a} vs {c}");
                }
            }
        }
    }

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
