//! What a run keeps: chosen joints' penetration, force and journal position, chosen nodes'
//! displacements, every k-th step from a start time; running extremes of every joint, which
//! cost O(joints) memory whatever the run length; and, when asked, an impact log per chosen joint
//! (one entry per contact episode: memory grows with the number of impacts, not of steps).

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
    /// Keep histories at all; `false` keeps only the running extremes.
    pub histories: bool,
    /// Histories and extremes start at this time, s (e.g. to skip a transient).
    pub start: f64,
    /// Keep an impact log ([`Impact`]) of the recorded joints (independent of `histories`).
    pub impacts: bool,
    /// Link channels of moving-frame runs, at the same stride (the constant stepper records the
    /// displacements of the chosen `nodes` instead).
    pub links: LinkChannels,
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
}

impl Default for LinkChannels {
    fn default() -> Self {
        LinkChannels {
            displacements: true,
            axial_force: false,
            midspan: false,
            energy: false,
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
            start: 0.0,
            impacts: false,
            links: LinkChannels::default(),
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

/// Histories of one joint.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JointHistory {
    /// Joint index.
    pub joint: usize,
    /// Penetration `delta_r - delta_c`, m (negative when open).
    pub penetration: Vec<f64>,
    /// Magnitude of the contact force that acted in the step, N.
    pub force: Vec<f64>,
    /// Journal position relative to the bearing centre, m (only when asked).
    pub qx: Vec<f64>,
    /// See `qx`.
    pub qy: Vec<f64>,
}

/// One contact episode of a joint (open -> closed -> open).
///
/// On fixed steps the entry and exit are known to the step: the entry is the first step that ends
/// closed, and the speed and peaks are those of the recorded steps. With event-aware stepping the
/// entry (and exit) is the cut at the crossing, the speed is the approach speed there and the
/// peak force includes the force just after the cut (the dashpot jump at entry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Entry time, s.
    pub time: f64,
    /// Normal approach speed at entry, `q' . q / |q|`, m/s.
    pub speed: f64,
    /// Largest contact force magnitude during the episode, N.
    pub peak_force: f64,
    /// Largest penetration during the episode, m.
    pub peak_penetration: f64,
    /// Time in contact (exit minus entry), s; NaN while still closed at the end of the run.
    pub duration: f64,
}

/// Histories of one node (link frame).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeHistory {
    /// Link index.
    pub link: usize,
    /// Node index.
    pub node: usize,
    /// Axial displacement, m.
    pub u: Vec<f64>,
    /// Transverse displacement, m.
    pub v: Vec<f64>,
    /// Rotation, rad.
    pub theta: Vec<f64>,
}

/// Histories of one link in a moving frame, on the output grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinkHistory {
    /// Frame state at each record: origin x, y (m), angle (rad), rate (rad/s).
    pub frame: Vec<[f64; 4]>,
    /// Nodal displacements, `3 (N + 1)` per record (link frame; m, m, rad).
    pub displacements: Vec<f64>,
    /// Element axial forces, N per record, N.
    pub axial_force: Vec<f64>,
    /// Midspan deflection relative to the chord, m.
    pub midspan: Vec<f64>,
    /// Kinetic energy, J.
    pub kinetic: Vec<f64>,
    /// Linear strain energy `Q^T K1 Q / 2`, J.
    pub strain: Vec<f64>,
    /// Angular momentum about the frame origin, kg m^2/s.
    pub momentum: Vec<f64>,
}

/// Running extremes of one joint from `RecordSpec::start` on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointExtremes {
    /// Largest penetration, m (negative if never in contact).
    pub max_penetration: f64,
    /// Time of the largest penetration, s.
    pub time_of_max_penetration: f64,
    /// Largest contact force magnitude, N.
    pub max_force: f64,
    /// Number of impacts (open -> closed transitions).
    pub impacts: u64,
    /// Total time in contact, s.
    pub contact_time: f64,
    /// Largest magnitude of the journal's velocity relative to the bearing, `|q'|`, m/s.
    pub max_velocity: f64,
    /// Largest normal approach speed `q' . q / |q|` at an impact (the step that closes), m/s.
    pub max_impact_velocity: f64,
    /// Sum of squared penetrations over the recorded steps, m^2 (for the RMS); scaled by
    /// `2^-1200` when `sums_scaled[0]` (see [`SQUARE_SCALE_FROM`]).
    pub sum_sq_penetration: f64,
    /// Sum of squared force magnitudes over the recorded steps, N^2 (for the RMS); scaled as the
    /// penetration's when `sums_scaled[1]`.
    pub sum_sq_force: f64,
    /// Whether each sum (penetration, force) is kept scaled.
    pub sums_scaled: [bool; 2],
    /// Steps that entered the sums (from `RecordSpec::start` on).
    pub samples: u64,
}

/// A value beyond this magnitude (2^500, about 3.3e150) would let a sum of squares overflow:
/// from the first such value on, the sum is kept scaled by 2^-1200 (a power of two: exact, apart
/// from parts below 1e-210 of the sum that drop out), so the RMS of a run with absurd values (a
/// clearance of 1e300 m) stays finite instead of turning inf. Ordinary runs never reach it and
/// keep the plain sum, bit for bit.
pub const SQUARE_SCALE_FROM: f64 = 3.273_390_607_896_142e150;
const DOWN: f64 = 2.409_919_865_102_884e-181; // 2^-600

/// Adds `x^2` to `sum` (scaled per `scaled`, see [`SQUARE_SCALE_FROM`]).
#[inline(always)]
fn add_square(sum: &mut f64, scaled: &mut bool, x: f64) {
    if *scaled || x.abs() > SQUARE_SCALE_FROM {
        add_square_scaled(sum, scaled, x);
    } else {
        *sum += x * x;
    }
}

#[cold]
fn add_square_scaled(sum: &mut f64, scaled: &mut bool, x: f64) {
    if !*scaled {
        *sum *= DOWN * DOWN;
        *scaled = true;
    }
    let y = x * DOWN;
    *sum += y * y;
}

/// `sqrt(sum / n)` of a sum kept as [`add_square`] keeps it.
fn root_mean(sum: f64, scaled: bool, n: u64) -> f64 {
    let r = (sum / n as f64).sqrt();
    if scaled {
        r / DOWN
    } else {
        r
    }
}

impl JointExtremes {
    /// Root mean square of the penetration over the recorded steps, m (NaN before any step).
    pub fn rms_penetration(&self) -> f64 {
        root_mean(self.sum_sq_penetration, self.sums_scaled[0], self.samples)
    }

    /// Root mean square of the contact force magnitude over the recorded steps, N.
    pub fn rms_force(&self) -> f64 {
        root_mean(self.sum_sq_force, self.sums_scaled[1], self.samples)
    }
}

impl Default for JointExtremes {
    fn default() -> Self {
        JointExtremes {
            max_penetration: f64::NEG_INFINITY,
            time_of_max_penetration: 0.0,
            max_force: 0.0,
            impacts: 0,
            contact_time: 0.0,
            max_velocity: 0.0,
            max_impact_velocity: 0.0,
            sum_sq_penetration: 0.0,
            sum_sq_force: 0.0,
            sums_scaled: [false; 2],
            samples: 0,
        }
    }
}

/// The recorder of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Recorder {
    /// Sample times, s.
    pub time: Vec<f64>,
    /// Joint histories.
    pub joints: Vec<JointHistory>,
    /// Node histories.
    pub nodes: Vec<NodeHistory>,
    /// Link histories of a moving-frame run (one per link; empty for the constant stepper,
    /// whose link channels come from `nodes`).
    pub links: Vec<LinkHistory>,
    /// Extremes of every joint (indexed like the model's joints).
    pub extremes: Vec<JointExtremes>,
    /// Impact logs of the recorded joints (parallel to `joints` of the spec; empty unless
    /// `RecordSpec::impacts`): `(joint index, impacts)`.
    pub impacts: Vec<(usize, Vec<Impact>)>,
    /// For every joint, the slot in `impacts` when it is logged.
    impact_slot: Vec<Option<usize>>,
    was_closed: Vec<bool>,
    spec_every: usize,
    spec_start: f64,
    histories: bool,
    position: bool,
    node_dofs: Vec<usize>,
}

/// Samples reserved per history channel when a recorder is made; beyond that the histories grow
/// (amortized doubling) as the run records them.
pub const INITIAL_SAMPLES: usize = 1 << 16;

impl Recorder {
    /// A recorder for `spec`; `node_dof(link, node)` gives a node's first global DOF; `steps` sets
    /// the expected number of samples, of which at most [`INITIAL_SAMPLES`] are reserved up front
    /// (histories then grow in chunks: a long run never reserves its whole history at once).
    pub fn new(spec: &RecordSpec, joints: usize, node_dof: impl Fn(usize, usize) -> usize, steps: u64) -> Self {
        let js: Vec<usize> = spec.joints.clone().unwrap_or_else(|| (0..joints).collect());
        let samples = if spec.histories {
            (steps / spec.every as u64 + 2) as usize
        } else {
            0
        };
        let samples = samples.min(INITIAL_SAMPLES);
        let cap = |on: bool| if on { Vec::with_capacity(samples) } else { Vec::new() };
        Recorder {
            time: cap(spec.histories),
            joints: if spec.histories {
                js.iter()
                    .map(|&j| JointHistory {
                        joint: j,
                        penetration: cap(true),
                        force: cap(true),
                        qx: cap(spec.joint_position),
                        qy: cap(spec.joint_position),
                    })
                    .collect()
            } else {
                Vec::new()
            },
            nodes: if spec.histories {
                spec.nodes
                    .iter()
                    .map(|&(l, n)| NodeHistory {
                        link: l,
                        node: n,
                        u: cap(true),
                        v: cap(true),
                        theta: cap(true),
                    })
                    .collect()
            } else {
                Vec::new()
            },
            links: Vec::new(),
            node_dofs: spec.nodes.iter().map(|&(l, n)| node_dof(l, n)).collect(),
            impacts: if spec.impacts {
                js.iter().map(|&j| (j, Vec::new())).collect()
            } else {
                Vec::new()
            },
            impact_slot: (0..joints)
                .map(|j| {
                    if spec.impacts {
                        js.iter().position(|&k| k == j)
                    } else {
                        None
                    }
                })
                .collect(),
            extremes: vec![JointExtremes::default(); joints],
            was_closed: vec![false; joints],
            spec_every: spec.every,
            spec_start: spec.start,
            histories: spec.histories,
            position: spec.joint_position,
        }
    }

    /// Takes the state at an instant `t` (s) between output steps (the cut of an event-aware
    /// step, just after a contact status change; arguments as in [`Self::record`]): the force
    /// enters the running largest force, and a joint whose status changed there starts its impact
    /// (counted here, with the approach speed at the cut) or ends it (exact duration). Nothing
    /// enters the histories or the RMS sums.
    pub fn record_event(&mut self, t: f64, pen: &[f64], force: &[f64], q: &[[f64; 2]], qd: &[[f64; 2]]) {
        if t < self.spec_start {
            return;
        }
        for (j, e) in self.extremes.iter_mut().enumerate() {
            e.max_force = e.max_force.max(force[j]);
            let closed = pen[j] > 0.0;
            let log = self.impact_slot[j].map(|k| &mut self.impacts[k].1);
            if closed && !self.was_closed[j] {
                enter(e, log, t, pen[j], force[j], q[j], qd[j]);
            } else if let Some(last) = open_impact(log) {
                if closed {
                    last.peak_force = last.peak_force.max(force[j]);
                } else if self.was_closed[j] {
                    last.duration = t - last.time;
                }
            }
            self.was_closed[j] = closed;
        }
    }

    /// Records step `step` at time `t` (s), step length `dt` (s). `pen[j]`, `force[j]`, `q[j]`
    /// and `qd[j]` are every joint's penetration (m), force magnitude (N), position (m) and
    /// velocity (m/s); `u` the global displacement vector.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        step: u64,
        t: f64,
        dt: f64,
        pen: &[f64],
        force: &[f64],
        q: &[[f64; 2]],
        qd: &[[f64; 2]],
        u: &[f64],
    ) {
        if t < self.spec_start {
            for (c, &p) in self.was_closed.iter_mut().zip(pen) {
                *c = p > 0.0;
            }
            return;
        }
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            if p > e.max_penetration {
                e.max_penetration = p;
                e.time_of_max_penetration = t;
            }
            let f = force[j];
            e.max_force = e.max_force.max(f);
            add_square(&mut e.sum_sq_penetration, &mut e.sums_scaled[0], p);
            add_square(&mut e.sum_sq_force, &mut e.sums_scaled[1], f);
            e.samples += 1;
            let [vx, vy] = qd[j];
            let v2 = vx * vx + vy * vy;
            if v2 > e.max_velocity * e.max_velocity {
                e.max_velocity = v2.sqrt();
            }
            let closed = p > 0.0;
            let log = self.impact_slot[j].map(|k| &mut self.impacts[k].1);
            if closed {
                if !self.was_closed[j] && step > 0 {
                    enter(e, log, t, p, f, q[j], qd[j]);
                } else if let Some(last) = open_impact(log) {
                    last.peak_force = last.peak_force.max(f);
                    last.peak_penetration = last.peak_penetration.max(p);
                }
                if step > 0 {
                    e.contact_time += dt;
                }
            } else if self.was_closed[j] {
                if let Some(last) = open_impact(log) {
                    last.duration = t - last.time;
                }
            }
            self.was_closed[j] = closed;
        }
        if !self.histories || !step.is_multiple_of(self.spec_every as u64) {
            return;
        }
        self.time.push(t);
        for h in &mut self.joints {
            h.penetration.push(pen[h.joint]);
            h.force.push(force[h.joint]);
            if self.position {
                h.qx.push(q[h.joint][0]);
                h.qy.push(q[h.joint][1]);
            }
        }
        for (h, &d) in self.nodes.iter_mut().zip(&self.node_dofs) {
            h.u.push(u[d]);
            h.v.push(u[d + 1]);
            h.theta.push(u[d + 2]);
        }
    }
}

/// An impact of a joint at time `t` (s): counted in its extremes `e` with its normal approach
/// speed, and started in its impact log (if kept) with penetration `pen` (m) and force `force` (N).
fn enter(
    e: &mut JointExtremes,
    log: Option<&mut Vec<Impact>>,
    t: f64,
    pen: f64,
    force: f64,
    q: [f64; 2],
    qd: [f64; 2],
) {
    let speed = normal_speed(q, qd);
    e.impacts += 1;
    e.max_impact_velocity = e.max_impact_velocity.max(speed);
    if let Some(log) = log {
        log.push(Impact {
            time: t,
            speed,
            peak_force: force,
            peak_penetration: pen,
            duration: f64::NAN,
        });
    }
}

/// The impact of a log that is still going on (the last one, with no duration yet).
fn open_impact(log: Option<&mut Vec<Impact>>) -> Option<&mut Impact> {
    log?.last_mut().filter(|i| i.duration.is_nan())
}

/// The normal approach speed `q' . q / |q|` (m/s) of a journal at `q` (m) moving at `qd` (m/s);
/// zero at the bearing centre.
#[inline]
fn normal_speed(q: [f64; 2], qd: [f64; 2]) -> f64 {
    let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
    if r > 0.0 {
        (qd[0] * q[0] + qd[1] * q[1]) / r
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_of_squares_of_huge_values_stay_finite_and_ordinary_ones_are_untouched() {
        assert_eq!(SQUARE_SCALE_FROM, 2f64.powi(500));
        assert_eq!(DOWN, 2f64.powi(-600));
        // ordinary values: the plain sum, bit for bit
        let (mut sum, mut scaled) = (0.0, false);
        for x in [1e-6, -2.5e-5, 3.0] {
            add_square(&mut sum, &mut scaled, x);
        }
        assert!(!scaled);
        assert_eq!(sum, 1e-6 * 1e-6 + 2.5e-5 * 2.5e-5 + 3.0 * 3.0);
        // a clearance of 1e300 m: the RMS of (-1e300, -1e300, 2) is 1e300 sqrt(2/3)
        let (mut sum, mut scaled) = (0.0, false);
        for x in [2.0, -1e300, -1e300] {
            add_square(&mut sum, &mut scaled, x);
        }
        assert!(scaled);
        let rms = root_mean(sum, scaled, 3);
        assert!((rms / (1e300 * (2.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-15, "{rms}");
    }
}
