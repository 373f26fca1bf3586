//! The residual's element forces of a beam link, four elements at a time in an AVX2 build (one
//! element per lane of a 256-bit register).
//!
//! The elements of a link share their matrices (mass, the frame's damping and stiffness at zero
//! axial force, the geometric terms per unit axial force); what differs is each element's six
//! unknowns. Element by element, a 6 x 6 product ran in mostly scalar instructions; in the lanes
//! each matrix entry is broadcast once and multiplies the same entry of four element vectors side
//! by side. Each lane performs the element-by-element path's operations in the same order
//! (nalgebra's column-by-column sums for a full matrix, [`mul6`]'s for the sparse patterns, then
//! the same additions; a multiply and an add stay two roundings), so the residual is bitwise the
//! same (`the_avx2_residual_equals_the_baseline_one_bitwise` in `newton.rs`, the golden cases).

use super::{mul6, LinkData, Sparsity, SplitMat};
use crate::element::{Mat6, Vec6};

/// The frame's terms an element's force uses, the same for every element of a link.
pub(super) struct LinkForces<'a> {
    pub ld: &'a LinkData,
    /// `(C, K)` at zero axial force for the current frames.
    pub ck: &'a (Mat6, Mat6),
    /// The nominal acceleration of the frame origin in link components (m/s^2, gravity
    /// removed), the frame's rate (rad/s) and its angular acceleration (rad/s^2).
    pub fs: [f64; 2],
    pub rate: f64,
    pub accel: f64,
}

/// Four element vectors, entry `j` of lane `l` at `[j][l]` (lanes past those in use are zero).
pub(super) type Lanes = [[f64; 4]; 6];

/// The inertia load vectors of a link's elements by entry, for the lanes starting at each
/// element: entry `i` of vector `k` (bx, by, bxx, byx) of element `e + l` at
/// `96 e + 4 (6 k + i) + l` (zero past the last element), so that the four lanes' loads from any
/// `e` are one contiguous block of 96.
pub(super) fn loads_by_entry(loads: &[[Vec6; 4]]) -> Vec<f64> {
    let n = loads.len();
    let mut out = vec![0.0; 96 * n];
    for e in 0..n {
        for (l, b) in loads[e..].iter().take(4).enumerate() {
            for k in 0..4 {
                for i in 0..6 {
                    out[96 * e + 4 * (6 * k + i) + l] = b[k][i];
                }
            }
        }
    }
    out
}

/// The force of one element from its element vectors (`q`, `qd`, `qdd`, link-frame components),
/// with nalgebra's products: the path without AVX2, and the lanes' reference.
#[inline(always)]
pub(super) fn element_force(lf: &LinkForces, e: usize, q: &Vec6, qd: &Vec6, qdd: &Vec6) -> Vec6 {
    let ld = lf.ld;
    let (c0, k0) = lf.ck;
    let mut f = mul6(&ld.m, ld.m_sparsity, &ld.m_split, qdd) + c0 * qd + k0 * q;
    if ld.active.geometric {
        let fax = ld.ea_l * (q[3] - q[0]);
        let mut g = mul6(&ld.k23, ld.k23_sparsity, &ld.k23_split, q);
        if ld.d2_sparsity != Sparsity::Zero {
            g += mul6(&ld.d2, ld.d2_sparsity, &ld.d2_split, qd);
        }
        f += g * fax;
    }
    if ld.active.load {
        let b = &ld.loads[e];
        f += b[0] * lf.fs[0] + b[1] * lf.fs[1] - b[2] * (lf.rate * lf.rate) + b[3] * lf.accel;
    }
    f
}

#[cfg(target_arch = "x86_64")]
pub(super) use avx2::{forces, gather_run};

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{Lanes, LinkForces, Sparsity, SplitMat};
    use crate::element::Mat6;

    type V = [__m256d; 6];

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load(x: &Lanes) -> V {
        std::array::from_fn(|j| _mm256_loadu_pd(x[j].as_ptr()))
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn add(a: &mut V, b: &V) {
        for i in 0..6 {
            a[i] = _mm256_add_pd(a[i], b[i]);
        }
    }

    /// `a v` for the lanes' vectors with [`super::mul6`]'s operations for pattern `s`
    /// (nalgebra's column-by-column order for a full matrix). A macro so that it is inlined
    /// into [`forces`] (`#[inline(always)]` is not allowed with `#[target_feature]`, and a call
    /// passes its six registers through memory).
    macro_rules! mul {
        ($a:expr, $s:expr, $split:expr, $v:expr) => {{
            let (a, split, v): (&Mat6, &SplitMat, &V) = ($a, $split, $v);
            let b = |x: f64| _mm256_set1_pd(x);
            let mut y = [_mm256_setzero_pd(); 6];
            match $s {
                Sparsity::Zero => {}
                Sparsity::Full => {
                    for i in 0..6 {
                        y[i] = _mm256_mul_pd(b(a[(i, 0)]), v[0]);
                    }
                    for j in 1..6 {
                        for i in 0..6 {
                            y[i] = _mm256_add_pd(y[i], _mm256_mul_pd(b(a[(i, j)]), v[j]));
                        }
                    }
                }
                Sparsity::Split => {
                    for (r, i) in [0, 3].into_iter().enumerate() {
                        y[i] = _mm256_add_pd(
                            _mm256_mul_pd(b(split.ax3[r]), v[3]),
                            _mm256_mul_pd(b(split.ax0[r]), v[0]),
                        );
                    }
                    let c = &split.bend;
                    for (r, i) in SplitMat::BEND.into_iter().enumerate() {
                        let mut x = _mm256_mul_pd(b(c[0][r]), v[1]);
                        x = _mm256_add_pd(x, _mm256_mul_pd(b(c[1][r]), v[2]));
                        x = _mm256_add_pd(x, _mm256_mul_pd(b(c[2][r]), v[4]));
                        y[i] = _mm256_add_pd(x, _mm256_mul_pd(b(c[3][r]), v[5]));
                    }
                }
                Sparsity::Node0 => {
                    for i in 0..3 {
                        let mut x = _mm256_mul_pd(b(a[(i, 0)]), v[0]);
                        x = _mm256_add_pd(x, _mm256_mul_pd(b(a[(i, 1)]), v[1]));
                        y[i] = _mm256_add_pd(_mm256_mul_pd(b(a[(i, 2)]), v[2]), x);
                    }
                }
            }
            y
        }};
    }

    /// The lanes of four elements whose six unknowns start at `s`, `s + 3`, `s + 6` and `s + 9`
    /// (a run of elements numbered node after node), from each of `vs` (displacements,
    /// velocities, accelerations) into `out`: entry `j` of lane `l` is `v[s + 3 l + j]`, as
    /// the element-by-element gather writes it, but each entry's four lanes are written as one
    /// vector (which [`forces`] reads back as one, without waiting on four scalar stores).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::integrator::newton) unsafe fn gather_run(vs: [&[f64]; 3], s: usize, out: &mut [Lanes; 3]) {
        for (o, v) in out.iter_mut().zip(vs) {
            let v: &[f64; 15] = v[s..s + 15].try_into().expect("four elements' unknowns");
            for j in 0..6 {
                _mm256_storeu_pd(o[j].as_mut_ptr(), _mm256_set_pd(v[j + 9], v[j + 6], v[j + 3], v[j]));
            }
        }
    }

    /// The forces of elements `e .. e + 4` of a beam link (lanes past the link's last element
    /// hold zero vectors and give what nobody reads) from their element vectors: lane `l` is
    /// bitwise [`super::element_force`] of element `e + l`.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::integrator::newton) unsafe fn forces(
        lf: &LinkForces,
        e: usize,
        q: &Lanes,
        qd: &Lanes,
        qdd: &Lanes,
    ) -> Lanes {
        let ld = lf.ld;
        let (c0, k0) = lf.ck;
        let none = SplitMat::default();
        let (q, qd, qdd) = (load(q), load(qd), load(qdd));
        let mut f = mul!(&ld.m, ld.m_sparsity, &ld.m_split, &qdd);
        add(&mut f, &mul!(c0, Sparsity::Full, &none, &qd));
        add(&mut f, &mul!(k0, Sparsity::Full, &none, &q));
        if ld.active.geometric {
            let fax = _mm256_mul_pd(_mm256_set1_pd(ld.ea_l), _mm256_sub_pd(q[3], q[0]));
            let mut g = mul!(&ld.k23, ld.k23_sparsity, &ld.k23_split, &q);
            if ld.d2_sparsity != Sparsity::Zero {
                add(&mut g, &mul!(&ld.d2, ld.d2_sparsity, &ld.d2_split, &qd));
            }
            for i in 0..6 {
                f[i] = _mm256_add_pd(f[i], _mm256_mul_pd(g[i], fax));
            }
        }
        if ld.active.load {
            let blk: &[f64; 96] = ld.loads_t[96 * e..96 * e + 96].try_into().expect("load block");
            let (fs0, fs1) = (_mm256_set1_pd(lf.fs[0]), _mm256_set1_pd(lf.fs[1]));
            let (w2, al) = (_mm256_set1_pd(lf.rate * lf.rate), _mm256_set1_pd(lf.accel));
            for i in 0..6 {
                let b: [__m256d; 4] = std::array::from_fn(|k| _mm256_loadu_pd(blk[4 * (6 * k + i)..].as_ptr()));
                let mut l = _mm256_add_pd(_mm256_mul_pd(b[0], fs0), _mm256_mul_pd(b[1], fs1));
                l = _mm256_sub_pd(l, _mm256_mul_pd(b[2], w2));
                l = _mm256_add_pd(l, _mm256_mul_pd(b[3], al));
                f[i] = _mm256_add_pd(f[i], l);
            }
        }
        let mut out = [[0.0; 4]; 6];
        for i in 0..6 {
            _mm256_storeu_pd(out[i].as_mut_ptr(), f[i]);
        }
        out
    }
}
