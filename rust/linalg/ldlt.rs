//! Sparse LDL^T with faer on a fixed pattern: the symbolic analysis once per pattern (shared
//! among runs by [`AnalysisCache`]), the numeric factorization redone into persistent buffers,
//! and the banded substitution (scalar and multi-lane) that the constant stepper's solves use.

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

use crate::error::{Error, Result};
use crate::plan::assembly::Pattern;

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
    /// The band's factorization has not been copied into faer's layout (`values`) yet: done
    /// when [`Self::solve_in_place_faer`] needs it.
    faer_stale: bool,
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
    /// For a banded factor: each upper entry's place in the band, `(i * (BAND + 1) + k, p)` for
    /// `A[i, i - k] = a[p]` (the values' position `p` in the full pattern).
    band_map: Vec<(usize, usize)>,
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
        // A's pattern lies within L's: within the band where L is
        let band_map = if banded {
            (0..n)
                .flat_map(|c| (col_ptr[c]..col_ptr[c + 1]).map(move |p| (c, p)))
                .map(|(c, p)| (c * (BAND + 1) + (c - row_idx[p]), src[p]))
                .collect()
        } else {
            Vec::new()
        };
        Ok(Arc::new(Analysis {
            symbolic,
            col_ptr,
            row_idx,
            src,
            full_col_ptr: pattern.col_ptr.clone(),
            full_row_idx: pattern.row_idx.clone(),
            banded,
            band_map,
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
    /// The pivots `D[i]` themselves (for faer's layout, [`Cholesky::band_to_faer`]).
    d: Vec<f64>,
    /// The matrix's band while it is factorized: `abd[i][k] = A[i, i - k]`, k = 0 ..= BAND.
    abd: Vec<[f64; BAND + 1]>,
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
            d: vec![0.0; n],
            abd: vec![[0.0; BAND + 1]; n],
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
            faer_stale: false,
            factorizations: 0,
        }
    }

    /// The symbolic analysis this factorization uses.
    pub fn analysis(&self) -> &Arc<Analysis> {
        &self.analysis
    }

    /// Numeric factorization of the matrix with values `a` on the full pattern that was
    /// analyzed (only its upper triangle is read). Fails with [`Error::Singular`] naming `what`
    /// (and the first pivot that is not positive and finite) if the matrix is not positive
    /// definite. A factor within half-bandwidth [`BAND`] (chains of beam elements) is computed by
    /// the band's own LDL^T (`Self::factorize_band`: about a tenth of faer's simplicial
    /// factorization's work at these sizes, n = 39 and b = 5 on the slider-yoke, where adaptive
    /// steps refactorize for every new step length), else by faer.
    pub fn factorize(&mut self, a: &[f64], what: &str) -> Result<()> {
        if self.band.is_some() {
            self.factorize_band(a, what)
        } else {
            self.factorize_faer(a, what)
        }
    }

    /// The numeric factorization by faer's simplicial LDL^T, whatever the band (the reference
    /// the band's own factorization is tested against, within round-off).
    pub fn factorize_faer(&mut self, a: &[f64], what: &str) -> Result<()> {
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
            dof: String::new(),
        })?;
        // D sits first in each column of the factor; every pivot must be positive and finite.
        let cp = an.symbolic.col_ptr();
        for k in 0..n {
            let d = self.values[cp[k]];
            if !(d > 0.0 && d.is_finite()) {
                return Err(Error::Singular {
                    what: what.to_string(),
                    index: k,
                    dof: String::new(),
                });
            }
        }
        self.faer_stale = false;
        if let Some(b) = self.band.as_mut() {
            let ri = an.symbolic.row_idx();
            for j in 0..n {
                b.d[j] = self.values[cp[j]];
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

    /// The LDL^T of a banded matrix by rows within the band (Crout: row `i` of `L` from the
    /// rows above it, `w_j = L[i, j] d_j` carried so each entry costs one multiply-add per
    /// earlier column), into the band's layout; faer's (`values`) is filled from it only when
    /// [`Self::solve_in_place_faer`] reads it. No fill outside the band (the analysis found none).
    /// Rows from `BAND` on have every earlier column of the band: their loops have constant trip
    /// counts (unrolled, no bounds checks); the arithmetic and its order are the same in both.
    fn factorize_band(&mut self, a: &[f64], what: &str) -> Result<()> {
        let an = &*self.analysis;
        let n = an.n();
        let b = self.band.as_mut().expect("a banded factor");
        // the band of A from the upper triangle: A[i, i - k] = A[i - k, i]; the band's other
        // entries are zero from the start and never written
        let abd = b.abd.as_flattened_mut();
        for &(dst, src) in &an.band_map {
            abd[dst] = a[src];
        }
        self.factorizations += 1;
        for i in 0..n {
            // w[k - 1] = L[i, i - k] d_(i-k)
            let mut w = [0.0f64; BAND];
            let mut row = [0.0f64; BAND];
            let ai = b.abd[i];
            let mut di = ai[0];
            if i >= BAND {
                // (exclusive ranges: an inclusive one's end flag keeps these from unrolling)
                let lrows: &[[f64; BAND]; BAND] = b.lrow[i - BAND..i].try_into().expect("BAND rows");
                let dinvs: &[f64; BAND] = b.dinv[i - BAND..i].try_into().expect("BAND pivots");
                for kj in (1..BAND + 1).rev() {
                    let lj = &lrows[BAND - kj];
                    let mut t = ai[kj];
                    for km in (kj + 1..BAND + 1).rev() {
                        t -= w[km - 1] * lj[km - kj - 1];
                    }
                    w[kj - 1] = t;
                    row[kj - 1] = t * dinvs[BAND - kj];
                }
                for kj in (1..BAND + 1).rev() {
                    di -= w[kj - 1] * row[kj - 1];
                }
            } else {
                for j in 0..i {
                    let kj = i - j;
                    let mut t = ai[kj];
                    for m in 0..j {
                        t -= w[i - m - 1] * b.lrow[j][j - m - 1];
                    }
                    w[kj - 1] = t;
                    row[kj - 1] = t * b.dinv[j];
                }
                for j in 0..i {
                    di -= w[i - j - 1] * row[i - j - 1];
                }
            }
            if !(di > 0.0 && di.is_finite()) {
                return Err(Error::Singular {
                    what: what.to_string(),
                    index: i,
                    dof: String::new(),
                });
            }
            b.lrow[i] = row;
            b.d[i] = di;
            b.dinv[i] = 1.0 / di;
        }
        for j in 0..n {
            for k in 1..BAND + 1 {
                b.lcol[j][k - 1] = if j + k < n { b.lrow[j + k][k - 1] } else { 0.0 };
            }
        }
        self.faer_stale = true;
        Ok(())
    }

    /// Copies the band's factorization into faer's layout (`values`: D first in column `i`,
    /// then L below it).
    fn band_to_faer(&mut self) {
        let an = &*self.analysis;
        let b = self.band.as_ref().expect("a banded factor");
        let (cp, ri) = (an.symbolic.col_ptr(), an.symbolic.row_idx());
        for j in 0..an.n() {
            self.values[cp[j]] = b.d[j];
            for p in cp[j] + 1..cp[j + 1] {
                self.values[p] = b.lrow[ri[p]][ri[p] - j - 1];
            }
        }
        self.faer_stale = false;
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
        if self.faer_stale {
            self.band_to_faer();
        }
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

/// True when the CPU has AVX2 and fused multiply-add (x86_64): the one test behind every AVX2
/// build of the crate (these substitutions, the constant stepper's lockstep, the Newton step).
pub(crate) fn avx2_fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma") && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the CPU has AVX-512F besides AVX2 and FMA (the Newton residual's beam elements then
/// take eight lanes at a time).
pub(crate) fn avx512_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        avx2_fma_available() && std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The widest SIMD paths the core takes on this CPU: `"avx512"` (AVX-512F besides AVX2 and FMA:
/// the Newton residual's beam elements eight at a time, the rest as with `"avx2"`), `"avx2"` (AVX2
/// and FMA: the band substitutions, the constant stepper's lockstep lanes, the Newton step and
/// residual) or `"baseline"` (neither, or not x86-64: the portable code). Every path gives
/// bitwise the same results; they differ only in speed.
pub fn simd_paths() -> &'static str {
    if avx512_available() {
        "avx512"
    } else if avx2_fma_available() {
        "avx2"
    } else {
        "baseline"
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
