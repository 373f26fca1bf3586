//! Linear solves with faer: a simplicial sparse Cholesky (LDL^T) whose symbolic analysis is done
//! once per pattern and whose numeric factorization is redone into persistent buffers, plus the
//! low-rank (Sherman-Morrison-Woodbury) correction that lets the contact-free factorization serve
//! a step whose effective matrix differs only on the joints' DOFs (docs/method.md section 5).
//!
//! Nothing here allocates after construction.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::simplicial::{
    factorize_simplicial_numeric_ldlt, factorize_simplicial_numeric_ldlt_scratch,
    factorize_simplicial_symbolic_cholesky, factorize_simplicial_symbolic_cholesky_scratch,
    prefactorize_symbolic_cholesky, prefactorize_symbolic_cholesky_scratch, SimplicialLdltRef,
    SymbolicSimplicialCholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};
use std::sync::Arc;

use crate::assembly::Pattern;
use crate::error::{Error, Result};

/// Sparse Cholesky factorization (LDL^T, no pivoting) of a symmetric positive definite matrix on
/// a fixed pattern; D is checked to be positive, so an indefinite matrix is reported, not solved.
/// LDL^T rather than LL^T because its solve divides once per row instead of twice.
/// Natural ordering: a chain of beam elements numbered along the chain is banded, so it has no
/// fill outside the band.
pub struct Cholesky {
    analysis: Arc<Analysis>,
    upper: Vec<f64>,
    values: Vec<f64>,
    mem: MemBuffer,
    /// The factor copied into a dense band after each factorization, when it fits in
    /// half-bandwidth [`BAND`] (every chain of beam elements does).
    band: Option<BandedFactor>,
    /// One lane's right-hand side, for [`Self::solve_lanes`] without a band.
    lane_tmp: Vec<f64>,
    /// Number of numeric factorizations done.
    pub factorizations: u64,
}

/// The symbolic analysis of one pattern: faer's elimination tree and factor structure, and the
/// pattern's upper triangle. Immutable, so one analysis serves every factorization of matrices on
/// that pattern, in one run (effective, contact and mass matrices) and across the samples of a
/// study (shared through an `Arc`).
pub struct Analysis {
    symbolic: SymbolicSimplicialCholesky<usize>,
    /// Upper-triangle pattern (faer reads every stored entry of a column).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Positions of the upper entries in the full pattern's value array.
    src: Vec<usize>,
    /// The full pattern this was built from (to check that a shared analysis fits a model).
    full_col_ptr: Vec<usize>,
    full_row_idx: Vec<usize>,
    banded: bool,
}

impl std::fmt::Debug for Analysis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Analysis")
            .field("n", &self.symbolic.nrows())
            .field("nnz_l", &self.symbolic.len_val())
            .field("banded", &self.banded)
            .finish()
    }
}

impl Analysis {
    /// Symbolic analysis of `pattern` (its upper triangle; natural ordering).
    pub fn new(pattern: &Pattern) -> Result<Arc<Self>> {
        let n = pattern.n;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut src = Vec::new();
        col_ptr.push(0);
        for c in 0..n {
            for p in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                if pattern.row_idx[p] <= c {
                    row_idx.push(pattern.row_idx[p]);
                    src.push(p);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let mut etree = vec![0isize; n];
        let mut counts = vec![0usize; n];
        let mut mem = MemBuffer::new(StackReq::any_of(&[
            prefactorize_symbolic_cholesky_scratch::<usize>(n, pattern.nnz()),
            factorize_simplicial_symbolic_cholesky_scratch::<usize>(n),
        ]));
        let stack = MemStack::new(&mut mem);
        let etree_ref = prefactorize_symbolic_cholesky(&mut etree, &mut counts, sym, stack);
        let symbolic = factorize_simplicial_symbolic_cholesky(sym, etree_ref, &counts, stack).map_err(|e| {
            Error::InvalidModel {
                message: format!("symbolic factorization failed: {e:?}"),
            }
        })?;
        let (lcp, lri) = (symbolic.col_ptr(), symbolic.row_idx());
        let banded = (0..n).all(|j| lri[lcp[j]..lcp[j + 1]].iter().all(|&i| i >= j && i - j <= BAND));
        Ok(Arc::new(Analysis {
            symbolic,
            col_ptr,
            row_idx,
            src,
            full_col_ptr: pattern.col_ptr.clone(),
            full_row_idx: pattern.row_idx.clone(),
            banded,
        }))
    }

    /// True when this analysis was made for exactly `pattern`.
    pub fn fits(&self, pattern: &Pattern) -> bool {
        self.full_col_ptr == pattern.col_ptr && self.full_row_idx == pattern.row_idx
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.col_ptr.len() - 1
    }
}

/// Half-bandwidth of the factors solved by the banded substitution: a chain of 2-node beam
/// elements with 3 DOFs per node couples DOFs at most 5 apart.
pub const BAND: usize = 5;

/// faer's LDL^T factor laid out by rows and by columns of the band, for a substitution whose
/// critical path is one multiply-add per row (the older terms of each row are summed
/// independently of the newest one).
struct BandedFactor {
    /// `lrow[i][k - 1] = L[i, i - k]`, k = 1 ..= BAND.
    lrow: Vec<[f64; BAND]>,
    /// `lcol[j][k - 1] = L[j + k, j]`, k = 1 ..= BAND.
    lcol: Vec<[f64; BAND]>,
    dinv: Vec<f64>,
    /// The CPU has fused multiply-add (x86_64): use [`BandedFactor::solve_fma`].
    fma: bool,
    /// The CPU also has AVX2: the lane substitution uses 256-bit registers.
    avx2: bool,
}

impl BandedFactor {
    #[inline]
    fn solve(&self, x: &mut [f64]) {
        assert_eq!(x.len(), self.dinv.len());
        #[cfg(target_arch = "x86_64")]
        if self.fma {
            // SAFETY: `fma` is set only when the CPU reports the FMA extension.
            unsafe { self.solve_fma(x) };
            return;
        }
        self.solve_plain(x);
    }

    #[inline]
    fn solve_plain(&self, x: &mut [f64]) {
        // Forward L y = b: the last BAND values of y ride in registers (p1 newest), so only
        // `r[0] * p1` is on the serial path of each row; x receives y / D directly, which is
        // what the backward pass needs.
        let (mut p1, mut p2, mut p3, mut p4, mut p5) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for ((r, xi), d) in self.lrow.iter().zip(x.iter_mut()).zip(&self.dinv) {
            let s = (r[1] * p2 + r[2] * p3) + (r[3] * p4 + r[4] * p5);
            let y = (*xi - s) - r[0] * p1;
            *xi = y * d;
            (p5, p4, p3, p2, p1) = (p4, p3, p2, p1, y);
        }
        // Backward L^T x = y / D, same register scheme from the last row up.
        let (mut p1, mut p2, mut p3, mut p4, mut p5) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (c, xi) in self.lcol.iter().zip(x.iter_mut()).rev() {
            let s = (c[1] * p2 + c[2] * p3) + (c[3] * p4 + c[4] * p5);
            let y = (*xi - s) - c[0] * p1;
            *xi = y;
            (p5, p4, p3, p2, p1) = (p4, p3, p2, p1, y);
        }
    }

    /// The same substitution as a chain of fused multiply-adds, oldest term first: each row adds
    /// one FMA latency (about 4 cycles) to the critical path instead of a multiply and a
    /// subtraction. Rounding differs from [`Self::solve_plain`] in the last bits (tested close).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "fma")]
    unsafe fn solve_fma(&self, x: &mut [f64]) {
        let (mut p1, mut p2, mut p3, mut p4, mut p5) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for ((r, xi), d) in self.lrow.iter().zip(x.iter_mut()).zip(&self.dinv) {
            let y = (-r[0]).mul_add(
                p1,
                (-r[1]).mul_add(p2, (-r[2]).mul_add(p3, (-r[3]).mul_add(p4, (-r[4]).mul_add(p5, *xi)))),
            );
            *xi = y * d;
            (p5, p4, p3, p2, p1) = (p4, p3, p2, p1, y);
        }
        let (mut p1, mut p2, mut p3, mut p4, mut p5) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (c, xi) in self.lcol.iter().zip(x.iter_mut()).rev() {
            let y = (-c[0]).mul_add(
                p1,
                (-c[1]).mul_add(p2, (-c[2]).mul_add(p3, (-c[3]).mul_add(p4, (-c[4]).mul_add(p5, *xi)))),
            );
            *xi = y;
            (p5, p4, p3, p2, p1) = (p4, p3, p2, p1, y);
        }
    }
}

/// One row of the lane substitution: `y = x - (r0 p1 + r1 p2 + ... + r4 p5)` for every lane,
/// with exactly the operations (and their order) of the single-vector substitution, so that each
/// lane's result is bitwise that of [`BandedFactor::solve_plain`] or [`BandedFactor::solve_fma`].
#[inline(always)]
fn lane_row<const L: usize, const FMA: bool>(r: &[f64; BAND], p: &[[f64; L]; BAND], x: &[f64; L]) -> [f64; L] {
    let mut y = [0.0; L];
    for l in 0..L {
        y[l] = if FMA {
            (-r[0]).mul_add(
                p[0][l],
                (-r[1]).mul_add(
                    p[1][l],
                    (-r[2]).mul_add(p[2][l], (-r[3]).mul_add(p[3][l], (-r[4]).mul_add(p[4][l], x[l]))),
                ),
            )
        } else {
            let s = (r[1] * p[1][l] + r[2] * p[2][l]) + (r[3] * p[3][l] + r[4] * p[4][l]);
            (x[l] - s) - r[0] * p[0][l]
        };
    }
    y
}

impl BandedFactor {
    /// Solves for `L` right-hand sides stored lane-fastest (`x[i][lane]`): every factor entry is
    /// loaded once for all lanes and the lanes' dependency chains run side by side, which hides
    /// the latency that bounds a single substitution. Each lane gets bitwise the result of
    /// [`Self::solve`] on that lane alone.
    #[inline]
    fn solve_lanes<const L: usize>(&self, x: &mut [[f64; L]]) {
        assert_eq!(x.len(), self.dinv.len());
        #[cfg(target_arch = "x86_64")]
        if self.fma {
            if self.avx2 {
                // SAFETY: `avx2` is set only when the CPU reports AVX2 and FMA.
                unsafe { self.solve_lanes_avx2(x) };
            } else {
                // SAFETY: `fma` is set only when the CPU reports the FMA extension.
                unsafe { self.solve_lanes_fma(x) };
            }
            return;
        }
        self.solve_lanes_body::<L, false>(x);
    }

    #[inline(always)]
    fn solve_lanes_body<const L: usize, const FMA: bool>(&self, x: &mut [[f64; L]]) {
        // p[0] is the newest value (p1 of the single substitution), p[4] the oldest.
        let mut p = [[0.0f64; L]; BAND];
        for ((r, xi), &d) in self.lrow.iter().zip(x.iter_mut()).zip(&self.dinv) {
            let y = lane_row::<L, FMA>(r, &p, xi);
            for l in 0..L {
                xi[l] = y[l] * d;
            }
            p = [y, p[0], p[1], p[2], p[3]];
        }
        let mut p = [[0.0f64; L]; BAND];
        for (c, xi) in self.lcol.iter().zip(x.iter_mut()).rev() {
            let y = lane_row::<L, FMA>(c, &p, xi);
            *xi = y;
            p = [y, p[0], p[1], p[2], p[3]];
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn solve_lanes_avx2<const L: usize>(&self, x: &mut [[f64; L]]) {
        self.solve_lanes_body::<L, true>(x);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "fma")]
    unsafe fn solve_lanes_fma<const L: usize>(&self, x: &mut [[f64; L]]) {
        self.solve_lanes_body::<L, true>(x);
    }
}

impl std::fmt::Debug for Cholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cholesky")
            .field("n", &self.analysis.n())
            .field("nnz_l", &self.values.len())
            .finish()
    }
}

impl Cholesky {
    /// Symbolic analysis of `pattern` followed by [`Self::with_analysis`].
    pub fn analyze(pattern: &Pattern) -> Result<Self> {
        Ok(Self::with_analysis(Analysis::new(pattern)?))
    }

    /// A factorization on a (possibly shared) symbolic analysis; allocates the numeric buffers.
    pub fn with_analysis(analysis: Arc<Analysis>) -> Self {
        let n = analysis.n();
        let mem = MemBuffer::new(factorize_simplicial_numeric_ldlt_scratch::<usize, f64>(n));
        let band = analysis.banded.then(|| BandedFactor {
            lrow: vec![[0.0; BAND]; n],
            lcol: vec![[0.0; BAND]; n],
            dinv: vec![0.0; n],
            fma: fma_available(),
            avx2: avx2_fma_available(),
        });
        Cholesky {
            upper: vec![0.0; analysis.src.len()],
            values: vec![0.0; analysis.symbolic.len_val()],
            analysis,
            mem,
            band,
            lane_tmp: Vec::new(),
            factorizations: 0,
        }
    }

    /// The symbolic analysis this factorization uses.
    pub fn analysis(&self) -> &Arc<Analysis> {
        &self.analysis
    }

    /// Numeric factorization of the matrix with values `a` on the full pattern that was
    /// analyzed (only its upper triangle is read). Fails with [`Error::Singular`] naming `what`
    /// if the matrix is not positive definite.
    pub fn factorize(&mut self, a: &[f64], what: &str) -> Result<()> {
        let an = &*self.analysis;
        let n = an.n();
        for (u, &p) in self.upper.iter_mut().zip(&an.src) {
            *u = a[p];
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &an.col_ptr, None, &an.row_idx);
        let mat = SparseColMatRef::new(sym, &self.upper);
        let stack = MemStack::new(&mut self.mem);
        self.factorizations += 1;
        factorize_simplicial_numeric_ldlt(
            &mut self.values,
            mat,
            LdltRegularization::default(),
            &an.symbolic,
            stack,
        )
        .map_err(|_| Error::Singular {
            what: what.to_string(),
            index: 0,
        })?;
        // D sits first in each column of the factor; every pivot must be positive and finite.
        let cp = an.symbolic.col_ptr();
        for k in 0..n {
            let d = self.values[cp[k]];
            if !(d > 0.0 && d.is_finite()) {
                return Err(Error::Singular {
                    what: what.to_string(),
                    index: k,
                });
            }
        }
        if let Some(b) = self.band.as_mut() {
            let ri = an.symbolic.row_idx();
            for j in 0..n {
                b.dinv[j] = 1.0 / self.values[cp[j]];
                for p in cp[j] + 1..cp[j + 1] {
                    let k = ri[p] - j;
                    b.lcol[j][k - 1] = self.values[p];
                    b.lrow[ri[p]][k - 1] = self.values[p];
                }
            }
        }
        Ok(())
    }

    /// Solves `A x = b` in place (`x` holds `b` on entry); does not allocate. For a factor within
    /// half-bandwidth [`BAND`] (chains of beam elements) this is a banded substitution on faer's
    /// factor, else faer's `SimplicialLdltRef::solve_in_place_with_conj`
    /// ([`Self::solve_in_place_faer`]). The two are tested equal; `cargo bench --bench core --
    /// linsolve` measures both.
    #[inline]
    pub fn solve_in_place(&mut self, x: &mut [f64]) {
        match self.band.as_ref() {
            Some(b) => b.solve(x),
            None => self.solve_in_place_faer(x),
        }
    }

    /// The solve through faer's `SimplicialLdltRef::solve_in_place_with_conj`.
    pub fn solve_in_place_faer(&mut self, x: &mut [f64]) {
        let n = x.len();
        let ldlt = SimplicialLdltRef::new(&self.analysis.symbolic, &self.values);
        let rhs = MatMut::from_column_major_slice_mut(x, n, 1);
        let stack = MemStack::new(&mut self.mem);
        ldlt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
    }

    /// Solves `A X = B` in place for `L` right-hand sides stored lane-fastest (`x[i][lane]`,
    /// holding `B` on entry). Each lane's result is bitwise that of [`Self::solve_in_place`] on
    /// that lane alone; for a banded factor the lanes advance together (one load of each factor
    /// entry, `L` independent dependency chains), otherwise lane by lane through faer.
    #[inline]
    pub fn solve_lanes<const L: usize>(&mut self, x: &mut [[f64; L]]) {
        if L == 1 {
            return self.solve_in_place(x.as_flattened_mut());
        }
        match self.band.as_ref() {
            Some(b) => b.solve_lanes(x),
            None => {
                let mut col = std::mem::take(&mut self.lane_tmp);
                col.resize(x.len(), 0.0);
                for l in 0..L {
                    for (c, xi) in col.iter_mut().zip(x.iter()) {
                        *c = xi[l];
                    }
                    self.solve_in_place_faer(&mut col);
                    for (c, xi) in col.iter().zip(x.iter_mut()) {
                        xi[l] = *c;
                    }
                }
                self.lane_tmp = col;
            }
        }
    }

    /// True when [`Self::solve_in_place`] uses the banded substitution.
    pub fn is_banded(&self) -> bool {
        self.band.is_some()
    }
}

/// Solves the small dense system `a x = b` (size `m`, row-major `a`) in place by Gaussian
/// elimination with partial pivoting. Returns the ratio of the smallest to the largest pivot
/// magnitude (0 when singular), a cheap conditioning indicator.
#[inline]
pub fn solve_dense_in_place(a: &mut [f64], b: &mut [f64], m: usize) -> f64 {
    if m == 2 {
        return solve_dense_2(a, b);
    }
    solve_dense_general(a, b, m)
}

/// The general elimination of [`solve_dense_in_place`], without its `m = 2` shortcut.
#[inline]
fn solve_dense_general(a: &mut [f64], b: &mut [f64], m: usize) -> f64 {
    let (mut pmin, mut pmax) = (f64::INFINITY, 0.0f64);
    for k in 0..m {
        let mut p = k;
        for i in k + 1..m {
            if a[i * m + k].abs() > a[p * m + k].abs() {
                p = i;
            }
        }
        if p != k {
            for j in 0..m {
                a.swap(k * m + j, p * m + j);
            }
            b.swap(k, p);
        }
        let piv = a[k * m + k];
        pmin = pmin.min(piv.abs());
        pmax = pmax.max(piv.abs());
        if piv == 0.0 || !piv.is_finite() {
            return 0.0;
        }
        for i in k + 1..m {
            let f = a[i * m + k] / piv;
            if f != 0.0 {
                for j in k..m {
                    a[i * m + j] -= f * a[k * m + j];
                }
                b[i] -= f * b[k];
            }
        }
    }
    for k in (0..m).rev() {
        let mut s = b[k];
        for j in k + 1..m {
            s -= a[k * m + j] * b[j];
        }
        b[k] = s / a[k * m + k];
    }
    if pmax > 0.0 {
        pmin / pmax
    } else {
        0.0
    }
}

/// [`solve_dense_in_place`] for `m = 2` (one joint) unrolled: the same operations in the same
/// order, so the same `b` and pivot ratio bit for bit (`a` is left partly eliminated).
#[inline]
fn solve_dense_2(a: &mut [f64], b: &mut [f64]) -> f64 {
    let (mut a00, mut a01, mut a10, mut a11) = (a[0], a[1], a[2], a[3]);
    let (mut b0, mut b1) = (b[0], b[1]);
    if a10.abs() > a00.abs() {
        std::mem::swap(&mut a00, &mut a10);
        std::mem::swap(&mut a01, &mut a11);
        std::mem::swap(&mut b0, &mut b1);
    }
    let (mut pmin, mut pmax) = (f64::INFINITY.min(a00.abs()), 0.0f64.max(a00.abs()));
    if a00 == 0.0 || !a00.is_finite() {
        (b[0], b[1]) = (b0, b1);
        return 0.0;
    }
    let f = a10 / a00;
    if f != 0.0 {
        a10 -= f * a00;
        a11 -= f * a01;
        b1 -= f * b0;
    }
    pmin = pmin.min(a11.abs());
    pmax = pmax.max(a11.abs());
    (a[0], a[1], a[2], a[3]) = (a00, a01, a10, a11);
    if a11 == 0.0 || !a11.is_finite() {
        (b[0], b[1]) = (b0, b1);
        return 0.0;
    }
    b1 /= a11;
    b0 = (b0 - a01 * b1) / a00;
    (b[0], b[1]) = (b0, b1);
    if pmax > 0.0 {
        pmin / pmax
    } else {
        0.0
    }
}

/// True when the CPU has fused multiply-add (detected once per factorization object).
fn fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// True when the CPU has AVX2 and fused multiply-add (x86_64).
fn avx2_fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma") && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Symbolic analyses shared among runs whose models have the same sparsity pattern (the samples
/// of a study that differ only in values share one; a sample that changes the element count gets
/// its own). Thread-safe; the lock is taken once per run, before the time loop.
#[derive(Debug, Default)]
pub struct AnalysisCache {
    analyses: std::sync::Mutex<Vec<Arc<Analysis>>>,
}

impl AnalysisCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// The analysis of `pattern`, made on first request.
    pub fn get(&self, pattern: &Pattern) -> Result<Arc<Analysis>> {
        let mut list = self.analyses.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(a) = list.iter().find(|a| a.fits(pattern)) {
            return Ok(Arc::clone(a));
        }
        let a = Analysis::new(pattern)?;
        list.push(Arc::clone(&a));
        Ok(a)
    }

    /// Number of distinct patterns analyzed so far.
    pub fn len(&self) -> usize {
        self.analyses.lock().unwrap_or_else(|p| p.into_inner()).len()
    }

    /// True when nothing has been analyzed yet.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Dense-band LU factorization without pivoting, for the nonsymmetric effective matrices of
/// rotating links (the Coriolis term `2 phidot rho A int N^T S N` and the `phiddot` part of
/// `M_IC` are skew-symmetric). Refactorized in place with no allocation, `O(n b^2)` for
/// half-bandwidth `b`, so cost grows linearly with the element count of a chain.
///
/// Without pivoting the factorization exists whenever the symmetric part of the matrix is
/// positive definite (every leading principal minor is then nonzero), which holds for Newmark
/// effective matrices `M/(beta dt^2) + gamma/(beta dt) C + K` at the steps of interest; a pivot that
/// is not finite or is tiny relative to the diagonal's scale is reported as
/// [`Error::Singular`] instead of being divided by.
#[derive(Debug, Clone)]
pub struct BandLu {
    n: usize,
    b: usize,
    /// Row-major band: entry (i, j) at `i * (2b + 1) + (j + b - i)`, for `|i - j| <= b`.
    a: Vec<f64>,
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
        let scale = (0..n).fold(0.0f64, |s, i| s.max(self.a[i * w + b].abs()));
        let tiny = scale * 1e-14;
        for k in 0..n {
            let piv = self.a[k * w + b];
            if !piv.is_finite() || piv.abs() <= tiny {
                return Err(Error::Singular {
                    what: what.to_string(),
                    index: k,
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
mod dense_tests {
    /// The unrolled 2 x 2 solve is bitwise the general elimination (pivoting both ways, a
    /// singular matrix, a zero off-diagonal).
    #[test]
    fn unrolled_2x2_is_the_general_elimination() {
        let cases = [
            [4.0, 1.5, 0.3, 2.0, 1.0, -2.0],
            [0.3, 2.0, 4.0, 1.5, 1.0, -2.0],
            [1.0, 2.0, 2.0, 4.0, 1.0, 1.0],
            [1.0 + 1e-9, 0.0, 0.0, 1.0 + 3e-7, 0.7, 0.1],
            [0.0, 0.0, 0.0, 0.0, 1.0, 1.0],
        ];
        for c in cases {
            let (mut a1, mut b1) = ([c[0], c[1], c[2], c[3]], [c[4], c[5]]);
            let (mut a2, mut b2) = (a1, b1);
            let r1 = super::solve_dense_2(&mut a1, &mut b1);
            let r2 = super::solve_dense_general(&mut a2, &mut b2, 2);
            assert_eq!(r1.to_bits(), r2.to_bits(), "{c:?}");
            assert_eq!(b1.map(f64::to_bits), b2.map(f64::to_bits), "{c:?}");
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

    #[test]
    fn zero_pivot_is_an_error() {
        let mut m = BandLu::new(3, 1);
        m.add(0, 0, 1.0);
        m.add(2, 2, 1.0);
        assert!(m.factorize("K").is_err());
    }
}
