//! The Flores et al. law (2011), for any restitution.

use super::power::hysteresis_law;

hysteresis_law! {
    /// Flores, Machado, Silva & Martins (2011), "On the continuous contact force models for soft
    /// materials in multibody dynamics", Multibody Syst. Dyn. 25:357-375: `chi = 8 (1 - e) / (5 e)`
    /// (Chrono's SMC "Flores" model). Nominal `e` in (0, 1].
    Flores, "Flores", restitution_from(0.0, open: true),
    chi(e) = 1.6 * (1.0 - e) / e, "`chi = 8 (1 - e) / (5 e)`"
}
