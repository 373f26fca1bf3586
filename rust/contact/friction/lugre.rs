//! The LuGre friction model (Canudas de Wit, Olsson, Astrom & Lischinsky 1995), with its
//! internal bristle state, normalized by the normal force.

use super::super::laws::pname;
use super::coulomb::sign;
use crate::error::{check_non_negative, check_positive, Error, Result};

/// The largest microslip `mu_static / sigma0` (m) a LuGre law may have: a bristle deflection of
/// a metre is far beyond any joint's clearance, and it keeps the steady state `g(v) / sigma0`
/// finite.
pub const MAX_MICROSLIP: f64 = 1.0;

/// The smallest microslip `mu / sigma0` (m) a LuGre law may have: a femtometre, far below any
/// bristle deflection that means something, and it keeps the bristle rate `sigma0 |v| / g(v)`
/// finite (at most 1e15 |v| 1/s): at mu = 5e-324 that rate overflowed and the run's friction
/// history came out NaN (`inf * 0` in the tangent).
pub const MIN_MICROSLIP: f64 = 1e-15;

/// LuGre friction with the coefficients scaled by the normal force `F_N`, so that a joint whose
/// load varies keeps a friction coefficient (Canudas de Wit et al. 1995, "A new model for control
/// of systems with friction", IEEE Trans. Autom. Control 40:419-425, with `F_c = mu F_N`,
/// `F_s = mu_static F_N`):
///
/// - bristle state `z` (m): `z' = v - sigma0 |v| z / g(v)`,
///   `g(v) = mu + (mu_static - mu) exp(-(v / stribeck_speed)^2)`;
/// - force on the body slipping at `v`: `F = -(F_N (sigma0 z + sigma1 z') + sigma2 v)`.
///
/// At constant `v` the state tends to `z_ss = g(v) sign(v) / sigma0` and the force to
/// `-(g(v) F_N sign(v) + sigma2 v)`: the Stribeck curve plus viscous friction. The state is
/// the caller's (explicit `state` + `derivative` API): [`LuGre::derivative`] for any integrator,
/// [`LuGre::advance`] for the exact update over a step at constant `v` (stable for any step,
/// the bristle dynamics being stiff: time constant `g / (sigma0 |v|)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LuGre {
    /// Kinetic (Coulomb) friction coefficient `mu` (>= 0).
    pub mu: f64,
    /// Static friction coefficient (>= `mu`).
    pub mu_static: f64,
    /// Stribeck speed, m/s (> 0).
    pub stribeck_speed: f64,
    /// Bristle stiffness per unit normal force `sigma0`, 1/m (at least `mu_static /
    /// MAX_MICROSLIP`; default 1e5: a microslip `mu / sigma0` of 1 micrometre at mu = 0.1).
    pub sigma0: f64,
    /// Bristle damping per unit normal force `sigma1`, s/m (>= 0; default 0).
    pub sigma1: f64,
    /// Viscous friction `sigma2`, N s/m (>= 0; default 0).
    pub sigma2: f64,
}

impl LuGre {
    /// Coulomb coefficient `mu`, static coefficient `mu_static` and Stribeck speed (m/s); the
    /// bristle parameters at their defaults.
    pub fn new(mu: f64, mu_static: f64, stribeck_speed: f64) -> Self {
        LuGre {
            mu,
            mu_static,
            stribeck_speed,
            sigma0: 1e5,
            sigma1: 0.0,
            sigma2: 0.0,
        }
    }

    /// The Stribeck curve `g(v)` (dimensionless) and `dg/dv` (s/m).
    #[inline]
    pub fn stribeck(&self, v: f64) -> (f64, f64) {
        let x = v / self.stribeck_speed;
        let ex = (-x * x).exp();
        let dmu = self.mu_static - self.mu;
        (self.mu + dmu * ex, -2.0 * dmu * x / self.stribeck_speed * ex)
    }

    /// `z'` (m/s) at state `z` (m) and slip speed `v` (m/s).
    #[inline]
    pub fn derivative(&self, z: f64, v: f64) -> f64 {
        let (g, _) = self.stribeck(v);
        v - self.sigma0 * v.abs() * z / g
    }

    /// Steady state `z_ss(v) = g(v) sign(v) / sigma0`, m.
    #[inline]
    pub fn steady_state(&self, v: f64) -> f64 {
        self.stribeck(v).0 * sign(v) / self.sigma0
    }

    /// The state after `dt` (s) at constant `v`, exactly: `z_ss + (z - z_ss) exp(-a dt)`,
    /// `a = sigma0 |v| / g(v)`.
    #[inline]
    pub fn advance(&self, z: f64, v: f64, dt: f64) -> f64 {
        if v == 0.0 {
            return z;
        }
        let (g, _) = self.stribeck(v);
        let a = self.sigma0 * v.abs() / g;
        let zs = g * sign(v) / self.sigma0;
        zs + (z - zs) * (-a * dt).exp()
    }

    /// Friction force, N, at state `z` (m), slip speed `v` (m/s) and normal force `f_n` (N,
    /// taken as `max(f_n, 0)`).
    #[inline]
    pub fn force(&self, z: f64, v: f64, f_n: f64) -> f64 {
        let zd = self.derivative(z, v);
        -(f_n.max(0.0) * (self.sigma0 * z + self.sigma1 * zd) + self.sigma2 * v)
    }

    /// Closed-form tangents of [`LuGre::force`]: `(dF/dz, dF/dv, dF/dF_N)` in N/m, N s/m, N/N.
    #[inline]
    pub fn tangent(&self, z: f64, v: f64, f_n: f64) -> (f64, f64, f64) {
        let (g, dg) = self.stribeck(v);
        let n = f_n.max(0.0);
        let (s0, s1) = (self.sigma0, self.sigma1);
        // z' = v - s0 |v| z / g: dz'/dz = -s0 |v| / g, dz'/dv = 1 - s0 z (sign(v) / g - |v| g' / g^2)
        let dzd_dz = -s0 * v.abs() / g;
        let dzd_dv = 1.0 - s0 * z * (sign(v) / g - v.abs() * dg / (g * g));
        let dz = -n * (s0 + s1 * dzd_dz);
        let dv = -(n * s1 * dzd_dv + self.sigma2);
        let dn = if f_n > 0.0 {
            -(s0 * z + s1 * self.derivative(z, v))
        } else {
            0.0
        };
        (dz, dv, dn)
    }

    /// Checks the parameters; `name` prefixes parameter names in errors.
    pub fn validate(&self, name: &str) -> Result<()> {
        check_positive(
            &pname(name, "mu"),
            self.mu,
            "(dimensionless; LuGre needs mu > 0: g(v) divides)",
        )?;
        if !(self.mu_static.is_finite() && self.mu_static >= self.mu) {
            return Err(Error::param(
                pname(name, "mu_static"),
                self.mu_static,
                format!("finite and >= mu = {}", self.mu),
            ));
        }
        check_positive(&pname(name, "stribeck_speed"), self.stribeck_speed, "m/s")?;
        check_positive(&pname(name, "sigma0"), self.sigma0, "1/m")?;
        // the microslip mu_static / sigma0 (the bristles' steady deflection) at most
        // MAX_MICROSLIP: beyond it the law is no friction model, and at a subnormal sigma0 the
        // steady state g / sigma0 overflows (the bristle update then computes inf - inf)
        if self.mu_static / self.sigma0 > MAX_MICROSLIP {
            return Err(Error::param(
                pname(name, "sigma0"),
                self.sigma0,
                format!(
                    ">= mu_static / {MAX_MICROSLIP} m = {} 1/m (a microslip mu_static / sigma0 of at most {MAX_MICROSLIP} m)",
                    self.mu_static / MAX_MICROSLIP
                ),
            ));
        }
        if self.mu / self.sigma0 < MIN_MICROSLIP {
            return Err(Error::param(
                pname(name, "sigma0"),
                self.sigma0,
                format!(
                    "<= mu / {MIN_MICROSLIP:e} m = {:e} 1/m (a microslip mu / sigma0 of at least {MIN_MICROSLIP:e} m)",
                    self.mu / MIN_MICROSLIP
                ),
            ));
        }
        check_non_negative(&pname(name, "sigma1"), self.sigma1, "s/m")?;
        check_non_negative(&pname(name, "sigma2"), self.sigma2, "N s/m")
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Coulomb, Regularization, Stribeck};
    use super::*;

    #[test]
    fn steady_state_is_the_stribeck_curve() {
        let lg = LuGre {
            sigma1: 300.0,
            sigma2: 0.4,
            ..LuGre::new(0.1, 0.15, 1e-3)
        };
        let coulomb = Coulomb {
            mu: 0.1,
            regularization: Regularization::Linear { v_reg: 1e-9 },
            stribeck: Some(Stribeck {
                mu_static: 0.15,
                speed: 1e-3,
                exponent: 2.0,
            }),
        };
        for v in [-0.2, -2e-3, 1e-3, 5e-4, 0.05] {
            // from rest, 50 time constants of the bristle: exp(-50) ~ 2e-22 of the start value
            let (g, _) = lg.stribeck(v);
            let tau = g / (lg.sigma0 * f64::abs(v));
            let mut z = 0.0;
            for _ in 0..50 {
                z = lg.advance(z, v, tau);
            }
            let f = lg.force(z, v, 800.0);
            let expect = coulomb.force(v, 800.0) - 0.4 * v;
            assert!((f - expect).abs() <= 1e-12 * expect.abs(), "{v}: {f} {expect}");
            // and the explicit derivative vanishes there
            assert!(lg.derivative(z, v).abs() <= 1e-12 * v.abs());
        }
    }

    #[test]
    fn advance_agrees_with_the_derivative() {
        let lg = LuGre::new(0.1, 0.12, 2e-3);
        let (z, v, dt) = (3e-7, 0.01, 1e-9);
        // a step far below the time constant (1e-4 s): forward difference error ~ dt / tau
        let fd = (lg.advance(z, v, dt) - z) / dt;
        assert!((fd - lg.derivative(z, v)).abs() <= 1e-4 * lg.derivative(z, v).abs());
    }

    #[test]
    fn tangents_match_central_differences() {
        let lg = LuGre {
            sigma1: 250.0,
            sigma2: 0.3,
            ..LuGre::new(0.1, 0.15, 1e-3)
        };
        for (z, v) in [(4e-7, 2e-3), (-1e-6, -5e-4), (1.2e-6, 0.3)] {
            let fnorm = 900.0;
            let (dz, dv, dn) = lg.tangent(z, v, fnorm);
            let (hz, hv) = (1e-6 * z.abs(), 1e-6 * v.abs());
            let fdz = (lg.force(z + hz, v, fnorm) - lg.force(z - hz, v, fnorm)) / (2.0 * hz);
            let fdv = (lg.force(z, v + hv, fnorm) - lg.force(z, v - hv, fnorm)) / (2.0 * hv);
            let fdn = (lg.force(z, v, fnorm + 1.0) - lg.force(z, v, fnorm - 1.0)) / 2.0;
            // relative steps 1e-6: truncation ~1e-12, round-off ~1e-10 of the force scale
            let f = lg.force(z, v, fnorm).abs().max(1.0);
            assert!((dz - fdz).abs() <= 1e-6 * dz.abs().max(f / z.abs()), "{dz} {fdz}");
            assert!((dv - fdv).abs() <= 1e-6 * dv.abs().max(f / v.abs()), "{dv} {fdv}");
            assert!((dn - fdn).abs() <= 1e-9 * dn.abs().max(1.0), "{dn} {fdn}");
        }
    }
}
