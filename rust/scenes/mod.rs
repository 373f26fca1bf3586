//! The test mechanisms flexclear ships (`docs/scenes.md`), built as plain [`Model`]s (the
//! slider-yoke) or KED [`Mechanism`]s (the flexible slider-crank) so that Rust tests, benches and
//! the Python API share one definition.
//!
//! [`Model`]: crate::model::Model
//! [`Mechanism`]: crate::model::mechanism::Mechanism

pub mod slider_crank;
pub mod slider_yoke;

pub use slider_crank::{FlexibleSliderCrank, SliderCrankPin};
pub use slider_yoke::{SliderYoke, SliderYokeGeometry};
