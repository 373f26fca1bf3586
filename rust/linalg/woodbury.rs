//! The Sherman-Morrison-Woodbury low-rank update, written once for every [`Factor`]
//! (docs/method.md section 5).
//!
//! The matrix to solve with is `A = A0 + P^T G P`: `A0` is factorized once (contact-free), `P`
//! (m x n, m = 2 per joint) projects the unknowns on the joints' relative coordinates, and `G`
//! is block diagonal with one 2 x 2 block per joint (the contact's stiffness and damping scaled
//! by the integrator). With a right-hand side `b + P^T h` (the joints' explicit forces `h`):
//!
//! ```text
//! z = A0^-1 b,  Z = A0^-1 P^T,  W = P Z,  y = P z + W h,
//! (I + G W) s = G y,  x = z + Z (h - s),  P x = y - W s.
//! ```
//!
//! `Z` and `W` depend only on `A0` and `P` ([`Woodbury::new`]); a step solves the small
//! capacitance system ([`capacitance_solve`]) and adds the columns ([`Woodbury::add_columns`]).

use super::{solve_dense_in_place, Factor};
use crate::contact::Mat2;

/// The low-rank operator `P` of a Woodbury update as 2-row blocks (one per joint), each a sparse
/// combination of the unknowns.
pub trait LowRankBlocks {
    /// Number of 2-row blocks (m = 2 x blocks).
    fn blocks(&self) -> usize;
    /// Adds row `r` (0 or 1) of block `b` of `P` to `col` (that is, column `2b + r` of `P^T`).
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]);
    /// Block `b` of `P x`.
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2];
}

/// The Woodbury columns of a factorized `A0` and an operator `P`: `Z = A0^-1 P^T` (n x m, column
/// by column) and `W = P Z` (m x m, row major).
#[derive(Debug, Clone, Default)]
pub struct Woodbury {
    n: usize,
    m: usize,
    /// Column `c` of `Z` at `z[c n..(c + 1) n]`.
    z: Vec<f64>,
    /// `W[r][c]` at `w[r m + c]`.
    w: Vec<f64>,
}

impl Woodbury {
    /// Builds `Z` and `W` with `factor` (which holds `A0`): m solves of dimension n.
    pub fn new<F: Factor, P: LowRankBlocks + ?Sized>(factor: &mut F, p: &P) -> Self {
        let mut wb = Woodbury::default();
        wb.rebuild(factor, p);
        wb
    }

    /// Rebuilds `Z` and `W` for `factor` and `p` in place, as [`Woodbury::new`] does, reusing the
    /// storage (nothing is allocated when the dimensions are those of the last build).
    pub fn rebuild<F: Factor, P: LowRankBlocks + ?Sized>(&mut self, factor: &mut F, p: &P) {
        let n = factor.dim();
        let m = 2 * p.blocks();
        self.n = n;
        self.m = m;
        self.z.clear();
        self.z.resize(n * m, 0.0);
        for b in 0..p.blocks() {
            let (c0, c1) = self.z[2 * b * n..(2 * b + 2) * n].split_at_mut(n);
            p.scatter(b, 0, c0);
            p.scatter(b, 1, c1);
            factor.solve_pair_in_place(c0, c1);
        }
        self.fill_w(p);
    }

    /// Rebuilds `Z` and `W` as [`Self::rebuild`] does, with the columns of `Z` given: `column(c,
    /// z_c)` writes column `c` of `A0^-1 P^T` into `z_c` (zeroed, length `n`). For an operator
    /// whose rows move in the span of a few fixed unit vectors (the rows of a joint turning
    /// against its reference axes), the columns are combinations of those vectors' solves, kept
    /// while the factor is (one solve each per factorization instead of two per rebuild).
    pub fn rebuild_with<P: LowRankBlocks + ?Sized>(
        &mut self,
        n: usize,
        p: &P,
        mut column: impl FnMut(usize, &mut [f64]),
    ) {
        let m = 2 * p.blocks();
        self.n = n;
        self.m = m;
        self.z.clear();
        self.z.resize(n * m, 0.0);
        for (c, z) in self.z.chunks_exact_mut(n).enumerate() {
            column(c, z);
        }
        self.fill_w(p);
    }

    /// `W = P Z` from the current `Z`.
    fn fill_w<P: LowRankBlocks + ?Sized>(&mut self, p: &P) {
        let mut w = std::mem::take(&mut self.w);
        self.project_z(p, &mut w);
        self.w = w;
    }

    /// The rank `m` (2 per joint).
    pub fn m(&self) -> usize {
        self.m
    }

    /// The dimension `n` of `A0`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// `Z = A0^-1 P^T`, column `c` at `[c n..(c + 1) n]`.
    pub fn z(&self) -> &[f64] {
        &self.z
    }

    /// `W = P A0^-1 P^T`, row major.
    pub fn w(&self) -> &[f64] {
        &self.w
    }

    /// `(Z, W)`, taken apart (for steppers that keep them in their own layout).
    pub fn into_parts(self) -> (Vec<f64>, Vec<f64>) {
        (self.z, self.w)
    }

    /// `x += Z d` (`d` of length m), column by column.
    #[inline]
    pub fn add_columns(&self, d: &[f64], x: &mut [f64]) {
        let n = self.n;
        for (c, &dc) in d.iter().enumerate().take(self.m) {
            if dc != 0.0 {
                let col = &self.z[c * n..(c + 1) * n];
                for (xi, zi) in x.iter_mut().zip(col) {
                    *xi += zi * dc;
                }
            }
        }
    }

    /// Solves `(A0 + P^T G P) x = b` in place (`x` holds `b` on entry) with `factor` (holding
    /// `A0`) and these columns: the single-vector form of the update, for steppers without
    /// lanes. `scratch` holds the small systems (resized as needed). Returns the capacitance's
    /// pivot ratio ([`capacitance_solve`]); below a caller's threshold the result should not be
    /// trusted (refactorize with the contact terms instead).
    pub fn solve<F: Factor, P: LowRankBlocks + ?Sized>(
        &self,
        factor: &mut F,
        p: &P,
        g: &[Mat2],
        x: &mut [f64],
        scratch: &mut WoodburyScratch,
    ) -> f64 {
        if self.m == 2 && g.len() == 1 {
            return self.solve_one_joint(factor, p, &g[0], x);
        }
        self.solve_general(factor, p, g, x, scratch)
    }

    /// [`Self::solve`] for any number of joints, the small systems in `scratch`.
    #[inline]
    fn solve_general<F: Factor, P: LowRankBlocks + ?Sized>(
        &self,
        factor: &mut F,
        p: &P,
        g: &[Mat2],
        x: &mut [f64],
        scratch: &mut WoodburyScratch,
    ) -> f64 {
        let m = self.m;
        self.solve_and_project(factor, p, x, scratch);
        scratch.h.fill(0.0);
        let WoodburyScratch { yb, h, y, cap, s } = scratch;
        let rcond = capacitance_solve(&self.w, m, g, yb, h, y, cap, s);
        self.subtract_columns(s, x);
        rcond
    }

    /// [`Self::solve`] for one joint (rank 2), the small systems in registers: the same
    /// operations in the same order as the general path (`capacitance_solve` with `m = 2` and
    /// `h = 0`, [`solve_dense_in_place`]'s 2 x 2 elimination, `x -= Z s`), so bitwise its
    /// result, without its scratch vectors and loops over `m` (the crank-pin slider-crank: about
    /// a thousand instructions of each of its 1.1 solves a step).
    #[inline]
    fn solve_one_joint<F: Factor, P: LowRankBlocks + ?Sized>(
        &self,
        factor: &mut F,
        p: &P,
        g: &Mat2,
        x: &mut [f64],
    ) -> f64 {
        factor.solve_in_place(x);
        let yb = p.project(0, x);
        let w = [self.w[0], self.w[1], self.w[2], self.w[3]];
        // y = yb + W h with h = 0, as the general path forms it
        let y = [yb[0] + w[0] * 0.0 + w[1] * 0.0, yb[1] + w[2] * 0.0 + w[3] * 0.0];
        let mut cap = [0.0; 4];
        let mut s = [0.0; 2];
        for rr in 0..2 {
            for c in 0..2 {
                let gw = g[rr][0] * w[c] + g[rr][1] * w[2 + c];
                cap[rr * 2 + c] = if rr == c { 1.0 + gw } else { gw };
            }
            s[rr] = g[rr][0] * y[0] + g[rr][1] * y[1];
        }
        let rcond = solve_dense_in_place(&mut cap, &mut s, 2);
        let n = self.n;
        for (c, &sc) in s.iter().enumerate() {
            let dc = -sc;
            if dc != 0.0 {
                for (xi, zi) in x.iter_mut().zip(&self.z[c * n..(c + 1) * n]) {
                    *xi += zi * dc;
                }
            }
        }
        rcond
    }

    /// The first half of a solve: `x = A0^-1 x` and `P x` into `scratch.yb` (sized for this
    /// update's rank).
    #[inline]
    fn solve_and_project<F: Factor, P: LowRankBlocks + ?Sized>(
        &self,
        factor: &mut F,
        p: &P,
        x: &mut [f64],
        scratch: &mut WoodburyScratch,
    ) {
        scratch.resize(self.m);
        factor.solve_in_place(x);
        for b in 0..p.blocks() {
            let pz = p.project(b, x);
            scratch.yb[2 * b] = pz[0];
            scratch.yb[2 * b + 1] = pz[1];
        }
    }

    /// The last: `x -= Z s` (`s` negated in place, then added as [`Self::add_columns`]).
    #[inline]
    fn subtract_columns(&self, s: &mut [f64], x: &mut [f64]) {
        for v in s.iter_mut() {
            *v = -*v;
        }
        self.add_columns(s, x);
    }

    /// `V Z` (m x m, row major) into `out`, for an operator `V` of `P`'s shape (2-row blocks,
    /// one per joint): the right factor of [`Self::solve_with`]'s second term (and, for `V =
    /// P`, `W`).
    pub fn project_z<V: LowRankBlocks + ?Sized>(&self, v: &V, out: &mut Vec<f64>) {
        let (n, m) = (self.n, self.m);
        out.clear();
        out.resize(m * m, 0.0);
        for b in 0..v.blocks() {
            for c in 0..m {
                let vz = v.project(b, &self.z[c * n..(c + 1) * n]);
                out[(2 * b) * m + c] = vz[0];
                out[(2 * b + 1) * m + c] = vz[1];
            }
        }
    }

    /// Solves `(A0 + P^T (G P + H V)) x = b` in place (`x` holds `b` on entry): [`Self::solve`]
    /// with a second term whose right factor is another operator `V` of `P`'s shape, `H` block
    /// diagonal like `G` (the contact damping of a joint whose two sides turn at different rates:
    /// its relative velocity depends on the positions through `V`, not through `P`). `wv` is `V
    /// Z` ([`Self::project_z`]). With `E = G P + H V`:
    ///
    /// ```text
    /// z = A0^-1 b,  (I + G W + H V Z) s = G P z + H V z,  x = z - Z s.
    /// ```
    ///
    /// Returns the capacitance's pivot ratio, as [`Self::solve`] does.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_with<F: Factor, P: LowRankBlocks + ?Sized, V: LowRankBlocks + ?Sized>(
        &self,
        factor: &mut F,
        p: &P,
        v: &V,
        g: &[Mat2],
        h: &[Mat2],
        wv: &[f64],
        x: &mut [f64],
        scratch: &mut WoodburyScratch,
    ) -> f64 {
        let m = self.m;
        self.solve_and_project(factor, p, x, scratch);
        let WoodburyScratch { yb, h: yv, cap, s, .. } = scratch;
        for b in 0..v.blocks() {
            let vz = v.project(b, x);
            (yv[2 * b], yv[2 * b + 1]) = (vz[0], vz[1]);
        }
        let w = &self.w;
        for (jj, (g, hh)) in g.iter().zip(h).enumerate() {
            let (r0, r1) = (2 * jj * m, (2 * jj + 1) * m);
            for rr in 0..2 {
                let row = 2 * jj + rr;
                for c in 0..m {
                    let e =
                        g[rr][0] * w[r0 + c] + g[rr][1] * w[r1 + c] + hh[rr][0] * wv[r0 + c] + hh[rr][1] * wv[r1 + c];
                    cap[row * m + c] = if row == c { 1.0 + e } else { e };
                }
                s[row] = g[rr][0] * yb[2 * jj]
                    + g[rr][1] * yb[2 * jj + 1]
                    + hh[rr][0] * yv[2 * jj]
                    + hh[rr][1] * yv[2 * jj + 1];
            }
        }
        let rcond = solve_dense_in_place(cap, s, m);
        self.subtract_columns(s, x);
        rcond
    }
}

/// Work vectors of [`Woodbury::solve`].
#[derive(Debug, Clone, Default)]
pub struct WoodburyScratch {
    yb: Vec<f64>,
    h: Vec<f64>,
    y: Vec<f64>,
    cap: Vec<f64>,
    s: Vec<f64>,
}

impl WoodburyScratch {
    /// Work vectors sized for rank `m` (2 per joint), so that [`Woodbury::solve`] allocates
    /// nothing.
    pub fn for_rank(m: usize) -> Self {
        let mut s = WoodburyScratch::default();
        s.resize(m);
        s
    }

    fn resize(&mut self, m: usize) {
        if self.cap.len() == m * m && self.yb.len() == m {
            // sized already (every solve of a run asks for the same rank)
            return;
        }
        self.yb.resize(m, 0.0);
        self.h.resize(m, 0.0);
        self.y.resize(m, 0.0);
        self.cap.resize(m * m, 0.0);
        self.s.resize(m, 0.0);
    }
}

/// The capacitance step of the update: `y = yb + W h`, `cap = I + G W`, solves `cap s = G y`
/// (`s`, length m) and returns the pivot ratio of that solve (0 when singular, NaN possible with
/// non-finite input); `y` is left in `y`, `cap` partly eliminated. `w` is `W` (m x m, row
/// major), `g` the 2 x 2 blocks of `G` (one per joint, m = 2 g.len()).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn capacitance_solve(
    w: &[f64],
    m: usize,
    g: &[Mat2],
    yb: &[f64],
    h: &[f64],
    y: &mut [f64],
    cap: &mut [f64],
    s: &mut [f64],
) -> f64 {
    for r in 0..m {
        let mut v = yb[r];
        for c in 0..m {
            v += w[r * m + c] * h[c];
        }
        y[r] = v;
    }
    for (jj, g) in g.iter().enumerate() {
        for rr in 0..2 {
            let row = 2 * jj + rr;
            for c in 0..m {
                let gw = g[rr][0] * w[(2 * jj) * m + c] + g[rr][1] * w[(2 * jj + 1) * m + c];
                cap[row * m + c] = if row == c { 1.0 + gw } else { gw };
            }
            s[row] = g[rr][0] * y[2 * jj] + g[rr][1] * y[2 * jj + 1];
        }
    }
    solve_dense_in_place(cap, s, m)
}

/// `y -= W s`: the joints' values `P x` after the capacitance step.
#[inline]
pub fn subtract_ws(w: &[f64], m: usize, s: &[f64], y: &mut [f64]) {
    for r in 0..m {
        let mut x = y[r];
        for c in 0..m {
            x -= w[r * m + c] * s[c];
        }
        y[r] = x;
    }
}

#[cfg(test)]
mod woodbury_tests {
    use super::{LowRankBlocks, Mat2, Woodbury, WoodburyScratch};
    use crate::linalg::BandLu;

    /// Two joints: (dofs, coefficients of the two rows).
    struct Joints(Vec<(Vec<usize>, [Vec<f64>; 2])>);

    impl LowRankBlocks for Joints {
        fn blocks(&self) -> usize {
            self.0.len()
        }
        fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
            let (d, c) = &self.0[b];
            for (k, &i) in d.iter().enumerate() {
                col[i] += c[r][k];
            }
        }
        fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
            let (d, c) = &self.0[b];
            let mut p = [0.0; 2];
            for (k, &i) in d.iter().enumerate() {
                p[0] += c[0][k] * x[i];
                p[1] += c[1][k] * x[i];
            }
            p
        }
    }

    /// `A0` (n x n, half-bandwidth `bw`, entries `entry(i, j)`) twice: one to factorize as it is,
    /// one to add the update to and factorize directly (the independent computation).
    fn band_pair(n: usize, bw: usize, entry: impl Fn(usize, usize) -> f64) -> (BandLu, BandLu) {
        let mut a0 = BandLu::new(n, bw);
        let mut full = BandLu::new(n, bw);
        for i in 0..n {
            for j in i.saturating_sub(bw)..=(i + bw).min(n - 1) {
                a0.add(i, j, entry(i, j));
                full.add(i, j, entry(i, j));
            }
        }
        (a0, full)
    }

    /// Adds `P^T (G P + H V)` (joint by joint; `H V` left out without `hv`) to `full`.
    fn add_update(full: &mut BandLu, p: &Joints, g: &[Mat2], hv: Option<(&Joints, &[Mat2])>) {
        for b in 0..p.0.len() {
            let (d, c) = &p.0[b];
            for (ki, &i) in d.iter().enumerate() {
                for (kj, &j) in d.iter().enumerate() {
                    let mut x = 0.0;
                    for r in 0..2 {
                        for s in 0..2 {
                            x += c[r][ki] * g[b][r][s] * c[s][kj];
                            if let Some((v, h)) = hv {
                                x += c[r][ki] * h[b][r][s] * v.0[b].1[s][kj];
                            }
                        }
                    }
                    full.add(i, j, x);
                }
            }
        }
    }

    /// `x` equals `x_direct` within 1e-13 of its largest entry (rounding of two factorizations).
    fn assert_direct(x: &[f64], x_direct: &[f64]) {
        let scale = x_direct.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for (i, (a, b)) in x.iter().zip(x_direct).enumerate() {
            assert!((a - b).abs() < 1e-13 * scale, "{i}: {a} vs {b}");
        }
    }

    /// One joint takes [`Woodbury::solve_one_joint`]: bitwise the general path's result and
    /// pivot ratio, for contact blocks from soft to stiff and one that makes the capacitance
    /// indefinite (and a zero right-hand side); for the soft ones also the direct solve of `A0 +
    /// P^T G P` to rounding.
    #[test]
    fn one_joint_solve_is_the_general_path_bitwise() {
        let n = 26;
        let (mut a0, base) = band_pair(n, 5, |i, j| {
            if i == j {
                6.0 + i as f64 * 0.3
            } else {
                ((i * 7 + j * 3) % 5) as f64 * 0.3 - 0.6 + (j as f64 - i as f64) * 0.05
            }
        });
        a0.factorize("A0").unwrap();
        let p = Joints(vec![(vec![0, 1, 2], [vec![1.0, 0.0, 0.02], vec![0.0, 1.0, -0.3]])]);
        let wb = Woodbury::new(&mut a0, &p);
        for (k, g) in [
            [[1e-3, 0.0], [0.0, 1e-3]],
            [[3.0, 0.4], [-0.2, 2.5]],
            [[4e6, -1e5], [2e5, 3e6]],
            [[-0.9, 0.1], [0.1, -0.7]],
        ]
        .into_iter()
        .enumerate()
        {
            for zero in [false, true] {
                let b: Vec<f64> = (0..n)
                    .map(|i| if zero { 0.0 } else { (i as f64 * 0.37 + k as f64).sin() })
                    .collect();
                let (mut fast, mut general) = (b.clone(), b.clone());
                let r1 = wb.solve(&mut a0, &p, &[g], &mut fast, &mut WoodburyScratch::default());
                let r2 = wb.solve_general(&mut a0, &p, &[g], &mut general, &mut WoodburyScratch::default());
                assert_eq!(r1.to_bits(), r2.to_bits(), "{k}");
                for (a, c) in fast.iter().zip(&general) {
                    assert_eq!(a.to_bits(), c.to_bits(), "{k} {zero}");
                }
                if !zero && k < 2 {
                    let mut full = base.clone();
                    add_update(&mut full, &p, &[g], None);
                    full.factorize("A").unwrap();
                    let mut direct = b.clone();
                    full.solve_in_place(&mut direct);
                    assert_direct(&fast, &direct);
                }
            }
        }
    }

    /// The update on a nonsymmetric band LU reproduces a direct factorization of
    /// `A0 + P^T G P` (an independent computation) to rounding; the joints' DOFs lie within the
    /// band so the updated matrix is banded too.
    #[test]
    fn woodbury_on_band_lu_is_the_direct_solve() {
        let n = 30;
        let (mut a0, mut full) = band_pair(n, 3, |i, j| {
            if i == j {
                8.0 + i as f64 * 0.2
            } else {
                ((i * 5 + j * 3) % 7) as f64 * 0.2 - 0.5 + (j as f64 - i as f64) * 0.07
            }
        });
        let p = Joints(vec![
            (vec![4, 6], [vec![1.0, -1.0], vec![0.3, 0.8]]),
            (vec![20, 21, 22], [vec![0.5, 0.0, -0.5], vec![0.0, 1.0, 0.2]]),
        ]);
        let g = [[[3.0, 0.4], [-0.2, 2.5]], [[40.0, 1.0], [1.0, 15.0]]];
        add_update(&mut full, &p, &g, None);
        a0.factorize("A0").unwrap();
        full.factorize("A").unwrap();
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.61).cos()).collect();
        let mut x_direct = rhs.clone();
        full.solve_in_place(&mut x_direct);
        let wb = Woodbury::new(&mut a0, &p);
        assert_eq!((wb.n(), wb.m()), (n, 4));
        let mut x = rhs.clone();
        let rcond = wb.solve(&mut a0, &p, &g, &mut x, &mut WoodburyScratch::default());
        assert!(rcond > 1e-3, "{rcond}");
        assert_direct(&x, &x_direct);
    }

    /// The update with a second term `P^T H V` (`V` another operator on the same unknowns)
    /// reproduces a direct factorization of the nonsymmetric `A0 + P^T (G P + H V)` to rounding,
    /// and the plain update is another matrix's solve (the test tells them apart).
    #[test]
    fn the_second_term_reproduces_the_direct_solve() {
        let n = 24;
        let (mut a0, mut full) = band_pair(n, 3, |i, j| {
            if i == j {
                9.0 + i as f64 * 0.1
            } else {
                ((i * 3 + j * 5) % 7) as f64 * 0.15 - 0.4
            }
        });
        let p = Joints(vec![
            (vec![3, 5], [vec![1.0, -1.0], vec![0.2, 0.7]]),
            (vec![14, 15, 16], [vec![0.6, 0.0, -0.4], vec![0.0, 1.0, 0.3]]),
        ]);
        // the velocity rows: other coefficients on the same unknowns
        let v = Joints(vec![
            (vec![3, 5], [vec![0.0, 2.0], vec![-1.5, 0.0]]),
            (vec![14, 15, 16], [vec![0.0, -3.0, 1.0], vec![2.5, 0.0, 0.0]]),
        ]);
        let g = [[[3.0, 0.4], [-0.2, 2.5]], [[30.0, 1.0], [1.0, 12.0]]];
        let h = [[[0.8, 0.1], [0.0, 0.6]], [[2.0, -0.3], [0.2, 1.5]]];
        add_update(&mut full, &p, &g, Some((&v, &h)));
        a0.factorize("A0").unwrap();
        full.factorize("A").unwrap();
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() + 0.2).collect();
        let mut x_direct = rhs.clone();
        full.solve_in_place(&mut x_direct);
        let wb = Woodbury::new(&mut a0, &p);
        let mut wv = Vec::new();
        wb.project_z(&v, &mut wv);
        let mut x = rhs.clone();
        let rcond = wb.solve_with(&mut a0, &p, &v, &g, &h, &wv, &mut x, &mut WoodburyScratch::default());
        assert!(rcond > 1e-3, "{rcond}");
        assert_direct(&x, &x_direct);
        let mut x0 = rhs.clone();
        wb.solve(&mut a0, &p, &g, &mut x0, &mut WoodburyScratch::default());
        let scale = x_direct.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        assert!(x0.iter().zip(&x_direct).any(|(a, b)| (a - b).abs() > 1e-6 * scale));
    }
}
