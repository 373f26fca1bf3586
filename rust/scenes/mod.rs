//! The test mechanisms flexclear ships (`docs/scenes.md`), every one built here as the one user
//! model, a [`Mechanism`], so that Rust tests, benches and the Python API (`flexclear.scenes`,
//! thin wrappers over these) share one definition: the slider-yoke, the flexible slider-crank,
//! the four-bar, the spin-up, the spinning beam in a bearing and the Flores slider-crank (rigid
//! links, a clearance joint at the piston pin).
//!
//! [`Mechanism`]: crate::model::mechanism::Mechanism

pub mod bearing;
pub mod flores;
pub mod four_bar;
pub mod slider_crank;
pub mod slider_yoke;
pub mod spin_up;
pub mod spinning_beam;

pub use bearing::{hertz_pin_stiffness, hertz_secant, BearingDerived};
pub use flores::FloresSliderCrank;
pub use four_bar::{FlexibleFourBar, FourBarPin};
pub use slider_crank::{FlexibleSliderCrank, SliderCrankPin};
pub use slider_yoke::{SliderYoke, SliderYokeGeometry};
pub use spin_up::{SpinUp, SpinUpData, SpinUpValues};
pub use spinning_beam::spinning_beam_in_a_bearing;

use crate::error::{Error, Result};

/// An invalid scene parameter; the value is shown with a decimal point (`-1.0`, as Python shows
/// it: these errors reach Python users of `flexclear.scenes.slider_crank` unchanged).
fn bad(name: &str, value: f64, allowed: impl Into<String>) -> Error {
    Error::param(name, format!("{value:?}"), allowed)
}

/// `value` must be finite and > 0.
fn positive(name: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(bad(name, value, "a finite number > 0"))
    }
}

/// `value` must be finite.
fn finite(name: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(bad(name, value, "a finite number"))
    }
}
