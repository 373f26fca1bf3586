//! The Hunt-Crossley law (1975): hysteresis damping proportional to the elastic force.

use super::power::hysteresis_law;

hysteresis_law! {
    /// Hunt & Crossley (1975), "Coefficient of restitution interpreted as damping in vibroimpact",
    /// J. Appl. Mech. 42:440-445: `chi = 3 (1 - e) / 2`, derived for `e` near 1. Nominal `e` in
    /// [0, 1]; its effective restitution exceeds `e` as `e` falls (0.663 at nominal 0.5).
    HuntCrossley, "HuntCrossley", restitution_from(0.0, open: false),
    chi(e) = 1.5 * (1.0 - e), "`chi = 3 (1 - e) / 2`"
}
