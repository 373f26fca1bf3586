//! The residual's element forces of a beam link, four elements at a time in an AVX2 build (one
//! element per lane of a 256-bit register), eight at a time where the CPU has AVX-512 (a
//! 512-bit register).
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

/// The most lanes a kernel takes (AVX-512's eight).
pub(super) const MAX_LANES: usize = 8;

/// Up to [`MAX_LANES`] element vectors, entry `j` of lane `l` at `[j][l]`: a kernel of `W` lanes
/// reads and writes the first `W` of each row (lanes past those in use are zero).
pub(super) type Lanes = [[f64; MAX_LANES]; 6];

/// The inertia load vectors of a link's elements by entry, for `w` lanes starting at each
/// element: entry `i` of vector `k` (bx, by, bxx, byx) of element `e + l` at
/// `24 w e + w (6 k + i) + l` (zero past the last element), so that the `w` lanes' loads from
/// any `e` are one contiguous block of `24 w`.
pub(super) fn loads_by_entry(loads: &[[Vec6; 4]], w: usize) -> Vec<f64> {
    let n = loads.len();
    let mut out = vec![0.0; 24 * w * n];
    for e in 0..n {
        for (l, b) in loads[e..].iter().take(w).enumerate() {
            for k in 0..4 {
                for i in 0..6 {
                    out[24 * w * e + w * (6 * k + i) + l] = b[k][i];
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

/// `a v` for the lanes' vectors `v` (`[V; 6]`) with [`mul6`]'s operations for pattern `s`
/// (nalgebra's column-by-column order for a full matrix), with the vector operations `set1`,
/// `mul`, `add` and `zero` of the register width. A macro so that it is inlined into
/// `forces` (`#[inline(always)]` is not allowed with `#[target_feature]`, and a call passes its
/// six registers through memory).
macro_rules! lanes_mul {
    ($set1:ident, $mul:ident, $add:ident, $zero:ident; $a:expr, $s:expr, $split:expr, $v:expr) => {{
        let (a, split, v) = ($a, $split, $v);
        let _: (&Mat6, &SplitMat) = (a, split);
        let b = |x: f64| $set1(x);
        let mut y = [$zero(); 6];
        match $s {
            Sparsity::Zero => {}
            Sparsity::Full => {
                for i in 0..6 {
                    y[i] = $mul(b(a[(i, 0)]), v[0]);
                }
                for j in 1..6 {
                    for i in 0..6 {
                        y[i] = $add(y[i], $mul(b(a[(i, j)]), v[j]));
                    }
                }
            }
            Sparsity::Split => {
                for (r, i) in [0, 3].into_iter().enumerate() {
                    y[i] = $add($mul(b(split.ax3[r]), v[3]), $mul(b(split.ax0[r]), v[0]));
                }
                let c = &split.bend;
                for (r, i) in SplitMat::BEND.into_iter().enumerate() {
                    let mut x = $mul(b(c[0][r]), v[1]);
                    x = $add(x, $mul(b(c[1][r]), v[2]));
                    x = $add(x, $mul(b(c[2][r]), v[4]));
                    y[i] = $add(x, $mul(b(c[3][r]), v[5]));
                }
            }
            Sparsity::Node0 => {
                for i in 0..3 {
                    let mut x = $mul(b(a[(i, 0)]), v[0]);
                    x = $add(x, $mul(b(a[(i, 1)]), v[1]));
                    y[i] = $add($mul(b(a[(i, 2)]), v[2]), x);
                }
            }
        }
        y
    }};
}

/// A module of the lanes' kernels for one register width: `W` lanes of vector type `V`, built
/// with target features `feat`, from the width's intrinsics. Both widths run the same
/// operations in the same order, lane by lane [`element_force`]'s.
macro_rules! lanes_kernels {
    ($name:ident, $w:literal, $v:ty, $feat:literal, $set1:ident, $mul:ident, $add:ident, $sub:ident,
     $zero:ident, $loadu:ident, $storeu:ident, $setr:ident) => {
        #[cfg(target_arch = "x86_64")]
        pub(super) mod $name {
            use std::arch::x86_64::*;

            use super::{Lanes, LinkForces, Sparsity, SplitMat};
            use crate::element::Mat6;

            /// Lanes in a register.
            pub(in crate::integrator::newton) const W: usize = $w;

            type V = [$v; 6];

            #[inline]
            #[target_feature(enable = $feat)]
            unsafe fn load(x: &Lanes) -> V {
                std::array::from_fn(|j| $loadu(x[j].as_ptr()))
            }

            #[inline]
            #[target_feature(enable = $feat)]
            unsafe fn add(a: &mut V, b: &V) {
                for i in 0..6 {
                    a[i] = $add(a[i], b[i]);
                }
            }

            /// The lanes of `W` elements whose six unknowns start at `s`, `s + 3`, ...,
            /// `s + 3 (W - 1)` (a run of elements numbered node after node), from each of `vs`
            /// (displacements, velocities, accelerations) into `out`: entry `j` of lane `l` is
            /// `v[s + 3 l + j]`, as the element-by-element gather writes it, but each entry's
            /// lanes are written as one vector (which [`forces`] reads back as one, without
            /// waiting on scalar stores).
            ///
            /// # Safety
            /// The CPU must support the module's target features.
            #[inline]
            #[target_feature(enable = $feat)]
            pub(in crate::integrator::newton) unsafe fn gather_run(
                vs: [&[f64]; 3],
                s: usize,
                out: &mut [Lanes; 3],
            ) {
                for (o, v) in out.iter_mut().zip(vs) {
                    let v: &[f64; 3 * W + 3] = v[s..s + 3 * W + 3].try_into().expect("a run of elements' unknowns");
                    for j in 0..6 {
                        let e: [f64; W] = std::array::from_fn(|l| v[j + 3 * l]);
                        $storeu(o[j].as_mut_ptr(), super::$setr(e));
                    }
                }
            }

            /// The forces of elements `e .. e + W` of a beam link (lanes past the link's last
            /// element hold zero vectors and give what nobody reads) from their element vectors:
            /// lane `l` is bitwise [`super::element_force`] of element `e + l`.
            ///
            /// # Safety
            /// The CPU must support the module's target features.
            #[inline]
            #[target_feature(enable = $feat)]
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
                let mut f = lanes_mul!($set1, $mul, $add, $zero; &ld.m, ld.m_sparsity, &ld.m_split, &qdd);
                add(&mut f, &lanes_mul!($set1, $mul, $add, $zero; c0, Sparsity::Full, &none, &qd));
                add(&mut f, &lanes_mul!($set1, $mul, $add, $zero; k0, Sparsity::Full, &none, &q));
                if ld.active.geometric {
                    let fax = $mul($set1(ld.ea_l), $sub(q[3], q[0]));
                    let mut g = lanes_mul!($set1, $mul, $add, $zero; &ld.k23, ld.k23_sparsity, &ld.k23_split, &q);
                    if ld.d2_sparsity != Sparsity::Zero {
                        add(&mut g, &lanes_mul!($set1, $mul, $add, $zero; &ld.d2, ld.d2_sparsity, &ld.d2_split, &qd));
                    }
                    for i in 0..6 {
                        f[i] = $add(f[i], $mul(g[i], fax));
                    }
                }
                if ld.active.load {
                    let loads = ld.lane_loads(W);
                    let blk: &[f64; 24 * W] = loads[24 * W * e..24 * W * (e + 1)].try_into().expect("load block");
                    let (fs0, fs1) = ($set1(lf.fs[0]), $set1(lf.fs[1]));
                    let (w2, al) = ($set1(lf.rate * lf.rate), $set1(lf.accel));
                    for i in 0..6 {
                        let b: [$v; 4] = std::array::from_fn(|k| $loadu(blk[W * (6 * k + i)..].as_ptr()));
                        let mut l = $add($mul(b[0], fs0), $mul(b[1], fs1));
                        l = $sub(l, $mul(b[2], w2));
                        l = $add(l, $mul(b[3], al));
                        f[i] = $add(f[i], l);
                    }
                }
                let mut out = [[0.0; super::MAX_LANES]; 6];
                for i in 0..6 {
                    $storeu(out[i].as_mut_ptr(), f[i]);
                }
                out
            }
        }
    };
}

/// `_mm256_set_pd` with its lanes in memory order.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn set4(e: [f64; 4]) -> std::arch::x86_64::__m256d {
    std::arch::x86_64::_mm256_set_pd(e[3], e[2], e[1], e[0])
}

/// `_mm512_set_pd` with its lanes in memory order.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn set8(e: [f64; 8]) -> std::arch::x86_64::__m512d {
    std::arch::x86_64::_mm512_set_pd(e[7], e[6], e[5], e[4], e[3], e[2], e[1], e[0])
}

lanes_kernels!(
    avx2,
    4,
    __m256d,
    "avx2,fma",
    _mm256_set1_pd,
    _mm256_mul_pd,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_setzero_pd,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    set4
);
lanes_kernels!(
    avx512,
    8,
    __m512d,
    "avx512f,avx2,fma",
    _mm512_set1_pd,
    _mm512_mul_pd,
    _mm512_add_pd,
    _mm512_sub_pd,
    _mm512_setzero_pd,
    _mm512_loadu_pd,
    _mm512_storeu_pd,
    set8
);
