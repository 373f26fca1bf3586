//! What a run is asked to record ([`RecordSpec`]): which joints, nodes and link channels, how
//! often and from when, and its checks.

use std::sync::Arc;

use super::SliderReference;
use crate::error::{Error, Result};

/// What to record. The default records every joint's penetration and force at every step.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSpec {
    /// Joints (indices) whose histories are kept; `None` = all joints.
    pub joints: Option<Vec<usize>>,
    /// Also keep the journal position `q` (qx, qy), m, of the recorded joints.
    pub joint_position: bool,
    /// Nodes `(link, node)` whose displacements `(u, v, theta)` (link frame) are kept.
    pub nodes: Vec<(usize, usize)>,
    /// Keep every k-th step (k >= 1); step 0 (the initial state) is always a sample.
    pub every: usize,
    /// Keep histories at all; `false` keeps only the running extremes (and, on the Newton
    /// stepper, the output grid with the link channels and slider histories only when those are
    /// asked for: `links` or `sliders`).
    pub histories: bool,
    /// Keep the sliders' position, velocity and acceleration histories (and the output grid they
    /// live on) even when `histories` is `false`. With `histories` they are kept anyway.
    pub sliders: bool,
    /// A reference motion of the sliders on this run's output grid (e.g. the same mechanism with
    /// ideal joints): each slider accumulates online, at every output point from `start` on, the
    /// sum and the largest of `|x - x_ref|` per channel ([`SliderHistory::deviation_sum`](super::SliderHistory::deviation_sum)): O(1)
    /// memory per slider. Shared (one reference for many runs).
    pub slider_reference: Option<Arc<SliderReference>>,
    /// Histories and extremes start at this time, s (e.g. to skip a transient).
    pub start: f64,
    /// Keep an impact log ([`Impact`](super::Impact)) of the recorded joints (independent of `histories`).
    pub impacts: bool,
    /// Link channels of moving-frame runs, at the same stride (the constant stepper records the
    /// displacements of the chosen `nodes` instead).
    pub links: LinkChannels,
    /// Track every joint's contact modes (free flight, impact, continuous contact) and the energy
    /// dissipated in it ([`JointExtremes::free_flight_fraction`](super::JointExtremes::free_flight_fraction),
    /// [`JointExtremes::dissipated_energy`](super::JointExtremes::dissipated_energy)): O(1) per joint, but a few more operations per joint
    /// and step, so off unless asked for (the fractions and the energy are then NaN).
    pub contact_modes: bool,
}

/// Per-link channels a moving-frame run records every `every` steps (with the frame state of
/// every link, always).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkChannels {
    /// All nodal displacements `u, v, theta` of every link (link frame, m and rad).
    pub displacements: bool,
    /// Axial force of every element, N.
    pub axial_force: bool,
    /// Midspan transverse deflection of every link relative to the chord through its end
    /// nodes, m.
    pub midspan: bool,
    /// Kinetic energy (absolute motion, J), linear strain energy (J) and angular momentum about
    /// the frame origin (kg m^2/s) of every link.
    pub energy: bool,
    /// The running peaks of every flexible link: the largest magnitude of its midspan deflection
    /// (m) and of any element's axial force (N) over every step from `RecordSpec::start` on
    /// ([`LinkHistory::peaks`](super::LinkHistory::peaks)): O(1) memory per link,
    /// whatever the stride and `histories`. Tracked by the Newton stepper (a model the constant
    /// stepper would run runs there when they are asked for, as for `energy`).
    pub peaks: bool,
}

impl LinkChannels {
    /// No link channel (the frame state alone): a run that keeps joint outputs only.
    pub const NONE: LinkChannels = LinkChannels {
        displacements: false,
        axial_force: false,
        midspan: false,
        energy: false,
        peaks: false,
    };
}

impl Default for LinkChannels {
    fn default() -> Self {
        LinkChannels {
            displacements: true,
            axial_force: false,
            midspan: false,
            energy: false,
            peaks: false,
        }
    }
}

impl Default for RecordSpec {
    fn default() -> Self {
        RecordSpec {
            joints: None,
            joint_position: false,
            nodes: Vec::new(),
            every: 1,
            histories: true,
            sliders: false,
            slider_reference: None,
            start: 0.0,
            impacts: false,
            links: LinkChannels::default(),
            contact_modes: false,
        }
    }
}

impl RecordSpec {
    /// Checks the spec against a model with `joints` joints and the given links' node counts.
    pub fn validate(&self, joints: usize, link_nodes: &[usize]) -> Result<()> {
        if self.every < 1 {
            return Err(Error::param("record.every", self.every, "an integer >= 1"));
        }
        if !self.start.is_finite() || self.start < 0.0 {
            return Err(Error::param("record.start", self.start, "finite and >= 0 s"));
        }
        if let Some(js) = &self.joints {
            if let Some(&j) = js.iter().find(|&&j| j >= joints) {
                return Err(Error::param("record.joints", j, format!("joint indices 0 .. {joints}")));
            }
        }
        for &(l, n) in &self.nodes {
            match link_nodes.get(l) {
                None => {
                    return Err(Error::param(
                        "record.nodes",
                        format!("link #{l}"),
                        format!("a link index 0 .. {}", link_nodes.len()),
                    ))
                }
                Some(&count) if n >= count => {
                    return Err(Error::param(
                        "record.nodes",
                        format!("node {n} of link #{l}"),
                        format!("a node 0 ..= {}", count - 1),
                    ))
                }
                _ => {}
            }
        }
        Ok(())
    }
}
