//! The offset slider-crank: crank angle from its driver, rod angle and slider position from the
//! loop closure, and the frames of its crank, rod and slider.

use super::*;

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
    /// The last pose solved ([`PoseMemo`]).
    last: PoseMemo<SliderCrankPose>,
}

/// Solved configuration of a slider-crank at one instant.
#[derive(Debug, Clone, Copy)]
struct SliderCrankPose {
    theta: (f64, f64, f64),
    psi: (f64, f64, f64),
    /// `(cos psi, sin psi)` of the loop closure (from which `psi` is taken).
    psi_cs: (f64, f64),
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
        // lengths and offset at most 1e75 m (error.rs MAX_MAGNITUDE): the closed forms take
        // products of up to four lengths, which stay finite
        check_positive("crank", crank, "m")?;
        check_positive("rod", rod, "m")?;
        check_finite("offset", offset, "m")?;
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
            last: PoseMemo::default(),
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

    /// The pose at `t` (s), solved once per instant ([`PoseMemo`]).
    fn pose(&self, t: f64) -> SliderCrankPose {
        self.last.get(t, |t| self.solve(t))
    }

    /// Solves the loop closure at `t` (s).
    fn solve(&self, t: f64) -> SliderCrankPose {
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
            psi_cs: (cp, sp),
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
        self.last
            .with(t, |t| self.solve(t), |p| FrameState::at(&p.pin_a, p.psi))
    }

    /// [`Self::rod_frame`] with the rod's rotation matrix from the loop closure's own `cos psi`
    /// and `sin psi` (`psi` itself is their `atan2`).
    pub fn rod_frame_rotation(&self, t: f64) -> (FrameState, [[f64; 2]; 2]) {
        self.last.with(
            t,
            |t| self.solve(t),
            |p| {
                let (c, s) = p.psi_cs;
                (FrameState::at(&p.pin_a, p.psi), [[c, -s], [s, c]])
            },
        )
    }

    /// Position (m), velocity (m/s) and acceleration (m/s^2) of the slider pin B at `t` (s).
    pub fn slider(&self, t: f64) -> Kinematics {
        self.last.with(t, |t| self.solve(t), |p| p.pin_b)
    }

    /// Frame of the slider block at `t` (s): origin at B, axes parallel to the global axes (the
    /// guide is along global x, so the angle is 0 and the block does not rotate).
    pub fn slider_frame(&self, t: f64) -> FrameState {
        FrameState::at(&self.slider(t), (0.0, 0.0, 0.0))
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

    /// The rod's rotation from the loop closure's `(cos psi, sin psi)`; the crank's and the
    /// slider's from their angles.
    fn frame_rotation(&self, t: f64) -> (FrameState, [[f64; 2]; 2]) {
        match self.link {
            SliderCrankLink::Rod => self.mechanism.rod_frame_rotation(t),
            _ => {
                let f = self.frame(t);
                (f, f.rotation())
            }
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

    /// The crank turns with the driver ([`Rotation::constant_rate`]); the slider never rotates;
    /// the rod's rate varies unless the driver is fixed.
    fn constant_rate(&self) -> Option<f64> {
        match self.link {
            SliderCrankLink::Crank => self.mechanism.driver.constant_rate(),
            SliderCrankLink::Slider => Some(0.0),
            SliderCrankLink::Rod => self.mechanism.driver.is_fixed().then_some(0.0),
        }
    }

    /// The rod's origin (crank pin) and the slider move unless the driver is fixed; the crank's
    /// origin is the fixed pivot.
    fn translates(&self) -> bool {
        self.link != SliderCrankLink::Crank && !self.mechanism.driver.is_fixed()
    }
}
