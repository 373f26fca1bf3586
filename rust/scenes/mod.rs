//! The test mechanisms flexclear ships (`shared/SCENES.md`), built as plain [`Model`]s so that
//! Rust benches and the Python API share one definition.
//!
//! [`Model`]: crate::model::Model

pub mod slider_yoke;

pub use slider_yoke::{SliderYoke, SliderYokeGeometry};
