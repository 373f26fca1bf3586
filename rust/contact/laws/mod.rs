//! Normal-force laws of a contact: the force `F(d, dd)` along the contact normal as a function of
//! the penetration `d` (m, contact when `d > 0`) and its rate `dd` (m/s, positive while the
//! bodies approach), with its closed-form tangents. One law per file; the formulas, their
//! sources and the effective restitution of each are in `docs/contact.md`.
//!
//! Most dissipative laws share the form `F = K d^n (1 + chi dd / v0)` ([`PowerLaw`]) with `chi`
//! a function of the nominal restitution `e` only and `v0` the normal approach speed of the
//! current contact episode. Their force is zero at entry (`d = 0`), unlike the linear
//! spring-dashpot ([`KelvinVoigt`]) whose dashpot jumps there.
//!
//! Two choices every law documents:
//! - **Approach speed.** `v0` is the penetration rate at the first instant of the episode (the
//!   caller keeps it: with event location it is the rate at the located entry, otherwise the
//!   rate at the first step found in contact). The law uses `max(v0, min_approach_speed)`, so a
//!   persistent contact that starts with `v0 -> 0` (or a caller that passes 0, a negative value
//!   or NaN) gets a bounded damping coefficient `chi K d^n / min_approach_speed` instead of a
//!   division by ~0. Default floor [`DEFAULT_MIN_APPROACH_SPEED`].
//! - **Tension.** During restitution `dd < 0` and, when `chi |dd| / v0 > 1`, the formula gives a
//!   tensile (pulling) force. With `clip_tension` (the default) the force is `max(F, 0)`: a
//!   contact cannot pull, and both tangents are zero where the clip is active. Without it the
//!   formula is used as is.
//!
//! [`NormalContact`] turns any law into the engine's [`ContactLaw`](super::ContactLaw) for a
//! pin in a hole; the integrators do not use it yet.

mod adapter;
mod carvalho_martins;
mod flores;
mod gonthier;
mod hertz;
mod hunt_crossley;
mod kelvin_voigt;
mod lankarani_nikravesh;
mod power;

pub use adapter::NormalContact;
pub use carvalho_martins::CarvalhoMartins;
pub use flores::Flores;
pub use gonthier::Gonthier;
pub use hertz::Hertz;
pub use hunt_crossley::HuntCrossley;
pub use kelvin_voigt::KelvinVoigt;
pub use lankarani_nikravesh::LankaraniNikravesh;
pub use power::PowerLaw;

use crate::error::{Error, Result};

/// Default floor of the approach speed, m/s. Impacts slower than 1 mm/s carry negligible energy
/// in the mechanisms flexclear models (journal impact speeds of 0.01 to 1 m/s), and the floor
/// bounds the damping coefficient `chi K d^n / v0` of persistent contacts.
pub const DEFAULT_MIN_APPROACH_SPEED: f64 = 1e-3;

/// Default stiffness exponent of the Hertz family (point contact of Hertz theory; the value of
/// the Flores pin-in-hole benchmark).
pub const DEFAULT_EXPONENT: f64 = 1.5;

/// A normal-force law `F(d, dd; v0)`, N, compressive positive (the force pushes the bodies
/// apart). Implementations must return finite values for every finite input; `d <= 0` (open)
/// gives zero force and zero tangents.
pub trait NormalLaw: std::fmt::Debug + Send + Sync {
    /// Short name of the law, as in the Python class (`"LankaraniNikravesh"`).
    fn name(&self) -> &'static str;

    /// Normal force, N, at penetration `d` (m), penetration rate `dd` (m/s, positive closing)
    /// and approach speed of the episode `v0` (m/s; ignored by laws that do not need it, floored
    /// by those that do).
    fn force(&self, d: f64, dd: f64, v0: f64) -> f64;

    /// Closed-form tangents `(dF/dd, dF/d(dd))` in N/m and N s/m at the same arguments as
    /// [`NormalLaw::force`]. At `d = 0` the one-sided (contact side) limit is returned.
    fn tangent(&self, d: f64, dd: f64, v0: f64) -> (f64, f64);

    /// Whether the force depends on `dd` (a damped law).
    fn velocity_dependent(&self) -> bool;

    /// Whether the force depends on the approach speed of the episode.
    fn needs_approach_speed(&self) -> bool;

    /// Stiffness coefficient `K`, N/m^n.
    fn stiffness(&self) -> f64;

    /// Stiffness exponent `n` (1 for the linear spring-dashpot).
    fn exponent(&self) -> f64;

    /// Checks the parameters; `name` prefixes parameter names in errors (`"law"` gives
    /// `law.restitution`). The error names the parameter and its allowed range.
    fn validate(&self, name: &str) -> Result<()>;
}

/// A shared law is a law (the bindings hold laws in an `Arc`, so one Python law object can serve
/// several joints).
impl<T: NormalLaw + ?Sized> NormalLaw for std::sync::Arc<T> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    #[inline]
    fn force(&self, d: f64, dd: f64, v0: f64) -> f64 {
        (**self).force(d, dd, v0)
    }
    #[inline]
    fn tangent(&self, d: f64, dd: f64, v0: f64) -> (f64, f64) {
        (**self).tangent(d, dd, v0)
    }
    fn velocity_dependent(&self) -> bool {
        (**self).velocity_dependent()
    }
    fn needs_approach_speed(&self) -> bool {
        (**self).needs_approach_speed()
    }
    fn stiffness(&self) -> f64 {
        (**self).stiffness()
    }
    fn exponent(&self) -> f64 {
        (**self).exponent()
    }
    fn validate(&self, name: &str) -> Result<()> {
        (**self).validate(name)
    }
}

/// `prefix.field`, or `field` when `prefix` is empty.
pub(crate) fn pname(prefix: &str, field: &str) -> String {
    if prefix.is_empty() {
        field.to_string()
    } else {
        format!("{prefix}.{field}")
    }
}

/// Checks a stiffness coefficient: finite and > 0.
pub(crate) fn check_stiffness(prefix: &str, k: f64, unit: &str) -> Result<()> {
    crate::error::check_positive(&pname(prefix, "stiffness"), k, unit)
}

/// Checks a stiffness exponent: 1 <= n <= 3. Below 1 the tangent `n K d^(n-1)` is unbounded at
/// entry; no published contact model uses more than 3.
pub(crate) fn check_exponent(prefix: &str, n: f64) -> Result<()> {
    if n.is_finite() && (1.0..=3.0).contains(&n) {
        Ok(())
    } else {
        Err(Error::param(pname(prefix, "exponent"), n, "1 <= exponent <= 3"))
    }
}

/// Checks a restitution coefficient within `[lo, 1]` (`lo_open`: `lo` itself excluded).
pub(crate) fn check_restitution(prefix: &str, e: f64, lo: f64, lo_open: bool) -> Result<()> {
    let ok = e.is_finite() && e <= 1.0 && if lo_open { e > lo } else { e >= lo };
    if ok {
        Ok(())
    } else {
        let op = if lo_open { "<" } else { "<=" };
        Err(Error::param(
            pname(prefix, "restitution"),
            e,
            format!("{lo} {op} restitution <= 1"),
        ))
    }
}

/// Checks the approach-speed floor: finite and > 0 m/s.
pub(crate) fn check_min_approach_speed(prefix: &str, v: f64) -> Result<()> {
    crate::error::check_positive(&pname(prefix, "min_approach_speed"), v, "m/s")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every law of the module with the given nominal restitution (Hertz ignores it).
    pub(crate) fn all_laws(k: f64, e: f64) -> Vec<Box<dyn NormalLaw>> {
        vec![
            Box::new(Hertz::new(k)),
            Box::new(HuntCrossley::new(k, e)),
            Box::new(LankaraniNikravesh::new(k, e)),
            Box::new(Flores::new(k, e)),
            Box::new(Gonthier::new(k, e)),
            Box::new(CarvalhoMartins::new(k, e)),
            Box::new(KelvinVoigt::new(k, 1e-3 * k)),
        ]
    }

    #[test]
    fn closed_form_tangents_match_central_differences() {
        for e in [0.05, 0.5, 0.9, 1.0] {
            for law in all_laws(6.61e10, e) {
                for &(d, dd, v0) in &[
                    (1e-6, 0.3, 0.5),
                    (2.5e-5, -0.2, 0.7),
                    (4e-5, 0.0, 1e-4),
                    (1e-5, -0.01, 0.3),
                ] {
                    let (kd, kv) = law.tangent(d, dd, v0);
                    // central differences with relative steps 1e-6: truncation ~1e-12 relative,
                    // round-off ~1e-16 / 1e-6 = 1e-10 relative; 1e-6 leaves a wide margin
                    let hd = 1e-6 * d;
                    let fd = (law.force(d + hd, dd, v0) - law.force(d - hd, dd, v0)) / (2.0 * hd);
                    let hv = 1e-6 * dd.abs().max(1e-3);
                    let fv = (law.force(d, dd + hv, v0) - law.force(d, dd - hv, v0)) / (2.0 * hv);
                    let f = law.force(d, dd, v0);
                    let skip = law.force(d, dd + hv, v0) == 0.0 || law.force(d, dd - hv, v0) == 0.0;
                    if skip {
                        // a step across the tension clip: the derivative is one-sided there
                        continue;
                    }
                    let sd = (f / d).abs().max(kd.abs()) * 1e-6 + 1e-300;
                    let sv = fv.abs().max(kv.abs()) * 1e-6 + (f.abs() / 1.0) * 1e-9;
                    assert!(
                        (kd - fd).abs() <= sd,
                        "{} e={e} d={d} dd={dd}: {kd} vs {fd}",
                        law.name()
                    );
                    assert!(
                        (kv - fv).abs() <= sv,
                        "{} e={e} d={d} dd={dd}: {kv} vs {fv}",
                        law.name()
                    );
                }
            }
        }
    }

    #[test]
    fn open_contact_gives_zero() {
        for law in all_laws(1e9, 0.7) {
            for d in [0.0, -1e-6, -1.0] {
                assert_eq!(law.force(d, 1.0, 1.0), 0.0, "{}", law.name());
                if d < 0.0 {
                    assert_eq!(law.tangent(d, 1.0, 1.0), (0.0, 0.0), "{}", law.name());
                }
            }
        }
    }

    #[test]
    fn extremes_are_finite_or_named_errors() {
        for k in [1e3, 1e8, 1e13] {
            for e in [0.01, 0.3, 1.0] {
                for law in all_laws(k, e) {
                    law.validate("law").unwrap();
                    for &(d, dd, v0) in &[
                        (1e-12, 1e3, 0.0),
                        (1.0, -1e3, f64::NAN),
                        (1e-3, 1e-9, -5.0),
                        (10.0, 1e6, 1e-9),
                    ] {
                        let f = law.force(d, dd, v0);
                        let (a, b) = law.tangent(d, dd, v0);
                        assert!(
                            f.is_finite() && a.is_finite() && b.is_finite(),
                            "{} {k} {e}",
                            law.name()
                        );
                    }
                }
            }
        }
        let bad = [
            HuntCrossley::new(1e9, 1.5).validate("j").unwrap_err(),
            Flores::new(1e9, 0.0).validate("j").unwrap_err(),
            Gonthier::new(f64::NAN, 0.5).validate("j").unwrap_err(),
        ];
        let names: Vec<_> = bad
            .iter()
            .map(|e| match e {
                Error::InvalidParameter { name, .. } => name.clone(),
                _ => panic!("{e}"),
            })
            .collect();
        assert_eq!(names, ["j.restitution", "j.restitution", "j.stiffness"]);
    }
}
