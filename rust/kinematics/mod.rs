//! Nominal (rigid-body) kinematics of link frames.
//!
//! In the floating frame of reference formulation every flexible link carries a frame whose motion
//! is prescribed; the elastic displacements are measured in it. This module computes that nominal
//! motion:
//!
//! * [`FrameState`]: origin, angle and their first two time derivatives at one instant, with the
//!   rigid-body kinematics of material points ([`FrameState::point`]);
//! * [`Rotation`]: prescribed angle drivers (fixed, constant rate, Kane's smooth spin-up,
//!   harmonic, tabulated);
//! * [`FrameKinematics`]: anything that yields a [`FrameState`] at time `t`, implemented by
//!   [`RotatingFrame`] (a translating and rotating frame, e.g. a beam clamped to a spinning hub),
//!   [`SliderCrankFrame`] (a link of a [`SliderCrank`]) and [`FourBarFrame`] (a link of a
//!   [`FourBar`]).
//!
//! Conventions: SI units (m, s, rad); angles are counter-clockwise from the global +x axis; planar
//! vectors are `[x, y]` in global coordinates. Evaluation (`at`, `frame`, ...) never fails and
//! never panics: parameters are checked once, by the constructors (`new`, [`Rotation::tabulated`]),
//! by [`Rotation::validate`] and by [`FrameKinematics::check`] over a time span.

use std::f64::consts::{PI, TAU};
use std::sync::Arc;

use crate::error::{check_finite, check_non_negative, check_positive, Error, Result};
use crate::model::{Kinematics, Motion};

pub(crate) type Vec2 = [f64; 2];

/// Unit vector at `angle` (rad).
pub(crate) fn unit(angle: f64) -> Vec2 {
    let (s, c) = angle.sin_cos();
    [c, s]
}

/// The vector turned by +90 degrees (`S v` with `S = [[0, -1], [1, 0]]`).
pub(crate) fn perp(v: Vec2) -> Vec2 {
    [-v[1], v[0]]
}

/// z component of `a x b`.
pub(crate) fn cross(a: Vec2, b: Vec2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Linear combination `sum c_i v_i`.
pub(crate) fn comb<const N: usize>(terms: [(f64, Vec2); N]) -> Vec2 {
    terms
        .iter()
        .fold([0.0, 0.0], |acc, (c, v)| [acc[0] + c * v[0], acc[1] + c * v[1]])
}

/// Solves `x1 c1 + x2 c2 = r` by Cramer's rule.
pub(crate) fn solve2(c1: Vec2, c2: Vec2, r: Vec2) -> (f64, f64) {
    let det = cross(c1, c2);
    (cross(r, c2) / det, cross(c1, r) / det)
}

/// `name.field`, or just `field` when `name` is empty.
pub(crate) fn field(name: &str, field: &str) -> String {
    if name.is_empty() {
        field.to_string()
    } else {
        format!("{name}.{field}")
    }
}

// ---------------------------------------------------------------------------------------------
// Frame state
// ---------------------------------------------------------------------------------------------

/// The rigid-body state of a link frame at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameState {
    /// Global position of the frame origin, m.
    pub origin: [f64; 2],
    /// Global velocity of the frame origin, m/s.
    pub origin_vel: [f64; 2],
    /// Global acceleration of the frame origin, m/s^2.
    pub origin_acc: [f64; 2],
    /// Angle of the frame x axis from the global x axis, counter-clockwise, rad.
    pub angle: f64,
    /// Angular velocity, rad/s.
    pub rate: f64,
    /// Angular acceleration, rad/s^2.
    pub accel: f64,
}

impl FrameState {
    /// The frame whose origin moves as `origin` and whose angle, rate and acceleration are
    /// `(angle, rate, accel)` (rad, rad/s, rad/s^2).
    #[inline]
    pub fn at(origin: &Kinematics, (angle, rate, accel): (f64, f64, f64)) -> Self {
        FrameState {
            origin: origin.pos,
            origin_vel: origin.vel,
            origin_acc: origin.acc,
            angle,
            rate,
            accel,
        }
    }

    /// Rotation matrix `R = [[cos, -sin], [sin, cos]]` of the frame, row-major: its columns are the
    /// frame's x and y axes in global coordinates, so `global = origin + R local`.
    pub fn rotation(&self) -> [[f64; 2]; 2] {
        let (s, c) = self.angle.sin_cos();
        [[c, -s], [s, c]]
    }

    /// Global position (m), velocity (m/s) and acceleration (m/s^2) of the material point at
    /// `local` (m, frame coordinates) moving rigidly with the frame:
    /// `r = R local`, `pos = origin + r`, `vel = origin_vel + rate S r`,
    /// `acc = origin_acc + accel S r - rate^2 r`, with `S = [[0, -1], [1, 0]]`.
    pub fn local_point(&self, local: [f64; 2]) -> Kinematics {
        let rot = self.rotation();
        let r = [
            rot[0][0] * local[0] + rot[0][1] * local[1],
            rot[1][0] * local[0] + rot[1][1] * local[1],
        ];
        let sr = perp(r);
        let w2 = self.rate * self.rate;
        Kinematics {
            pos: comb([(1.0, self.origin), (1.0, r)]),
            vel: comb([(1.0, self.origin_vel), (self.rate, sr)]),
            acc: comb([(1.0, self.origin_acc), (self.accel, sr), (-w2, r)]),
        }
    }

    /// Global position (m), velocity (m/s) and acceleration (m/s^2) of the material point at
    /// distance `x` (m) along the frame's x axis, moving rigidly with the frame (see
    /// [`FrameState::local_point`]).
    pub fn point(&self, x: f64) -> Kinematics {
        self.local_point([x, 0.0])
    }
}

// ---------------------------------------------------------------------------------------------
// Angle drivers
// ---------------------------------------------------------------------------------------------

/// A prescribed angle `phi(t)` (rad) with its rate (rad/s) and acceleration (rad/s^2).
///
/// Build the `Tabulated` variant with [`Rotation::tabulated`]; check the other variants' numbers
/// with [`Rotation::validate`] (evaluating invalid parameters does not panic, it may give
/// non-finite values).
#[derive(Debug, Clone, PartialEq)]
pub enum Rotation {
    /// At rest at `angle`.
    Fixed {
        /// Angle, rad.
        angle: f64,
    },
    /// `phi = angle0 + rate t`.
    Constant {
        /// Angle at t = 0, rad.
        angle0: f64,
        /// Angular velocity, rad/s.
        rate: f64,
    },
    /// Kane, Ryan & Banerjee (1987) smooth spin-up from rest to `final_rate` W over `ramp_time` T:
    /// for `0 <= t < T`, `rate = (W/T) (t - (T/(2 pi)) sin(2 pi t/T))`,
    /// `phi = angle0 + (W/T) (t^2/2 + (T/(2 pi))^2 (cos(2 pi t/T) - 1))`,
    /// `accel = (W/T) (1 - cos(2 pi t/T))`; for `t >= T`, `rate = W`, `accel = 0`,
    /// `phi = angle0 + W T/2 + W (t - T)`. At rest at `angle0` for `t < 0`.
    SpinUp {
        /// Angle at t = 0, rad.
        angle0: f64,
        /// Angular velocity reached at the end of the ramp, rad/s.
        final_rate: f64,
        /// Duration of the ramp, s (> 0).
        ramp_time: f64,
    },
    /// `phi = mean + amplitude sin(2 pi frequency t + phase)`.
    Harmonic {
        /// Mean angle, rad.
        mean: f64,
        /// Amplitude, rad.
        amplitude: f64,
        /// Frequency, Hz (>= 0).
        frequency: f64,
        /// Phase, rad.
        phase: f64,
    },
    /// Tabulated angle, interpolated by Hermite polynomials (quintic with accelerations given,
    /// else cubic; see [`AngleTable`]).
    Tabulated(AngleTable),
}

/// Samples of a tabulated angle: times (s), angles (rad), rates (rad/s) and accelerations
/// (rad/s^2). Between two samples the angle is the quintic Hermite polynomial through their
/// angles, rates and accelerations, and the rate and acceleration are its derivatives
/// (`crate::model::motion::quintic_hermite`: consistent, twice continuously differentiable,
/// `O(h^6)`); a table built without accelerations takes the cubic through angles and rates
/// (`crate::model::motion::cubic_hermite`); outside the table the end sample's values are
/// held. Build it with [`AngleTable::new`] or [`Rotation::tabulated`].
#[derive(Debug, Clone, PartialEq)]
pub struct AngleTable {
    time: Vec<f64>,
    angle: Vec<f64>,
    rate: Vec<f64>,
    /// The accelerations when given (quintic interpolation); None: cubic through angles and
    /// rates.
    accel: Option<Vec<f64>>,
}

/// [`crate::model::motion::gradient`] of scalar samples.
pub(crate) fn gradient(t: &[f64], y: &[f64]) -> Vec<f64> {
    let y: Vec<[f64; 1]> = y.iter().map(|&v| [v]).collect();
    crate::model::motion::gradient(t, &y).into_iter().map(|[v]| v).collect()
}

impl AngleTable {
    /// Builds a table from strictly increasing finite times (s) and finite angles (rad); rates
    /// (rad/s) and accelerations (rad/s^2) are derived by central differences (one-sided at the
    /// ends) when not given. `name` prefixes parameter names in errors (`name.time[3]`; no prefix
    /// when empty).
    ///
    /// Fails with [`Error::InvalidParameter`] for fewer than 2 samples, non-finite or
    /// non-increasing times, arrays of different lengths, non-finite values or values beyond
    /// 1e75, or samples closer than their rates allow
    /// (`check_spacing`, naming `name.time[i]`).
    pub fn new(
        name: &str,
        time: Vec<f64>,
        angle: Vec<f64>,
        rate: Option<Vec<f64>>,
        accel: Option<Vec<f64>>,
    ) -> Result<Self> {
        let n = time.len();
        if n < 2 {
            return Err(Error::param(
                field(name, "time"),
                format!("{n} samples"),
                "at least 2 samples",
            ));
        }
        if !time[0].is_finite() {
            return Err(Error::param(field(name, "time[0]"), time[0], "finite, s"));
        }
        for (i, w) in time.windows(2).enumerate() {
            if !(w[1].is_finite() && w[1] > w[0]) {
                return Err(Error::param(
                    field(name, &format!("time[{}]", i + 1)),
                    w[1],
                    "finite and strictly increasing, s",
                ));
            }
        }
        for (label, unit, values) in [
            ("angle", "rad", Some(&angle)),
            ("rate", "rad/s", rate.as_ref()),
            ("accel", "rad/s^2", accel.as_ref()),
        ] {
            if let Some(v) = values {
                if v.len() != n {
                    return Err(Error::param(
                        field(name, label),
                        format!("{} samples", v.len()),
                        format!("as many samples as time ({n})"),
                    ));
                }
                check_angle_samples(name, label, v, unit)?;
            }
        }
        let rate = rate.unwrap_or_else(|| gradient(&time, &angle));
        // derived by differences: samples too close for their angles give rates beyond range
        // (the rates' differences bound the cubic's accelerations, which are not kept)
        check_angle_samples(name, "rate (from the angles)", &rate, "rad/s")?;
        if accel.is_none() {
            check_angle_samples(name, "accel (from the angles)", &gradient(&time, &rate), "rad/s^2")?;
        }
        crate::model::motion::check_spacing(
            &time,
            1,
            |i, _| angle[i],
            |i, _| rate[i],
            |i| field(name, &format!("time[{i}]")),
            "rad",
        )?;
        Ok(AngleTable {
            time,
            angle,
            rate,
            accel,
        })
    }

    /// First tabulated time, s.
    pub fn start_time(&self) -> f64 {
        self.time[0]
    }

    /// Last tabulated time, s.
    pub fn end_time(&self) -> f64 {
        self.time[self.time.len() - 1]
    }

    /// The sample times, s.
    pub fn times(&self) -> &[f64] {
        &self.time
    }

    /// `(angle, rate, accel)` at `t` (s): the Hermite interpolant of the interval holding `t`
    /// (quintic with given accelerations, else cubic), held outside the table.
    fn eval(&self, t: f64) -> (f64, f64, f64) {
        let (i, s) = crate::model::motion::segment(&self.time, t);
        let two = |a: &[f64]| [a[i], a[i + 1]];
        let h = self.time[i + 1] - self.time[i];
        let accel = self.accel.as_deref().map(two);
        crate::model::motion::hermite(h, s, two(&self.angle), two(&self.rate), accel)
    }
}

impl Rotation {
    /// A tabulated angle: strictly increasing times (s), angles (rad), and optionally rates
    /// (rad/s) and accelerations (rad/s^2), derived by central differences when `None`.
    ///
    /// Fails with [`Error::InvalidParameter`] naming `time`, `angle`, `rate` or `accel` (see
    /// [`AngleTable::new`]).
    pub fn tabulated(time: Vec<f64>, angle: Vec<f64>, rate: Option<Vec<f64>>, accel: Option<Vec<f64>>) -> Result<Self> {
        AngleTable::new("", time, angle, rate, accel).map(Rotation::Tabulated)
    }

    /// `(angle, rate, accel)` at time `t` (s): rad, rad/s, rad/s^2.
    #[inline]
    pub fn at(&self, t: f64) -> (f64, f64, f64) {
        match self {
            Rotation::Fixed { angle } => (*angle, 0.0, 0.0),
            Rotation::Constant { angle0, rate } => (angle0 + rate * t, *rate, 0.0),
            Rotation::SpinUp {
                angle0,
                final_rate,
                ramp_time,
            } => {
                let (w, tr) = (*final_rate, *ramp_time);
                if t <= 0.0 {
                    (*angle0, 0.0, 0.0)
                } else if t < tr {
                    let k = TAU / tr;
                    let g = w / tr;
                    let (s, c) = (k * t).sin_cos();
                    // cos x - 1 = -2 sin^2(x/2), without the cancellation near t = 0.
                    let half = (0.5 * k * t).sin();
                    let angle = angle0 + g * (0.5 * t * t - 2.0 * half * half / (k * k));
                    (angle, g * (t - s / k), g * (1.0 - c))
                } else {
                    (angle0 + w * (t - 0.5 * tr), w, 0.0)
                }
            }
            Rotation::Harmonic {
                mean,
                amplitude,
                frequency,
                phase,
            } => {
                let om = TAU * frequency;
                let (s, c) = (om * t + phase).sin_cos();
                (mean + amplitude * s, amplitude * om * c, -amplitude * om * om * s)
            }
            Rotation::Tabulated(table) => table.eval(t),
        }
    }

    /// True when the rate and acceleration are identically zero (the angle never changes):
    /// `Fixed`, a zero `Constant` rate or spin-up `final_rate`, a zero harmonic amplitude or
    /// frequency, a table whose angles are all equal and whose rates and accelerations are all zero.
    pub fn is_fixed(&self) -> bool {
        match self {
            Rotation::Fixed { .. } => true,
            Rotation::Constant { rate, .. } => *rate == 0.0,
            Rotation::SpinUp { final_rate, .. } => *final_rate == 0.0,
            Rotation::Harmonic {
                amplitude, frequency, ..
            } => *amplitude == 0.0 || *frequency == 0.0,
            // the angles too: the cubic through equal-rate samples of different angles turns
            Rotation::Tabulated(table) => {
                table.angle.windows(2).all(|w| w[0] == w[1])
                    && table.rate.iter().chain(table.accel.iter().flatten()).all(|&x| x == 0.0)
            }
        }
    }

    /// The rate (rad/s) when it is the same at every time with zero angular acceleration:
    /// `Some(rate)` for `Constant`, `Some(0.0)` for a rotation that never changes
    /// ([`Rotation::is_fixed`]), `None` otherwise (the rate may vary).
    pub fn constant_rate(&self) -> Option<f64> {
        match self {
            Rotation::Constant { rate, .. } => Some(*rate),
            r if r.is_fixed() => Some(0.0),
            _ => None,
        }
    }

    /// Checks the parameters: every number finite, `ramp_time > 0`, `frequency >= 0`. A table is
    /// valid by construction. `name` prefixes parameter names in errors (`name.ramp_time`).
    ///
    /// Fails with [`Error::InvalidParameter`] naming the field and its allowed range.
    pub fn validate(&self, name: &str) -> Result<()> {
        let f = |s: &str| field(name, s);
        match self {
            Rotation::Fixed { angle } => check_finite(&f("angle"), *angle, "rad"),
            Rotation::Constant { angle0, rate } => {
                check_finite(&f("angle0"), *angle0, "rad")?;
                check_finite(&f("rate"), *rate, "rad/s")
            }
            Rotation::SpinUp {
                angle0,
                final_rate,
                ramp_time,
            } => {
                check_finite(&f("angle0"), *angle0, "rad")?;
                check_finite(&f("final_rate"), *final_rate, "rad/s")?;
                check_positive(&f("ramp_time"), *ramp_time, "s")
            }
            Rotation::Harmonic {
                mean,
                amplitude,
                frequency,
                phase,
            } => {
                check_finite(&f("mean"), *mean, "rad")?;
                check_finite(&f("amplitude"), *amplitude, "rad")?;
                check_non_negative(&f("frequency"), *frequency, "Hz")?;
                check_finite(&f("phase"), *phase, "rad")
            }
            Rotation::Tabulated(_) => Ok(()),
        }
    }

    /// Checks that a table covers `[0, t_end]` (s); the other variants cover every time.
    ///
    /// Fails with [`Error::InvalidParameter`] naming `name.time`.
    pub fn covers(&self, name: &str, t_end: f64) -> Result<()> {
        match self {
            Rotation::Tabulated(table) if table.start_time() > 0.0 || table.end_time() < t_end => Err(Error::param(
                field(name, "time"),
                format!("[{}, {}] s", table.start_time(), table.end_time()),
                format!("a table covering [0, t_end = {t_end}] s"),
            )),
            _ => Ok(()),
        }
    }
}

/// Every value of `v` finite and at most [`crate::error::MAX_MAGNITUDE`] in magnitude, else an
/// error naming `name.label[i]`.
fn check_angle_samples(name: &str, label: &str, v: &[f64], unit: &str) -> Result<()> {
    match v
        .iter()
        .position(|x| !(x.is_finite() && x.abs() <= crate::error::MAX_MAGNITUDE))
    {
        None => Ok(()),
        Some(i) => Err(Error::param(
            field(name, &format!("{label}[{i}]")),
            v[i],
            format!("finite values of magnitude at most 1e75, {unit}"),
        )),
    }
}

// ---------------------------------------------------------------------------------------------
// Frame kinematics
// ---------------------------------------------------------------------------------------------

/// The prescribed (nominal, rigid-body) motion of a link frame or rigid body.
pub trait FrameKinematics: std::fmt::Debug + Send + Sync {
    /// The frame state at time `t` (s). Never fails; the values are meaningful where
    /// [`FrameKinematics::check`] passes.
    fn frame(&self, t: f64) -> FrameState;

    /// The frame state at `t` (s) with its rotation matrix `R` (row-major; its columns are the
    /// frame's axes in global coordinates, [`FrameState::rotation`]). The default takes `R` from
    /// the angle; a mechanism whose loop closure gives the angle's cosine and sine returns those,
    /// without the round trip through the angle (one `sin_cos` a call fewer in the Newton
    /// stepper's frame update).
    fn frame_rotation(&self, t: f64) -> (FrameState, [[f64; 2]; 2]) {
        let f = self.frame(t);
        (f, f.rotation())
    }

    /// Checks that the motion is defined over `[0, t_end]` (s): parameters, table coverage,
    /// closure of a mechanism's loop. `name` prefixes parameter names in errors.
    ///
    /// Fails with [`Error::InvalidParameter`] or [`Error::InvalidModel`]. The default accepts.
    fn check(&self, name: &str, t_end: f64) -> Result<()> {
        let _ = (name, t_end);
        Ok(())
    }

    /// Whether the frame may rotate (non-zero rate or angular acceleration at some time); used to
    /// switch rotation-dependent terms on automatically. The default, `true`, is conservative.
    fn rotates(&self) -> bool {
        true
    }

    /// Whether the frame origin may move (non-zero velocity or acceleration at some time). The
    /// default, `true`, is conservative.
    fn translates(&self) -> bool {
        true
    }

    /// The frame's rate (rad/s) when it is the same at every time with zero angular acceleration
    /// (a frame at rest or spinning steadily: the constant-rate stepper's condition), `None` when
    /// it may vary. The default, `None`, is conservative.
    fn constant_rate(&self) -> Option<f64> {
        None
    }

    /// The frame as a translation at a fixed angle: the origin's prescribed motion and the angle
    /// (rad), when the frame is exactly that (a translating frame of the constant stepper);
    /// `None` otherwise (the default).
    fn fixed_angle_translation(&self) -> Option<(&Motion, f64)> {
        None
    }
}

/// A frame whose origin translates by `origin` and which rotates by `rotation`, independently: for
/// example a beam clamped to a spinning hub (origin fixed at the hub centre, or on its rim).
#[derive(Debug, Clone, PartialEq)]
pub struct RotatingFrame {
    /// Prescribed translation of the frame origin (global, m).
    pub origin: Motion,
    /// Prescribed angle of the frame x axis (rad).
    pub rotation: Rotation,
}

impl RotatingFrame {
    /// A checked rotating frame: validates `origin` and `rotation` (errors name `origin.*` and
    /// `rotation.*`, [`Error::InvalidParameter`]). Table coverage is checked later, by
    /// [`FrameKinematics::check`].
    pub fn new(origin: Motion, rotation: Rotation) -> Result<Self> {
        origin.validate("origin")?;
        rotation.validate("rotation")?;
        Ok(RotatingFrame { origin, rotation })
    }
}

impl FrameKinematics for RotatingFrame {
    fn frame(&self, t: f64) -> FrameState {
        FrameState::at(&self.origin.at(t), self.rotation.at(t))
    }

    /// Validates `name.origin` and `name.rotation` and checks that tables cover `[0, t_end]`.
    fn check(&self, name: &str, t_end: f64) -> Result<()> {
        let origin = field(name, "origin");
        self.origin.validate(&origin)?;
        if let Motion::Tabulated(table) = &self.origin {
            if table.start_time() > 0.0 || table.end_time() < t_end {
                return Err(Error::param(
                    field(&origin, "time"),
                    format!("[{}, {}] s", table.start_time(), table.end_time()),
                    format!("a table covering [0, t_end = {t_end}] s"),
                ));
            }
        }
        let rotation = field(name, "rotation");
        self.rotation.validate(&rotation)?;
        self.rotation.covers(&rotation, t_end)
    }

    /// False when the rotation is fixed ([`Rotation::is_fixed`]).
    fn rotates(&self) -> bool {
        !self.rotation.is_fixed()
    }

    /// False when the origin is fixed ([`Motion::is_fixed`]).
    fn translates(&self) -> bool {
        !self.origin.is_fixed()
    }

    /// [`Rotation::constant_rate`] of the rotation (the origin's motion does not matter).
    fn constant_rate(&self) -> Option<f64> {
        self.rotation.constant_rate()
    }

    /// The origin's motion and the angle when the rotation is [`Rotation::Fixed`].
    fn fixed_angle_translation(&self) -> Option<(&Motion, f64)> {
        match self.rotation {
            Rotation::Fixed { angle } => Some((&self.origin, angle)),
            _ => None,
        }
    }
}

/// The last solved pose of a closed-loop mechanism and its time (the bits of `t`): the frames of
/// its links (and of a slider on its guide) ask for the same instant in turn, and each would solve
/// the loop closure again. The pose is a pure function of `t`, so a hit is bitwise the solve.
/// Behind a `Mutex` because the mechanism is shared (`Arc`) and `Sync`; a clone starts empty, and
/// two memos always compare equal (the mechanism's equality is its geometry and driver).
#[derive(Debug)]
pub(crate) struct PoseMemo<P>(std::sync::Mutex<Option<(u64, P)>>);

impl<P: Copy> PoseMemo<P> {
    /// The pose at `t`: the kept one when `t` is its time, else `solve(t)`, kept. A poisoned
    /// lock (a panic elsewhere while it was held) only skips the memo.
    pub(crate) fn get(&self, t: f64, solve: impl FnOnce(f64) -> P) -> P {
        self.with(t, solve, |p| *p)
    }

    /// What `read` takes from the pose at `t` (as [`Self::get`]), read in place: the pose is not
    /// copied out (a link's frame needs a few of its entries).
    #[inline]
    pub(crate) fn with<R>(&self, t: f64, solve: impl FnOnce(f64) -> P, read: impl FnOnce(&P) -> R) -> R {
        let key = t.to_bits();
        let Ok(mut last) = self.0.lock() else {
            return read(&solve(t));
        };
        match &*last {
            Some((k, p)) if *k == key => read(p),
            _ => {
                let p = solve(t);
                let r = read(&p);
                *last = Some((key, p));
                r
            }
        }
    }
}

impl<P> PoseMemo<P> {
    /// Whether the kept value is that of `t` (a poisoned lock: no).
    pub(crate) fn holds(&self, t: f64) -> bool {
        self.0
            .lock()
            .is_ok_and(|last| last.as_ref().is_some_and(|(k, _)| *k == t.to_bits()))
    }
}

impl<P> Default for PoseMemo<P> {
    fn default() -> Self {
        PoseMemo(std::sync::Mutex::new(None))
    }
}

impl<P> Clone for PoseMemo<P> {
    fn clone(&self) -> Self {
        PoseMemo::default()
    }
}

impl<P> PartialEq for PoseMemo<P> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

mod four_bar;
pub mod linkage;
mod slider_crank;
#[cfg(test)]
mod tests;

pub use four_bar::{FourBar, FourBarFrame, FourBarLink};
pub use slider_crank::{SliderCrank, SliderCrankFrame, SliderCrankLink};
