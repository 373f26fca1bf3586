//! Helpers shared by the integration tests (a module of `tests/integration.rs`, the one test
//! binary; each test file uses what it needs).

use std::sync::Arc;

use flexclear::kinematics::{FrameKinematics, RotatingFrame, Rotation};
use flexclear::model::mechanism::Link;
use flexclear::model::section::BeamSection;
use flexclear::model::Motion;

/// A frame at the global origin with the given rotation.
pub fn hub(rotation: Rotation) -> Arc<dyn FrameKinematics> {
    Arc::new(RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, rotation).unwrap())
}

/// A frame at rest.
pub fn fixed_frame() -> Arc<dyn FrameKinematics> {
    hub(Rotation::Fixed { angle: 0.0 })
}

/// A beam link `name` of `elements` elements (SI units, no damping) in `frame`.
#[allow(clippy::too_many_arguments)]
pub fn link(
    name: &str,
    length: f64,
    elements: usize,
    e: f64,
    rho: f64,
    area: f64,
    inertia: f64,
    frame: Arc<dyn FrameKinematics>,
) -> Link {
    Link::new(
        name,
        BeamSection {
            length,
            elements,
            youngs_modulus: e,
            density: rho,
            damping: 0.0,
            area,
            inertia,
        },
        frame,
    )
}
