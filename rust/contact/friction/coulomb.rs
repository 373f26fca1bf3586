//! Coulomb friction, regularized near zero slip, with an optional Stribeck curve.

use super::super::laws::pname;
use crate::error::{check_non_negative, check_positive, Error, Result};

/// How the sign function of Coulomb friction is regularized near zero slip speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Regularization {
    /// Ambrosio's modified Coulomb law (Ambrosio 2003; Flores et al. 2008): the dynamic
    /// correction `c_d` is 0 for `|v| <= v0`, `(|v| - v0) / (v1 - v0)` between, 1 above. No
    /// friction below `v0` (no stiction); typical `v0` 1e-4..1e-3 m/s, `v1` 1e-2..5e-2 m/s.
    Ambrosio {
        /// Speed below which friction vanishes, m/s (>= 0).
        v0: f64,
        /// Speed above which full friction acts, m/s (> v0).
        v1: f64,
    },
    /// Linear regularization (as Exudyn's contact elements): `c_d = |v| / v_reg` below `v_reg`,
    /// 1 above.
    Linear {
        /// Regularization speed, m/s (> 0; Exudyn's default 1e-3).
        v_reg: f64,
    },
}

/// A Stribeck curve: the friction coefficient rises from `mu` (kinetic, fast sliding) to
/// `mu_static` at zero slip, `mu(v) = mu + (mu_static - mu) exp(-(|v| / speed)^exponent)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stribeck {
    /// Static friction coefficient (>= the kinetic one).
    pub mu_static: f64,
    /// Stribeck speed, m/s (> 0).
    pub speed: f64,
    /// Shape exponent (> 0; 2 is the Gaussian curve of the LuGre papers).
    pub exponent: f64,
}

/// Regularized Coulomb friction `F_t = -mu(v) c_d(v) F_N sign(v)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coulomb {
    /// Kinetic friction coefficient `mu` (dimensionless, >= 0).
    pub mu: f64,
    /// Regularization near zero slip.
    pub regularization: Regularization,
    /// Optional Stribeck curve (`None`: `mu` at every speed).
    pub stribeck: Option<Stribeck>,
}

impl Coulomb {
    /// Ambrosio's modified Coulomb law with `v0 = 1e-4` and `v1 = 1e-2` m/s (the lower ends of
    /// the ranges used in the clearance-joint literature), no Stribeck curve.
    pub fn new(mu: f64) -> Self {
        Coulomb {
            mu,
            regularization: Regularization::Ambrosio { v0: 1e-4, v1: 1e-2 },
            stribeck: None,
        }
    }

    /// Friction coefficient at slip speed `v` (m/s) before regularization (the Stribeck curve,
    /// or `mu`), and its derivative with respect to `|v|` (s/m).
    #[inline]
    pub fn coefficient(&self, v: f64) -> (f64, f64) {
        match self.stribeck {
            None => (self.mu, 0.0),
            Some(s) => {
                let x = v.abs() / s.speed;
                let p = x.powf(s.exponent);
                let g = (-p).exp();
                let dmu = s.mu_static - self.mu;
                // d/d|v| of exp(-x^a) = -a x^(a-1) / speed exp(-x^a); x^(a-1) -> 0 or 1 at x = 0
                let xa1 = if x == 0.0 {
                    if s.exponent == 1.0 {
                        1.0
                    } else {
                        0.0
                    }
                } else {
                    p / x
                };
                (self.mu + dmu * g, -dmu * s.exponent * xa1 / s.speed * g)
            }
        }
    }

    /// The regularization factor `c_d(|v|)` in [0, 1] and its derivative with respect to `|v|`.
    #[inline]
    pub fn regularization_factor(&self, v: f64) -> (f64, f64) {
        let a = v.abs();
        match self.regularization {
            Regularization::Ambrosio { v0, v1 } => {
                if a <= v0 {
                    (0.0, 0.0)
                } else if a < v1 {
                    ((a - v0) / (v1 - v0), 1.0 / (v1 - v0))
                } else {
                    (1.0, 0.0)
                }
            }
            Regularization::Linear { v_reg } => {
                if a < v_reg {
                    (a / v_reg, 1.0 / v_reg)
                } else {
                    (1.0, 0.0)
                }
            }
        }
    }

    /// Friction force, N, on the body slipping at `v` (m/s) under normal force `f_n` (N).
    #[inline]
    pub fn force(&self, v: f64, f_n: f64) -> f64 {
        let (mu, _) = self.coefficient(v);
        let (cd, _) = self.regularization_factor(v);
        // `+ 0.0` turns the -0.0 of a zero product into 0.0
        -mu * cd * f_n.max(0.0) * sign(v) + 0.0
    }

    /// Closed-form tangents `(dF_t/dv, dF_t/dF_N)` in N s/m and N/N. At the kinks of the
    /// regularization (|v| = v0, v1, v_reg) the derivative of the side `|v|` is on is returned
    /// (`|v| < v1` counts as inside the ramp).
    #[inline]
    pub fn tangent(&self, v: f64, f_n: f64) -> (f64, f64) {
        let (mu, dmu) = self.coefficient(v);
        let (cd, dcd) = self.regularization_factor(v);
        let n = f_n.max(0.0);
        // F = -s mu(|v|) cd(|v|) n with s = sign(v): dF/dv = -(mu' cd + mu cd') n (the two signs cancel)
        let dv = -(dmu * cd + mu * dcd) * n;
        let dn = if f_n > 0.0 { -mu * cd * sign(v) } else { 0.0 };
        (dv, dn)
    }

    /// Checks the parameters; `name` prefixes parameter names in errors.
    pub fn validate(&self, name: &str) -> Result<()> {
        check_non_negative(&pname(name, "mu"), self.mu, "(dimensionless)")?;
        match self.regularization {
            Regularization::Ambrosio { v0, v1 } => {
                check_non_negative(&pname(name, "v0"), v0, "m/s")?;
                if !(v1.is_finite() && v1 > v0) {
                    return Err(Error::param(
                        pname(name, "v1"),
                        v1,
                        format!("finite and > v0 = {v0} m/s"),
                    ));
                }
            }
            Regularization::Linear { v_reg } => check_positive(&pname(name, "v_reg"), v_reg, "m/s")?,
        }
        if let Some(s) = self.stribeck {
            if !(s.mu_static.is_finite() && s.mu_static >= self.mu) {
                return Err(Error::param(
                    pname(name, "mu_static"),
                    s.mu_static,
                    format!("finite and >= mu = {}", self.mu),
                ));
            }
            check_positive(&pname(name, "stribeck_speed"), s.speed, "m/s")?;
            check_positive(&pname(name, "stribeck_exponent"), s.exponent, "(dimensionless)")?;
        }
        Ok(())
    }
}

/// sign(v) with sign(0) = 0.
#[inline]
pub(crate) fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_friction_beyond_the_regularization_speed() {
        let c = Coulomb::new(0.1);
        for v in [1e-2, 0.05, -3.0] {
            // exactly mu F_N against v beyond v1: no tolerance needed beyond round-off
            assert_eq!(c.force(v, 2719.0), -0.1 * 2719.0 * v.signum());
        }
        assert_eq!(c.force(5e-5, 100.0), 0.0);
        // halfway up the ramp
        let v = 0.5 * (1e-4 + 1e-2);
        assert!((c.force(v, 100.0) + 0.1 * 100.0 * 0.5).abs() < 1e-12);
        let lin = Coulomb {
            regularization: Regularization::Linear { v_reg: 1e-3 },
            ..c
        };
        assert!((lin.force(-2.5e-4, 100.0) - 0.1 * 100.0 * 0.25).abs() < 1e-12);
        assert_eq!(lin.force(2.0, -5.0), 0.0);
    }

    #[test]
    fn tangents_match_central_differences() {
        let laws = [
            Coulomb::new(0.2),
            Coulomb {
                mu: 0.1,
                regularization: Regularization::Linear { v_reg: 1e-3 },
                stribeck: Some(Stribeck {
                    mu_static: 0.15,
                    speed: 1e-2,
                    exponent: 2.0,
                }),
            },
        ];
        for law in laws {
            for v in [-0.3, -5e-4, 3e-3, 7e-3, 0.02, 1.0] {
                let fnorm = 1500.0;
                let (dv, dn) = law.tangent(v, fnorm);
                let h = 1e-7 * v.abs();
                let fdv = (law.force(v + h, fnorm) - law.force(v - h, fnorm)) / (2.0 * h);
                let fdn = (law.force(v, fnorm + 1.0) - law.force(v, fnorm - 1.0)) / 2.0;
                // relative step 1e-7 away from the kinks: truncation ~1e-14, round-off ~1e-9
                assert!((dv - fdv).abs() <= 1e-6 * dv.abs().max(1.0), "{law:?} {v}: {dv} {fdv}");
                assert!((dn - fdn).abs() <= 1e-9, "{v}: {dn} {fdn}");
            }
        }
    }

    #[test]
    fn validation_names_the_parameter() {
        let bad = Coulomb {
            regularization: Regularization::Ambrosio { v0: 1e-2, v1: 1e-3 },
            ..Coulomb::new(0.1)
        };
        match bad.validate("friction") {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "friction.v1"),
            other => panic!("{other:?}"),
        }
    }
}
