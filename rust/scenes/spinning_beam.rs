//! A spinning cantilever whose tip rattles in a clearance bearing on its hub: the test case of the
//! constant-rate stepper (moving frames at a constant rate of rotation, no geometric terms), used
//! by `tests/constant_rate.rs` and `examples/profile_newton.rs`.

use std::sync::Arc;

use crate::contact::{DampingLaw, SpringDamper};
use crate::kinematics::{FrameKinematics, RotatingFrame, Rotation};
use crate::model::mechanism::{Clearance, Endpoint, Link, Mechanism, Support, Terms};
use crate::model::section::BeamSection;
use crate::model::Motion;

fn hub(rotation: Rotation) -> Arc<dyn FrameKinematics> {
    Arc::new(
        RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, rotation)
            .expect("a fixed origin and a constant rotation are valid"),
    )
}

/// A steel cantilever (0.3 m, 8 x 8 mm, 6 elements, first bending frequency about 72 Hz, 5 %
/// of E as Kelvin-Voigt damping rate 1e-5 s) clamped to a hub spinning at 30 rad/s, geometric
/// terms off; its tip is the journal of a clearance joint (0.1 mm, K_B = 1e7 N/m, C_B = 20 N s/m)
/// whose bearing rides on the hub at the tip's nominal position. The beam starts with a
/// transverse velocity growing linearly to 0.2 m/s at the tip (about 4e-4 m of amplitude against
/// 1e-4 of clearance): the tip rattles in the bearing.
pub fn spinning_beam_in_a_bearing() -> Mechanism {
    let spin = Rotation::Constant {
        angle0: 0.3,
        rate: 30.0,
    };
    let a = 0.008f64;
    let n = 6;
    let mut v0 = vec![0.0; 3 * (n + 1)];
    for nd in 0..=n {
        v0[3 * nd + 1] = 0.2 * nd as f64 / n as f64;
    }
    Mechanism {
        links: vec![Link {
            name: "beam".into(),
            section: BeamSection {
                length: 0.3,
                elements: n,
                youngs_modulus: 2e11,
                density: 7870.0,
                damping: 2e6,
                area: a * a,
                inertia: a.powi(4) / 12.0,
            },
            frame: hub(spin.clone()),
            terms: Terms {
                geometric: Some(false),
                ..Terms::default()
            },
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: Some(v0),
            rigid: None,
        }],
        supports: vec![Support {
            link: 0,
            node: 0,
            fixed: [true; 3],
        }],
        joints: vec![Clearance {
            friction: None,
            name: "tip".into(),
            journal: Endpoint::Node { link: 0, node: n },
            bearing: Endpoint::Body {
                frame: hub(spin),
                point: [0.3, 0.0],
                name: "hub".into(),
            },
            clearance: 1e-4,
            law: Arc::new(SpringDamper {
                stiffness: 1e7,
                damping: 20.0,
                damping_law: DampingLaw::Viscous,
                no_tension: false,
            }),
        }],
        ..Default::default()
    }
}
