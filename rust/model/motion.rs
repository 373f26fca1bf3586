//! Prescribed planar motions of rigid bodies and of flexible links' frames.

use crate::error::{check_finite, check_non_negative, in_range, Error, Result};

/// Position, velocity and acceleration of a point, m, m/s, m/s^2.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kinematics {
    /// Position, m.
    pub pos: [f64; 2],
    /// Velocity, m/s.
    pub vel: [f64; 2],
    /// Acceleration, m/s^2.
    pub acc: [f64; 2],
}

/// A prescribed translation `r(t)` in the global frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Motion {
    /// At rest at `position` (m).
    Fixed {
        /// Position, m.
        position: [f64; 2],
    },
    /// `r(t) = offset + amplitude sin(2 pi f t + phase)`.
    Harmonic {
        /// Mean position, m.
        offset: [f64; 2],
        /// Amplitude per axis, m.
        amplitude: [f64; 2],
        /// Frequency f, Hz.
        frequency: f64,
        /// Phase, rad.
        phase: f64,
    },
    /// Tabulated motion: positions, velocities and accelerations at the samples (the last two
    /// given by the caller or derived by central differences at construction), interpolated by
    /// the quintic Hermite polynomial of each interval when the accelerations were given
    /// (`quintic_hermite`), else by the cubic through positions and velocities
    /// (`cubic_hermite`).
    Tabulated(Table),
}

/// The quintic Hermite interpolant on an interval of length `h` (s) at the fraction `s` in
/// [0, 1] of it, through the values `y`, first derivatives `v` (per s) and second derivatives `a`
/// (per s^2) at its two ends: its value, first and second derivative at `s`.
///
/// The value, velocity and acceleration of a tabulated motion are this one polynomial and its
/// derivatives, so they agree with one another (a linear interpolation of each would give a
/// velocity that is not the position's derivative), and the motion is twice continuously
/// differentiable across the samples. Its error is `O(h^6)` in the value, `h^6 max|y^(6)| / 46080`
/// at most: a link of a mechanism tabulated from its exact kinematics at 1e-3 s at 150 rad/s
/// keeps its pins closed to 1e-10 of its length between the samples.
#[inline]
pub(crate) fn quintic_hermite(h: f64, s: f64, y: [f64; 2], v: [f64; 2], a: [f64; 2]) -> (f64, f64, f64) {
    let (s2, s3) = (s * s, s * s * s);
    let (s4, s5) = (s3 * s, s3 * s2);
    // the six basis polynomials (of y0, h v0, h^2 a0, y1, h v1, h^2 a1) and their derivatives in s
    let b = [
        [
            1.0 - 10.0 * s3 + 15.0 * s4 - 6.0 * s5,
            -30.0 * s2 + 60.0 * s3 - 30.0 * s4,
            -60.0 * s + 180.0 * s2 - 120.0 * s3,
        ],
        [
            s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5,
            1.0 - 18.0 * s2 + 32.0 * s3 - 15.0 * s4,
            -36.0 * s + 96.0 * s2 - 60.0 * s3,
        ],
        [
            0.5 * (s2 - 3.0 * s3 + 3.0 * s4 - s5),
            0.5 * (2.0 * s - 9.0 * s2 + 12.0 * s3 - 5.0 * s4),
            0.5 * (2.0 - 18.0 * s + 36.0 * s2 - 20.0 * s3),
        ],
        [
            10.0 * s3 - 15.0 * s4 + 6.0 * s5,
            30.0 * s2 - 60.0 * s3 + 30.0 * s4,
            60.0 * s - 180.0 * s2 + 120.0 * s3,
        ],
        [
            -4.0 * s3 + 7.0 * s4 - 3.0 * s5,
            -12.0 * s2 + 28.0 * s3 - 15.0 * s4,
            -24.0 * s + 84.0 * s2 - 60.0 * s3,
        ],
        [
            0.5 * (s3 - 2.0 * s4 + s5),
            0.5 * (3.0 * s2 - 8.0 * s3 + 5.0 * s4),
            0.5 * (6.0 * s - 24.0 * s2 + 20.0 * s3),
        ],
    ];
    // the parts of the values, the rates and the accelerations, put together in powers of h
    // without forming h^2 (a span of 1e200 s with zero accelerations must not give inf * 0)
    let part = |k: usize, i: usize, x: [f64; 2]| b[i][k] * x[0] + b[i + 3][k] * x[1];
    let value = part(0, 0, y) + h * (part(0, 1, v) + h * part(0, 2, a));
    let rate = part(1, 0, y) / h + part(1, 1, v) + h * part(1, 2, a);
    let accel = (part(2, 0, y) / h + part(2, 1, v)) / h + part(2, 2, a);
    (value, rate, accel)
}

/// The cubic Hermite interpolant on an interval of length `h` (s) at the fraction `s` in [0, 1]
/// of it, through the values `y` and first derivatives `v` (per s) at its two ends: its value,
/// first and second derivative at `s` (the second is linear in `s` and jumps at the ends). What a
/// table without accelerations interpolates by: the quintic through derived accelerations can
/// swing far outside its samples where their spacing varies (central differences of central
/// differences over uneven intervals), the cubic stays within about `h |v|` of them.
#[inline]
pub(crate) fn cubic_hermite(h: f64, s: f64, y: [f64; 2], v: [f64; 2]) -> (f64, f64, f64) {
    let s2 = s * s;
    let s3 = s2 * s;
    let (h00, h10, h01, h11) = (
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        3.0 * s2 - 2.0 * s3,
        s3 - s2,
    );
    let (d00, d10, d11) = (6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, 3.0 * s2 - 2.0 * s);
    let (e00, e10, e11) = (12.0 * s - 6.0, 6.0 * s - 4.0, 6.0 * s - 2.0);
    let value = h00 * y[0] + h01 * y[1] + h * (h10 * v[0] + h11 * v[1]);
    let rate = d00 * (y[0] - y[1]) / h + d10 * v[0] + d11 * v[1];
    let accel = (e00 * (y[0] - y[1]) / h + e10 * v[0] + e11 * v[1]) / h;
    (value, rate, accel)
}

/// A tabulated sample interval's interpolant: [`quintic_hermite`] when the table was given its
/// accelerations, else [`cubic_hermite`] (values and rates).
#[inline]
pub(crate) fn hermite(h: f64, s: f64, y: [f64; 2], v: [f64; 2], a: Option<[f64; 2]>) -> (f64, f64, f64) {
    match a {
        Some(a) => quintic_hermite(h, s, y, v, a),
        None => cubic_hermite(h, s, y, v),
    }
}

/// Samples of a tabulated motion. Build it with [`Table::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    time: Vec<f64>,
    pos: Vec<[f64; 2]>,
    vel: Vec<[f64; 2]>,
    /// The accelerations when given (quintic interpolation); None: cubic through positions and
    /// velocities.
    acc: Option<Vec<[f64; 2]>>,
}

/// Checks that the interpolant of every sample interval stays within range: its second derivative
/// is of the order `(|y1 - y0| / h + |v0| + |v1|) / h` (the values' change `y1 - y0` and the
/// rates `v0`, `v1` at the ends of an interval of `h` s, per component), which must be at most
/// [`MAX_MAGNITUDE`](crate::error::MAX_MAGNITUDE) (1e75): samples far closer than their rates
/// allow (1e20 rad/s tabulated 1e-300 s apart) would give infinite accelerations. `dim`
/// components, `y(i, k)` and `v(i, k)` the value and rate of component `k` at sample `i`; the
/// error names `time(i)`, the later sample of the interval, with `unit` the values' unit.
pub(crate) fn check_spacing(
    time: &[f64],
    dim: usize,
    y: impl Fn(usize, usize) -> f64,
    v: impl Fn(usize, usize) -> f64,
    time_field: impl Fn(usize) -> String,
    unit: &str,
) -> Result<()> {
    for i in 0..time.len().saturating_sub(1) {
        let h = time[i + 1] - time[i];
        for k in 0..dim {
            let dy = (y(i + 1, k) - y(i, k)).abs();
            let scale = (dy / h + v(i, k).abs() + v(i + 1, k).abs()) / h;
            if !crate::error::in_range(scale) {
                return Err(Error::param(
                    time_field(i + 1),
                    time[i + 1],
                    format!(
                        "a sample far enough after the one before it (at {} s) for the rates: {} s \
                         apart, with the values changing by {} and the rates reaching {} {unit}/s, \
                         the interpolated accelerations are of the order of {} {unit}/s^2 (at most \
                         1e75)",
                        crate::error::g6(time[i]),
                        crate::error::g6(h),
                        crate::error::g6(dy),
                        crate::error::g6(v(i, k).abs().max(v(i + 1, k).abs())),
                        crate::error::g6(scale),
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Central differences (one-sided at the ends) of the samples `y` over the strictly increasing
/// times `t` (s), per component: the derivative of every tabulated motion (translations here,
/// frame angles in [`crate::kinematics::AngleTable`]).
pub(crate) fn gradient<const D: usize>(t: &[f64], y: &[[f64; D]]) -> Vec<[f64; D]> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let (a, b) = if i == 0 {
                (0, 1)
            } else if i == n - 1 {
                (n - 2, n - 1)
            } else {
                (i - 1, i + 1)
            };
            let dt = t[b] - t[a];
            std::array::from_fn(|k| (y[b][k] - y[a][k]) / dt)
        })
        .collect()
}

impl Table {
    /// Builds a table from strictly increasing times (s) and positions (m); velocity (m/s) and
    /// acceleration (m/s^2) are derived by central differences when not given. With the
    /// accelerations given it is interpolated by `quintic_hermite`, else by `cubic_hermite`.
    ///
    /// Fails with [`Error::InvalidParameter`] if fewer than 2 samples, non-increasing or
    /// non-finite times, arrays of different lengths, values beyond 1e75, or samples closer than
    /// their rates allow (`check_spacing`, naming `name.time[i]`).
    pub fn new(
        name: &str,
        time: Vec<f64>,
        pos: Vec<[f64; 2]>,
        vel: Option<Vec<[f64; 2]>>,
        acc: Option<Vec<[f64; 2]>>,
    ) -> Result<Self> {
        let n = time.len();
        if n < 2 {
            return Err(Error::param(
                format!("{name}.time"),
                format!("{n} samples"),
                "at least 2 samples",
            ));
        }
        for (i, w) in time.windows(2).enumerate() {
            if !(w[0].is_finite() && w[1].is_finite() && w[1] > w[0]) {
                return Err(Error::param(
                    format!("{name}.time[{}]", i + 1),
                    w[1],
                    "finite and strictly increasing, s",
                ));
            }
        }
        for (label, arr) in [
            ("position", Some(&pos)),
            ("velocity", vel.as_ref()),
            ("acceleration", acc.as_ref()),
        ] {
            if let Some(a) = arr {
                if a.len() != n {
                    return Err(Error::param(
                        format!("{name}.{label}"),
                        format!("{} samples", a.len()),
                        format!("as many samples as time ({n})"),
                    ));
                }
                check_samples(name, label, a)?;
            }
        }
        let vel = vel.unwrap_or_else(|| gradient(&time, &pos));
        // derived by differences: samples too close for their positions give rates beyond range
        // (the accelerations' differences bound the cubic's, which are not kept)
        check_samples(name, "velocity (from the positions)", &vel)?;
        if acc.is_none() {
            check_samples(name, "acceleration (from the positions)", &gradient(&time, &vel))?;
        }
        check_spacing(
            &time,
            2,
            |i, k| pos[i][k],
            |i, k| vel[i][k],
            |i| format!("{name}.time[{i}]"),
            "m",
        )?;
        Ok(Table { time, pos, vel, acc })
    }

    /// Last tabulated time, s.
    pub fn end_time(&self) -> f64 {
        *self.time.last().expect("table has >= 2 samples")
    }

    /// First tabulated time, s.
    pub fn start_time(&self) -> f64 {
        self.time[0]
    }

    /// Position, velocity and acceleration at `t` (s): the Hermite interpolant of the interval
    /// holding `t` ([`hermite`]); before the first sample and after the last
    /// the end sample's values are held.
    fn eval(&self, t: f64) -> Kinematics {
        let (i, s) = segment(&self.time, t);
        let h = self.time[i + 1] - self.time[i];
        let mut k = Kinematics::default();
        for c in 0..2 {
            let two = |a: &[[f64; 2]]| [a[i][c], a[i + 1][c]];
            let acc = self.acc.as_deref().map(two);
            (k.pos[c], k.vel[c], k.acc[c]) = hermite(h, s, two(&self.pos), two(&self.vel), acc);
        }
        k
    }
}

impl Motion {
    /// Kinematics at time `t` (s).
    #[inline]
    pub fn at(&self, t: f64) -> Kinematics {
        match self {
            Motion::Fixed { position } => Kinematics {
                pos: *position,
                ..Default::default()
            },
            Motion::Harmonic {
                offset,
                amplitude,
                frequency,
                phase,
            } => {
                let w = 2.0 * std::f64::consts::PI * frequency;
                let (s, c) = (w * t + phase).sin_cos();
                Kinematics {
                    pos: [offset[0] + amplitude[0] * s, offset[1] + amplitude[1] * s],
                    vel: [amplitude[0] * w * c, amplitude[1] * w * c],
                    acc: [-amplitude[0] * w * w * s, -amplitude[1] * w * w * s],
                }
            }
            Motion::Tabulated(table) => table.eval(t),
        }
    }

    /// True when the acceleration is identically zero (no inertia load to apply).
    pub fn is_fixed(&self) -> bool {
        matches!(self, Motion::Fixed { .. })
    }

    /// Validates the parameters; `name` prefixes parameter names in errors.
    pub fn validate(&self, name: &str) -> Result<()> {
        match self {
            Motion::Fixed { position } => {
                check_finite(&format!("{name}.position[0]"), position[0], "m")?;
                check_finite(&format!("{name}.position[1]"), position[1], "m")
            }
            Motion::Harmonic {
                offset,
                amplitude,
                frequency,
                phase,
            } => {
                for k in 0..2 {
                    check_finite(&format!("{name}.offset[{k}]"), offset[k], "m")?;
                    check_finite(&format!("{name}.amplitude[{k}]"), amplitude[k], "m")?;
                }
                check_non_negative(&format!("{name}.frequency"), *frequency, "Hz")?;
                check_finite(&format!("{name}.phase"), *phase, "rad")
            }
            Motion::Tabulated(_) => Ok(()),
        }
    }
}

/// The segment of the strictly increasing sample times `time` (at least two) that holds `t`, s,
/// and the fraction of the way through it, clamped to [0, 1]: values held outside the table.
#[inline]
pub(crate) fn segment(time: &[f64], t: f64) -> (usize, f64) {
    let n = time.len();
    let i = match time.partition_point(|&x| x <= t) {
        0 => 0,
        k if k >= n => n - 2,
        k => k - 1,
    };
    (i, ((t - time[i]) / (time[i + 1] - time[i])).clamp(0.0, 1.0))
}

/// Every sample of `a` finite and at most [`MAX_MAGNITUDE`](crate::error::MAX_MAGNITUDE) in magnitude (SI), else an error
/// naming `name.label[i]`.
fn check_samples(name: &str, label: &str, a: &[[f64; 2]]) -> Result<()> {
    match a.iter().position(|p| !(in_range(p[0]) && in_range(p[1]))) {
        None => Ok(()),
        Some(i) => Err(Error::param(
            format!("{name}.{label}[{i}]"),
            format!("[{}, {}]", a[i][0], a[i][1]),
            "finite values of magnitude at most 1e75 (SI)",
        )),
    }
}
