//! A normal law as the engine's pin-in-hole [`ContactLaw`].

use super::NormalLaw;
use crate::contact::{ContactLaw, ContactTerms, Mat2};
use crate::error::{check_positive, Result};

/// A [`NormalLaw`] acting between a journal and its bearing: with `q` the journal centre relative
/// to the bearing centre (m), `r = |q|`, `n = q / r`, the penetration is `d = r - clearance` and
/// its rate `dd = n . qdot`; the force on the journal is `-F(d, dd, v0) n`.
///
/// The split into [`ContactTerms`] (docs/method.md section 4) is exact:
/// - stiffness `k = kappa I` with `kappa = F(d, 0, v0) / r` (the elastic part over `|q|`),
/// - damping `c = (dF/d(dd)) n n^T` (radial),
/// - `f_explicit = -(F - F(d, 0, v0) - (dF/d(dd)) dd) n`, the remainder (zero for every law of
///   the form `K d^n (1 + chi dd / v0)` and the viscous spring-dashpot, which are linear in `dd`).
///
/// When the law clips a tensile force, the clipped state returns zero terms.
///
/// `approach_speed` (m/s) is the normal approach speed used by [`ContactLaw::evaluate`]; the
/// steppers track each joint's episode and call [`ContactLaw::evaluate_episode`] with its own
/// (see [`crate::contact::approach_speed`]); the laws floor it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalContact<L: NormalLaw> {
    /// The normal law.
    pub law: L,
    /// Approach speed of the current episode, m/s.
    pub approach_speed: f64,
    /// Penetration (m) at which [`ContactLaw::stiffness`] reports the law's tangent stiffness
    /// (default 1e-5 m, the order of the penetration of a steel pin under a few kN).
    pub reference_penetration: f64,
}

impl<L: NormalLaw> NormalContact<L> {
    /// The law with no episode yet (approach speed 0, i.e. the law's floor).
    pub fn new(law: L) -> Self {
        NormalContact {
            law,
            approach_speed: 0.0,
            reference_penetration: 1e-5,
        }
    }

    /// The same contact with the approach speed of a new episode, m/s.
    pub fn with_approach_speed(mut self, approach_speed: f64) -> Self {
        self.approach_speed = approach_speed;
        self
    }
}

impl<L: NormalLaw> ContactLaw for NormalContact<L> {
    fn evaluate(&self, q: [f64; 2], qd: [f64; 2], clearance: f64) -> ContactTerms {
        self.evaluate_episode(q, qd, clearance, self.approach_speed)
    }

    fn needs_approach_speed(&self) -> bool {
        self.law.needs_approach_speed()
    }

    fn evaluate_episode(&self, q: [f64; 2], qd: [f64; 2], clearance: f64, approach_speed: f64) -> ContactTerms {
        let r = q[0].hypot(q[1]);
        let d = r - clearance;
        if d <= 0.0 || r == 0.0 {
            return ContactTerms {
                penetration: d,
                ..Default::default()
            };
        }
        let n = [q[0] / r, q[1] / r];
        let dd = n[0] * qd[0] + n[1] * qd[1];
        let v0 = approach_speed;
        let f = self.law.force(d, dd, v0);
        if f == 0.0 {
            return ContactTerms {
                penetration: d,
                ..Default::default()
            };
        }
        let fs = self.law.force(d, 0.0, v0);
        let (_, cn) = self.law.tangent(d, dd, v0);
        let kappa = fs / r;
        let rest = f - fs - cn * dd;
        ContactTerms {
            penetration: d,
            k: [[kappa, 0.0], [0.0, kappa]],
            c: [
                [cn * n[0] * n[0], cn * n[0] * n[1]],
                [cn * n[1] * n[0], cn * n[1] * n[1]],
            ],
            f_explicit: [-rest * n[0], -rest * n[1]],
        }
    }

    fn validate(&self, name: &str) -> Result<()> {
        self.law.validate(name)?;
        check_positive(
            &super::pname(name, "reference_penetration"),
            self.reference_penetration,
            "m",
        )
    }

    /// `dF/dd` at [`NormalContact::reference_penetration`] with `dd = 0`, N/m.
    fn stiffness(&self) -> f64 {
        self.law.tangent(self.reference_penetration, 0.0, self.approach_speed).0
    }

    /// `-d(-F_s(r - c) n)/dq = F_s'(d) n n^T + (F_s(d) / r) (I - n n^T)` in contact, with `F_s` the
    /// elastic part `F(d, 0, v0)`; zero when open.
    fn spring_tangent(&self, q: [f64; 2], clearance: f64) -> Mat2 {
        let r = q[0].hypot(q[1]);
        if r <= clearance || r == 0.0 {
            return [[0.0; 2]; 2];
        }
        let d = r - clearance;
        let n = [q[0] / r, q[1] / r];
        let v0 = self.approach_speed;
        let (a, b) = (self.law.tangent(d, 0.0, v0).0, self.law.force(d, 0.0, v0) / r);
        [
            [a * n[0] * n[0] + b * (1.0 - n[0] * n[0]), (a - b) * n[0] * n[1]],
            [(a - b) * n[1] * n[0], a * n[1] * n[1] + b * (1.0 - n[1] * n[1])],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Flores, Hertz, KelvinVoigt, LankaraniNikravesh};
    use super::*;
    use crate::contact::{DampingLaw, SpringDamper};

    #[test]
    fn terms_reproduce_the_normal_force() {
        let c = 5e-4;
        let law = NormalContact::new(LankaraniNikravesh::new(6.61e10, 0.9)).with_approach_speed(0.4);
        for (q, qd) in [
            ([4e-4, 3.1e-4], [0.2, -0.1]),
            ([-5.1e-4, 1e-5], [-0.3, 0.05]),
            ([0.0, -5.02e-4], [0.0, 0.01]),
        ] {
            let t = law.evaluate(q, qd, c);
            let f = t.force(q, qd);
            let r = q[0].hypot(q[1]);
            let n = [q[0] / r, q[1] / r];
            let dd = n[0] * qd[0] + n[1] * qd[1];
            let expect = law.law.force(r - c, dd, 0.4);
            for i in 0..2 {
                // the split is exact algebra: only round-off (a few ulp of F) separates the two
                assert!(
                    (f[i] + expect * n[i]).abs() <= 1e-12 * expect.abs().max(1.0),
                    "{f:?} {expect}"
                );
            }
        }
    }

    #[test]
    fn linear_law_matches_the_spring_damper() {
        // along the normal the adapter of the linear law must give today's radial spring-dashpot
        let sd = SpringDamper {
            stiffness: 3e8,
            damping: 40.0,
            damping_law: DampingLaw::Radial,
            no_tension: false,
        };
        let kv = NormalContact::new(KelvinVoigt::new(3e8, 40.0));
        for (q, qd) in [([1.2e-4, 0.3e-4], [0.5, -0.2]), ([-0.5e-4, 1.05e-4], [0.1, 0.3])] {
            let (a, b) = (
                sd.evaluate(q, qd, 1e-4).force(q, qd),
                kv.evaluate(q, qd, 1e-4).force(q, qd),
            );
            for i in 0..2 {
                assert!((a[i] - b[i]).abs() <= 1e-12 * a[i].abs().max(1.0), "{a:?} {b:?}");
            }
            let (ta, tb) = (sd.spring_tangent(q, 1e-4), kv.spring_tangent(q, 1e-4));
            for r in 0..2 {
                for c in 0..2 {
                    assert!((ta[r][c] - tb[r][c]).abs() <= 1e-6, "{ta:?} {tb:?}");
                }
            }
        }
    }

    #[test]
    fn spring_tangent_matches_central_differences() {
        let c = 5e-4;
        let hz = NormalContact::new(Hertz::new(6.61e10));
        let fl = NormalContact::new(Flores::new(6.61e10, 0.5)).with_approach_speed(0.3);
        let laws: [&dyn ContactLaw; 2] = [&hz, &fl];
        for law in laws {
            for q in [[4e-4, 3.2e-4], [-5.2e-4, 1e-5]] {
                let kt = law.spring_tangent(q, c);
                let fs = |q: [f64; 2]| law.evaluate(q, [0.0; 2], c).force(q, [0.0; 2]);
                let h = 1e-10;
                for col in 0..2 {
                    let (mut qp, mut qm) = (q, q);
                    qp[col] += h;
                    qm[col] -= h;
                    let (fp, fm) = (fs(qp), fs(qm));
                    for row in 0..2 {
                        let fd = -(fp[row] - fm[row]) / (2.0 * h);
                        // step 1e-10 m against a penetration ~1e-5 m: truncation ~1e-10
                        // relative; round-off ~1e-16 F / 1e-10 m, far below the tolerance
                        let scale = kt[0][0].abs().max(kt[1][1].abs());
                        assert!((kt[row][col] - fd).abs() <= 1e-6 * scale, "{kt:?} {fd}");
                    }
                }
            }
        }
    }
}
