//! Rigid-body kinematics of a planar linkage of one's own: the positions, velocities and
//! accelerations of its points over a table of instants, from its loop-closure constraints.
//!
//! The linkage is a set of points: *moving* ones, whose positions are the unknowns (two
//! coordinates each), and *known* ones, fixed on the ground or carried by a driven crank. The
//! constraints, each a scalar in metres, are
//!
//! * a distance between two points of a rigid link, `(|x_p - x_q|^2 - L^2) / (2 L)`;
//! * a pin on a straight guide through `x_0` along the unit `e`, `(x_p - x_0) x e`;
//! * a pin in a slot along the line through the points `a` and `b` of a moving link, `(x_p - x_a)
//!   x (x_b - x_a) / L` with `L = |x_b - x_a|`.
//!
//! At each instant the positions are solved by Newton's method from the last instant's Taylor
//! step (from the caller's guesses at the first: they pick the branch), to `TOLERANCE` times the
//! linkage's size; the velocities and accelerations then follow from the constraints' first and
//! second time derivatives with the same Jacobian: `J_u v_u = -J_k v_k` and `J_u a_u = -J_k a_k -
//! g`, `g` the terms quadratic in the velocities. This is what `flexclear.Linkage` runs (its
//! Python side builds the constraints and the frames of the links).

use super::{cross, Rotation, Vec2};
use crate::error::{g6, Error, Result};
use crate::linalg::solve_dense_in_place;

/// Newton's tolerance on the constraints, as a fraction of the linkage's size.
pub const TOLERANCE: f64 = 1e-13;
/// Largest 2-norm condition number of the constraint Jacobian before a position counts as a dead
/// point.
pub const MAX_CONDITION: f64 = 1e10;
/// Newton iterations at one instant before the linkage counts as not assembling.
const MAX_ITERATIONS: usize = 50;

/// One scalar constraint (m) on the points, indexed as in [`LinkageSystem`].
#[derive(Debug, Clone, PartialEq)]
pub enum Constraint {
    /// Points `p` and `q` of one rigid link at `length` (m > 0) apart.
    Distance {
        /// One point.
        p: usize,
        /// The other.
        q: usize,
        /// Their distance, m.
        length: f64,
    },
    /// Point `p` on the straight line through `through` (m) along the unit vector `dir`.
    Line {
        /// The pin.
        p: usize,
        /// A point of the line, m.
        through: Vec2,
        /// Its unit direction.
        dir: Vec2,
    },
    /// Point `p` on the line through the points `a` and `b` of one link, `length` (m > 0) apart.
    Slot {
        /// The pin.
        p: usize,
        /// The line's first point.
        a: usize,
        /// Its second point.
        b: usize,
        /// `|x_b - x_a|`, m.
        length: f64,
    },
}

/// A driven crank: its tip (a known point) at `length` (m) from the ground `pivot` (m), at the
/// driver's angle from the global x axis.
#[derive(Debug, Clone)]
pub struct Crank {
    /// The crank's name, for errors.
    pub name: String,
    /// The pivot's global position, m.
    pub pivot: Vec2,
    /// The tip's point index.
    pub tip: usize,
    /// Pivot to tip, m.
    pub length: f64,
    /// The crank's angle (rad) in time.
    pub driver: Rotation,
}

/// A linkage's points and constraints. Points `0..moving` are the unknowns; each of the others
/// is a ground point (`ground`) or a crank's tip (`cranks`).
#[derive(Debug, Clone)]
pub struct LinkageSystem {
    /// Number of moving points (the first ones).
    pub moving: usize,
    /// Number of points.
    pub points: usize,
    /// As many constraints as the moving points' coordinates.
    pub constraints: Vec<Constraint>,
    /// Ground points: index, global position (m).
    pub ground: Vec<(usize, Vec2)>,
    /// Driven cranks.
    pub cranks: Vec<Crank>,
}

/// Positions (m), velocities (m/s) and accelerations (m/s^2) of every point at every instant:
/// entry `(k, i, c)` (instant, point, coordinate) at `(k * points + i) * 2 + c`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinkageMotion {
    /// Positions, m.
    pub position: Vec<f64>,
    /// Velocities, m/s.
    pub velocity: Vec<f64>,
    /// Accelerations, m/s^2.
    pub acceleration: Vec<f64>,
}

impl LinkageSystem {
    /// Checks the indices and numbers: points in range, moving points first, as many constraints
    /// as unknowns, positive lengths, unit guide directions. Fails with
    /// [`Error::InvalidModel`].
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| {
            Err(Error::InvalidModel {
                message: format!("linkage: {m}"),
            })
        };
        let n = self.points;
        if self.moving > n {
            return bad(format!("{} moving points of {n}", self.moving));
        }
        if self.constraints.len() != 2 * self.moving {
            return bad(format!(
                "{} constraints for {} moving points ({} coordinates)",
                self.constraints.len(),
                self.moving,
                2 * self.moving
            ));
        }
        let mut known = vec![false; n];
        for &(i, xy) in &self.ground {
            if i < self.moving || i >= n || !xy.iter().all(|v| v.is_finite()) {
                return bad(format!("ground point #{i} at {xy:?}"));
            }
            known[i] = true;
        }
        for c in &self.cranks {
            let ok = c.tip >= self.moving && c.tip < n && c.length > 0.0 && c.length.is_finite();
            if !ok || !c.pivot.iter().all(|v| v.is_finite()) {
                return bad(format!("crank {:?}", c.name));
            }
            known[c.tip] = true;
        }
        if let Some(i) = (self.moving..n).find(|&i| !known[i]) {
            return bad(format!("point #{i} is neither moving, on the ground nor a crank's tip"));
        }
        for c in &self.constraints {
            let ok = match *c {
                Constraint::Distance { p, q, length } => p < n && q < n && p != q && length > 0.0 && length.is_finite(),
                Constraint::Line { p, through, dir } => {
                    p < n
                        && through.iter().all(|v| v.is_finite())
                        && ((dir[0] * dir[0] + dir[1] * dir[1]) - 1.0).abs() < 1e-12
                }
                Constraint::Slot { p, a, b, length } => {
                    p < n && a < n && b < n && a != b && length > 0.0 && length.is_finite()
                }
            };
            if !ok {
                return bad(format!("constraint {c:?}"));
            }
        }
        Ok(())
    }

    /// The constraints' values (m) at the positions `pos` (`2 * points`), into `f`.
    fn values(&self, pos: &[f64], f: &mut [f64]) {
        let x = |i: usize| [pos[2 * i], pos[2 * i + 1]];
        for (fr, c) in f.iter_mut().zip(&self.constraints) {
            *fr = match *c {
                Constraint::Distance { p, q, length } => {
                    let (xp, xq) = (x(p), x(q));
                    let d = [xp[0] - xq[0], xp[1] - xq[1]];
                    (d[0] * d[0] + d[1] * d[1] - length * length) / (2.0 * length)
                }
                Constraint::Line { p, through, dir } => {
                    let xp = x(p);
                    let r = [xp[0] - through[0], xp[1] - through[1]];
                    r[0] * dir[1] - r[1] * dir[0]
                }
                Constraint::Slot { p, a, b, length } => {
                    let (xp, xa, xb) = (x(p), x(a), x(b));
                    cross([xp[0] - xa[0], xp[1] - xa[1]], [xb[0] - xa[0], xb[1] - xa[1]]) / length
                }
            };
        }
    }

    /// The constraints' Jacobian at `pos` over every point's two coordinates (row-major, `rows x
    /// 2 points`), into `jac`.
    fn jacobian(&self, pos: &[f64], jac: &mut [f64]) {
        let cols = 2 * self.points;
        jac.fill(0.0);
        let x = |i: usize| [pos[2 * i], pos[2 * i + 1]];
        for (r, c) in self.constraints.iter().enumerate() {
            let row = &mut jac[r * cols..(r + 1) * cols];
            let mut add = |i: usize, g: Vec2| {
                row[2 * i] += g[0];
                row[2 * i + 1] += g[1];
            };
            match *c {
                Constraint::Distance { p, q, length } => {
                    let (xp, xq) = (x(p), x(q));
                    let s = [(xp[0] - xq[0]) / length, (xp[1] - xq[1]) / length];
                    add(p, s);
                    add(q, [-s[0], -s[1]]);
                }
                Constraint::Line { p, dir, .. } => add(p, [dir[1], -dir[0]]),
                Constraint::Slot { p, a, b, length } => {
                    // (P - A) x (B - A) / L: d/dP = (w_y, -w_x) / L, d/dB = (-u_y, u_x) / L,
                    // d/dA the negative sum (u = P - A, w = B - A)
                    let (xp, xa, xb) = (x(p), x(a), x(b));
                    let (u, w) = ([xp[0] - xa[0], xp[1] - xa[1]], [xb[0] - xa[0], xb[1] - xa[1]]);
                    let dp = [w[1] / length, -w[0] / length];
                    let db = [-u[1] / length, u[0] / length];
                    add(p, dp);
                    add(b, db);
                    add(a, [-(dp[0] + db[0]), -(dp[1] + db[1])]);
                }
            }
        }
    }

    /// The terms of the constraints' second time derivative quadratic in the velocities `vel`.
    fn quadratic(&self, vel: &[f64], g: &mut [f64]) {
        let v = |i: usize| [vel[2 * i], vel[2 * i + 1]];
        for (gr, c) in g.iter_mut().zip(&self.constraints) {
            *gr = match *c {
                Constraint::Distance { p, q, length } => {
                    let (vp, vq) = (v(p), v(q));
                    let d = [vp[0] - vq[0], vp[1] - vq[1]];
                    (d[0] * d[0] + d[1] * d[1]) / length
                }
                Constraint::Line { .. } => 0.0,
                Constraint::Slot { p, a, b, length } => {
                    let (vp, va, vb) = (v(p), v(a), v(b));
                    2.0 * cross([vp[0] - va[0], vp[1] - va[1]], [vb[0] - va[0], vb[1] - va[1]]) / length
                }
            };
        }
    }

    /// Sets the known points' positions, velocities and accelerations at `t` (s).
    fn known(&self, t: f64, pos: &mut [f64], vel: &mut [f64], acc: &mut [f64]) -> Result<()> {
        for &(i, xy) in &self.ground {
            pos[2 * i..2 * i + 2].copy_from_slice(&xy);
            vel[2 * i..2 * i + 2].fill(0.0);
            acc[2 * i..2 * i + 2].fill(0.0);
        }
        for c in &self.cranks {
            let (phi, w, al) = c.driver.at(t);
            if !(phi.is_finite() && w.is_finite() && al.is_finite()) {
                return Err(Error::InvalidModel {
                    message: format!(
                        "linkage: crank '{}''s driver gives angle {}, rate {}, acceleration {} at t = {} s: \
                         finite values needed",
                        c.name,
                        g6(phi),
                        g6(w),
                        g6(al),
                        g6(t)
                    ),
                });
            }
            let (s, co) = phi.sin_cos();
            let (l, i) = (c.length, c.tip);
            pos[2 * i] = c.pivot[0] + l * co;
            pos[2 * i + 1] = c.pivot[1] + l * s;
            vel[2 * i] = l * w * -s;
            vel[2 * i + 1] = l * w * co;
            acc[2 * i] = l * (al * -s - w * w * co);
            acc[2 * i + 1] = l * (al * co - w * w * s);
        }
        Ok(())
    }

    /// The motion of every point at the increasing `times` (s), from the moving points' guesses
    /// `near` (m, `2 * moving`; they pick the branch at the first instant). `scale` (m) is the
    /// linkage's size, to which the tolerance is relative.
    ///
    /// Fails with [`Error::InvalidModel`] naming the instant where the linkage does not assemble
    /// (no position within the tolerance: lengths that cannot close, or past a dead point), where
    /// it sits at a dead point (the Jacobian's condition number over [`MAX_CONDITION`]), or
    /// where a crank's driver is not finite; with [`Error::InvalidParameter`] for times that are
    /// not finite and increasing, or guesses that are not finite.
    pub fn solve(&self, times: &[f64], near: &[f64], scale: f64) -> Result<LinkageMotion> {
        self.validate()?;
        if times.is_empty() || !times.iter().all(|t| t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::param(
                "times",
                format!("{} values", times.len()),
                "finite, strictly increasing times, s",
            ));
        }
        let (mp, n) = (self.moving, self.points);
        if near.len() != 2 * mp || !near.iter().all(|v| v.is_finite()) {
            return Err(Error::param(
                "near",
                format!("{near:?}"),
                format!("{} finite coordinates, m", 2 * mp),
            ));
        }
        let (m, cols) = (2 * mp, 2 * n);
        let tol = TOLERANCE * scale;
        let size = times.len() * cols;
        let mut out = LinkageMotion {
            position: Vec::with_capacity(size),
            velocity: Vec::with_capacity(size),
            acceleration: Vec::with_capacity(size),
        };
        let (mut pos, mut vel, mut acc) = (vec![0.0; cols], vec![0.0; cols], vec![0.0; cols]);
        pos[..m].copy_from_slice(near);
        let (mut f, mut jac) = (vec![0.0; m], vec![0.0; m * cols]);
        let (mut ju, mut rhs) = (vec![0.0; m * m], vec![0.0; m]);
        let mut guess = vec![0.0; m];
        for (k, &t) in times.iter().enumerate() {
            if k > 0 {
                // Newton starts from the Taylor step of the last instant's motion (from the
                // last positions where that overflows: a huge step)
                let h = t - times[k - 1];
                for (i, g) in guess.iter_mut().enumerate() {
                    *g = pos[i] + h * vel[i] + 0.5 * h * h * acc[i];
                }
                if guess.iter().all(|g| g.is_finite()) {
                    pos[..m].copy_from_slice(&guess);
                }
            }
            self.known(t, &mut pos, &mut vel, &mut acc)?;
            self.newton(t, tol, &mut pos, &mut f, &mut jac, &mut ju, &mut rhs)?;
            if m > 0 {
                // J_u v_u = -J_k v_k, J_u a_u = -J_k a_k - g (J at the solved positions)
                self.rates(&jac, &vel, None, &mut ju, &mut rhs);
                vel[..m].copy_from_slice(&rhs);
                self.quadratic(&vel, &mut f);
                self.rates(&jac, &acc, Some(&f), &mut ju, &mut rhs);
                acc[..m].copy_from_slice(&rhs);
            }
            out.position.extend_from_slice(&pos);
            out.velocity.extend_from_slice(&vel);
            out.acceleration.extend_from_slice(&acc);
        }
        Ok(out)
    }

    /// The moving points' rates (`x` the velocities or accelerations of every point, of which the
    /// known ones are read) into `out`: `J_u x_u = -J_k x_k - g` (`g` zero for the velocities).
    fn rates(&self, jac: &[f64], x: &[f64], g: Option<&[f64]>, ju: &mut [f64], out: &mut [f64]) {
        let (m, cols) = (2 * self.moving, 2 * self.points);
        for r in 0..m {
            let row = &jac[r * cols..(r + 1) * cols];
            let known: f64 = row[m..].iter().zip(&x[m..]).map(|(a, b)| a * b).sum();
            out[r] = -known - g.map_or(0.0, |g| g[r]);
            ju[r * m..(r + 1) * m].copy_from_slice(&row[..m]);
        }
        solve_dense_in_place(ju, out, m);
    }

    /// Newton's method on the moving points of `pos` at `t` (s), to `tol` (m); leaves the
    /// Jacobian at the solution in `jac`.
    #[allow(clippy::too_many_arguments)]
    fn newton(
        &self,
        t: f64,
        tol: f64,
        pos: &mut [f64],
        f: &mut [f64],
        jac: &mut [f64],
        ju: &mut [f64],
        step: &mut [f64],
    ) -> Result<()> {
        let (m, cols) = (2 * self.moving, 2 * self.points);
        for _ in 0..MAX_ITERATIONS {
            self.values(pos, f);
            self.jacobian(pos, jac);
            if f.iter().fold(0.0f64, |a, v| a.max(v.abs())) <= tol {
                let cond = condition(jac, m, cols);
                if cond.is_nan() || cond > MAX_CONDITION {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "linkage: at a dead point at t = {} s (constraint Jacobian condition {cond:.2e}): the \
                             driver cannot move it through this position",
                            g6(t)
                        ),
                    });
                }
                return Ok(());
            }
            if !f.iter().all(|v| v.is_finite()) {
                break;
            }
            for r in 0..m {
                ju[r * m..(r + 1) * m].copy_from_slice(&jac[r * cols..r * cols + m]);
            }
            step.copy_from_slice(f);
            if solve_dense_in_place(ju, step, m) == 0.0 {
                break;
            }
            for (p, s) in pos[..m].iter_mut().zip(step.iter()) {
                *p -= s;
            }
            if !pos.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        Err(Error::InvalidModel {
            message: format!(
                "linkage: does not assemble at t = {} s (Newton's method found no position within {tol:.1e} m: \
                 lengths that cannot close, or past a dead point); check the lengths and the `near` guesses",
                g6(t)
            ),
        })
    }
}

/// The 2-norm condition number of the leading `m x m` block of the row-major `jac` (`cols`
/// columns): the ratio of its largest to its smallest singular value (1 when `m` is 0, infinite
/// when singular).
fn condition(jac: &[f64], m: usize, cols: usize) -> f64 {
    if m == 0 {
        return 1.0;
    }
    let a = nalgebra::DMatrix::from_fn(m, m, |r, c| jac[r * cols + c]);
    let s = a.singular_values();
    let (lo, hi) = s
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if lo > 0.0 {
        hi / lo
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::FourBar;

    /// The four-bar of the README (m): B moving, O2 and O4 on the ground, A the crank's tip.
    fn four_bar(coupler: f64) -> LinkageSystem {
        LinkageSystem {
            moving: 1,
            points: 4,
            constraints: vec![
                Constraint::Distance {
                    p: 0,
                    q: 3,
                    length: coupler,
                },
                Constraint::Distance {
                    p: 0,
                    q: 2,
                    length: 0.2794,
                },
            ],
            ground: vec![(1, [0.0, 0.0]), (2, [0.254, 0.0])],
            cranks: vec![Crank {
                name: "crank".into(),
                pivot: [0.0, 0.0],
                tip: 3,
                length: 0.0508,
                driver: Rotation::Constant {
                    angle0: 0.0,
                    rate: 150.0,
                },
            }],
        }
    }

    #[test]
    fn a_four_bars_coupler_pin_follows_the_closed_form() {
        let times: Vec<f64> = (0..=100).map(|k| k as f64 * 5e-4).collect();
        let motion = four_bar(0.2794).solve(&times, &[0.15, 0.26], 0.3).unwrap();
        let driver = Rotation::Constant {
            angle0: 0.0,
            rate: 150.0,
        };
        let closed = FourBar::new(0.254, 0.0508, 0.2794, 0.2794, 1.0, driver).unwrap();
        let (mut dx, mut dv, mut da) = (0.0f64, 0.0f64, 0.0f64);
        for (k, &t) in times.iter().enumerate() {
            // B = O4 + rocker (cos th4, sin th4), differentiated
            let f = closed.rocker_frame(t);
            let (s, c) = f.angle.sin_cos();
            let (l, w, al) = (0.2794, f.rate, f.accel);
            let b = [0.254 + l * c, l * s];
            let vb = [-l * w * s, l * w * c];
            let ab = [l * (-al * s - w * w * c), l * (al * c - w * w * s)];
            let at = |v: &[f64], c: usize| v[k * 8 + c];
            for c in 0..2 {
                dx = dx.max((at(&motion.position, c) - b[c]).abs());
                dv = dv.max((at(&motion.velocity, c) - vb[c]).abs());
                da = da.max((at(&motion.acceleration, c) - ab[c]).abs());
            }
            // the crank's tip and the ground points are as given
            assert_eq!(at(&motion.position, 6), 0.0508 * (150.0 * t).cos());
            assert_eq!(at(&motion.position, 4), 0.254);
        }
        // round-off of sizes 0.3 m, 8 m/s and 1200 m/s^2
        assert!(dx < 1e-14, "position {dx:e} m");
        assert!(dv < 1e-12, "velocity {dv:e} m/s");
        assert!(da < 1e-9, "acceleration {da:e} m/s^2");
    }

    #[test]
    fn a_four_bar_that_cannot_close_names_the_instant() {
        // a coupler too short to reach the rocker's circle: |0.2794 - 0.01| > |O4 - A| = 0.2032 m at t = 0
        let times: Vec<f64> = (0..=100).map(|k| k as f64 * 5e-4).collect();
        let e = four_bar(0.01).solve(&times, &[0.15, 0.26], 0.3).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("does not assemble at t = 0 s"), "{text}");
        // the times are checked before anything is solved
        let e = four_bar(0.2794).solve(&[0.0, 0.0], &[0.15, 0.26], 0.3).unwrap_err();
        assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
    }
}
