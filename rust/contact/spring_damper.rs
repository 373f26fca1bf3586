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

    fn validate(&self, name: &str) -> Result<()> {
        check_non_negative(&format!("{name}.stiffness"), self.stiffness, "N/m")?;
        check_non_negative(&format!("{name}.damping"), self.damping, "N s/m")
    }

    fn stiffness(&self) -> f64 {
        self.stiffness
    }
}
