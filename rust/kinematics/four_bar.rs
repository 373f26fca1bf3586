//! The four-bar linkage: the coupler and rocker angles from the loop closure (either assembly
//! branch), their exact rates and accelerations, and the frames of crank, coupler and rocker.

use super::*;

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
    /// The last pose solved ([`PoseMemo`]).
    last: PoseMemo<FourBarPose>,
    /// The last `t_end` (s) for which [`FourBar::check`] passed ([`PoseMemo`]'s rules: a clone
    /// starts empty, memos compare equal): a run validates its mechanism several times, and the
    /// coupler's and rocker's frames share this four-bar.
    checked: PoseMemo<()>,
}

/// Solved configuration of a four-bar at one instant: angles, rates, accelerations of crank (2),
/// coupler (3) and rocker (4), and the crank pin A.
#[derive(Debug, Clone, Copy)]
struct FourBarPose {
    th: [f64; 3],
    w: [f64; 3],
    al: [f64; 3],
    /// `(cos, sin)` of each angle of `th` (the closure's own `sin_cos` of it).
    e: [Vec2; 3],
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
            check_positive(name, l, "m")?;
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
            last: PoseMemo::default(),
            checked: PoseMemo::default(),
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

    /// Solves the loop closure at `t` (s).
    fn solve(&self, t: f64) -> FourBarPose {
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
            e: [e2, e3, e4],
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
        self.last
            .with(t, |t| self.solve(t), |p| self.pose_frame(p, FourBarLink::Coupler))
    }

    /// Frame of the rocker at `t` (s): origin at O4 = (ground, 0), at rest; angle `theta4`, x
    /// axis toward B.
    pub fn rocker_frame(&self, t: f64) -> FrameState {
        self.last
            .with(t, |t| self.solve(t), |p| self.pose_frame(p, FourBarLink::Rocker))
    }

    /// The frame of `link` in the pose `p`: at rest on O2 (the crank), on the crank pin A (the
    /// coupler) or at rest on O4 (the rocker), at the link's angle, rate and acceleration.
    fn pose_frame(&self, p: &FourBarPose, link: FourBarLink) -> FrameState {
        let k = pose_index(link);
        let turn = (p.th[k], p.w[k], p.al[k]);
        match link {
            FourBarLink::Coupler => FrameState::at(&p.pin_a, turn),
            FourBarLink::Crank | FourBarLink::Rocker => {
                let at_rest = Kinematics {
                    pos: if link == FourBarLink::Crank {
                        [0.0; 2]
                    } else {
                        [self.ground, 0.0]
                    },
                    ..Kinematics::default()
                };
                FrameState::at(&at_rest, turn)
            }
        }
    }

    /// The frame of `link` at `t` (s) with its rotation matrix from the closure's own `cos` and
    /// `sin` of the link's angle: the frame of [`Self::crank_frame`], [`Self::coupler_frame`] or
    /// [`Self::rocker_frame`], and bitwise the matrix of its angle ([`FrameState::rotation`], the
    /// same `sin_cos` of the same angle), with no `sin_cos` of its own.
    pub fn frame_rotation(&self, link: FourBarLink, t: f64) -> (FrameState, [[f64; 2]; 2]) {
        self.last.with(
            t,
            |t| self.solve(t),
            |p| {
                let [c, s] = p.e[pose_index(link)];
                (self.pose_frame(p, link), [[c, -s], [s, c]])
            },
        )
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
        if self.checked.holds(t_end) {
            // passed at this very t_end (the outcome does not depend on `name`)
            return Ok(());
        }
        self.check_closure(name, t_end)?;
        self.checked.get(t_end, |_| ());
        Ok(())
    }

    /// [`FourBar::check`]'s loop-closure test over `[0, t_end]` (s), not memoized.
    fn check_closure(&self, name: &str, t_end: f64) -> Result<()> {
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
    pub(super) fn check_times(&self, t_end: f64) -> Vec<f64> {
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
        // made for an error only (this runs at thousands of angles per check)
        let prefix = || {
            if name.is_empty() {
                String::new()
            } else {
                format!("{name}: ")
            }
        };
        if d < lo - tol || d > hi + tol {
            let prefix = prefix();
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
            let prefix = prefix();
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

/// The index of `link`'s angle in a [`FourBarPose`] (`th`, `w`, `al`, `e`).
fn pose_index(link: FourBarLink) -> usize {
    match link {
        FourBarLink::Crank => 0,
        FourBarLink::Coupler => 1,
        FourBarLink::Rocker => 2,
    }
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

    /// The rotation from the closure's own `(cos, sin)` of the link's angle
    /// ([`FourBar::frame_rotation`]).
    fn frame_rotation(&self, t: f64) -> (FrameState, [[f64; 2]; 2]) {
        self.mechanism.frame_rotation(self.link, t)
    }

    /// [`FourBar::check`]: loop closure over `[0, t_end]` and table coverage.
    fn check(&self, name: &str, t_end: f64) -> Result<()> {
        self.mechanism.check(name, t_end)
    }

    /// Every link rotates unless the driver is fixed.
    fn rotates(&self) -> bool {
        !self.mechanism.driver.is_fixed()
    }

    /// The crank turns with the driver ([`Rotation::constant_rate`]); the coupler's and the
    /// rocker's rates vary unless the driver is fixed.
    fn constant_rate(&self) -> Option<f64> {
        match self.link {
            FourBarLink::Crank => self.mechanism.driver.constant_rate(),
            _ => self.mechanism.driver.is_fixed().then_some(0.0),
        }
    }

    /// Only the coupler's origin (the crank pin) moves, unless the driver is fixed; crank and
    /// rocker frames sit on the ground pivots.
    fn translates(&self) -> bool {
        self.link == FourBarLink::Coupler && !self.mechanism.driver.is_fixed()
    }
}
