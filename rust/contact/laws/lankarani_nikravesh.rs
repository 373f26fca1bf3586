//! The Lankarani-Nikravesh law (1990), the default of most clearance-joint papers.

use super::power::hysteresis_law;

hysteresis_law! {
    /// Lankarani & Nikravesh (1990), "A contact force model with hysteresis damping for impact
    /// analysis of multibody systems", J. Mech. Des. 112:369-376: `chi = 3 (1 - e^2) / 4`, from an
    /// energy balance valid for `e` near 1 (0.9 and above). Nominal `e` in [0, 1]; effective
    /// restitution 0.913 at nominal 0.9, 0.725 at 0.5.
    LankaraniNikravesh, "LankaraniNikravesh", restitution_from(0.0, open: false),
    chi(e) = 0.75 * (1.0 - e * e), "`chi = 3 (1 - e^2) / 4`"
}
