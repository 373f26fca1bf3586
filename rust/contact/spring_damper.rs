//! The spring-dashpot bearing of Dubowsky & Freudenstein (1971), as the paper uses it.

use super::{ContactLaw, ContactTerms};
use crate::error::{check_non_negative, Result};

/// How the bearing's damping acts while in contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DampingLaw {
    /// `-C_B qdot` (the paper's modified-matrix form; our default for both methods).
    #[default]
    Viscous,
    /// `-C_B (n . qdot) n`, `n = q/|q|`: damps only the normal approach velocity.
    Radial,
    /// The paper's literal force-method form `-C_B |qdot| n`: always pushes outward. Documented
    /// as unstable on the slider-yoke; kept for comparison.
    Literal,
}

/// Linear spring-dashpot contact: in contact, `f = -K_B delta n + damping`, `n = q/|q|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringDamper {
    /// Bearing stiffness K_B, N/m.
    pub stiffness: f64,
    /// Bearing damping C_B, N s/m (active only in contact).
    pub damping: f64,
    /// Form of the damping force.
    pub damping_law: DampingLaw,
    /// Forbid a tensile (sticky) total force: when the normal component of the force would pull
    /// the journal into the wall (`f . n > 0`), the force is zero.
    pub no_tension: bool,
}

impl ContactLaw for SpringDamper {
    #[inline]
    fn evaluate(&self, q: [f64; 2], qd: [f64; 2], clearance: f64) -> ContactTerms {
        let dr = (q[0] * q[0] + q[1] * q[1]).sqrt();
        let delta = dr - clearance;
        // delta > 0 implies dr > clearance >= 0, so dr > 0 below: no division by zero.
        if delta <= 0.0 || dr == 0.0 {
            return ContactTerms {
                penetration: delta,
                ..Default::default()
            };
        }
        let kappa = delta / dr;
        let n = [q[0] / dr, q[1] / dr];
        let kk = kappa * self.stiffness;
        let cb = self.damping;
        let mut t = ContactTerms {
            penetration: delta,
            k: [[kk, 0.0], [0.0, kk]],
            ..Default::default()
        };
        match self.damping_law {
            DampingLaw::Viscous => t.c = [[cb, 0.0], [0.0, cb]],
            DampingLaw::Radial => {
                t.c = [
                    [cb * n[0] * n[0], cb * n[0] * n[1]],
                    [cb * n[1] * n[0], cb * n[1] * n[1]],
                ];
            }
            DampingLaw::Literal => {
                let s = cb * (qd[0] * qd[0] + qd[1] * qd[1]).sqrt();
                t.f_explicit = [-s * n[0], -s * n[1]];
            }
        }
        if self.no_tension {
            let f = t.force(q, qd);
            if f[0] * n[0] + f[1] * n[1] > 0.0 {
                return ContactTerms {
                    penetration: delta,
                    ..Default::default()
                };
            }
        }
        t
    }

    fn as_spring_damper(&self) -> Option<&SpringDamper> {
        Some(self)
    }

    fn validate(&self, name: &str) -> Result<()> {
        check_non_negative(&format!("{name}.stiffness"), self.stiffness, "N/m")?;
        check_non_negative(&format!("{name}.damping"), self.damping, "N s/m")
    }

    fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// `K_B [(1 - c/r) I + (c/r) n n^T]` in contact (`r = |q| > c`, `n = q/r`), else zero: the
    /// derivative of `-K_B (r - c) n`.
    #[inline]
    fn spring_tangent(&self, q: [f64; 2], clearance: f64) -> [[f64; 2]; 2] {
        let r = q[0].hypot(q[1]);
        if r <= clearance || r == 0.0 {
            return [[0.0; 2]; 2];
        }
        let (n, a) = ([q[0] / r, q[1] / r], clearance / r);
        let k = self.stiffness;
        [
            [k * (1.0 - a + a * n[0] * n[0]), k * a * n[0] * n[1]],
            [k * a * n[1] * n[0], k * (1.0 - a + a * n[1] * n[1])],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_tangent_matches_central_differences() {
        let law = SpringDamper {
            stiffness: 3.0e9,
            damping: 50.0,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
        };
        let fd = |q: [f64; 2]| {
            // the trait's default (finite differences of evaluate)
            struct Fd(SpringDamper);
            impl std::fmt::Debug for Fd {
                fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                    self.0.fmt(f)
                }
            }
            impl ContactLaw for Fd {
                fn evaluate(&self, q: [f64; 2], qd: [f64; 2], c: f64) -> ContactTerms {
                    self.0.evaluate(q, qd, c)
                }
                fn validate(&self, name: &str) -> Result<()> {
                    self.0.validate(name)
                }
                fn stiffness(&self) -> f64 {
                    self.0.stiffness
                }
            }
            Fd(law).spring_tangent(q, 1e-4)
        };
        for q in [[1.2e-4, 0.3e-4], [-0.5e-4, 1.05e-4], [0.0, 1.0001e-4]] {
            let (a, b) = (law.spring_tangent(q, 1e-4), fd(q));
            for r in 0..2 {
                for c in 0..2 {
                    // central differences with a 1e-11 m step: truncation ~ 1e-8 relative
                    assert!((a[r][c] - b[r][c]).abs() <= 1e-5 * law.stiffness, "{q:?} {a:?} {b:?}");
                }
            }
        }
        assert_eq!(law.spring_tangent([0.5e-4, 0.0], 1e-4), [[0.0; 2]; 2]);
    }
}
