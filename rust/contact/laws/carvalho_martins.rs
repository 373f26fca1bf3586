//! The Carvalho-Martins law (2019): a Hunt-Crossley form whose effective restitution is close to
//! the nominal one over the whole range.

use super::power::hysteresis_law;

hysteresis_law! {
    /// Carvalho & Martins (2019), "Exact restitution and generalizations for the Hunt-Crossley
    /// contact model", Mech. Mach. Theory 139:174-194: `chi = (3/2) (1 - e) (11 - e) / (1 + 9 e)`,
    /// an approximation of the exact restitution of the Hunt-Crossley form (Exudyn uses it above
    /// e = 1/3). Nominal `e` in (0, 1]. Its effective restitution (measured by
    /// [`effective_restitution`](crate::contact::restitution::effective_restitution)) is within
    /// 2e-4 of the nominal one for e >= 0.5 and 4e-3 at e = 0.3, but 0.21 at e = 0.2 and 0.067 at
    /// e = 0.01: below about 1/3 use [`Gonthier`](super::Gonthier).
    CarvalhoMartins, "CarvalhoMartins", restitution_from(0.0, open: true),
    chi(e) = 1.5 * (1.0 - e) * (11.0 - e) / (1.0 + 9.0 * e), "`chi = (3/2) (1 - e) (11 - e) / (1 + 9 e)`"
}
