//! The histories a run records on its output grid (joints, nodes, links, sliders), a joint's
//! impact log, and the sliders' reference motion their deviations are measured against.

use crate::error::{Error, Result};

/// The sliders' motion along their guides on an output grid: the reference of
/// [`RecordSpec::slider_reference`](super::RecordSpec::slider_reference) (typically the histories of the same mechanism with ideal
/// joints, run with the same `t_end`, `dt` and `every`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SliderReference {
    /// The output grid, s.
    pub time: Vec<f64>,
    /// Per slider, in the mechanism's order: its name and its position (m), velocity (m/s) and
    /// acceleration (m/s^2) along the guide on `time`.
    pub sliders: Vec<(String, [Vec<f64>; 3])>,
}

impl SliderReference {
    /// A reference from its grid and slider histories; every history must have the grid's length.
    pub fn new(time: Vec<f64>, sliders: Vec<(String, [Vec<f64>; 3])>) -> Result<Self> {
        for (name, h) in &sliders {
            if let Some(x) = h.iter().find(|x| x.len() != time.len()) {
                return Err(Error::param(
                    "slider_reference",
                    format!("{} values for slider {name:?}", x.len()),
                    format!("one value per grid point ({})", time.len()),
                ));
            }
        }
        Ok(SliderReference { time, sliders })
    }

    /// Checks that the reference lines up with a run of sliders `names` (in order) on the grid
    /// `t_k = k dt`, `k = 0 ..= steps` (`steps = round(t_end / dt)`, at least 1), keeping every
    /// `every`-th step and the last: the same number of points at bitwise the same times. A
    /// reference on another grid is refused (never silently misaligned).
    pub fn check_grid(&self, names: &[&str], t_end: f64, dt: f64, every: usize) -> Result<()> {
        let mine: Vec<&str> = self.sliders.iter().map(|(n, _)| n.as_str()).collect();
        if mine != names {
            return Err(Error::param(
                "record.slider_reference",
                format!("sliders {mine:?}"),
                format!("the run's sliders {names:?}, in order"),
            ));
        }
        let steps = (t_end / dt).round().max(1.0) as u64;
        let every = every.max(1) as u64;
        let points = 1 + steps / every + u64::from(!steps.is_multiple_of(every));
        let grid = std::iter::once(0).chain((1..=steps).filter(|k| k.is_multiple_of(every) || *k == steps));
        let same = self.time.len() as u64 == points
            && grid
                .zip(&self.time)
                .all(|(k, &t)| (k as f64 * dt).to_bits() == t.to_bits());
        if !same {
            return Err(Error::param(
                "record.slider_reference",
                format!(
                    "a grid of {} points ending at {:?} s",
                    self.time.len(),
                    self.time.last()
                ),
                format!(
                    "the run's output grid: {points} points k dt (dt = {dt} s, every {every}-th step of {steps} \
                     and the last); run the reference with the same t_end, dt and every"
                ),
            ));
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
    /// Friction force `F_t` on the journal along the tangent `t = S n`, N (joints with friction
    /// on the Newton stepper; empty otherwise).
    pub friction: Vec<f64>,
    /// Slip speed `(v_J - v_B) . t + R_J w_J - R_B w_B`, m/s (as `friction`).
    pub slip: Vec<f64>,
}

/// One impact of a joint: from the closing that starts it to the opening that ends its last
/// rebound (closings after a separation of at most [`REBOUND_DEPTH`](super::REBOUND_DEPTH) of the clearance).
///
/// On fixed steps the entry and exit are known to the step: the entry is the first step that ends
/// closed, the peaks are those of the recorded steps and the speed is that of the last state
/// before the entry (still open). With event-aware stepping the
/// entry (and exit) is the cut at the crossing, the speed is the approach speed there and the
/// peak force includes the force just after the cut (the dashpot jump at entry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Entry time, s.
    pub time: f64,
    /// Normal approach speed at entry, `q' . q / |q|`, m/s.
    pub speed: f64,
    /// Largest contact force magnitude during the impact and its rebounds, N.
    pub peak_force: f64,
    /// Largest penetration during the impact and its rebounds, m.
    pub peak_penetration: f64,
    /// Last exit minus entry, s; NaN while still closed at the end of the run.
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

/// Histories of one link in a moving frame, on the output grid, and its running peaks.
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
    /// The running peaks over every step from `RecordSpec::start` on; `None` unless tracked
    /// ([`LinkChannels::peaks`](super::LinkChannels::peaks)), and for a rigid link.
    pub peaks: Option<LinkPeaks>,
}

impl LinkHistory {
    /// `[peak midspan deflection m, peak axial force N]` ([`Self::peaks`]), NaN where they were
    /// not tracked (and for a rigid link).
    pub fn peak_values(&self) -> [f64; 2] {
        self.peaks.map_or([f64::NAN; 2], |p| [p.midspan, p.axial_force])
    }
}

/// The running peaks of one flexible link ([`LinkChannels::peaks`](super::LinkChannels::peaks)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkPeaks {
    /// Largest magnitude of the midspan deflection relative to the chord through the end nodes, m.
    pub midspan: f64,
    /// Largest magnitude of any element's axial force, N.
    pub axial_force: f64,
}

/// One slider of a moving-frame run: its motion along the guide (nominal path plus its elastic
/// unknown), histories on the output grid and the running peak acceleration (every step from
/// `RecordSpec::start` on).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SliderHistory {
    /// Slider name.
    pub name: String,
    /// Position along the guide, `e . origin + s`, m (`e` the guide direction, `origin` the
    /// nominal pin position, `s` the elastic travel).
    pub position: Vec<f64>,
    /// Velocity along the guide, m/s.
    pub velocity: Vec<f64>,
    /// Acceleration along the guide, m/s^2.
    pub acceleration: Vec<f64>,
    /// Largest magnitude of the acceleration along the guide, m/s^2 (every step from `start`).
    pub max_acceleration: f64,
    /// Whether the deviations from a reference motion are accumulated
    /// ([`RecordSpec::slider_reference`](super::RecordSpec::slider_reference)); when not, they stay zero and their means are NaN.
    pub deviation: bool,
    /// Sums of `|x - x_ref|` over the output points from `start` on, per channel: position (m),
    /// velocity (m/s), acceleration (m/s^2).
    pub deviation_sum: [f64; 3],
    /// Largest `|x - x_ref|` over the same points, per channel (NaN if any was NaN).
    pub deviation_max: [f64; 3],
    /// Output points that entered the sums.
    pub deviation_points: u64,
}

impl SliderHistory {
    /// Takes the slider's state along the guide `(position m, velocity m/s, acceleration m/s^2)`
    /// at a step: the peak acceleration, and the histories when `keep` (an output step).
    #[inline]
    pub fn take(&mut self, state: [f64; 3], counted: bool, keep: bool) {
        if counted {
            self.max_acceleration = self.max_acceleration.max(state[2].abs());
        }
        if keep {
            self.position.push(state[0]);
            self.velocity.push(state[1]);
            self.acceleration.push(state[2]);
        }
    }

    /// Adds an output point's deviation from the reference `reference` (position m, velocity
    /// m/s, acceleration m/s^2) to the sums and maxima.
    #[inline]
    pub fn deviate(&mut self, state: [f64; 3], reference: [f64; 3]) {
        for c in 0..3 {
            let d = (state[c] - reference[c]).abs();
            self.deviation_sum[c] += d;
            if d > self.deviation_max[c] || d.is_nan() {
                self.deviation_max[c] = d; // NaN propagates, as in a max over the histories
            }
        }
        self.deviation_points += 1;
    }

    /// Mean `|x - x_ref|` per channel over the output points from `start` on (position m,
    /// velocity m/s, acceleration m/s^2); NaN without a reference or before any point.
    pub fn deviation_mean(&self) -> [f64; 3] {
        if !self.deviation || self.deviation_points == 0 {
            return [f64::NAN; 3];
        }
        self.deviation_sum.map(|s| s / self.deviation_points as f64)
    }

    /// Largest `|x - x_ref|` per channel (as [`Self::deviation_mean`]; NaN when it is).
    pub fn deviation_peak(&self) -> [f64; 3] {
        if !self.deviation || self.deviation_points == 0 {
            return [f64::NAN; 3];
        }
        self.deviation_max
    }
}
