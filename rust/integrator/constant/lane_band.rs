//! Products and lane access on lane-fastest vectors (`x[dof][lane]`): the stiffness and damping
//! matrices as dense bands multiplied on every lane at once (the sums in the single run's order,
//! lane by lane), and one lane's values read, written or projected on a joint.

use super::*;

/// A symmetric matrix stored as a dense band (row `r` holds columns `r - w ..= r + w`), for the
/// per-step products `K x` and `C x` on lane-fastest vectors; the sums are formed in the order of
/// [`crate::plan::assembly::Band::mul`], lane by lane.
pub(super) struct LaneBand {
    n: usize,
    w: usize,
    vals: Vec<f64>,
    /// The CPU has AVX2 (x86_64): products of several lanes use 256-bit registers.
    avx2: bool,
}

impl LaneBand {
    /// The band of values `a` on `pattern` ([`crate::plan::assembly::Band::from_csc`]), or `None` when
    /// the band would hold more than twice the pattern's entries.
    pub(super) fn from_csc(pattern: &Pattern, a: &[f64]) -> Option<LaneBand> {
        let (n, w, vals) = crate::plan::assembly::Band::from_csc(pattern, a)?.into_parts();
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        Some(LaneBand { n, w, vals, avx2 })
    }

    pub(super) fn padded_len(&self) -> usize {
        self.n + 2 * self.w
    }

    /// `y = A x` for every lane, `xpad` holding `x` at `xpad[w .. w + n]` and zeros at the ends.
    #[inline]
    fn mul<const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        let width = 2 * self.w + 1;
        assert!(xpad.len() == self.padded_len() && y.len() >= self.n);
        if width == 11 {
            #[cfg(target_arch = "x86_64")]
            if L.is_multiple_of(4) && self.avx2 {
                // SAFETY: the CPU reports AVX2.
                return unsafe { self.mul_fixed_avx2::<11, L>(xpad, y) };
            }
            return self.mul_fixed::<11, L>(xpad, y);
        }
        for (r, (row, yr)) in self.vals.chunks_exact(width).zip(y.iter_mut()).enumerate() {
            let x = &xpad[r..r + width];
            for l in 0..L {
                let mut s = [0.0; 4];
                let (rc, xc) = (row.chunks_exact(4), x.chunks_exact(4));
                let (rr, xr) = (rc.remainder(), xc.remainder());
                for (a, b) in rc.zip(xc) {
                    for k in 0..4 {
                        s[k] += a[k] * b[k][l];
                    }
                }
                let mut t = (s[0] + s[1]) + (s[2] + s[3]);
                for (a, b) in rr.iter().zip(xr) {
                    t += a * b[l];
                }
                yr[l] = t;
            }
        }
    }

    /// [`Self::mul_fixed`] for `L` a multiple of 4 with explicit 256-bit vectors across lanes
    /// (left to itself, the compiler vectorizes across rows instead, with shuffles and spills).
    /// The same IEEE additions and multiplications in the same order, so bitwise the same.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn mul_fixed_avx2<const W: usize, const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        use std::arch::x86_64::{
            _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
        };
        assert!(L.is_multiple_of(4) && xpad.len() >= self.n + W - 1 && y.len() >= self.n);
        for (r, (row, yr)) in self.vals.chunks_exact(W).zip(y.iter_mut()).enumerate() {
            let x = &xpad[r..r + W];
            let mut c = 0;
            while c < L {
                // SAFETY: c + 4 <= L, so every load and the store stay within one [f64; L].
                unsafe {
                    macro_rules! term {
                        ($k:expr) => {
                            _mm256_mul_pd(
                                _mm256_set1_pd(row[$k]),
                                _mm256_loadu_pd(x[$k].as_ptr().add(c)),
                            )
                        };
                    }
                    let (mut a0, mut a1, mut b0, mut b1) = (
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                    );
                    let mut k = 0;
                    while k + 4 <= W {
                        a0 = _mm256_add_pd(a0, term!(k));
                        a1 = _mm256_add_pd(a1, term!(k + 1));
                        b0 = _mm256_add_pd(b0, term!(k + 2));
                        b1 = _mm256_add_pd(b1, term!(k + 3));
                        k += 4;
                    }
                    while k + 2 <= W {
                        a0 = _mm256_add_pd(a0, term!(k));
                        a1 = _mm256_add_pd(a1, term!(k + 1));
                        k += 2;
                    }
                    let mut t = _mm256_add_pd(_mm256_add_pd(a0, b0), _mm256_add_pd(a1, b1));
                    if k < W {
                        t = _mm256_add_pd(t, term!(k));
                    }
                    _mm256_storeu_pd(yr.as_mut_ptr().add(c), t);
                }
                c += 4;
            }
        }
    }

    #[inline(always)]
    fn mul_fixed<const W: usize, const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        for (r, (row, yr)) in self.vals.chunks_exact(W).zip(y.iter_mut()).enumerate() {
            let row: &[f64; W] = row.try_into().expect("chunk of width W");
            let x: &[[f64; L]; W] = xpad[r..r + W].try_into().expect("window of width W");
            // the accumulators and order of `Band::mul_fixed`, lane by lane
            let (mut a0, mut a1, mut b0, mut b1) = ([0.0f64; L], [0.0f64; L], [0.0f64; L], [0.0f64; L]);
            let mut k = 0;
            while k + 4 <= W {
                for l in 0..L {
                    a0[l] += row[k] * x[k][l];
                    a1[l] += row[k + 1] * x[k + 1][l];
                    b0[l] += row[k + 2] * x[k + 2][l];
                    b1[l] += row[k + 3] * x[k + 3][l];
                }
                k += 4;
            }
            while k + 2 <= W {
                for l in 0..L {
                    a0[l] += row[k] * x[k][l];
                    a1[l] += row[k + 1] * x[k + 1][l];
                }
                k += 2;
            }
            for l in 0..L {
                let mut t = (a0[l] + b0[l]) + (a1[l] + b1[l]);
                if k < W {
                    t += row[k] * x[k][l];
                }
                yr[l] = t;
            }
        }
    }
}

/// `y = A x` on every lane through the band when there is one, else lane by lane on the pattern.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn matvec<const L: usize>(
    pattern: &Pattern,
    band: Option<&LaneBand>,
    a: &[f64],
    x: &[[f64; L]],
    xpad: &mut [[f64; L]],
    y: &mut [[f64; L]],
    col_x: &mut [f64],
    col_y: &mut [f64],
) {
    match band {
        Some(b) => {
            let w = b.w;
            xpad[w..w + x.len()].copy_from_slice(x);
            b.mul(xpad, y);
        }
        None if L == 1 => pattern.mul(a, x.as_flattened(), y.as_flattened_mut()),
        None => {
            for l in 0..L {
                get_lane(x, l, col_x);
                pattern.mul(a, col_x, col_y);
                set_lane(y, l, col_y);
            }
        }
    }
}

/// Copies lane `l` of `x` into `out`.
#[inline]
pub(super) fn get_lane<const L: usize>(x: &[[f64; L]], l: usize, out: &mut [f64]) {
    for (o, xi) in out.iter_mut().zip(x) {
        *o = xi[l];
    }
}

/// Copies `v` into lane `l` of `x`.
#[inline]
pub(super) fn set_lane<const L: usize>(x: &mut [[f64; L]], l: usize, v: &[f64]) {
    for (xi, &o) in x.iter_mut().zip(v) {
        xi[l] = o;
    }
}

/// `P x` of joint `j` on lane `l`, with the operations of [`System::joint_project`].
#[inline]
pub(super) fn project_lane<const L: usize>(j: &crate::plan::assembly::JointPlan, x: &[[f64; L]], l: usize) -> [f64; 2] {
    let mut r = [0.0; 2];
    for k in 0..j.ndof {
        let v = x[j.dofs[k]][l];
        r[0] += j.coef[0][k] * v;
        r[1] += j.coef[1][k] * v;
    }
    r
}
