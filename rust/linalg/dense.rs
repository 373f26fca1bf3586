//! Small dense solves (Gaussian elimination with partial pivoting) for the Woodbury capacitance
//! systems of the contact update.

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
