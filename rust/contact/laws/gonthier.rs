//! The Gonthier et al. law (2004), usable at low restitution.

use super::power::hysteresis_law;

hysteresis_law! {
    /// Gonthier, McPhee, Lange & Piedboeuf (2004), "A regularized contact model with asymmetric
    /// damping and dwell-time dependent friction", Multibody Syst. Dyn. 11:209-233:
    /// `chi = (1 - e^2) / e`. Nominal `e` in (0, 1] (chi is unbounded as e -> 0).
    Gonthier, "Gonthier", restitution_from(0.0, open: true),
    chi(e) = (1.0 - e * e) / e, "`chi = (1 - e^2) / e`"
}
