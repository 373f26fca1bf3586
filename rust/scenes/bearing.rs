//! The bearing of a scene's pin clearance joint when its data are derived: the Hertz secant
//! stiffness of a journal in its bore, and the derived values a scene reports.

/// Secant stiffness (N/m) at `penetration` (m) of the Hertz law `F = K_h delta^1.5` for a journal
/// of `radius` (m) in a bearing of radius `radius + clearance`, both of the same material
/// (Young's modulus in Pa): `K_h = (4/3) E* sqrt(R*)` with `E* = E / (2 (1 - nu^2))` and
/// `R* = R (R + c) / c` (the conformal internal contact, as in Lankarani & Nikravesh 1990).
pub fn hertz_secant(youngs_modulus: f64, poisson_ratio: f64, radius: f64, clearance: f64, penetration: f64) -> f64 {
    let e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio * poisson_ratio));
    let r_star = radius * (radius + clearance) / clearance;
    4.0 / 3.0 * e_star * r_star.sqrt() * penetration.sqrt()
}

/// Derived values of the clearance joint's bearing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingDerived {
    /// Bearing stiffness K_B, N/m.
    pub bearing_stiffness: f64,
    /// Bearing damping C_B, N s/m.
    pub bearing_damping: f64,
    /// The mass the derived C_B is critical for, kg.
    pub effective_mass: f64,
}
