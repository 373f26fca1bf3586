//! The Newmark state updates of a Newton step over all unknowns: the predictors and first
//! iterate ([`predict`]), each correction with its largest entries ([`correct`]), and the
//! truncation test's largest acceleration change ([`max_abs_difference`]). Each has an AVX2
//! form ([`predict_avx2`], [`correct_avx2`], [`max_abs_difference_avx2`]) that
//! performs the scalar form's operations lane by lane, so both give the same values
//! (`a_run_in_the_avx2_build_equals_the_baseline_run_bitwise` in `newton.rs`).

/// The largest of four running maxima (the lanes of the loops here and of
/// `Extrapolation::converged` and `max_abs_or_inf`: unknown `i` in lane `i % 4`).
#[inline(always)]
pub(super) fn max_of_lanes(m: [f64; 4]) -> f64 {
    m[0].max(m[1]).max(m[2].max(m[3]))
}

/// The Newmark predictors of a step of `h` (s) from the start state `[y, yd, ydd]` into `[y_pred,
/// v_pred]`, and its first iterate `a = a_n + w (a_n - a_prev)` (`a_n` where `w = 0`) into `a`
/// and the state `state` (whose entries are overwritten, not read: the caller swaps the start
/// state out of it, no copy); `c = [h, beta, gamma, beta h^2, gamma h, w]`. A function of its own
/// so that the slices are known not to overlap. [`predict_avx2`] gives the same values.
#[inline(always)]
pub(super) fn predict(start: [&[f64]; 3], state: [&mut [f64]; 3], pred: [&mut [f64]; 3], a_prev: &[f64], c: [f64; 6]) {
    let [y0v, v0v, a0v] = start;
    let [yv, ydv, yddv] = state;
    let [yp, vp, av] = pred;
    let [h, beta, gamma, bh2, gh, w] = c;
    let n = yv.len();
    let (y0v, v0v, a0v, ydv, yddv, yp, vp, av, a_prev) = (
        &y0v[..n],
        &v0v[..n],
        &a0v[..n],
        &mut ydv[..n],
        &mut yddv[..n],
        &mut yp[..n],
        &mut vp[..n],
        &mut av[..n],
        &a_prev[..n],
    );
    for i in 0..n {
        let (y0, v0, a0) = (y0v[i], v0v[i], a0v[i]);
        yp[i] = y0 + h * v0 + (0.5 - beta) * h * h * a0;
        vp[i] = v0 + (1.0 - gamma) * h * a0;
        let a = if w > 0.0 { a0 + w * (a0 - a_prev[i]) } else { a0 };
        av[i] = a;
        yv[i] = yp[i] + bh2 * a;
        ydv[i] = vp[i] + gh * a;
        yddv[i] = a;
    }
}

/// [`predict`] four unknowns at a time in AVX2 registers, lane by lane the same operations in
/// the same order (no fused multiply-add): the same values. Written out because the loop over
/// nine slices is not vectorized by the compiler.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn predict_avx2(
    start: [&[f64]; 3],
    state: [&mut [f64]; 3],
    pred: [&mut [f64]; 3],
    a_prev: &[f64],
    c: [f64; 6],
) {
    use std::arch::x86_64::*;
    let [y0v, v0v, a0v] = start;
    let [yv, ydv, yddv] = state;
    let [yp, vp, av] = pred;
    let [h, beta, gamma, bh2, gh, w] = c;
    let n = yv.len();
    // the loop reads and writes through pointers: every slice must hold n entries
    assert!(
        [
            y0v.len(),
            v0v.len(),
            a0v.len(),
            ydv.len(),
            yddv.len(),
            yp.len(),
            vp.len(),
            av.len(),
            a_prev.len()
        ]
        .iter()
        .all(|&l| l >= n),
        "predict_avx2: slices shorter than the unknowns"
    );
    let whole = n / 4 * 4;
    // `(0.5 - beta) * h * h * a0` and `(1 - gamma) * h * a0` multiply left to right: the
    // factors before `a0` first, as here
    let (c1, c2) = ((0.5 - beta) * h * h, (1.0 - gamma) * h);
    let set = _mm256_set1_pd;
    let (hv, c1v, c2v, bv, gv, wv) = (set(h), set(c1), set(c2), set(bh2), set(gh), set(w));
    let extrapolate = w > 0.0;
    let mut i = 0;
    while i < whole {
        // SAFETY: i + 4 <= whole <= n, within every slice (asserted above)
        let ld = |v: &[f64]| _mm256_loadu_pd(v.as_ptr().add(i));
        let st = |v: &mut [f64], x: __m256d| _mm256_storeu_pd(v.as_mut_ptr().add(i), x);
        let (y0, v0, a0) = (ld(y0v), ld(v0v), ld(a0v));
        let ypi = _mm256_add_pd(_mm256_add_pd(y0, _mm256_mul_pd(hv, v0)), _mm256_mul_pd(c1v, a0));
        let vpi = _mm256_add_pd(v0, _mm256_mul_pd(c2v, a0));
        let a = if extrapolate {
            _mm256_add_pd(a0, _mm256_mul_pd(wv, _mm256_sub_pd(a0, ld(a_prev))))
        } else {
            a0
        };
        st(yp, ypi);
        st(vp, vpi);
        st(av, a);
        st(yv, _mm256_add_pd(ypi, _mm256_mul_pd(bv, a)));
        st(ydv, _mm256_add_pd(vpi, _mm256_mul_pd(gv, a)));
        st(yddv, a);
        i += 4;
    }
    // the last `n % 4` unknowns by the scalar form
    predict(
        [&y0v[whole..n], &v0v[whole..n], &a0v[whole..n]],
        [&mut yv[whole..n], &mut ydv[whole..n], &mut yddv[whole..n]],
        [&mut yp[whole..n], &mut vp[whole..n], &mut av[whole..n]],
        &a_prev[whole..n],
        c,
    );
}

/// A Newton correction `dx` (the accelerations' `-dx`) into `[a, ydd, y, yd]` from the predictors
/// `[y_pred, v_pred]` (`bh2 = beta h^2`, `gh = gamma h`); returns the largest displacement
/// correction `bh2 |dx|` and the largest `|y|` (NaN entries skipped, as `f64::max` does; four
/// running maxima each, exact whatever the order). A function of its own so that the slices
/// are known not to overlap.
#[inline(always)]
pub(super) fn correct(state: [&mut [f64]; 4], pred: [&[f64]; 3], bh2: f64, gh: f64) -> (f64, f64) {
    let [av, yddv, yv, ydv] = state;
    let [ypv, vpv, dxv] = pred;
    let [mut dm, mut ym] = [[0.0f64; 4]; 2];
    for i in 0..av.len() {
        // unknown i into maximum i % 4
        let k = i % 4;
        let da = -dxv[i];
        av[i] += da;
        yddv[i] = av[i];
        yv[i] = ypv[i] + bh2 * av[i];
        ydv[i] = vpv[i] + gh * av[i];
        // `if d > m`, not f64::max (whose NaN rule keeps a loop from vectorizing); NaN is
        // skipped alike, and it is `_mm256_max_pd(d, m)` of the AVX2 form
        let d = (bh2 * da).abs();
        dm[k] = if d > dm[k] { d } else { dm[k] };
        let y = yv[i].abs();
        ym[k] = if y > ym[k] { y } else { ym[k] };
    }
    (max_of_lanes(dm), max_of_lanes(ym))
}

/// [`correct`] four unknowns at a time in AVX2 registers (the compiler keeps the scalar form's
/// loop scalar): each entry's operations are the scalar form's (a sign flip, then separate
/// multiplies and adds), and `_mm256_max_pd(d, m)` is `if d > m { d } else { m }` lane by lane,
/// unknown `i` in lane `i % 4` as there: the same values.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn correct_avx2(state: [&mut [f64]; 4], pred: [&[f64]; 3], bh2: f64, gh: f64) -> (f64, f64) {
    use std::arch::x86_64::*;
    let [av, yddv, yv, ydv] = state;
    let [ypv, vpv, dxv] = pred;
    let n = av.len();
    // the masked tail below reads and writes through pointers: every slice must hold n entries
    assert!(
        [yddv.len(), yv.len(), ydv.len(), ypv.len(), vpv.len(), dxv.len()]
            .iter()
            .all(|&l| l >= n),
        "correct_avx2: slices shorter than the unknowns"
    );
    let whole = n / 4 * 4;
    let (b, g, sign) = (_mm256_set1_pd(bh2), _mm256_set1_pd(gh), _mm256_set1_pd(-0.0));
    let (mut dm, mut ym) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let outs = av[..whole]
        .chunks_exact_mut(4)
        .zip(yddv[..whole].chunks_exact_mut(4))
        .zip(yv[..whole].chunks_exact_mut(4).zip(ydv[..whole].chunks_exact_mut(4)));
    let ins = ypv[..whole]
        .chunks_exact(4)
        .zip(vpv[..whole].chunks_exact(4))
        .zip(dxv[..whole].chunks_exact(4));
    // four unknowns' operations, the whole chunks' and the tail's: `(a, y, yd)`, the maxima
    // updated
    let mut four = |dx: __m256d, a0: __m256d, yp: __m256d, vp: __m256d| {
        let da = _mm256_xor_pd(dx, sign);
        let a = _mm256_add_pd(a0, da);
        let y = _mm256_add_pd(yp, _mm256_mul_pd(b, a));
        let yd = _mm256_add_pd(vp, _mm256_mul_pd(g, a));
        dm = _mm256_max_pd(_mm256_andnot_pd(sign, _mm256_mul_pd(b, da)), dm);
        ym = _mm256_max_pd(_mm256_andnot_pd(sign, y), ym);
        (a, y, yd)
    };
    for (((a4, ydd4), (y4, yd4)), ((yp4, vp4), dx4)) in outs.zip(ins) {
        let ld = |v: &[f64]| _mm256_loadu_pd(v.as_ptr());
        let (a, y, yd) = four(ld(dx4), ld(a4), ld(yp4), ld(vp4));
        _mm256_storeu_pd(a4.as_mut_ptr(), a);
        _mm256_storeu_pd(ydd4.as_mut_ptr(), a);
        _mm256_storeu_pd(y4.as_mut_ptr(), y);
        _mm256_storeu_pd(yd4.as_mut_ptr(), yd);
    }
    if whole < n {
        // the last `n % 4` unknowns in lanes 0.. (unknown i in lane i % 4, as in the scalar
        // form), the lanes past the end neither read nor written; their zeros leave the
        // maxima as they are (`max(0, m) = m` for the maxima >= 0 or NaN of the lanes before)
        let mask = _mm256_castpd_si256(_mm256_cmp_pd::<_CMP_LT_OQ>(
            _mm256_set_pd(3.0, 2.0, 1.0, 0.0),
            _mm256_set1_pd((n - whole) as f64),
        ));
        // SAFETY: the pointers are the slices' entries from `whole` (< n) on; the mask keeps
        // every access below `n`
        let ld = |v: &[f64]| _mm256_maskload_pd(v.as_ptr().add(whole), mask);
        let (a, y, yd) = four(ld(dxv), ld(av), ld(ypv), ld(vpv));
        _mm256_maskstore_pd(av.as_mut_ptr().add(whole), mask, a);
        _mm256_maskstore_pd(yddv.as_mut_ptr().add(whole), mask, a);
        _mm256_maskstore_pd(yv.as_mut_ptr().add(whole), mask, y);
        _mm256_maskstore_pd(ydv.as_mut_ptr().add(whole), mask, yd);
    }
    let mut maxima = [[0.0; 4]; 2];
    _mm256_storeu_pd(maxima[0].as_mut_ptr(), dm);
    _mm256_storeu_pd(maxima[1].as_mut_ptr(), ym);
    (max_of_lanes(maxima[0]), max_of_lanes(maxima[1]))
}

/// `max |a_i - b_i|` over two slices of one length, four running maxima (no chain through
/// every entry; the maximum is exact, so the order does not matter).
pub(super) fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    max_abs_difference_from(a, b, 0, [0.0; 4])
}

/// [`max_abs_difference`] from entry `start` (a multiple of 4) on, its four running maxima
/// starting at `m`.
#[inline(always)]
fn max_abs_difference_from(a: &[f64], b: &[f64], start: usize, mut m: [f64; 4]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[start.min(n)..n], &b[start.min(n)..n]);
    // `if d > m` (not f64::max, whose NaN rule keeps it from vectorizing): skips NaN alike
    for (ca, cb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for k in 0..4 {
            let d = (ca[k] - cb[k]).abs();
            m[k] = if d > m[k] { d } else { m[k] };
        }
    }
    let whole = a.len() / 4 * 4;
    for i in whole..a.len() {
        let d = (a[i] - b[i]).abs();
        m[i % 4] = if d > m[i % 4] { d } else { m[i % 4] };
    }
    max_of_lanes(m)
}

/// [`max_abs_difference`] four entries at a time in AVX2 registers, lane by lane the same
/// operations (`_mm256_max_pd(d, m)` is `if d > m { d } else { m }`): the same value.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn max_abs_difference_avx2(a: &[f64], b: &[f64]) -> f64 {
    use std::arch::x86_64::*;
    let whole = a.len().min(b.len()) / 4 * 4;
    let sign = _mm256_set1_pd(-0.0);
    let mut m = _mm256_setzero_pd();
    for i in (0..whole).step_by(4) {
        let d = _mm256_sub_pd(
            _mm256_loadu_pd(a[i..i + 4].as_ptr()),
            _mm256_loadu_pd(b[i..i + 4].as_ptr()),
        );
        m = _mm256_max_pd(_mm256_andnot_pd(sign, d), m);
    }
    let mut lanes = [0.0; 4];
    _mm256_storeu_pd(lanes.as_mut_ptr(), m);
    max_abs_difference_from(a, b, whole, lanes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers uniform in [-0.5, 0.5) from a linear congruential generator seeded with `seed`.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// The AVX2 correction (whole chunks and the masked tail) gives the scalar form's state
    /// and maxima bit for bit, for every remainder of the unknowns' count modulo 4.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_correction_equals_the_scalar_one_bitwise() {
        if !crate::linalg::avx2_fma_available() {
            return;
        }
        let mut next = uniform(7);
        for n in 1..=13 {
            let mut vs: Vec<Vec<f64>> = (0..7).map(|_| (0..n).map(|_| next()).collect()).collect();
            if n == 6 {
                vs[6][5] = f64::NAN; // a NaN correction is skipped by the maxima alike
            }
            let (bh2, gh) = (2.5e-11, 5e-6);
            let mut scalar = vs.clone();
            let (s0, rest) = scalar.split_at_mut(4);
            let [a, ydd, y, yd] = s0 else { unreachable!() };
            let m_scalar = correct([a, ydd, y, yd], [&rest[0], &rest[1], &rest[2]], bh2, gh);
            let (v0, rest) = vs.split_at_mut(4);
            let [a, ydd, y, yd] = v0 else { unreachable!() };
            // SAFETY: the CPU has AVX2 and FMA (checked above)
            let m_avx2 = unsafe { correct_avx2([a, ydd, y, yd], [&rest[0], &rest[1], &rest[2]], bh2, gh) };
            let bits = |v: &[Vec<f64>]| -> Vec<u64> { v.iter().flatten().map(|x| x.to_bits()).collect() };
            assert_eq!(bits(&vs), bits(&scalar), "n {n}");
            assert_eq!(m_avx2.0.to_bits(), m_scalar.0.to_bits(), "n {n}");
            assert_eq!(m_avx2.1.to_bits(), m_scalar.1.to_bits(), "n {n}");
        }
    }

    /// The AVX2 predictor (whole chunks and the scalar tail) gives the scalar form's predictors,
    /// first iterate and state bit for bit, with and without the extrapolation, for every
    /// remainder of the unknowns' count modulo 4 and the Newmark constants of a run.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_predictor_equals_the_scalar_one_bitwise() {
        if !crate::linalg::avx2_fma_available() {
            return;
        }
        let mut next = uniform(11);
        for n in 1..=13 {
            for (h, beta, gamma, w) in [
                (1e-5, 0.25, 0.5, 0.0),
                (1e-5, 0.25, 0.5, 1.0),
                (3.7e-6, 0.3025, 0.6, 0.61),
            ] {
                let start: Vec<Vec<f64>> = (0..3).map(|_| (0..n).map(|_| 1e3 * next()).collect()).collect();
                let a_prev: Vec<f64> = (0..n).map(|_| 1e3 * next()).collect();
                let c = [h, beta, gamma, beta * h * h, gamma * h, w];
                let run = |avx2: bool| {
                    let mut out: Vec<Vec<f64>> = (0..6).map(|_| vec![f64::NAN; n]).collect();
                    let (state, pred) = out.split_at_mut(3);
                    let [y, yd, ydd] = state else { unreachable!() };
                    let [yp, vp, a] = pred else { unreachable!() };
                    let s = [&start[0][..], &start[1][..], &start[2][..]];
                    if avx2 {
                        // SAFETY: the CPU has AVX2 and FMA (checked above)
                        unsafe { predict_avx2(s, [y, yd, ydd], [yp, vp, a], &a_prev, c) }
                    } else {
                        predict(s, [y, yd, ydd], [yp, vp, a], &a_prev, c)
                    }
                    out.iter().flatten().map(|x| x.to_bits()).collect::<Vec<u64>>()
                };
                assert_eq!(run(true), run(false), "n {n}, w {w}");
            }
        }
    }
}
