//! Dense-band LU without pivoting for `L` matrices of one band structure at once: the lockstep
//! lanes of a moving-frame study (issue 14, item 2), where every lane has its own effective
//! matrix (its own axial forces in the geometric terms, its own contact state) on the same
//! unknowns.
//!
//! Each lane's factorization and solve are the operations of [`BandLu`] in the same order, so
//! each lane's result is bitwise what [`BandLu`] gives for its matrix alone (tested); the lanes'
//! operations sit side by side in `[f64; L]` entries, so the compiler puts them in vector
//! registers (4 lanes of an AVX2 register), and the substitutions' dependency chains, which bound
//! a small system's solve, run `L` at a time instead of one after the other.
//!
//! The elimination and substitutions mirror [`BandLu`]'s line by line on `[f64; L]` entries (a
//! zero multiplier selects the old values where the scalar code skips a row): a change to one is
//! a change to the other, which `each_lane_factorizes_and_solves_bitwise_as_band_lu` enforces.
//!
//! Not yet used by a stepper: the Newton stepper's lanes are the rest of that item. Measured
//! (`cargo bench --bench newton -- linalg/band`, 26 unknowns, half-bandwidth 5, AVX2): four
//! matrices factorized and solved in 3.2 to 3.9 us against 3.7 to 5.1 us one after the other,
//! 1.15 to 1.45x; what is left per eliminated row (the division, the index arithmetic, the
//! scale's select) is about as long as the row update itself at this bandwidth. On an AVX-512
//! host (2026-11-29, medians): factorize and solve 2.49 against 2.68 us for four, 4.31 against
//! 5.48 us for eight (1.27x); the solve alone, which a Newton step does 1.2 times per factor it
//! keeps up to 20 steps, 319 against 497 ns for four and 393 against 1014 ns for eight (2.6x:
//! 49 against 127 ns a matrix). In a crank-pin step of about 1.3 us that is 7 % saved; with the
//! kinematics shared too (about 10 %, where the samples share the motion) the lanes of that
//! item are bounded near 1.2x as the step stands.

use super::band_lu::band_position;
use super::BandLu;
use crate::error::{Error, Result};

/// `L` dense-band LU factorizations without pivoting of `n x n` matrices of half-bandwidth `b`,
/// stored entry by entry with the lanes side by side (see the module documentation and
/// [`BandLu`], whose pivot test each lane takes).
#[derive(Debug, Clone)]
pub struct BandLuLanes<const L: usize> {
    n: usize,
    b: usize,
    /// Row-major band as [`BandLu`]'s: entry (i, j) at `i * (2b + 1) + (j + b - i)`, each entry
    /// the `L` lanes' values.
    a: Vec<[f64; L]>,
    /// Per row and lane, `|a_kk| + sum_j |l_kj u_jk|` ([`BandLu`]'s pivot scale).
    pivot_scale: Vec<[f64; L]>,
    /// `1 / u_jj` per lane.
    inv_diag: Vec<[f64; L]>,
    /// Numeric factorizations done (of all lanes at once).
    pub factorizations: u64,
    /// Whether the CPU has AVX2 and FMA ([`super::avx2_fma_available`]): the factorization and
    /// the solves then run in a build with 4 lanes to a register (the same operations: Rust
    /// contracts no multiply and add into an FMA, so bitwise the baseline build's results).
    avx2: bool,
}

impl<const L: usize> BandLuLanes<L> {
    /// `L` zero `n x n` matrices of half-bandwidth `b`.
    pub fn new(n: usize, b: usize) -> Self {
        BandLuLanes {
            n,
            b,
            a: vec![[0.0; L]; n * (2 * b + 1)],
            pivot_scale: vec![[0.0; L]; n],
            inv_diag: vec![[0.0; L]; n],
            factorizations: 0,
            avx2: super::avx2_fma_available(),
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

    /// Sets every entry of every lane to zero (before assembling new matrices).
    pub fn clear(&mut self) {
        self.a.fill([0.0; L]);
    }

    /// The storage position of entry `(i, j)` (`|i - j| <= b`), for [`Self::add_at`]. Panics
    /// outside the band (an assembly bug: the bandwidth comes from the same connectivity).
    #[inline]
    pub fn position(&self, i: usize, j: usize) -> usize {
        band_position(self.n, self.b, i, j)
    }

    /// Adds `v` (one value per lane) at a position from [`Self::position`].
    #[inline]
    pub fn add_at(&mut self, pos: usize, v: [f64; L]) {
        let e = &mut self.a[pos];
        for q in 0..L {
            e[q] += v[q];
        }
    }

    /// Lane `lane` of entry (i, j) (zero outside the band).
    pub fn get(&self, lane: usize, i: usize, j: usize) -> f64 {
        if i.abs_diff(j) > self.b {
            return 0.0;
        }
        self.a[band_position(self.n, self.b, i, j)][lane]
    }

    /// Copies the assembled (not factorized) matrix of `m` into lane `lane`. Panics when the
    /// dimensions or bandwidths differ.
    pub fn set_lane(&mut self, lane: usize, m: &BandLu) {
        assert!(
            m.n() == self.n && m.bandwidth() == self.b,
            "lanes share one band structure"
        );
        for i in 0..self.n {
            for j in i.saturating_sub(self.b)..(i + self.b + 1).min(self.n) {
                let p = self.position(i, j);
                self.a[p][lane] = m.get(i, j);
            }
        }
    }

    /// Factorizes every lane's matrix in place (L unit lower, U upper), each as
    /// [`BandLu::factorize`]; per lane, the error [`BandLu::factorize`] would give (a pivot that
    /// is not finite or is rounding noise, with its index; `what` names the matrix). A lane that
    /// fails is eliminated on (its factors are then meaningless, never an error of the others).
    pub fn factorize(&mut self, what: &str) -> [Result<()>; L] {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
            return unsafe { self.factorize_avx2(what) };
        }
        self.factorize_body(what)
    }

    /// [`Self::factorize`] in the AVX2 build.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn factorize_avx2(&mut self, what: &str) -> [Result<()>; L] {
        self.factorize_body(what)
    }

    #[inline(always)]
    fn factorize_body(&mut self, what: &str) -> [Result<()>; L] {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let noise = 8.0 * (b + 1) as f64 * f64::EPSILON;
        for (i, s) in self.pivot_scale.iter_mut().enumerate() {
            let d = &self.a[i * w + b];
            for q in 0..L {
                s[q] = d[q].abs();
            }
        }
        // the first failing pivot of each lane: (index, finite)
        let mut failed: [Option<(usize, bool)>; L] = [None; L];
        for k in 0..n {
            let piv = self.a[k * w + b];
            // the pivot test of every lane without a branch, the bookkeeping only on a failure
            let mut bad = false;
            for q in 0..L {
                bad |= !piv[q].is_finite() | (piv[q].abs() <= noise * self.pivot_scale[k][q]);
            }
            if bad {
                for q in 0..L {
                    if failed[q].is_none() && (!piv[q].is_finite() || piv[q].abs() <= noise * self.pivot_scale[k][q]) {
                        failed[q] = Some((k, piv[q].is_finite()));
                    }
                }
            }
            match b {
                1 => self.eliminate_fixed::<1>(k),
                2 => self.eliminate_fixed::<2>(k),
                3 => self.eliminate_fixed::<3>(k),
                4 => self.eliminate_fixed::<4>(k),
                5 => self.eliminate_fixed::<5>(k),
                6 => self.eliminate_fixed::<6>(k),
                7 => self.eliminate_fixed::<7>(k),
                8 => self.eliminate_fixed::<8>(k),
                _ => self.eliminate(k),
            }
        }
        for (j, d) in self.inv_diag.iter_mut().enumerate() {
            let p = &self.a[j * w + b];
            for q in 0..L {
                d[q] = 1.0 / p[q];
            }
        }
        self.factorizations += 1;
        failed.map(|f| match f {
            None => Ok(()),
            Some((index, finite)) => Err(Error::Singular {
                what: if finite {
                    what.to_string()
                } else {
                    format!("{what} (non-finite entries)")
                },
                index,
                dof: String::new(),
            }),
        })
    }

    /// [`Self::eliminate`] for `b == B` with the full band below `k` (rows of `B` entries fixed
    /// at compile time); near the end of the band, the general one. The same operations in the
    /// same order.
    #[inline(always)]
    fn eliminate_fixed<const B: usize>(&mut self, k: usize) {
        if k + B >= self.n {
            return self.eliminate(k);
        }
        let w = 2 * B + 1;
        let piv = self.a[k * w + B];
        let (head, tail) = self.a.split_at_mut((k + 1) * w);
        let urow: &[[f64; L]; B] = head[k * w + B + 1..k * w + B + 1 + B].try_into().expect("band row");
        for d in 1..=B {
            let ik = (d - 1) * w + B - d;
            let mut l = [0.0; L];
            for q in 0..L {
                l[q] = tail[ik][q] / piv[q];
            }
            tail[ik] = l;
            // a lane whose multiplier is zero keeps its row and scale (selects, no branch)
            let s = &mut self.pivot_scale[k + d];
            let ud = &urow[d - 1];
            for q in 0..L {
                let add = s[q] + (l[q] * ud[q]).abs();
                s[q] = if l[q] != 0.0 { add } else { s[q] };
            }
            let row: &mut [[f64; L]; B] = (&mut tail[ik + 1..ik + 1 + B]).try_into().expect("band row");
            for t in 0..B {
                for q in 0..L {
                    let y = row[t][q] - l[q] * urow[t][q];
                    row[t][q] = if l[q] != 0.0 { y } else { row[t][q] };
                }
            }
        }
    }

    /// Eliminates column `k` below the pivot in every lane, as [`BandLu`]'s elimination: a lane
    /// whose multiplier is zero leaves its row as it is (the scalar code skips the row).
    #[inline(always)]
    fn eliminate(&mut self, k: usize) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let piv = self.a[k * w + b];
        let last = (k + b).min(n - 1);
        let (head, tail) = self.a.split_at_mut((k + 1) * w);
        let urow = &head[k * w + b + 1..k * w + b + 1 + (last - k)];
        for i in k + 1..=last {
            let ri = (i - k - 1) * w;
            let ik = ri + k + b - i;
            let mut l = [0.0; L];
            let mut any = false;
            for q in 0..L {
                l[q] = tail[ik][q] / piv[q];
                any |= l[q] != 0.0;
            }
            tail[ik] = l;
            if !any {
                continue;
            }
            let s = &mut self.pivot_scale[i];
            let ui = &urow[i - k - 1];
            for q in 0..L {
                let add = (l[q] * ui[q]).abs();
                s[q] = if l[q] != 0.0 { s[q] + add } else { s[q] };
            }
            let row = &mut tail[ik + 1..ik + 1 + (last - k)];
            for (x, u) in row.iter_mut().zip(urow) {
                for q in 0..L {
                    let y = x[q] - l[q] * u[q];
                    x[q] = if l[q] != 0.0 { y } else { x[q] };
                }
            }
        }
    }

    /// Solves every lane's `A x = rhs` in place with its factorization (`x[i][lane]`), each lane
    /// as [`BandLu::solve_in_place`] (the column-oriented substitutions, the same operations in
    /// the same order).
    pub fn solve_in_place(&self, x: &mut [[f64; L]]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
            return unsafe { self.solve_avx2(x) };
        }
        self.solve_body(x)
    }

    /// [`Self::solve_in_place`] in the AVX2 build.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn solve_avx2(&self, x: &mut [[f64; L]]) {
        self.solve_body(x)
    }

    #[inline(always)]
    fn solve_body(&self, x: &mut [[f64; L]]) {
        let (n, b) = (self.n, self.b);
        let w = 2 * b + 1;
        let x = &mut x[..n];
        for j in 0..n {
            let xj = x[j];
            for i in j + 1..(j + b + 1).min(n) {
                let l = &self.a[i * w + j + b - i];
                for q in 0..L {
                    x[i][q] -= l[q] * xj[q];
                }
            }
        }
        for j in (0..n).rev() {
            let mut xj = x[j];
            for q in 0..L {
                xj[q] *= self.inv_diag[j][q];
            }
            x[j] = xj;
            for i in j.saturating_sub(b)..j {
                let u = &self.a[i * w + j + b - i];
                for q in 0..L {
                    x[i][q] -= u[q] * xj[q];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nonsymmetric band matrix of dimension `n`, half-bandwidth `b`, diagonally dominant,
    /// from `seed` (a small LCG: the tests need variety, not quality).
    fn band(n: usize, b: usize, seed: u64) -> BandLu {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut m = BandLu::new(n, b);
        for i in 0..n {
            for j in i.saturating_sub(b)..(i + b + 1).min(n) {
                let v = if i == j { 4.0 * b as f64 + next() } else { next() };
                // rows of very different scale, and a few exact zeros (skipped rows)
                let v = if (i + j) % 7 == 3 && i != j {
                    0.0
                } else {
                    v * 10f64.powi((i % 5) as i32 - 2)
                };
                m.add(i, j, v);
            }
        }
        m
    }

    #[test]
    fn each_lane_factorizes_and_solves_bitwise_as_band_lu() {
        for (n, b) in [(26, 3), (26, 5), (9, 8), (40, 12), (3, 4), (1, 1)] {
            let mut lanes = BandLuLanes::<4>::new(n, b);
            let mut scalars: Vec<BandLu> = (0..4).map(|q| band(n, b, 17 * q as u64 + n as u64)).collect();
            for (q, m) in scalars.iter().enumerate() {
                lanes.set_lane(q, m);
            }
            let res = lanes.factorize("test matrix");
            let mut rhs: Vec<[f64; 4]> = (0..n).map(|i| [1.0 + i as f64, -2.0, 0.5 * i as f64, 3e-3]).collect();
            lanes.solve_in_place(&mut rhs);
            for (q, m) in scalars.iter_mut().enumerate() {
                m.factorize("test matrix")
                    .expect("a diagonally dominant band factorizes");
                assert!(res[q].is_ok());
                let mut x: Vec<f64> = (0..n)
                    .map(|i| [1.0 + i as f64, -2.0, 0.5 * i as f64, 3e-3][q])
                    .collect();
                m.solve_in_place(&mut x);
                for i in 0..n {
                    assert_eq!(x[i].to_bits(), rhs[i][q].to_bits(), "n {n} b {b} lane {q} entry {i}");
                }
            }
        }
    }

    #[test]
    fn the_baseline_build_gives_the_avx2_builds_results_bitwise() {
        let (n, b) = (26, 5);
        let mut lanes = BandLuLanes::<4>::new(n, b);
        for q in 0..4 {
            lanes.set_lane(q, &band(n, b, 3 + q as u64));
        }
        let mut base = lanes.clone();
        base.avx2 = false;
        let mut x: Vec<[f64; 4]> = (0..n).map(|i| [i as f64, 1.0, -0.5, 2e-7 * i as f64]).collect();
        let mut xb = x.clone();
        assert!(lanes.factorize("m").iter().all(|r| r.is_ok()));
        assert!(base.factorize("m").iter().all(|r| r.is_ok()));
        lanes.solve_in_place(&mut x);
        base.solve_in_place(&mut xb);
        for (a, c) in x.iter().zip(&xb) {
            for q in 0..4 {
                assert_eq!(a[q].to_bits(), c[q].to_bits());
            }
        }
    }

    #[test]
    fn a_singular_lane_fails_alone_with_its_pivot_index() {
        let (n, b) = (12, 3);
        let mut lanes = BandLuLanes::<4>::new(n, b);
        let good = band(n, b, 5);
        for q in 0..4 {
            lanes.set_lane(q, &good);
        }
        // lane 1: row 6 zero (a massless unknown); lane 3: a NaN entry in row 2
        let mut singular = good.clone();
        for j in 3..=9 {
            let v = singular.get(6, j);
            singular.add(6, j, -v);
        }
        lanes.set_lane(1, &singular);
        let p = lanes.position(2, 2);
        lanes.a[p][3] = f64::NAN;
        let res = lanes.factorize("effective matrix");
        assert!(res[0].is_ok() && res[2].is_ok());
        match &res[1] {
            Err(Error::Singular { index, what, .. }) => assert_eq!((*index, what.as_str()), (6, "effective matrix")),
            r => panic!("expected a singular pivot at 6, got {r:?}"),
        }
        match &res[3] {
            Err(Error::Singular { index, what, .. }) => {
                assert_eq!(*index, 2);
                assert!(what.contains("non-finite"));
            }
            r => panic!("expected a non-finite pivot at 2, got {r:?}"),
        }
        // the scalar factorization agrees on lane 1's pivot
        let mut s = singular.clone();
        match s.factorize("effective matrix") {
            Err(Error::Singular { index, .. }) => assert_eq!(index, 6),
            r => panic!("expected a singular pivot, got {r:?}"),
        }
        // the good lanes' solves are still the scalar ones
        let mut g = good.clone();
        g.factorize("m").expect("factorizes");
        let mut x: Vec<f64> = (0..n).map(|i| i as f64 - 3.0).collect();
        let mut xl: Vec<[f64; 4]> = x.iter().map(|&v| [v; 4]).collect();
        g.solve_in_place(&mut x);
        lanes.solve_in_place(&mut xl);
        for i in 0..n {
            assert_eq!(x[i].to_bits(), xl[i][0].to_bits());
            assert_eq!(x[i].to_bits(), xl[i][2].to_bits());
        }
    }
}
