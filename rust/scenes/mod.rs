//! The test mechanisms flexclear ships (`docs/scenes.md`), every one built here as the one user
//! model, a [`Mechanism`], so that Rust tests, benches and the Python API (`flexclear.scenes`,
//! thin wrappers over these) share one definition: the slider-yoke, the flexible slider-crank,
//! the four-bar and the spin-up.
//!
//! [`Mechanism`]: crate::model::mechanism::Mechanism

pub mod four_bar;
pub mod slider_crank;
pub mod slider_yoke;
pub mod spin_up;

pub use four_bar::{FlexibleFourBar, FourBarPin};
pub use slider_crank::{FlexibleSliderCrank, SliderCrankPin};
pub use slider_yoke::{SliderYoke, SliderYokeGeometry};
pub use spin_up::{SpinUp, SpinUpData, SpinUpValues};
