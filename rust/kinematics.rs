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

type Vec2 = [f64; 2];

/// Unit vector at `angle` (rad).
fn unit(angle: f64) -> Vec2 {
    let (s, c) = angle.sin_cos();
    [c, s]
}

/// The vector turned by +90 degrees (`S v` with `S = [[0, -1], [1, 0]]`).
fn perp(v: Vec2) -> Vec2 {
    [-v[1], v[0]]
}

/// z component of `a x b`.
fn cross(a: Vec2, b: Vec2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Linear combination `sum c_i v_i`.
fn comb<const N: usize>(terms: [(f64, Vec2); N]) -> Vec2 {
    terms
        .iter()
        .fold([0.0, 0.0], |acc, (c, v)| [acc[0] + c * v[0], acc[1] + c * v[1]])
}

/// Solves `x1 c1 + x2 c2 = r` by Cramer's rule.
fn solve2(c1: Vec2, c2: Vec2, r: Vec2) -> (f64, f64) {
    let det = cross(c1, c2);
    (cross(r, c2) / det, cross(c1, r) / det)
}

/// `name.field`, or just `field` when `name` is empty.
fn field(name: &str, field: &str) -> String {
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
    /// Tabulated angle, linearly interpolated (see [`AngleTable`]).
    Tabulated(AngleTable),
}

/// Samples of a tabulated angle: times (s), angles (rad), rates (rad/s) and accelerations
/// (rad/s^2). Angle, rate and acceleration are each interpolated linearly between samples and
/// held at the end values outside the table (so rate and acceleration are those of the table, not
/// the derivatives of the interpolated angle). Build it with [`AngleTable::new`] or
/// [`Rotation::tabulated`].
#[derive(Debug, Clone, PartialEq)]
pub struct AngleTable {
    time: Vec<f64>,
    angle: Vec<f64>,
    rate: Vec<f64>,
    accel: Vec<f64>,
}

/// [`crate::model::motion::gradient`] of scalar samples.
fn gradient(t: &[f64], y: &[f64]) -> Vec<f64> {
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
    /// non-increasing times, arrays of different lengths or non-finite values.
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
                if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                    return Err(Error::param(
                        field(name, &format!("{label}[{i}]")),
                        v[i],
                        format!("finite values, {unit}"),
                    ));
                }
            }
        }
        let rate = rate.unwrap_or_else(|| gradient(&time, &angle));
        let accel = accel.unwrap_or_else(|| gradient(&time, &rate));
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

    /// `(angle, rate, accel)` at `t` (s), linearly interpolated, held outside the table.
    fn eval(&self, t: f64) -> (f64, f64, f64) {
        let n = self.time.len();
        let i = match self.time.partition_point(|&x| x <= t) {
            0 => 0,
            k if k >= n => n - 2,
            k => k - 1,
        };
        let s = ((t - self.time[i]) / (self.time[i + 1] - self.time[i])).clamp(0.0, 1.0);
        let lerp = |a: &[f64]| a[i] + s * (a[i + 1] - a[i]);
        (lerp(&self.angle), lerp(&self.rate), lerp(&self.accel))
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
    /// frequency, a table whose rates and accelerations are all zero.
    pub fn is_fixed(&self) -> bool {
        match self {
            Rotation::Fixed { .. } => true,
            Rotation::Constant { rate, .. } => *rate == 0.0,
            Rotation::SpinUp { final_rate, .. } => *final_rate == 0.0,
            Rotation::Harmonic {
                amplitude, frequency, ..
            } => *amplitude == 0.0 || *frequency == 0.0,
            Rotation::Tabulated(table) => table.rate.iter().chain(&table.accel).all(|&x| x == 0.0),
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

// ---------------------------------------------------------------------------------------------
// Frame kinematics
// ---------------------------------------------------------------------------------------------

/// The prescribed (nominal, rigid-body) motion of a link frame or rigid body.
pub trait FrameKinematics: std::fmt::Debug + Send + Sync {
    /// The frame state at time `t` (s). Never fails; the values are meaningful where
    /// [`FrameKinematics::check`] passes.
    fn frame(&self, t: f64) -> FrameState;

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

    /// The frame as a translation at a fixed angle: the origin's prescribed motion and the angle
    /// (rad), when the frame is exactly that (a translating frame of the constant stepper);
    /// `None` otherwise (the default).
    fn fixed_angle_translation(&self) -> Option<(&Motion, f64)> {
        None
    }
}

/// Largest link length of the loop kinematics, m: their closed forms take products of up to four
/// lengths, which stay finite below this (1e75 m, far beyond any mechanism).
pub const MAX_LINK_LENGTH: f64 = 1e75;

/// A link length of a mechanism's loop: > 0 and at most [`MAX_LINK_LENGTH`].
fn check_link_length(name: &str, l: f64) -> Result<()> {
    check_positive(name, l, "m")?;
    if l > MAX_LINK_LENGTH {
        return Err(Error::param(name, l, format!("a length in (0, {MAX_LINK_LENGTH:e}] m")));
    }
    Ok(())
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
        let o = self.origin.at(t);
        let (angle, rate, accel) = self.rotation.at(t);
        FrameState {
            origin: o.pos,
            origin_vel: o.vel,
            origin_acc: o.acc,
            angle,
            rate,
            accel,
        }
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

    /// The origin's motion and the angle when the rotation is [`Rotation::Fixed`].
    fn fixed_angle_translation(&self) -> Option<(&Motion, f64)> {
        match self.rotation {
            Rotation::Fixed { angle } => Some((&self.origin, angle)),
            _ => None,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Slider-crank
// ---------------------------------------------------------------------------------------------

/// An (offset) slider-crank: crank pivot O at the global origin, crank O->A at the driven angle
/// `theta(t)`, rod A->B at angle `psi`, slider pin B on the straight guide `y = offset` (along
/// global +x), on the +x side of the crank: `sin psi = (offset - crank sin theta) / rod`,
/// `cos psi > 0`, so `psi` lies in (-pi/2, pi/2).
///
/// The rod is longer than `crank + |offset|` (checked by [`SliderCrank::new`]), so the crank turns
/// fully and every configuration is regular.
#[derive(Debug, Clone, PartialEq)]
pub struct SliderCrank {
    crank: f64,
    rod: f64,
    offset: f64,
    driver: Rotation,
}

/// Solved configuration of a slider-crank at one instant.
struct SliderCrankPose {
    theta: (f64, f64, f64),
    psi: (f64, f64, f64),
    pin_a: Kinematics,
    pin_b: Kinematics,
}

impl SliderCrank {
    /// A slider-crank with crank length `crank` (m), rod length `rod` (m), guide offset `offset`
    /// (m, the guide is the line `y = offset`) and crank angle driver `driver`.
    ///
    /// Fails with [`Error::InvalidParameter`] naming `crank` or `rod` (not finite and > 0 m),
    /// `offset` (not finite), `rod` again when `rod <= crank + |offset|` (the rod could not reach
    /// the guide at every crank angle), or `driver.*` (see [`Rotation::validate`]).
    pub fn new(crank: f64, rod: f64, offset: f64, driver: Rotation) -> Result<Self> {
        check_link_length("crank", crank)?;
        check_link_length("rod", rod)?;
        check_finite("offset", offset, "m")?;
        if offset.abs() > MAX_LINK_LENGTH {
            return Err(Error::param(
                "offset",
                offset,
                format!("|offset| <= {MAX_LINK_LENGTH:e} m"),
            ));
        }
        let reach = crank + offset.abs();
        if rod <= reach {
            return Err(Error::param(
                "rod",
                rod,
                format!("> crank + |offset| = {reach} m (the rod cannot reach the guide at every crank angle)"),
            ));
        }
        driver.validate("driver")?;
        Ok(SliderCrank {
            crank,
            rod,
            offset,
            driver,
        })
    }

    /// Crank length, m.
    pub fn crank(&self) -> f64 {
        self.crank
    }

    /// Rod length, m.
    pub fn rod(&self) -> f64 {
        self.rod
    }

    /// Height of the guide line `y = offset`, m.
    pub fn offset(&self) -> f64 {
        self.offset
    }

    /// The crank angle driver.
    pub fn driver(&self) -> &Rotation {
        &self.driver
    }

    fn pose(&self, t: f64) -> SliderCrankPose {
        let (a, l) = (self.crank, self.rod);
        let (th, w, al) = self.driver.at(t);
        let e = unit(th);
        let n = perp(e);
        let pin_a = Kinematics {
            pos: comb([(a, e)]),
            vel: comb([(a * w, n)]),
            acc: comb([(a * al, n), (-a * w * w, e)]),
        };
        // Loop closure, y component: a sin(theta) + l sin(psi) = offset, and its derivatives.
        let sp = ((self.offset - a * e[1]) / l).clamp(-1.0, 1.0);
        let cp = (1.0 - sp * sp).sqrt();
        let psi = sp.atan2(cp);
        let psi_d = -a * w * e[0] / (l * cp);
        let psi_dd = (-a * al * e[0] + a * w * w * e[1] + l * psi_d * psi_d * sp) / (l * cp);
        let pin_b = Kinematics {
            pos: [pin_a.pos[0] + l * cp, self.offset],
            vel: [pin_a.vel[0] - l * psi_d * sp, 0.0],
            acc: [pin_a.acc[0] - l * psi_dd * sp - l * psi_d * psi_d * cp, 0.0],
        };
        SliderCrankPose {
            theta: (th, w, al),
            psi: (psi, psi_d, psi_dd),
            pin_a,
            pin_b,
        }
    }

    /// Frame of the crank at `t` (s): origin at the pivot (0, 0), at rest; angle `theta(t)` of the
    /// driver, x axis from the pivot toward the crank pin A.
    pub fn crank_frame(&self, t: f64) -> FrameState {
        let (angle, rate, accel) = self.driver.at(t);
        FrameState {
            angle,
            rate,
            accel,
            ..FrameState::default()
        }
    }

    /// Frame of the rod at `t` (s): origin at the crank pin A (moving with it), angle `psi` with x
    /// axis from A toward the slider pin B; rate and acceleration exact, from differentiating the
    /// loop closure (`psi_dot = -crank theta_dot cos(theta) / (rod cos(psi))`, and so on).
    pub fn rod_frame(&self, t: f64) -> FrameState {
        let p = self.pose(t);
        FrameState {
            origin: p.pin_a.pos,
            origin_vel: p.pin_a.vel,
            origin_acc: p.pin_a.acc,
            angle: p.psi.0,
            rate: p.psi.1,
            accel: p.psi.2,
        }
    }

    /// Position (m), velocity (m/s) and acceleration (m/s^2) of the slider pin B at `t` (s).
    pub fn slider(&self, t: f64) -> Kinematics {
        self.pose(t).pin_b
    }

    /// Frame of the slider block at `t` (s): origin at B, axes parallel to the global axes (the
    /// guide is along global x, so the angle is 0 and the block does not rotate).
    pub fn slider_frame(&self, t: f64) -> FrameState {
        let b = self.slider(t);
        FrameState {
            origin: b.pos,
            origin_vel: b.vel,
            origin_acc: b.acc,
            ..FrameState::default()
        }
    }

    /// Crank angle, rate and acceleration at `t` (s) together with the rod's: `((theta,
    /// theta_dot, theta_ddot), (psi, psi_dot, psi_ddot))`, rad, rad/s, rad/s^2.
    pub fn angles(&self, t: f64) -> ((f64, f64, f64), (f64, f64, f64)) {
        let p = self.pose(t);
        (p.theta, p.psi)
    }
}

/// Which link of a [`SliderCrank`] a [`SliderCrankFrame`] follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliderCrankLink {
    /// [`SliderCrank::crank_frame`].
    Crank,
    /// [`SliderCrank::rod_frame`].
    Rod,
    /// [`SliderCrank::slider_frame`].
    Slider,
}

/// The frame of one link of a shared [`SliderCrank`], as a [`FrameKinematics`]. Several links of
/// one mechanism share the `Arc`, so they all follow the same driver.
#[derive(Debug, Clone)]
pub struct SliderCrankFrame {
    /// The mechanism.
    pub mechanism: Arc<SliderCrank>,
    /// The link whose frame this is.
    pub link: SliderCrankLink,
}

impl FrameKinematics for SliderCrankFrame {
    fn frame(&self, t: f64) -> FrameState {
        match self.link {
            SliderCrankLink::Crank => self.mechanism.crank_frame(t),
            SliderCrankLink::Rod => self.mechanism.rod_frame(t),
            SliderCrankLink::Slider => self.mechanism.slider_frame(t),
        }
    }

    /// Checks that a tabulated driver covers `[0, t_end]` (error names `name.driver.time`); the
    /// geometry was checked by [`SliderCrank::new`].
    fn check(&self, name: &str, t_end: f64) -> Result<()> {
        self.mechanism.driver.covers(&field(name, "driver"), t_end)
    }

    /// The crank and rod rotate unless the driver is fixed; the slider does not.
    fn rotates(&self) -> bool {
        self.link != SliderCrankLink::Slider && !self.mechanism.driver.is_fixed()
    }

    /// The rod's origin (crank pin) and the slider move unless the driver is fixed; the crank's
    /// origin is the fixed pivot.
    fn translates(&self) -> bool {
        self.link != SliderCrankLink::Crank && !self.mechanism.driver.is_fixed()
    }
}

// ---------------------------------------------------------------------------------------------
// Four-bar
// ---------------------------------------------------------------------------------------------

/// Relative tolerance (of `coupler + rocker`) within which `|A - O4|` counts as reaching a closure
/// bound: there the coupler and rocker are collinear (a dead-centre position) and their rates are
/// undefined.
const DEAD_CENTRE_TOL: f64 = 1e-9;

/// Number of uniform time samples of the crank angle in [`FourBar::check`] (plus the driver's
/// extremes and the crank angles that are multiples of pi, where `|A - O4|` is extremal).
const CHECK_SAMPLES: usize = 2000;

/// A four-bar linkage: ground pivots O2 = (0, 0) and O4 = (`ground`, 0); crank O2->A at the driven
/// angle `theta2(t)`; coupler A->B at `theta3`; rocker O4->B at `theta4`. B is an intersection of
/// the circle of radius `coupler` about A with the circle of radius `rocker` about O4:
///
/// * `branch = +1`: B to the left of the directed line from A to O4, i.e. the transmission angle
///   `theta4 - theta3` lies in (0, pi). This is the *open* circuit (Norton's "open"
///   configuration): with the crank above the ground line, the quadrilateral O2-A-B-O4 does not
///   cross itself;
/// * `branch = -1`: the mirror image of B about the line A-O4, the *crossed* circuit.
///
/// The branch is kept for all `t`. The angles `theta3` and `theta4` are continuous in time (not
/// reduced to (-pi, pi]): they follow the crank's turns when the crank is longer than the ground.
/// Rates and accelerations are exact, from the differentiated loop closure
/// `crank e(theta2) + coupler e(theta3) = ground e_x + rocker e(theta4)`.
///
/// Where the loop does not close, the frames are those of the nearest collinear configuration and
/// meaningless; [`FourBar::check`] reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct FourBar {
    ground: f64,
    crank: f64,
    coupler: f64,
    rocker: f64,
    branch: f64,
    driver: Rotation,
}

/// Solved configuration of a four-bar at one instant: angles, rates, accelerations of crank (2),
/// coupler (3) and rocker (4), and the crank pin A.
struct FourBarPose {
    th: [f64; 3],
    w: [f64; 3],
    al: [f64; 3],
    pin_a: Kinematics,
}

impl FourBar {
    /// A four-bar with link lengths `ground`, `crank`, `coupler`, `rocker` (m), assembly `branch`
    /// (+1 open, -1 crossed; see [`FourBar`]) and crank angle driver `driver`.
    ///
    /// Fails with [`Error::InvalidParameter`] naming `ground`, `crank`, `coupler` or `rocker` (not
    /// finite and > 0 m), `branch` (not exactly +1 or -1) or `driver.*` (see
    /// [`Rotation::validate`]). Whether the loop closes along the driver's motion is checked by
    /// [`FourBar::check`].
    pub fn new(ground: f64, crank: f64, coupler: f64, rocker: f64, branch: f64, driver: Rotation) -> Result<Self> {
        for (name, l) in [
            ("ground", ground),
            ("crank", crank),
            ("coupler", coupler),
            ("rocker", rocker),
        ] {
            check_link_length(name, l)?;
        }
        if branch != 1.0 && branch != -1.0 {
            return Err(Error::param("branch", branch, "+1 (open) or -1 (crossed)"));
        }
        driver.validate("driver")?;
        Ok(FourBar {
            ground,
            crank,
            coupler,
            rocker,
            branch,
            driver,
        })
    }

    /// Distance between the ground pivots, m.
    pub fn ground(&self) -> f64 {
        self.ground
    }

    /// Crank length, m.
    pub fn crank(&self) -> f64 {
        self.crank
    }

    /// Coupler length, m.
    pub fn coupler(&self) -> f64 {
        self.coupler
    }

    /// Rocker length, m.
    pub fn rocker(&self) -> f64 {
        self.rocker
    }

    /// Assembly branch, +1 (open) or -1 (crossed).
    pub fn branch(&self) -> f64 {
        self.branch
    }

    /// The crank angle driver.
    pub fn driver(&self) -> &Rotation {
        &self.driver
    }

    /// `|A - O4|` at crank angle `theta2`, m.
    fn diagonal(&self, theta2: f64) -> f64 {
        let e = unit(theta2);
        (self.ground - self.crank * e[0]).hypot(self.crank * e[1])
    }

    fn pose(&self, t: f64) -> FourBarPose {
        let (g, a2, a3, a4, k) = (self.ground, self.crank, self.coupler, self.rocker, self.branch);
        let (th2, w2, al2) = self.driver.at(t);
        let e2 = unit(th2);
        let a = comb([(a2, e2)]);
        let d = [g - a[0], -a[1]];
        let dist = d[0].hypot(d[1]);
        // Direction of D = O4 - A, continuous in time: when the crank is shorter than the ground, D
        // stays in the right half-plane; otherwise measure it from the direction A->O2, from which
        // it deviates by less than pi/2, so that it turns with the crank.
        let phi = if a2 < g {
            d[1].atan2(d[0])
        } else {
            th2 + PI + (g * e2[1]).atan2(a2 - g * e2[0])
        };
        // B in the frame (D, S D) based at A: (p, branch h).
        let p = if dist > 0.0 {
            ((a3 * a3 - a4 * a4 + dist * dist) / (2.0 * dist)).clamp(-a3, a3)
        } else {
            a3
        };
        let h = (a3 * a3 - p * p).max(0.0).sqrt();
        let th3 = phi + k * h.atan2(p);
        let th4 = phi + k * h.atan2(p - dist);
        let (e3, e4) = (unit(th3), unit(th4));
        let (n2, n3, n4) = (perp(e2), perp(e3), perp(e4));
        // d/dt of the closure: a2 w2 S e2 + a3 w3 S e3 - a4 w4 S e4 = 0.
        let (c3, c4) = (comb([(a3, n3)]), comb([(-a4, n4)]));
        let (w3, w4) = solve2(c3, c4, comb([(-a2 * w2, n2)]));
        // d2/dt2: sum of +-a_i (al_i S e_i - w_i^2 e_i) = 0.
        let rhs = comb([
            (-a2 * al2, n2),
            (a2 * w2 * w2, e2),
            (a3 * w3 * w3, e3),
            (-a4 * w4 * w4, e4),
        ]);
        let (al3, al4) = solve2(c3, c4, rhs);
        FourBarPose {
            th: [th2, th3, th4],
            w: [w2, w3, w4],
            al: [al2, al3, al4],
            pin_a: Kinematics {
                pos: a,
                vel: comb([(a2 * w2, n2)]),
                acc: comb([(a2 * al2, n2), (-a2 * w2 * w2, e2)]),
            },
        }
    }

    /// Frame of the crank at `t` (s): origin at O2 = (0, 0), at rest; angle `theta2(t)` of the
    /// driver, x axis toward the crank pin A.
    pub fn crank_frame(&self, t: f64) -> FrameState {
        let (angle, rate, accel) = self.driver.at(t);
        FrameState {
            angle,
            rate,
            accel,
            ..FrameState::default()
        }
    }

    /// Frame of the coupler at `t` (s): origin at the crank pin A (moving with it), angle
    /// `theta3`, x axis toward B.
    pub fn coupler_frame(&self, t: f64) -> FrameState {
        let p = self.pose(t);
        FrameState {
            origin: p.pin_a.pos,
            origin_vel: p.pin_a.vel,
            origin_acc: p.pin_a.acc,
            angle: p.th[1],
            rate: p.w[1],
            accel: p.al[1],
        }
    }

    /// Frame of the rocker at `t` (s): origin at O4 = (ground, 0), at rest; angle `theta4`, x
    /// axis toward B.
    pub fn rocker_frame(&self, t: f64) -> FrameState {
        let p = self.pose(t);
        FrameState {
            origin: [self.ground, 0.0],
            angle: p.th[2],
            rate: p.w[2],
            accel: p.al[2],
            ..FrameState::default()
        }
    }

    /// Checks that the loop closes, away from dead-centre positions, at every crank angle the
    /// driver reaches over `[0, t_end]` (s): `|coupler - rocker| < |A - O4| < coupler + rocker`
    /// (up to a relative margin of 1e-9). The crank angle is sampled at 2000 uniform times plus
    /// the driver's extremes (harmonic peaks, table samples), and between samples at the
    /// multiples of pi, where `|A - O4|` is extremal; as the driven angle is continuous, this
    /// covers every angle reached (the time reported for an angle between samples is interpolated).
    ///
    /// Fails with [`Error::InvalidParameter`] naming `t_end` (not finite and >= 0 s) or
    /// `name.driver.time` (a table not covering `[0, t_end]`), and with [`Error::InvalidModel`]
    /// when the loop does not close or reaches a dead-centre position, giving the crank angle, the
    /// time, the violated bound and a Grashof hint.
    pub fn check(&self, name: &str, t_end: f64) -> Result<()> {
        check_non_negative("t_end", t_end, "s")?;
        self.driver.covers(&field(name, "driver"), t_end)?;
        let mut prev: Option<(f64, f64)> = None;
        for t in self.check_times(t_end) {
            let th = self.driver.at(t).0;
            if let Some((t0, th0)) = prev {
                for crit in pi_multiples_between(th0, th) {
                    let tc = t0 + (t - t0) * (crit - th0) / (th - th0);
                    self.check_angle(name, crit, tc)?;
                }
            }
            self.check_angle(name, th, t)?;
            prev = Some((t, th));
        }
        Ok(())
    }

    /// Sorted times at which [`FourBar::check`] samples the driver.
    fn check_times(&self, t_end: f64) -> Vec<f64> {
        let mut ts: Vec<f64> = (0..=CHECK_SAMPLES)
            .map(|i| t_end * i as f64 / CHECK_SAMPLES as f64)
            .collect();
        match &self.driver {
            Rotation::Harmonic {
                amplitude,
                frequency,
                phase,
                ..
            } if *frequency > 0.0 && *amplitude != 0.0 => {
                // Extremes at 2 pi f t + phase = pi/2 + j pi; all extreme values occur within one
                // period.
                let om = TAU * frequency;
                let horizon = t_end.min(1.0 / frequency);
                let mut j = ((phase - 0.5 * PI) / PI).ceil();
                for _ in 0..4 {
                    let t = (0.5 * PI + j * PI - phase) / om;
                    if t > horizon {
                        break;
                    }
                    if t >= 0.0 {
                        ts.push(t);
                    }
                    j += 1.0;
                }
            }
            Rotation::Tabulated(table) => {
                ts.extend(table.times().iter().copied().filter(|&x| (0.0..=t_end).contains(&x)))
            }
            _ => {}
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup();
        ts
    }

    fn check_angle(&self, name: &str, theta2: f64, t: f64) -> Result<()> {
        let d = self.diagonal(theta2);
        let lo = (self.coupler - self.rocker).abs();
        let hi = self.coupler + self.rocker;
        let tol = DEAD_CENTRE_TOL * hi;
        let prefix = if name.is_empty() {
            String::new()
        } else {
            format!("{name}: ")
        };
        if d < lo - tol || d > hi + tol {
            return Err(Error::InvalidModel {
                message: format!(
                    "{prefix}the four-bar does not close at crank angle {theta2} rad (t = {t} s): \
                     |coupler - rocker| <= |A - O4| <= coupler + rocker violated ({lo} <= {d} <= {hi} m); {}",
                    self.grashof_hint()
                ),
            });
        }
        if d <= lo + tol || d >= hi - tol {
            let (bound, which) = if d <= lo + tol {
                (lo, "|coupler - rocker|")
            } else {
                (hi, "coupler + rocker")
            };
            return Err(Error::InvalidModel {
                message: format!(
                    "{prefix}the four-bar reaches a dead-centre position at crank angle {theta2} rad (t = {t} s): \
                     |A - O4| = {d} m equals {which} = {bound} m, so the coupler and rocker are collinear and their \
                     rates are undefined; {}",
                    self.grashof_hint()
                ),
            });
        }
        Ok(())
    }

    /// Grashof classification and the crank angles at which the loop closes, in words.
    fn grashof_hint(&self) -> String {
        let (g, a2, a3, a4) = (self.ground, self.crank, self.coupler, self.rocker);
        let mut l = [g, a2, a3, a4];
        l.sort_by(f64::total_cmp);
        let (sl, pq) = (l[0] + l[3], l[1] + l[2]);
        let class = if sl > pq * (1.0 + 1e-12) {
            format!("non-Grashof (s + l = {sl} m > p + q = {pq} m): no link turns fully, the crank can only rock")
        } else if sl >= pq * (1.0 - 1e-12) {
            format!("change-point Grashof (s + l = p + q = {pq} m): the links pass through dead-centre positions")
        } else if a2 == l[0] || g == l[0] {
            format!(
                "Grashof (s + l = {sl} m < p + q = {pq} m) with the crank or ground shortest: the crank turns fully"
            )
        } else {
            format!(
                "Grashof (s + l = {sl} m < p + q = {pq} m) but the coupler or rocker is the shortest link: \
                 the crank can only rock"
            )
        };
        // |A - O4|^2 = crank^2 + ground^2 - 2 crank ground cos(theta2) must lie in [lo^2, hi^2].
        let (lo, hi) = ((a3 - a4).abs(), a3 + a4);
        let base = a2 * a2 + g * g;
        let cos_min = (base - hi * hi) / (2.0 * a2 * g);
        let cos_max = (base - lo * lo) / (2.0 * a2 * g);
        let range = if cos_min > 1.0 || cos_max < -1.0 {
            "the loop closes at no crank angle".to_string()
        } else {
            let (from, to) = (cos_max.min(1.0).acos(), cos_min.max(-1.0).acos());
            format!("the loop closes only for crank angles with |theta2| (mod 2 pi) in [{from}, {to}] rad")
        };
        format!("{class}; {range}")
    }
}

/// The first (at most two) multiples of pi strictly between `a` and `b`, in the order met going
/// from `a` to `b` (one even and one odd multiple: `|A - O4|` depends only on the parity).
fn pi_multiples_between(a: f64, b: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(2);
    if a < b {
        let mut j = (a / PI).floor() + 1.0;
        while out.len() < 2 && j * PI < b {
            out.push(j * PI);
            j += 1.0;
        }
    } else if b < a {
        let mut j = (a / PI).ceil() - 1.0;
        while out.len() < 2 && j * PI > b {
            out.push(j * PI);
            j -= 1.0;
        }
    }
    out
}

/// Which link of a [`FourBar`] a [`FourBarFrame`] follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FourBarLink {
    /// [`FourBar::crank_frame`].
    Crank,
    /// [`FourBar::coupler_frame`].
    Coupler,
    /// [`FourBar::rocker_frame`].
    Rocker,
}

/// The frame of one link of a shared [`FourBar`], as a [`FrameKinematics`]. Several links of one
/// mechanism share the `Arc`, so they all follow the same driver.
#[derive(Debug, Clone)]
pub struct FourBarFrame {
    /// The mechanism.
    pub mechanism: Arc<FourBar>,
    /// The link whose frame this is.
    pub link: FourBarLink,
}

impl FrameKinematics for FourBarFrame {
    fn frame(&self, t: f64) -> FrameState {
        match self.link {
            FourBarLink::Crank => self.mechanism.crank_frame(t),
            FourBarLink::Coupler => self.mechanism.coupler_frame(t),
            FourBarLink::Rocker => self.mechanism.rocker_frame(t),
        }
    }

    /// [`FourBar::check`]: loop closure over `[0, t_end]` and table coverage.
    fn check(&self, name: &str, t_end: f64) -> Result<()> {
        self.mechanism.check(name, t_end)
    }

    /// Every link rotates unless the driver is fixed.
    fn rotates(&self) -> bool {
        !self.mechanism.driver.is_fixed()
    }

    /// Only the coupler's origin (the crank pin) moves, unless the driver is fixed; crank and
    /// rocker frames sit on the ground pivots.
    fn translates(&self) -> bool {
        self.link == FourBarLink::Coupler && !self.mechanism.driver.is_fixed()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Table;

    // Finite-difference checks. Central differences with step h have truncation error
    // ~ h^2 |f'''| / 6 and round-off ~ eps |f| / h. The motions below have time scales of
    // 0.05 s or more (rates <= ~20 rad/s, frequencies <= 2 Hz), so with h = 1e-5 s the truncation
    // error is ~ (20 * 1e-5)^2 / 6 ~ 1e-8 relative and the round-off ~ 1e-16 / 1e-5 ~ 1e-11
    // relative: a tolerance of 1e-6 relative to the quantity's magnitude (over the whole run, so
    // that zero crossings do not demand absolute precision) leaves two orders of margin both ways.
    const H: f64 = 1e-5;
    const FD_TOL: f64 = 1e-6;

    fn assert_close(label: &str, t: f64, got: f64, want: f64, scale: f64) {
        let tol = FD_TOL * want.abs().max(scale).max(1e-12);
        assert!(
            (got - want).abs() <= tol,
            "{label} at t = {t}: finite difference {got} vs exact {want} (tol {tol})"
        );
    }

    fn times(t0: f64, t1: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| t0 + (t1 - t0) * i as f64 / (n - 1) as f64).collect()
    }

    fn max_abs(v: impl Iterator<Item = f64>) -> f64 {
        v.fold(0.0, |m, x| m.max(x.abs()))
    }

    /// Checks rate/accel of `(angle, rate, accel)` against central differences.
    fn check_angles(label: &str, f: impl Fn(f64) -> (f64, f64, f64), ts: &[f64]) {
        let rs = max_abs(ts.iter().map(|&t| f(t).1));
        let as_ = max_abs(ts.iter().map(|&t| f(t).2));
        for &t in ts {
            let (p, m, x) = (f(t + H), f(t - H), f(t));
            assert_close(&format!("{label} rate"), t, (p.0 - m.0) / (2.0 * H), x.1, rs);
            assert_close(&format!("{label} accel"), t, (p.1 - m.1) / (2.0 * H), x.2, as_);
        }
    }

    /// Checks a point's velocity/acceleration against central differences.
    fn check_point(label: &str, f: impl Fn(f64) -> Kinematics, ts: &[f64]) {
        let vs = max_abs(ts.iter().flat_map(|&t| f(t).vel));
        let acs = max_abs(ts.iter().flat_map(|&t| f(t).acc));
        for &t in ts {
            let (p, m, x) = (f(t + H), f(t - H), f(t));
            for k in 0..2 {
                assert_close(
                    &format!("{label} vel[{k}]"),
                    t,
                    (p.pos[k] - m.pos[k]) / (2.0 * H),
                    x.vel[k],
                    vs,
                );
                assert_close(
                    &format!("{label} acc[{k}]"),
                    t,
                    (p.vel[k] - m.vel[k]) / (2.0 * H),
                    x.acc[k],
                    acs,
                );
            }
        }
    }

    /// Checks a frame's origin and angle derivatives against central differences.
    fn check_frame(label: &str, f: impl Fn(f64) -> FrameState, ts: &[f64]) {
        check_angles(
            label,
            |t| {
                let s = f(t);
                (s.angle, s.rate, s.accel)
            },
            ts,
        );
        check_point(
            &format!("{label} origin"),
            |t| {
                let s = f(t);
                Kinematics {
                    pos: s.origin,
                    vel: s.origin_vel,
                    acc: s.origin_acc,
                }
            },
            ts,
        );
    }

    fn smooth_drivers() -> Vec<Rotation> {
        vec![
            Rotation::Constant { angle0: 0.3, rate: 7.0 },
            Rotation::Constant {
                angle0: -1.0,
                rate: -5.0,
            },
            Rotation::SpinUp {
                angle0: 0.2,
                final_rate: 15.0,
                ramp_time: 0.6,
            },
            Rotation::Harmonic {
                mean: 0.4,
                amplitude: 2.5,
                frequency: 1.5,
                phase: 0.3,
            },
        ]
    }

    fn err_name(e: Error) -> String {
        match e {
            Error::InvalidParameter { name, .. } => name,
            other => panic!("expected InvalidParameter, got {other:?}"),
        }
    }

    fn err_message(e: Error) -> String {
        match e {
            Error::InvalidModel { message } => message,
            other => panic!("expected InvalidModel, got {other:?}"),
        }
    }

    fn sub(a: Vec2, b: Vec2) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    #[test]
    fn frame_state_point_matches_finite_differences() {
        let frame = RotatingFrame::new(
            Motion::Harmonic {
                offset: [0.1, -0.2],
                amplitude: [0.05, 0.03],
                frequency: 2.0,
                phase: 0.4,
            },
            Rotation::Harmonic {
                mean: 0.2,
                amplitude: 1.2,
                frequency: 1.3,
                phase: -0.5,
            },
        )
        .unwrap();
        let ts = times(0.0, 1.5, 61);
        check_frame("rotating", |t| frame.frame(t), &ts);
        check_point("point(0.7)", |t| frame.frame(t).point(0.7), &ts);
        check_point("local_point", |t| frame.frame(t).local_point([0.3, -0.2]), &ts);
        let f = frame.frame(0.37);
        let r = f.rotation();
        let p = f.point(0.7).pos;
        assert!(sub(p, [f.origin[0] + 0.7 * r[0][0], f.origin[1] + 0.7 * r[1][0]]) < 1e-15);
        assert!((r[0][0] - f.angle.cos()).abs() < 1e-15 && (r[1][0] - f.angle.sin()).abs() < 1e-15);
    }

    #[test]
    fn drivers_match_finite_differences() {
        let ts = times(0.0, 2.0, 81);
        check_angles("fixed", |t| Rotation::Fixed { angle: 0.7 }.at(t), &ts);
        for d in smooth_drivers() {
            check_angles(&format!("{d:?}"), |t| d.at(t), &ts);
        }
        // Spin-up: during the ramp and after it (finite differences straddling t = T would mix the
        // two pieces of the definition).
        let spin = Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 20.0,
            ramp_time: 0.5,
        };
        check_angles("spin-up ramp", |t| spin.at(t), &times(0.01, 0.49, 49));
        check_angles("spin-up after", |t| spin.at(t), &times(0.51, 1.5, 20));
        // Tabulated: at interior samples of a uniform grid, the central difference of the
        // interpolant (h << spacing) equals the table's own central difference exactly.
        let tt = times(0.0, 1.0, 101);
        let angle: Vec<f64> = tt.iter().map(|t| (3.0 * t).sin()).collect();
        let table = Rotation::tabulated(tt.clone(), angle, None, None).unwrap();
        check_angles("tabulated", |t| table.at(t), &tt[2..99]);
    }

    #[test]
    fn spin_up_reaches_half_w_t_and_rate_is_continuous() {
        let (a0, w, tr) = (0.25, 12.0, 0.8);
        let d = Rotation::SpinUp {
            angle0: a0,
            final_rate: w,
            ramp_time: tr,
        };
        let (angle, rate, accel) = d.at(tr);
        assert!((angle - (a0 + w * tr / 2.0)).abs() < 1e-12);
        assert_eq!((rate, accel), (w, 0.0));
        let before = d.at(tr - 1e-9);
        assert!((before.0 - angle).abs() < 1e-7 && (before.1 - w).abs() < 1e-6 && before.2.abs() < 1e-6);
        assert_eq!(d.at(0.0), (a0, 0.0, 0.0));
        assert_eq!(d.at(-1.0), (a0, 0.0, 0.0));
        let (a, r, _) = d.at(tr + 1.0);
        assert!((a - (a0 + w * tr / 2.0 + w)).abs() < 1e-12 && r == w);
        // Smooth start: tiny but positive angle and rate just after 0.
        let (a, r, al) = d.at(1e-3);
        assert!(a > a0 && r > 0.0 && al > 0.0 && a - a0 < 1e-8);
    }

    #[test]
    fn tabulated_rotation_validates_and_interpolates() {
        let e = |r: Result<Rotation>| err_name(r.unwrap_err());
        assert_eq!(e(Rotation::tabulated(vec![0.0], vec![0.0], None, None)), "time");
        assert_eq!(
            e(Rotation::tabulated(vec![0.0, 1.0, 1.0], vec![0.0; 3], None, None)),
            "time[2]"
        );
        assert_eq!(
            e(Rotation::tabulated(vec![f64::NAN, 1.0], vec![0.0; 2], None, None)),
            "time[0]"
        );
        assert_eq!(
            e(Rotation::tabulated(vec![0.0, f64::INFINITY], vec![0.0; 2], None, None)),
            "time[1]"
        );
        assert_eq!(
            e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0; 3], None, None)),
            "angle"
        );
        assert_eq!(
            e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0, f64::NAN], None, None)),
            "angle[1]"
        );
        assert_eq!(
            e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0; 2], Some(vec![1.0]), None)),
            "rate"
        );
        assert_eq!(
            e(Rotation::tabulated(
                vec![0.0, 1.0],
                vec![0.0; 2],
                None,
                Some(vec![1.0, f64::NAN])
            )),
            "accel[1]"
        );
        let named = AngleTable::new("hub", vec![0.0, 0.0], vec![0.0; 2], None, None).unwrap_err();
        assert_eq!(err_name(named), "hub.time[1]");

        let d = Rotation::tabulated(vec![0.0, 1.0, 2.0], vec![0.0, 2.0, 3.0], None, None).unwrap();
        let (a, r, al) = d.at(0.5);
        assert_eq!((a, r), (1.0, 1.75)); // rates [2, 1.5, 1]
        assert_eq!(al, -0.5); // accels [-0.5, -0.5, -0.5]
        assert_eq!(d.at(-1.0).0, 0.0);
        assert_eq!(d.at(5.0).0, 3.0);
        let given = Rotation::tabulated(
            vec![0.0, 1.0],
            vec![0.0, 1.0],
            Some(vec![4.0, 4.0]),
            Some(vec![9.0, 9.0]),
        )
        .unwrap();
        assert_eq!(given.at(0.3), (0.3, 4.0, 9.0));

        assert!(d.covers("rot", 2.0).is_ok());
        assert_eq!(err_name(d.covers("rot", 2.5).unwrap_err()), "rot.time");
        let late = Rotation::tabulated(vec![0.1, 1.0], vec![0.0, 1.0], None, None).unwrap();
        assert_eq!(err_name(late.covers("rot", 0.5).unwrap_err()), "rot.time");
        assert!(Rotation::Constant { angle0: 0.0, rate: 1.0 }.covers("rot", 1e9).is_ok());
    }

    #[test]
    fn rotation_validate_names_the_field() {
        let v = |d: Rotation| err_name(d.validate("r").unwrap_err());
        assert_eq!(v(Rotation::Fixed { angle: f64::NAN }), "r.angle");
        assert_eq!(
            v(Rotation::Constant {
                angle0: 0.0,
                rate: f64::INFINITY
            }),
            "r.rate"
        );
        assert_eq!(
            v(Rotation::SpinUp {
                angle0: 0.0,
                final_rate: 1.0,
                ramp_time: 0.0
            }),
            "r.ramp_time"
        );
        assert_eq!(
            v(Rotation::Harmonic {
                mean: 0.0,
                amplitude: 1.0,
                frequency: -1.0,
                phase: 0.0
            }),
            "r.frequency"
        );
        match (Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 1.0,
            ramp_time: -2.0,
        })
        .validate("r")
        .unwrap_err()
        {
            Error::InvalidParameter { allowed, .. } => assert!(allowed.contains("> 0") && allowed.contains('s')),
            other => panic!("{other:?}"),
        }
        for d in smooth_drivers() {
            d.validate("r").unwrap();
        }
    }

    fn slider_cranks() -> Vec<SliderCrank> {
        let mut out = Vec::new();
        for d in smooth_drivers() {
            out.push(SliderCrank::new(0.15, 0.6, 0.0, d.clone()).unwrap());
            out.push(SliderCrank::new(0.15, 0.6, 0.08, d.clone()).unwrap());
            out.push(SliderCrank::new(0.2, 0.35, -0.1, d).unwrap());
        }
        out
    }

    #[test]
    fn slider_crank_frames_match_finite_differences() {
        let ts = times(0.0, 2.0, 81);
        for sc in slider_cranks() {
            let label = format!("{sc:?}");
            check_frame(&format!("crank {label}"), |t| sc.crank_frame(t), &ts);
            check_frame(&format!("rod {label}"), |t| sc.rod_frame(t), &ts);
            check_frame(&format!("slider {label}"), |t| sc.slider_frame(t), &ts);
            check_point(&format!("B {label}"), |t| sc.slider(t), &ts);
            check_point(
                &format!("rod midpoint {label}"),
                |t| sc.rod_frame(t).point(0.5 * sc.rod()),
                &ts,
            );
        }
    }

    #[test]
    fn slider_crank_loop_closes() {
        for sc in slider_cranks() {
            for t in times(0.0, 3.0, 1001) {
                let rod = sc.rod_frame(t);
                let end = rod.point(sc.rod());
                let b = sc.slider(t);
                assert!(
                    sub(end.pos, b.pos) < 1e-12,
                    "closure at t = {t}: {:?} vs {:?}",
                    end.pos,
                    b.pos
                );
                assert!((b.pos[1] - sc.offset()).abs() < 1e-15);
                // The rod's far end moves with the slider (exact identities up to round-off).
                let vs = 1.0 + b.vel[0].abs();
                let acs = 1.0 + b.acc[0].abs();
                assert!(sub(end.vel, b.vel) < 1e-9 * vs && sub(end.acc, b.acc) < 1e-9 * acs);
                // The rod starts at the crank pin.
                let pin = sc.crank_frame(t).point(sc.crank());
                assert!(sub(pin.pos, rod.origin) < 1e-15);
                assert!(rod.angle.cos() > 0.0);
            }
        }
    }

    #[test]
    fn slider_crank_dead_centres() {
        let (a, l) = (0.1, 0.45);
        let at = |th: f64| {
            SliderCrank::new(a, l, 0.0, Rotation::Fixed { angle: th })
                .unwrap()
                .slider(0.0)
        };
        let b0 = at(0.0);
        assert!(sub(b0.pos, [a + l, 0.0]) < 1e-15);
        let b1 = at(PI);
        assert!(sub(b1.pos, [l - a, 0.0]) < 1e-15);
        assert_eq!((b0.vel, b0.acc), ([0.0, 0.0], [0.0, 0.0]));
        // Constant rate w at theta = 0: the slider acceleration is -a w^2 (1 + a / l).
        let w = 10.0;
        let sc = SliderCrank::new(a, l, 0.0, Rotation::Constant { angle0: 0.0, rate: w }).unwrap();
        let b = sc.slider(0.0);
        assert!((b.acc[0] + a * w * w * (1.0 + a / l)).abs() < 1e-12);
        assert!(b.vel[0].abs() < 1e-15);
    }

    #[test]
    fn slider_crank_rejects_bad_geometry() {
        let d = || Rotation::Constant { angle0: 0.0, rate: 1.0 };
        let e = |r: Result<SliderCrank>| err_name(r.unwrap_err());
        assert_eq!(e(SliderCrank::new(0.3, 0.2, 0.0, d())), "rod");
        assert_eq!(e(SliderCrank::new(0.3, 0.4, 0.1, d())), "rod"); // rod == crank + |offset|
        assert_eq!(e(SliderCrank::new(0.3, 0.45, -0.2, d())), "rod");
        assert_eq!(e(SliderCrank::new(0.0, 1.0, 0.0, d())), "crank");
        assert_eq!(e(SliderCrank::new(0.1, f64::NAN, 0.0, d())), "rod");
        assert_eq!(e(SliderCrank::new(0.1, 1.0, f64::NAN, d())), "offset");
        let bad = Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 1.0,
            ramp_time: 0.0,
        };
        assert_eq!(e(SliderCrank::new(0.1, 1.0, 0.0, bad)), "driver.ramp_time");
        match SliderCrank::new(0.3, 0.2, 0.0, d()).unwrap_err() {
            Error::InvalidParameter { allowed, .. } => assert!(allowed.contains("crank + |offset| = 0.3 m")),
            other => panic!("{other:?}"),
        }
    }

    /// Crank-rocker (crank shortest, Grashof), both branches, and a drag link (ground shortest,
    /// crank longer than ground).
    fn four_bars(driver: &Rotation) -> Vec<FourBar> {
        vec![
            FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, driver.clone()).unwrap(),
            FourBar::new(0.4, 0.1, 0.35, 0.3, -1.0, driver.clone()).unwrap(),
            FourBar::new(0.1, 0.3, 0.35, 0.32, 1.0, driver.clone()).unwrap(),
            FourBar::new(0.1, 0.3, 0.35, 0.32, -1.0, driver.clone()).unwrap(),
        ]
    }

    #[test]
    fn four_bar_frames_match_finite_differences() {
        let ts = times(0.0, 2.0, 81);
        for d in smooth_drivers() {
            for fb in four_bars(&d) {
                fb.check("fb", 2.0 + H).unwrap();
                let label = format!("{fb:?}");
                check_frame(&format!("crank {label}"), |t| fb.crank_frame(t), &ts);
                check_frame(&format!("coupler {label}"), |t| fb.coupler_frame(t), &ts);
                check_frame(&format!("rocker {label}"), |t| fb.rocker_frame(t), &ts);
                check_point(&format!("B {label}"), |t| fb.rocker_frame(t).point(fb.rocker()), &ts);
            }
        }
    }

    #[test]
    fn four_bar_loop_closes() {
        for d in smooth_drivers() {
            for fb in four_bars(&d) {
                for t in times(0.0, 3.0, 1001) {
                    let (cr, co, ro) = (fb.crank_frame(t), fb.coupler_frame(t), fb.rocker_frame(t));
                    let a = cr.point(fb.crank());
                    let b3 = co.point(fb.coupler());
                    let b4 = ro.point(fb.rocker());
                    assert!(sub(a.pos, co.origin) < 1e-15);
                    assert!(sub(b3.pos, b4.pos) < 1e-12, "closure at t = {t}: {:?}", fb);
                    // B computed along the coupler and along the rocker moves the same way.
                    let vs = 1.0 + max_abs(b4.vel.into_iter());
                    let acs = 1.0 + max_abs(b4.acc.into_iter());
                    assert!(sub(b3.vel, b4.vel) < 1e-9 * vs, "velocity at t = {t}");
                    assert!(sub(b3.acc, b4.acc) < 1e-9 * acs, "acceleration at t = {t}");
                    assert!(sub(a.vel, co.origin_vel) < 1e-12 && sub(a.acc, co.origin_acc) < 1e-9 * acs);
                    assert_eq!(ro.origin, [fb.ground(), 0.0]);
                }
            }
        }
    }

    #[test]
    fn four_bar_branch_convention() {
        // Norton's open (+) and crossed (-) solutions for theta4 of a crank-rocker.
        let (a, b, c, d) = (0.1, 0.35, 0.3, 0.4);
        let norton = |th2: f64, sign: f64| {
            let (k1, k2, k3) = (d / a, d / c, (a * a - b * b + c * c + d * d) / (2.0 * a * c));
            let aa = th2.cos() - k1 - k2 * th2.cos() + k3;
            let bb = -2.0 * th2.sin();
            let cc = k1 - (k2 + 1.0) * th2.cos() + k3;
            2.0 * ((-bb - sign * (bb * bb - 4.0 * aa * cc).sqrt()) / (2.0 * aa)).atan()
        };
        for branch in [1.0, -1.0] {
            for th2 in times(-3.0, 3.0, 25) {
                let fb = FourBar::new(d, a, b, c, branch, Rotation::Fixed { angle: th2 }).unwrap();
                let (th3, th4) = (fb.coupler_frame(0.0).angle, fb.rocker_frame(0.0).angle);
                let diff = (th4 - norton(th2, branch)).rem_euclid(TAU);
                assert!(diff < 1e-12 || TAU - diff < 1e-12, "branch {branch} th2 {th2}");
                assert!(branch * (th4 - th3).sin() > 0.0);
            }
        }
        // With the crank straight up, the open assembly has B above the ground line.
        let fb = FourBar::new(d, a, b, c, 1.0, Rotation::Fixed { angle: PI / 2.0 }).unwrap();
        assert!(fb.rocker_frame(0.0).point(c).pos[1] > 0.0);
    }

    #[test]
    fn four_bar_angles_are_continuous() {
        // Two crank turns: crank-rocker angles oscillate, drag-link angles turn with the crank.
        let d = Rotation::Constant { angle0: 0.0, rate: TAU };
        for fb in four_bars(&d) {
            let ts = times(0.0, 2.0, 4001);
            for w in ts.windows(2) {
                for f in [FourBar::coupler_frame, FourBar::rocker_frame] {
                    let jump = (f(&fb, w[1]).angle - f(&fb, w[0]).angle).abs();
                    assert!(jump < 0.05, "jump {jump} at t = {} in {fb:?}", w[0]);
                }
            }
            let turns = (fb.coupler_frame(2.0).angle - fb.coupler_frame(0.0).angle) / TAU;
            let expected = if fb.crank() > fb.ground() { 2.0 } else { 0.0 };
            assert!((turns - expected).abs() < 1e-9, "coupler turns {turns} in {fb:?}");
        }
    }

    #[test]
    fn four_bar_check_reports_failures() {
        let spin = Rotation::Constant { angle0: 0.0, rate: 3.0 };
        // Can never close.
        let fb = FourBar::new(10.0, 1.0, 1.0, 1.0, 1.0, spin.clone()).unwrap();
        let msg = err_message(fb.check("links[0].frame", 1.0).unwrap_err());
        assert!(msg.starts_with("links[0].frame: the four-bar does not close at crank angle 0 rad (t = 0 s)"));
        assert!(msg.contains("|coupler - rocker| <= |A - O4| <= coupler + rocker violated"));
        assert!(
            msg.contains("non-Grashof") && msg.contains("closes at no crank angle"),
            "{msg}"
        );
        // Non-Grashof (s + l = 5 > p + q = 4.7): closes for |theta2| <= acos(-0.7575) = 2.43 rad.
        let rock = |amplitude: f64| Rotation::Harmonic {
            mean: 0.0,
            amplitude,
            frequency: 1.0,
            phase: 0.0,
        };
        let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(1.0)).unwrap();
        fb.check("fb", 3.0).unwrap();
        let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(3.0)).unwrap();
        let msg = err_message(fb.check("fb", 3.0).unwrap_err());
        assert!(msg.contains("does not close") && msg.contains("non-Grashof"), "{msg}");
        assert!(msg.contains("[0, 2.43"), "{msg}");
        // ... but only once the driver gets there.
        FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(3.0))
            .unwrap()
            .check("fb", 0.1)
            .unwrap();
        // Grashof, rocker shortest: the crank cannot turn fully.
        let fb = FourBar::new(0.4, 0.3, 0.35, 0.1, 1.0, spin.clone()).unwrap();
        let msg = err_message(fb.check("fb", 3.0).unwrap_err());
        assert!(msg.contains("coupler or rocker is the shortest"), "{msg}");
        // Parallelogram: dead centre at theta2 = pi (found between samples).
        let fb = FourBar::new(2.0, 1.0, 2.0, 1.0, 1.0, Rotation::Constant { angle0: 0.5, rate: 1.0 }).unwrap();
        fb.check("fb", 1.0).unwrap();
        let msg = err_message(fb.check("fb", 4.0).unwrap_err());
        assert!(msg.contains("dead-centre") && msg.contains("change-point"), "{msg}");
        assert!(msg.contains(&format!("crank angle {PI} rad")), "{msg}");
        // A harmonic driver just past the limit (2.43027 rad) is caught at its peak, which is
        // among the sampled times.
        let peak = |amplitude: f64| Rotation::Harmonic {
            mean: 0.0,
            amplitude,
            frequency: 0.37,
            phase: 0.1,
        };
        let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, peak(2.4303)).unwrap();
        let t_peak = (0.5 * PI - 0.1) / (TAU * 0.37);
        assert!(fb.check_times(100.0).contains(&t_peak));
        assert!(fb.check("fb", 100.0).is_err());
        FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, peak(2.4302))
            .unwrap()
            .check("fb", 100.0)
            .unwrap();
        // Parameter errors.
        assert_eq!(err_name(fb.check("fb", -1.0).unwrap_err()), "t_end");
        assert_eq!(err_name(fb.check("fb", f64::NAN).unwrap_err()), "t_end");
        let table = Rotation::tabulated(vec![0.0, 1.0], vec![0.0, 0.1], None, None).unwrap();
        let fb = FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, table).unwrap();
        fb.check("fb", 1.0).unwrap();
        assert_eq!(err_name(fb.check("fb", 2.0).unwrap_err()), "fb.driver.time");
    }

    #[test]
    fn four_bar_rejects_bad_parameters() {
        let d = || Rotation::Fixed { angle: 0.0 };
        let e = |r: Result<FourBar>| err_name(r.unwrap_err());
        assert_eq!(e(FourBar::new(-1.0, 1.0, 1.0, 1.0, 1.0, d())), "ground");
        assert_eq!(e(FourBar::new(1.0, 0.0, 1.0, 1.0, 1.0, d())), "crank");
        assert_eq!(e(FourBar::new(1.0, 1.0, f64::NAN, 1.0, 1.0, d())), "coupler");
        assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, f64::INFINITY, 1.0, d())), "rocker");
        assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, 1.0, 0.0, d())), "branch");
        assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, 1.0, 0.5, d())), "branch");
        assert_eq!(
            e(FourBar::new(
                1.0,
                1.0,
                1.0,
                1.0,
                1.0,
                Rotation::Fixed { angle: f64::NAN }
            )),
            "driver.angle"
        );
    }

    #[test]
    fn frame_kinematics_wrappers() {
        let driver = Rotation::SpinUp {
            angle0: 0.1,
            final_rate: 8.0,
            ramp_time: 0.5,
        };
        let sc = Arc::new(SliderCrank::new(0.1, 0.4, 0.02, driver.clone()).unwrap());
        let fb = Arc::new(FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, driver.clone()).unwrap());
        let mut frames: Vec<(Arc<dyn FrameKinematics>, FrameState)> = Vec::new();
        let t = 0.73;
        for (link, want) in [
            (SliderCrankLink::Crank, sc.crank_frame(t)),
            (SliderCrankLink::Rod, sc.rod_frame(t)),
            (SliderCrankLink::Slider, sc.slider_frame(t)),
        ] {
            let f: Arc<dyn FrameKinematics> = Arc::new(SliderCrankFrame {
                mechanism: sc.clone(),
                link,
            });
            frames.push((f, want));
        }
        for (link, want) in [
            (FourBarLink::Crank, fb.crank_frame(t)),
            (FourBarLink::Coupler, fb.coupler_frame(t)),
            (FourBarLink::Rocker, fb.rocker_frame(t)),
        ] {
            let f: Arc<dyn FrameKinematics> = Arc::new(FourBarFrame {
                mechanism: fb.clone(),
                link,
            });
            frames.push((f, want));
        }
        let rot = RotatingFrame::new(Motion::Fixed { position: [1.0, 2.0] }, driver).unwrap();
        let want = FrameState {
            origin: [1.0, 2.0],
            angle: sc.crank_frame(t).angle,
            rate: sc.crank_frame(t).rate,
            accel: sc.crank_frame(t).accel,
            ..FrameState::default()
        };
        let f: Arc<dyn FrameKinematics> = Arc::new(rot);
        frames.push((f, want));
        for (f, want) in &frames {
            assert_eq!(f.frame(t), *want, "{f:?}");
            f.check("f", 10.0).unwrap();
        }
        // rotates / translates: crank, rod, slider, crank, coupler, rocker, rotating frame.
        let flags: Vec<(bool, bool)> = frames.iter().map(|(f, _)| (f.rotates(), f.translates())).collect();
        let (y, n) = (true, false);
        assert_eq!(flags, [(y, n), (y, y), (n, y), (y, n), (y, y), (y, n), (y, n)]);
        let still = FourBarFrame {
            mechanism: Arc::new(FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, Rotation::Fixed { angle: 1.0 }).unwrap()),
            link: FourBarLink::Coupler,
        };
        assert!(!still.rotates() && !still.translates());
        let table_zero = Rotation::tabulated(vec![0.0, 1.0], vec![0.5, 0.5], None, None).unwrap();
        assert!(table_zero.is_fixed());
        assert!(Rotation::Constant { angle0: 1.0, rate: 0.0 }.is_fixed());
        assert!(!smooth_drivers().iter().any(Rotation::is_fixed));
        assert_eq!(sc.slider_frame(t).origin, sc.slider(t).pos);
        let ((th, _, _), (psi, _, _)) = sc.angles(t);
        assert_eq!((th, psi), (sc.crank_frame(t).angle, sc.rod_frame(t).angle));

        // Checks through the trait: coverage of tables and parameter validation.
        let table = Rotation::tabulated(vec![0.0, 1.0], vec![0.0, 1.0], None, None).unwrap();
        let short = RotatingFrame {
            origin: Motion::Fixed { position: [0.0, 0.0] },
            rotation: table.clone(),
        };
        assert!(short.check("f", 1.0).is_ok());
        assert_eq!(err_name(short.check("f", 2.0).unwrap_err()), "f.rotation.time");
        let origin = Table::new("o", vec![0.0, 0.5], vec![[0.0, 0.0], [1.0, 0.0]], None, None).unwrap();
        let moving = RotatingFrame {
            origin: Motion::Tabulated(origin),
            rotation: table.clone(),
        };
        assert_eq!(err_name(moving.check("f", 1.0).unwrap_err()), "f.origin.time");
        let bad = RotatingFrame {
            origin: Motion::Fixed { position: [0.0, 0.0] },
            rotation: Rotation::Harmonic {
                mean: 0.0,
                amplitude: 1.0,
                frequency: f64::NAN,
                phase: 0.0,
            },
        };
        assert_eq!(err_name(bad.check("f", 1.0).unwrap_err()), "f.rotation.frequency");
        assert_eq!(
            err_name(
                RotatingFrame::new(
                    Motion::Fixed {
                        position: [f64::NAN, 0.0]
                    },
                    table.clone()
                )
                .unwrap_err()
            ),
            "origin.position[0]"
        );
        let sct = SliderCrankFrame {
            mechanism: Arc::new(SliderCrank::new(0.1, 0.4, 0.0, table).unwrap()),
            link: SliderCrankLink::Rod,
        };
        assert!(sct.check("s", 1.0).is_ok());
        assert!(sct.rotates() && sct.translates());
        assert_eq!(err_name(sct.check("s", 1.5).unwrap_err()), "s.driver.time");
    }
}
