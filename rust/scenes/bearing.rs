//! The bearing of a scene's pin clearance joint when its data are derived: the Hertz secant
//! stiffness of a journal in its bore, and the derived values a scene reports.

/// Secant stiffness (N/m) at `penetration` (m) of the Hertz law `F = K_h delta^1.5` for a journal
/// of `radius` (m) in a bearing of radius `radius + clearance`, both of the same material
/// (Young's modulus in Pa): `K_h = (4/3) E* sqrt(R*)` with `E* = E / (2 (1 - nu^2))` and
/// `R* = R (R + c) / c` (the conformal internal contact, as in Lankarani & Nikravesh 1990).
pub fn hertz_secant(youngs_modulus: f64, poisson_ratio: f64, radius: f64, clearance: f64, penetration: f64) -> f64 {
    let r_star = radius * (radius + clearance) / clearance;
    hertz_stiffness(youngs_modulus, poisson_ratio, r_star) * penetration.sqrt()
}

/// The Hertz stiffness of a journal of radius `journal_radius` in a bearing of radius
/// `bearing_radius`, both of modulus `youngs_modulus` (Pa) and Poisson's ratio `poisson_ratio`:
/// `K = (4/3) E* sqrt(R_B R_J / (R_B - R_J))`, N/m^1.5 (as
/// `flexclear.contact.pin_in_hole(..., model="hertz")`).
pub fn hertz_pin_stiffness(bearing_radius: f64, journal_radius: f64, youngs_modulus: f64, poisson_ratio: f64) -> f64 {
    let r_star = bearing_radius * journal_radius / (bearing_radius - journal_radius);
    hertz_stiffness(youngs_modulus, poisson_ratio, r_star)
}

/// `K_h = (4/3) E* sqrt(R*)` (N/m^1.5) with `E* = E / (2 (1 - nu^2))` of one material (Pa) and
/// the effective radius `R*` (m).
fn hertz_stiffness(youngs_modulus: f64, poisson_ratio: f64, r_star: f64) -> f64 {
    let e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio * poisson_ratio));
    4.0 / 3.0 * e_star * r_star.sqrt()
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
