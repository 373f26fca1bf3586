//! What a run keeps: chosen joints' penetration, force and journal position, chosen nodes'
//! displacements, every k-th step from a start time; running extremes of every joint, which
//! cost O(joints) memory whatever the run length; and, when asked, an impact log per chosen joint
//! (one entry per impact, its rebounds included: memory grows with the number of impacts, not of
//! steps).

use std::sync::Arc;

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
    /// sum and the largest of `|x - x_ref|` per channel ([`SliderHistory::deviation_sum`]): O(1)
    /// memory per slider. Shared (one reference for many runs).
    pub slider_reference: Option<Arc<SliderReference>>,
    /// Histories and extremes start at this time, s (e.g. to skip a transient).
    pub start: f64,
    /// Keep an impact log ([`Impact`]) of the recorded joints (independent of `histories`).
    pub impacts: bool,
    /// Link channels of moving-frame runs, at the same stride (the constant stepper records the
    /// displacements of the chosen `nodes` instead).
    pub links: LinkChannels,
    /// Track every joint's contact modes (free flight, impact, continuous contact) and the energy
    /// dissipated in it ([`JointExtremes::free_flight_fraction`],
    /// [`JointExtremes::dissipated_energy`]): O(1) per joint, but a few more operations per joint
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
    /// ([`LinkHistory::peaks`]): O(1) memory per link,
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

/// The sliders' motion along their guides on an output grid: the reference of
/// [`RecordSpec::slider_reference`] (typically the histories of the same mechanism with ideal
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
/// rebound (closings after a separation of at most [`REBOUND_DEPTH`] of the clearance).
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
    /// ([`LinkChannels::peaks`]), and for a rigid link.
    pub peaks: Option<LinkPeaks>,
}

impl LinkHistory {
    /// `[peak midspan deflection m, peak axial force N]` ([`Self::peaks`]), NaN where they were
    /// not tracked (and for a rigid link).
    pub fn peak_values(&self) -> [f64; 2] {
        self.peaks.map_or([f64::NAN; 2], |p| [p.midspan, p.axial_force])
    }
}

/// The running peaks of one flexible link ([`LinkChannels::peaks`]).
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
    /// ([`RecordSpec::slider_reference`]); when not, they stay zero and their means are NaN.
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

/// Running extremes of one joint from `RecordSpec::start` on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointExtremes {
    /// Largest penetration, m (negative if never in contact).
    pub max_penetration: f64,
    /// Time of the largest penetration, s.
    pub time_of_max_penetration: f64,
    /// Largest contact force magnitude, N.
    pub max_force: f64,
    /// Number of impacts: closings after a separation deeper than [`REBOUND_DEPTH`] of the
    /// clearance (the first closing of a run that starts open is one; a joint closed in the
    /// initial state has none until it separates that far).
    pub impacts: u64,
    /// Number of contact episodes: every open -> closed transition, the rebounds of an impact
    /// included (a count that grows as the step resolves more of them).
    pub contact_episodes: u64,
    /// Total time in contact, s.
    pub contact_time: f64,
    /// Largest magnitude of the journal's velocity relative to the bearing, `|q'|`, m/s.
    pub max_velocity: f64,
    /// Largest normal approach speed `q' . q / |q|` at an impact, m/s: on fixed steps that of the
    /// last state before the step that closes (see [`Impact`]).
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
    /// Time the sums cover, s, where they are weighted by time ([`Recorder::weigh_by_time`]:
    /// adaptive runs); 0 where each step counts once.
    pub weighted_time: f64,
    /// Whether the contact modes and the work balance below are tracked
    /// (`RecordSpec::contact_modes`); when not, their accessors give NaN.
    pub modes: bool,
    /// Time covered by the recorded steps (from `RecordSpec::start` on), s: the denominator of
    /// the contact-mode fractions ([`Self::free_flight_fraction`]).
    pub recorded_time: f64,
    /// Contact time of the finished episodes classified as impacts ([`is_continuous`]), s.
    pub impact_time: f64,
    /// Contact time of the finished episodes classified as continuous contact, s.
    pub continuous_time: f64,
    /// The contact episode going on at the last recorded state (see [`Episode`]); `None` while
    /// the joint is open.
    pub episode: Option<Episode>,
    /// Work of the normal contact force on the penetration, `integral F_n d(delta)`, J, from
    /// `RecordSpec::start` on (trapezoidal over the recorded states; see
    /// [`Self::dissipated_energy`]), plus the elastic energy stored at `start` (`F_n delta / 2`
    /// of the last state before it).
    pub contact_work: f64,
    /// Signed normal force `F_n = -f . q / |q|` (N, compressive positive) and penetration
    /// `max(delta, 0)` (m) at the last recorded state: the previous node of the work integral.
    pub last_normal: [f64; 2],
    /// Energy dissipated by friction in the joint from `RecordSpec::start` on, J:
    /// `-integral F_t v dt` on Newmark's trapezoidal rule (set by the Newton stepper; 0 for a
    /// joint without friction). See [`Self::friction_energy`].
    pub friction_work: f64,
    /// Normal approach speed (m/s) and largest penetration so far (m, its rebounds included) of
    /// the impact going on, for [`Self::contact_period`].
    pub impact_state: [f64; 2],
    /// Largest penetration (m) of the impacts that have opened and the natural contact period
    /// `pi d / v` (s) of that impact (zeros before one): see [`Self::contact_period`].
    pub deepest_impact: [f64; 2],
}

/// The contact episode a joint is in (entry at `entry`), as the contact-mode classification
/// needs it: O(1) per joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Episode {
    /// Entry time, s (the first closed state: a step end, or an event cut).
    pub entry: f64,
    /// Normal approach speed at entry, `q' . q / |q|`, m/s.
    pub speed: f64,
    /// Largest penetration so far, m.
    pub peak: f64,
    /// Contact time of the episode counted so far (from `RecordSpec::start` on), s.
    pub time: f64,
    /// Time of the last recorded closed state, s.
    pub last: f64,
    /// Step length, s (one step of slack in the classification).
    pub dt: f64,
}

/// A closing is an impact when the joint has separated by more than this fraction of its radial
/// clearance since it last opened (the deepest `-penetration` of the free flight); after a
/// shallower separation it is a rebound of the impact going on, which neither counts nor starts
/// a log entry (the contact-mode classification still takes each closing as its own episode).
/// During continuous contact the journal leaves the wall for a few steps and closes again, and a
/// finer step resolves more of these: on the crank-pin slider-crank (clearance 0.5 mm, 0.1 s)
/// every closing counted gave 13, 37 and 103 impacts at dt = 1e-5, 2.5e-6 and 6.25e-7 s, whose
/// rebounds separated by at most 2.2, 0.29 and 0.16 um, while the three impacts proper follow
/// separations of 330-338 and 41-46 um at every step.
pub const REBOUND_DEPTH: f64 = 0.01;

/// An episode longer than this many natural contact periods is continuous contact.
pub const CONTINUOUS_PERIODS: f64 = 5.0;

/// Whether a contact episode of `duration` (s) that started at normal approach speed `speed`
/// (m/s) and reached peak penetration `peak` (m), on steps of `dt` (s), is continuous contact
/// rather than an impact.
///
/// The natural contact period is the duration of an undamped linear impact,
/// `T_n = pi sqrt(m_eff / k)`. Such an impact reaches `peak = speed sqrt(m_eff / k)`, so the
/// episode itself gives `T_n = pi peak / speed` without knowing the effective mass or the
/// stiffness (an undamped Hertz impact lasts `2.94 peak / speed`, a spring-dashpot impact of
/// damping ratio 0.8 about `3.9 T_n`). The episode is continuous contact when it lasts longer
/// than [`CONTINUOUS_PERIODS`] (5) such periods, with one step of slack for the step
/// resolution: `(duration - dt) speed > 5 pi peak`; an episode without approach (`speed <= 0`,
/// e.g. a journal in contact from the start) is continuous contact.
#[inline]
pub fn is_continuous(duration: f64, speed: f64, peak: f64, dt: f64) -> bool {
    !(speed > 0.0 && (duration - dt) * speed <= CONTINUOUS_PERIODS * std::f64::consts::PI * peak)
}

impl Episode {
    /// Whether the episode, as far as it went, is continuous contact ([`is_continuous`]).
    #[inline]
    pub fn is_continuous(&self) -> bool {
        is_continuous(self.last - self.entry, self.speed, self.peak, self.dt)
    }
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
fn root_mean(sum: f64, scaled: bool, n: f64) -> f64 {
    let r = (sum / n).sqrt();
    if scaled {
        r / DOWN
    } else {
        r
    }
}

/// Adds the interval from the last state weighed (`last`: time, penetration, force; NaN before
/// one) to `t` (s) to `e`'s RMS sums at that state's penetration and force, and makes the state
/// at `t`, penetration `pen` (m) and force `force` (N), the last one. A state at or before the
/// last one's time adds nothing (an instant taken twice).
#[inline]
fn weigh(e: &mut JointExtremes, last: &mut [f64; 3], t: f64, pen: f64, force: f64) {
    let [t0, p0, f0] = *last;
    if t > t0 {
        let w = (t - t0).sqrt();
        add_square(&mut e.sum_sq_penetration, &mut e.sums_scaled[0], p0 * w);
        add_square(&mut e.sum_sq_force, &mut e.sums_scaled[1], f0 * w);
        e.weighted_time += t - t0;
    }
    if t >= t0 || t0.is_nan() {
        *last = [t, pen, force];
    }
}

impl JointExtremes {
    /// Root mean square of the penetration over the recorded steps, m (NaN before any step).
    pub fn rms_penetration(&self) -> f64 {
        root_mean(self.sum_sq_penetration, self.sums_scaled[0], self.rms_weight())
    }

    /// Root mean square of the contact force magnitude over the recorded steps, N.
    pub fn rms_force(&self) -> f64 {
        root_mean(self.sum_sq_force, self.sums_scaled[1], self.rms_weight())
    }

    /// The denominator of the RMS: the time the sums cover where they are weighted by time, else
    /// the steps (NaN RMS before any).
    fn rms_weight(&self) -> f64 {
        if self.weighted_time > 0.0 {
            self.weighted_time
        } else {
            self.samples as f64
        }
    }

    /// Contact time of impacts and of continuous contact (s), the episode still going on
    /// classified by its duration so far.
    fn mode_times(&self) -> [f64; 2] {
        let (mut imp, mut cont) = (self.impact_time, self.continuous_time);
        if let Some(ep) = &self.episode {
            if ep.is_continuous() {
                cont += ep.time;
            } else {
                imp += ep.time;
            }
        }
        [imp, cont]
    }

    /// Fraction of the recorded time (from `RecordSpec::start` on) spent open (free flight);
    /// NaN before any step. With [`Self::impact_fraction`] and [`Self::continuous_fraction`] it
    /// sums to 1 (to rounding).
    pub fn free_flight_fraction(&self) -> f64 {
        if !self.modes {
            return f64::NAN;
        }
        (self.recorded_time - self.contact_time) / self.recorded_time
    }

    /// Fraction of the recorded time spent in contact episodes classified as impacts
    /// ([`is_continuous`]).
    pub fn impact_fraction(&self) -> f64 {
        if !self.modes {
            return f64::NAN;
        }
        self.mode_times()[0] / self.recorded_time
    }

    /// Fraction of the recorded time spent in continuous contact ([`is_continuous`]).
    pub fn continuous_fraction(&self) -> f64 {
        if !self.modes {
            return f64::NAN;
        }
        self.mode_times()[1] / self.recorded_time
    }

    /// Energy dissipated in the joint, J: the work balance of the normal contact force over the
    /// run, `integral F_n d(delta)` (trapezoidal rule on the recorded states, event cuts
    /// included), i.e. the energy the contact force took out of the relative motion of journal
    /// and bearing. Over a finished episode the elastic part returns to zero, so the balance is
    /// the energy dissipated; for an episode still closed at the end, the elastic energy still
    /// stored is estimated as `F_n delta / 2` (exact for a linear spring) and left out.
    pub fn dissipated_energy(&self) -> f64 {
        if !self.modes {
            return f64::NAN;
        }
        let [f, d] = self.last_normal;
        if self.episode.is_some() && d > 0.0 {
            self.contact_work - 0.5 * f * d
        } else {
            self.contact_work
        }
    }

    /// Energy dissipated by friction in the joint, J: `-integral F_t v dt` over the run from
    /// `RecordSpec::start` on (friction force `F_t`, slip speed `v`), on the rule of the
    /// average-acceleration step, `-(F_0 + F_1) (v_0 + v_1) dt / 4` per step (event cuts
    /// included): the work the friction force and moments did on both sides. NaN unless the
    /// contact modes are tracked (`RecordSpec::contact_modes`).
    pub fn friction_energy(&self) -> f64 {
        if !self.modes {
            return f64::NAN;
        }
        self.friction_work
    }

    /// The natural contact period of the joint, s: `T_n = pi d / v` of the impact that
    /// penetrated deepest from `RecordSpec::start` on (`v` its approach speed, `d` its largest
    /// penetration up to its first opening), the duration of an undamped linear impact
    /// (docs/contact.md, "Contact modes"); NaN before an impact has opened. A step above about a
    /// tenth of it does not resolve the contact, and the peak force then depends on the step:
    /// the crank-pin slider-crank's is 104.5, 104.3 and 104.2 us at dt 1e-5, 2.5e-6 and 6.25e-7
    /// s; the four-bar study file's rocker pin (0.15 mm) 14.2, 6.8, 3.9 and 3.4 us at dt 1e-5,
    /// 2.5e-6, 6.25e-7 and 1.5625e-7 s (an unresolved impact overshoots `d`: the estimate errs
    /// long, but stays under two steps). Impacts shorter than a step are sampled at their step
    /// ends only, and their `d` comes out too small: the deepest impact is the best sampled.
    pub fn contact_period(&self) -> f64 {
        if self.deepest_impact[0] > 0.0 {
            self.deepest_impact[1]
        } else {
            f64::NAN
        }
    }

    /// An impact's first opening: the deepest so far gives the contact period.
    #[inline]
    fn impact_opened(&mut self) {
        let [v, d] = self.impact_state;
        if v > 0.0 && d > self.deepest_impact[0] {
            self.deepest_impact = [d, std::f64::consts::PI * d / v];
        }
        self.impact_state = [0.0; 2];
    }

    /// Adds the work of the normal force from the last recorded state to the state with
    /// penetration `pen` (m), force `f` (N, on the journal) at `q` (m), when `counted`; before
    /// `start` it only follows the state.
    #[inline]
    fn work_to(&mut self, pen: f64, f: [f64; 2], q: [f64; 2], counted: bool) {
        let [f0, d0] = self.last_normal;
        if pen > 0.0 {
            let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
            let fnorm = -(f[0] * q[0] + f[1] * q[1]) / r;
            if counted {
                self.contact_work += 0.5 * (f0 + fnorm) * (pen - d0);
            }
            self.last_normal = [fnorm, pen];
        } else if d0 > 0.0 {
            if counted {
                self.contact_work -= 0.5 * f0 * d0;
            }
            self.last_normal = [0.0, 0.0];
        }
        if !counted {
            // before `start`: the balance from `start` on begins with the elastic energy stored
            // then (estimated as for the end), so that it cancels against the work that returns it
            let [f, d] = self.last_normal;
            self.contact_work = 0.5 * f * d;
        }
    }

    /// Ends the episode going on (if any), classifying its counted contact time.
    #[inline]
    fn end_episode(&mut self) {
        if let Some(ep) = self.episode.take() {
            if ep.is_continuous() {
                self.continuous_time += ep.time;
            } else {
                self.impact_time += ep.time;
            }
        }
    }
}

impl Default for JointExtremes {
    fn default() -> Self {
        JointExtremes {
            max_penetration: f64::NEG_INFINITY,
            time_of_max_penetration: 0.0,
            max_force: 0.0,
            impacts: 0,
            contact_episodes: 0,
            contact_time: 0.0,
            max_velocity: 0.0,
            max_impact_velocity: 0.0,
            sum_sq_penetration: 0.0,
            sum_sq_force: 0.0,
            sums_scaled: [false; 2],
            samples: 0,
            weighted_time: 0.0,
            modes: false,
            recorded_time: 0.0,
            impact_time: 0.0,
            continuous_time: 0.0,
            episode: None,
            contact_work: 0.0,
            last_normal: [0.0; 2],
            friction_work: 0.0,
            impact_state: [0.0; 2],
            deepest_impact: [0.0; 2],
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
    /// Sliders of a moving-frame run (empty for the constant stepper, which has none).
    pub sliders: Vec<SliderHistory>,
    /// Extremes of every joint (indexed like the model's joints).
    pub extremes: Vec<JointExtremes>,
    /// Impact logs of the recorded joints (parallel to `joints` of the spec; empty unless
    /// `RecordSpec::impacts`): `(joint index, impacts)`.
    pub impacts: Vec<(usize, Vec<Impact>)>,
    /// For every joint, the slot in `impacts` when it is logged.
    impact_slot: Vec<Option<usize>>,
    was_closed: Vec<bool>,
    /// Whether the RMS sums are weighted by time ([`Self::weigh_by_time`]), and every joint's
    /// last state taken for them: `(t, penetration, force magnitude)` (s, m, N; NaN before one).
    weighted: bool,
    last_weighed: Vec<[f64; 3]>,
    /// Every joint's last open state taken (NaN before one): on fixed steps an impact's approach
    /// speed is that of the state before it ([`entry_speed`]); at an event, that of the state
    /// nearer the circle ([`JointState::nearer`]).
    last_open: Vec<JointState>,
    /// Every joint's deepest separation since it last opened, m (the largest `-penetration`;
    /// infinite before its first contact: a run starts in free flight).
    retreat: Vec<f64>,
    /// Every joint's separation beyond which a closing is an impact, m ([`REBOUND_DEPTH`] times
    /// its clearance).
    rebound_depth: Vec<f64>,
    /// Step length of the last recorded step, s (with `modes`).
    dt: f64,
    /// `RecordSpec::contact_modes`.
    modes: bool,
    spec_every: usize,
    spec_start: f64,
    histories: bool,
    position: bool,
    node_dofs: Vec<usize>,
}

/// Samples reserved per history channel when a recorder is made; beyond that the histories grow
/// (amortized doubling) as the run records them.
pub const INITIAL_SAMPLES: usize = 1 << 16;

/// Histories shorter than this (bytes of spare capacity) are left to fault in as they fill.
const PREFAULT_MIN_BYTES: usize = 64 << 10;

/// Reserves room for `additional` more samples in `v` and backs it with memory at once, in one
/// call to the kernel, rather than one page fault per 4 KiB page as the run first writes it
/// (Linux: `madvise(MADV_POPULATE_WRITE)`, since 5.14; an older kernel leaves the pages to fault
/// in as before; elsewhere a plain `reserve`). Room under [`PREFAULT_MIN_BYTES`] is left to fault
/// in. On a virtual machine a first-touch fault costs microseconds: a fresh process's crank-pin
/// slider-crank run of 10^4 steps took about 700 of them for its default recording.
pub(crate) fn reserve_now<T>(v: &mut Vec<T>, additional: usize) {
    v.reserve(additional);
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let spare = v.spare_capacity_mut();
        let bytes = std::mem::size_of_val(spare);
        if bytes < PREFAULT_MIN_BYTES {
            return;
        }
        let start = spare.as_mut_ptr() as usize;
        let end = start + bytes;
        let (p0, p1) = (start.next_multiple_of(PAGE), end / PAGE * PAGE);
        // SAFETY: the range lies inside `v`'s allocation (its spare capacity), which `v` owns;
        // the advice does not change the memory's contents (errors, e.g. an older kernel's EINVAL,
        // are ignored: the pages then fault in as they are written)
        unsafe {
            if p1 > p0 {
                libc::madvise(p0 as *mut libc::c_void, p1 - p0, libc::MADV_POPULATE_WRITE);
            }
        }
    }
}

/// The samples reserved up front for the histories of a run of `steps` grid steps recorded every
/// `every`-th step (with the first and the last): at most [`INITIAL_SAMPLES`].
pub(crate) fn initial_samples(steps: u64, every: usize) -> usize {
    ((steps / every.max(1) as u64) as usize + 2).min(INITIAL_SAMPLES)
}

impl Recorder {
    /// A recorder for `spec` of joints of radial clearances `clearances` (m, one per joint: they
    /// set what separation makes the next closing an impact, [`REBOUND_DEPTH`]);
    /// `node_dof(link, node)` gives a node's first global DOF; `steps` sets the expected number of
    /// samples, of which at most [`INITIAL_SAMPLES`] are reserved up front (histories then grow in
    /// chunks: a long run never reserves its whole history at once).
    pub fn new(spec: &RecordSpec, clearances: &[f64], node_dof: impl Fn(usize, usize) -> usize, steps: u64) -> Self {
        let joints = clearances.len();
        let js: Vec<usize> = spec.joints.clone().unwrap_or_else(|| (0..joints).collect());
        let samples = if spec.histories {
            initial_samples(steps, spec.every)
        } else {
            0
        };
        let cap = |on: bool| {
            let mut v = Vec::new();
            if on {
                reserve_now(&mut v, samples);
            }
            v
        };
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
                        friction: Vec::new(),
                        slip: Vec::new(),
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
            sliders: Vec::new(),
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
            extremes: vec![
                JointExtremes {
                    modes: spec.contact_modes,
                    ..JointExtremes::default()
                };
                joints
            ],
            modes: spec.contact_modes,
            was_closed: vec![false; joints],
            weighted: false,
            last_weighed: vec![[f64::NAN; 3]; joints],
            last_open: vec![JointState::NONE; joints],
            retreat: vec![f64::INFINITY; joints],
            rebound_depth: clearances.iter().map(|c| REBOUND_DEPTH * c.max(0.0)).collect(),
            dt: 0.0,
            spec_every: spec.every,
            spec_start: spec.start,
            histories: spec.histories,
            position: spec.joint_position,
        }
    }

    /// Weighs the RMS sums by time: each state taken, at an output step, a cut or a substep
    /// end, counts for the time up to the next one (the rule of the rectangle on the left: the
    /// force over a contact's entry interval is the open state's, zero, and from the entry on the
    /// cut's right limit). For adaptive runs, whose output grid does not follow the contacts:
    /// the four-bar study file's rocker pin at tol 1e-3 and its default grid (t_end / 1000) had
    /// RMS forces up to 49 % off the fixed step's on the output grid alone.
    pub fn weigh_by_time(&mut self) {
        self.weighted = true;
    }

    /// Takes the state at an instant `t` (s) between output steps (the cut of an event-aware
    /// step, just after a contact status change; arguments as in [`Self::record`]): the force
    /// enters the running largest force (and the work balance), and a joint whose status changed
    /// there starts its impact (counted here, with the approach speed at the cut) or ends it
    /// (exact duration). Nothing enters the histories or the RMS sums.
    pub fn record_event(&mut self, t: f64, pen: &[f64], force: &[[f64; 2]], q: &[[f64; 2]], qd: &[[f64; 2]]) {
        if t < self.spec_start {
            return;
        }
        if self.modes {
            self.modes_at_event(t, pen, force, q, qd);
        }
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let fm = norm(force[j]);
            e.max_force = e.max_force.max(fm);
            if self.weighted {
                weigh(e, &mut self.last_weighed[j], t, pen[j], fm);
            }
            let state = JointState::at(t, pen[j], q[j], qd[j]);
            let closed = pen[j] > 0.0;
            let log = self.impact_slot[j].map(|k| &mut self.impacts[k].1);
            if closed && !self.was_closed[j] {
                if self.retreat[j] > self.rebound_depth[j] {
                    let (te, speed) = self.last_open[j].nearer(&state);
                    enter(e, log, te, pen[j], fm, speed);
                } else {
                    rebound(e, log, pen[j], fm);
                }
            } else if let Some(last) = open_impact(log) {
                if closed {
                    last.peak_force = last.peak_force.max(fm);
                } else if self.was_closed[j] {
                    last.duration = t - last.time;
                }
            }
            if closed {
                e.impact_state[1] = e.impact_state[1].max(pen[j]);
            } else if self.was_closed[j] {
                e.impact_opened();
            }
            next_status(
                &mut self.was_closed[j],
                &mut self.retreat[j],
                &mut self.last_open[j],
                state,
            );
        }
    }

    /// Takes an accepted state between output steps of an adaptive run (the end of a substep;
    /// arguments as in [`Self::record`]): as [`Self::record_event`], and the penetration enters
    /// the running largest penetration (with its time) and the open impact's peak. Nothing
    /// enters the histories or the RMS sums.
    pub fn record_substep(&mut self, t: f64, pen: &[f64], force: &[[f64; 2]], q: &[[f64; 2]], qd: &[[f64; 2]]) {
        if t < self.spec_start {
            return;
        }
        self.record_event(t, pen, force, q, qd);
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            if p > e.max_penetration {
                e.max_penetration = p;
                e.time_of_max_penetration = t;
            }
            if p > 0.0 {
                e.impact_state[1] = e.impact_state[1].max(p);
                if let Some(last) = open_impact(self.impact_slot[j].map(|k| &mut self.impacts[k].1)) {
                    last.peak_penetration = last.peak_penetration.max(p);
                }
            }
        }
    }

    /// Takes a contact peak of joint `j` found between the ends of an accepted adaptive step (an
    /// interpolated state at `t`, s, in contact: penetration `pen`, m, force magnitude `force`,
    /// N) into the running largest penetration (with its time) and force, and the open impact's
    /// peaks. Nothing else changes (no status, no histories).
    pub fn record_peak_within(&mut self, j: usize, t: f64, pen: f64, force: f64) {
        if t < self.spec_start {
            return;
        }
        let e = &mut self.extremes[j];
        if pen > e.max_penetration {
            e.max_penetration = pen;
            e.time_of_max_penetration = t;
        }
        e.max_force = e.max_force.max(force);
        e.impact_state[1] = e.impact_state[1].max(pen);
        if let Some(last) = open_impact(self.impact_slot[j].map(|k| &mut self.impacts[k].1)) {
            last.peak_force = last.peak_force.max(force);
            last.peak_penetration = last.peak_penetration.max(pen);
        }
    }

    /// Records step `step` at time `t` (s), step length `dt` (s). `pen[j]`, `force[j]`, `q[j]`
    /// and `qd[j]` are every joint's penetration (m), contact force on the journal (N), position
    /// (m) and velocity (m/s); `u` the global displacement vector.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        step: u64,
        t: f64,
        dt: f64,
        pen: &[f64],
        force: &[[f64; 2]],
        q: &[[f64; 2]],
        qd: &[[f64; 2]],
        u: &[f64],
    ) {
        if t < self.spec_start {
            self.before_start(t, dt, pen, force, q, qd);
            return;
        }
        if self.modes {
            self.modes_at_step(step, t, dt, pen, force, q, qd);
        }
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            if p > e.max_penetration {
                e.max_penetration = p;
                e.time_of_max_penetration = t;
            }
            let f = norm(force[j]);
            e.max_force = e.max_force.max(f);
            if self.weighted {
                weigh(e, &mut self.last_weighed[j], t, p, f);
            } else {
                add_square(&mut e.sum_sq_penetration, &mut e.sums_scaled[0], p);
                add_square(&mut e.sum_sq_force, &mut e.sums_scaled[1], f);
            }
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
                    if self.retreat[j] > self.rebound_depth[j] {
                        enter(e, log, t, p, f, entry_speed(self.last_open[j], q[j], qd[j]));
                    } else {
                        rebound(e, log, p, f);
                    }
                } else if let Some(last) = open_impact(log) {
                    last.peak_force = last.peak_force.max(f);
                    last.peak_penetration = last.peak_penetration.max(p);
                }
                if step > 0 {
                    e.contact_time += dt;
                }
                e.impact_state[1] = e.impact_state[1].max(p);
            } else if self.was_closed[j] {
                if let Some(last) = open_impact(log) {
                    last.duration = t - last.time;
                }
                e.impact_opened();
            }
            next_status(
                &mut self.was_closed[j],
                &mut self.retreat[j],
                &mut self.last_open[j],
                JointState::at(t, p, q[j], qd[j]),
            );
        }
        if !self.histories || !step.is_multiple_of(self.spec_every as u64) {
            return;
        }
        self.time.push(t);
        for h in &mut self.joints {
            h.penetration.push(pen[h.joint]);
            h.force.push(norm(force[h.joint]));
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

impl Recorder {
    /// A state before `RecordSpec::start`: nothing is counted, but the contact status and, with
    /// `RecordSpec::contact_modes`, the episode going on (its entry, approach speed and peak
    /// classify it once counted) and the last node of the work integral follow the run.
    #[cold]
    fn before_start(&mut self, t: f64, dt: f64, pen: &[f64], force: &[[f64; 2]], q: &[[f64; 2]], qd: &[[f64; 2]]) {
        self.dt = dt;
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            let closed = p > 0.0;
            if self.modes {
                if closed {
                    match &mut e.episode {
                        Some(ep) if self.was_closed[j] => {
                            ep.peak = ep.peak.max(p);
                            ep.last = t;
                        }
                        _ => e.episode = Some(Episode::new(t, normal_speed(q[j], qd[j]), p, dt)),
                    }
                } else {
                    e.episode = None;
                }
                e.work_to(p, force[j], q[j], false);
            }
            next_status(
                &mut self.was_closed[j],
                &mut self.retreat[j],
                &mut self.last_open[j],
                JointState::at(t, p, q[j], qd[j]),
            );
        }
    }

    /// The contact modes and the work balance at step `step` (arguments of [`Self::record`]),
    /// before the contact status moves on; only with `RecordSpec::contact_modes`.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn modes_at_step(
        &mut self,
        step: u64,
        t: f64,
        dt: f64,
        pen: &[f64],
        force: &[[f64; 2]],
        q: &[[f64; 2]],
        qd: &[[f64; 2]],
    ) {
        self.dt = dt;
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            let (closed, was) = (p > 0.0, self.was_closed[j]);
            if closed {
                if !was {
                    e.episode = Some(Episode::new(t, normal_speed(q[j], qd[j]), p, dt));
                } else if let Some(ep) = &mut e.episode {
                    ep.peak = ep.peak.max(p);
                    ep.last = t;
                }
                if step > 0 {
                    if let Some(ep) = &mut e.episode {
                        ep.time += dt;
                    }
                }
            } else if was {
                if let Some(ep) = &mut e.episode {
                    ep.last = t;
                }
                e.end_episode();
            }
            if step > 0 {
                e.recorded_time += dt;
            }
            e.work_to(p, force[j], q[j], true);
        }
    }

    /// The contact modes and the work balance at an event cut at `t` (s; arguments of
    /// [`Self::record_event`]), before the contact status moves on.
    #[inline(never)]
    fn modes_at_event(&mut self, t: f64, pen: &[f64], force: &[[f64; 2]], q: &[[f64; 2]], qd: &[[f64; 2]]) {
        for (j, e) in self.extremes.iter_mut().enumerate() {
            let p = pen[j];
            let (closed, was) = (p > 0.0, self.was_closed[j]);
            e.work_to(p, force[j], q[j], true);
            if closed && !was {
                // the state nearer the circle, as for the impact ([`JointState::nearer`])
                let closing = JointState::at(t, p, q[j], qd[j]);
                let (entry, speed) = self.last_open[j].nearer(&closing);
                // an entry at a cut is located, and so is the exit (a cut, or a substep end
                // within the tolerance's step): no step of slack for the classification (the
                // output step's, 1e-5 s, counted a 1e-5 s contact of the four-bar's 4 us period
                // as an impact)
                e.episode = Some(Episode::new(entry, speed, p, 0.0));
            } else if let Some(ep) = &mut e.episode {
                ep.last = t;
                if closed {
                    ep.peak = ep.peak.max(p);
                } else if was {
                    e.end_episode();
                }
            }
        }
    }
}

impl Episode {
    /// An episode entered at `t` (s) at approach speed `speed` (m/s) with penetration `pen` (m),
    /// on steps of `dt` (s).
    #[inline]
    fn new(t: f64, speed: f64, pen: f64, dt: f64) -> Self {
        Episode {
            entry: t,
            speed,
            peak: pen,
            time: 0.0,
            last: t,
            dt,
        }
    }
}

/// Magnitude of a force, N.
#[inline(always)]
fn norm(f: [f64; 2]) -> f64 {
    (f[0] * f[0] + f[1] * f[1]).sqrt()
}

/// An impact of a joint at time `t` (s): counted in its extremes `e` with its normal approach
/// speed `speed` (m/s), and started in its impact log (if kept) with penetration `pen` (m) and
/// force `force` (N).
fn enter(e: &mut JointExtremes, log: Option<&mut Vec<Impact>>, t: f64, pen: f64, force: f64, speed: f64) {
    e.impacts += 1;
    e.contact_episodes += 1;
    e.max_impact_velocity = e.max_impact_velocity.max(speed);
    e.impact_state = [speed, pen];
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

/// A closing after a separation no deeper than the joint's rebound depth ([`REBOUND_DEPTH`]): the
/// impact going on continues (the last entry of the log, if kept, is open again and takes the
/// closing state's penetration `pen`, m, and force `force`, N, into its peaks); nothing is
/// counted.
fn rebound(e: &mut JointExtremes, log: Option<&mut Vec<Impact>>, pen: f64, force: f64) {
    e.contact_episodes += 1;
    if let Some(last) = log.and_then(|l| l.last_mut()) {
        last.duration = f64::NAN;
        last.peak_force = last.peak_force.max(force);
        last.peak_penetration = last.peak_penetration.max(pen);
    }
}

/// A joint's state taken by the recorder: time `t` (s), penetration `pen` (m), journal position
/// `q` (m) and velocity `qd` (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
struct JointState {
    t: f64,
    pen: f64,
    q: [f64; 2],
    qd: [f64; 2],
}

impl JointState {
    /// The state at `t` (s): penetration `pen` (m), journal position `q` (m), velocity `qd` (m/s).
    #[inline(always)]
    fn at(t: f64, pen: f64, q: [f64; 2], qd: [f64; 2]) -> Self {
        JointState { t, pen, q, qd }
    }

    /// No state yet (all NaN).
    const NONE: JointState = JointState {
        t: f64::NAN,
        pen: f64::NAN,
        q: [f64::NAN; 2],
        qd: [f64::NAN; 2],
    };

    /// The instant (s) and approach speed (m/s) of an impact first seen closed at an event or
    /// substep, `closing` (penetration > 0): those of whichever of the last open state (`self`)
    /// and the closing state is nearer the circle. An event-aware fixed step cuts just past the
    /// circle, and there the closing state is the crossing; an adaptive step cuts just short of
    /// it, and there the last open state is (the closing state, a substep later, has been slowed
    /// by the contact: the four-bar's first rocker-pin impact read 0.197 m/s at tol 1e-3 against
    /// 0.2181 m/s converged on fixed steps).
    fn nearer(&self, closing: &JointState) -> (f64, f64) {
        if -self.pen < closing.pen {
            (self.t, normal_speed(self.q, self.qd))
        } else {
            (closing.t, normal_speed(closing.q, closing.qd))
        }
    }
}

/// A joint's contact status after a state `s`: `was` (closed) follows it, and at an open state
/// the deepest separation since the opening, `retreat` (m; reset at the opening), and the last
/// open state, `last`.
#[inline(always)]
fn next_status(was: &mut bool, retreat: &mut f64, last: &mut JointState, s: JointState) {
    let closed = s.pen > 0.0;
    if !closed {
        *retreat = if *was { -s.pen } else { retreat.max(-s.pen) };
        *last = s;
    }
    *was = closed;
}

/// The impact of a log that is still going on (the last one, with no duration yet).
fn open_impact(log: Option<&mut Vec<Impact>>) -> Option<&mut Impact> {
    log?.last_mut().filter(|i| i.duration.is_nan())
}

/// The approach speed (m/s) of an impact whose first closed state is `(q, qd)` (m, m/s), taken at
/// a step end: the normal speed of the state taken before it (`last`, open; NaN when there was
/// none), else its own.
///
/// The contact force has acted on the closing state for part of its step, and for a stiff
/// contact that is much of the approach speed: the crank-pin slider-crank's first impact gave
/// 1.165, 1.715, 2.001 and 2.101 m/s from the closing state at dt = 1e-5, 2.5e-6, 6.25e-7 and
/// 1.5625e-7 s, and 2.132, 2.129, 2.134 and 2.135 m/s from the last open state. (The
/// contact-mode classification keeps the closing state's speed: it divides the episode's peak
/// penetration, also sampled at the step ends, by it, and the two errors cancel there.)
#[inline]
fn entry_speed(last: JointState, q: [f64; 2], qd: [f64; 2]) -> f64 {
    if last.pen.is_nan() {
        normal_speed(q, qd)
    } else {
        normal_speed(last.q, last.qd)
    }
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
    fn reserve_now_keeps_the_samples_and_backs_the_room_with_memory() {
        let mut v: Vec<f64> = (0..10).map(f64::from).collect();
        let n = 1 << 19; // 4 MiB of room
        reserve_now(&mut v, n);
        assert!(v.capacity() >= 10 + n);
        assert_eq!(v, (0..10).map(f64::from).collect::<Vec<_>>());
        #[cfg(target_os = "linux")]
        {
            // every whole page of the room is resident before anything is written to it
            const PAGE: usize = 4096;
            let spare = v.spare_capacity_mut();
            let start = (spare.as_mut_ptr() as usize).next_multiple_of(PAGE);
            let end = (spare.as_mut_ptr() as usize + std::mem::size_of_val(spare)) / PAGE * PAGE;
            let pages = (end - start) / PAGE;
            let mut resident = vec![0u8; pages];
            // SAFETY: the range is mapped (inside `v`'s allocation); `resident` has a byte a page
            let rc = unsafe { libc::mincore(start as *mut libc::c_void, end - start, resident.as_mut_ptr()) };
            assert_eq!(rc, 0);
            // (MADV_POPULATE_WRITE came with Linux 5.14)
            let release = std::fs::read_to_string("/proc/sys/kernel/osrelease").unwrap_or_default();
            let mut parts = release
                .split(|c: char| !c.is_ascii_digit())
                .filter_map(|p| p.parse::<u32>().ok());
            let version = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
            if version >= (5, 14) {
                assert!(resident.iter().all(|&r| r & 1 == 1), "some pages were left unbacked");
            }
        }
        // room below PREFAULT_MIN_BYTES: a plain reserve
        let mut w: Vec<f64> = Vec::new();
        reserve_now(&mut w, 16);
        assert!(w.capacity() >= 16 && w.is_empty());
    }

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
        let rms = root_mean(sum, scaled, 3.0);
        assert!((rms / (1e300 * (2.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-15, "{rms}");
    }

    /// Drives a recorder through one joint's states: `(penetration, normal force, approach
    /// speed)` per step of `dt`, the journal on the +x axis.
    fn run(states: &[(f64, f64, f64)], dt: f64, start: f64) -> JointExtremes {
        let spec = RecordSpec {
            histories: false,
            contact_modes: true,
            start,
            ..RecordSpec::default()
        };
        let mut rec = Recorder::new(&spec, &[1e-3], |_, _| 0, states.len() as u64);
        let c = 1e-3;
        for (k, &(p, f, v)) in states.iter().enumerate() {
            rec.record(
                k as u64,
                k as f64 * dt,
                dt,
                &[p],
                &[[-f, 0.0]],
                &[[c + p, 0.0]],
                &[[v, 0.0]],
                &[],
            );
        }
        rec.extremes[0]
    }

    #[test]
    fn a_closing_after_a_shallow_separation_is_a_rebound_of_the_impact_going_on() {
        // clearance 1 mm: rebound depth 10 um. Closed, open by 2 um, closed (a rebound), open by
        // 50 um, closed (an impact), open by 10 um exactly (not deeper: a rebound), closed
        let states = [
            (-1e-4, 0.0, 1.0),
            (1e-6, 1.0, 1.0),
            (-2e-6, 0.0, -1.0),
            (2e-6, 3.0, 1.0),
            (-5e-5, 0.0, -1.0),
            (3e-6, 2.0, 1.0),
            (-1e-5, 0.0, -1.0),
            (1e-6, 1.0, 1.0),
            (-1e-6, 0.0, -1.0),
        ];
        let spec = RecordSpec {
            histories: false,
            impacts: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        assert_eq!(REBOUND_DEPTH * c, 1e-5);
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, states.len() as u64);
        for (k, &(p, f, v)) in states.iter().enumerate() {
            let (q, qd) = ([c + p, 0.0], [v, 0.0]);
            rec.record(k as u64, k as f64, 1.0, &[p], &[[-f, 0.0]], &[q], &[qd], &[]);
        }
        let e = rec.extremes[0];
        assert_eq!((e.impacts, e.contact_episodes), (2, 4));
        let log = &rec.impacts[0].1;
        assert_eq!(log.len(), 2);
        // each entry spans its rebounds: entry, exit of the last rebound, peaks over them
        assert_eq!((log[0].time, log[0].duration), (1.0, 3.0 - 1.0 + 1.0));
        assert_eq!((log[0].peak_force, log[0].peak_penetration), (3.0, 2e-6));
        assert_eq!((log[1].time, log[1].duration), (5.0, 8.0 - 5.0));
        assert_eq!((log[1].peak_force, log[1].peak_penetration), (2.0, 3e-6));
        // the approach speed of an impact is that of the state before it (open)
        assert_eq!((log[0].speed, log[1].speed), (1.0, -1.0));
        assert_eq!(e.max_impact_velocity, 1.0);
    }

    #[test]
    fn an_impact_between_steps_takes_the_state_nearer_the_circle() {
        let spec = RecordSpec {
            histories: false,
            impacts: true,
            contact_modes: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let state = |p: f64, v: f64| ([c + p, 0.0], [v, 0.0]);
        // an adaptive cut just short of the circle (open, 1 m/s), then the substep after it,
        // closed and slowed by the contact (0.5 m/s): the impact is the cut's
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        let (q, qd) = state(-1e-4, 1.0);
        rec.record(0, 0.0, 1e-5, &[-1e-4], &[[0.0; 2]], &[q], &[qd], &[]);
        let (q, qd) = state(-1e-10, 1.0);
        rec.record_substep(1e-6, &[-1e-10], &[[0.0; 2]], &[q], &[qd]);
        let (q, qd) = state(5e-8, 0.5);
        rec.record_substep(2e-6, &[5e-8], &[[-1.0, 0.0]], &[q], &[qd]);
        let log = &rec.impacts[0].1;
        assert_eq!((log.len(), log[0].time, log[0].speed), (1, 1e-6, 1.0));
        let ep = rec.extremes[0].episode.expect("an episode going on");
        assert_eq!((ep.entry, ep.speed), (1e-6, 1.0));
        // an event-aware fixed step cuts just past the circle: the closing state is the crossing,
        // the last open state a step before it
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        let (q, qd) = state(-1e-5, 1.2);
        rec.record(0, 0.0, 1e-5, &[-1e-5], &[[0.0; 2]], &[q], &[qd], &[]);
        let (q, qd) = state(1e-10, 0.99);
        rec.record_event(7e-6, &[1e-10], &[[-1e-4, 0.0]], &[q], &[qd]);
        let log = &rec.impacts[0].1;
        assert_eq!((log[0].time, log[0].speed), (7e-6, 0.99));
        let ep = rec.extremes[0].episode.expect("an episode going on");
        assert_eq!((ep.entry, ep.speed), (7e-6, 0.99));
    }

    #[test]
    fn an_episode_located_by_cuts_is_classified_without_a_steps_slack() {
        let spec = RecordSpec {
            histories: false,
            contact_modes: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 3);
        let mut at = |k: Option<u64>, t: f64, p: f64, v: f64| {
            let (q, qd, f) = ([c + p, 0.0], [v, 0.0], [-1e6 * p.max(0.0), 0.0]);
            match k {
                Some(k) => rec.record(k, t, 1e-5, &[p], &[f], &[q], &[qd], &[]),
                None => rec.record_substep(t, &[p], &[f], &[q], &[qd]),
            }
        };
        // entry at a cut at 1 us (1 m/s), peak 1 um: natural period pi 1e-6 s, five of them
        // 15.7 us; exit at a cut at 21 us: 20 us, continuous contact (with the output step's
        // 10 us of slack it counted as an impact)
        at(Some(0), 0.0, -1e-4, 1.0);
        at(None, 1e-6, -1e-12, 1.0);
        at(None, 2e-6, 1e-6, 0.0);
        at(Some(1), 1e-5, 5e-7, -0.1);
        at(Some(2), 2e-5, 1e-7, -0.1);
        at(None, 2.1e-5, -1e-12, -0.1);
        let e = rec.extremes[0];
        assert_eq!((e.continuous_time, e.impact_time), (2e-5, 0.0));
    }

    #[test]
    fn time_weighted_sums_count_each_state_up_to_the_next() {
        let spec = RecordSpec {
            histories: false,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        rec.weigh_by_time();
        let at = |f: f64| [[-f, 0.0]];
        let q = [[c, 0.0]];
        let v = [[0.0; 2]];
        rec.record(0, 0.0, 1e-5, &[-1e-6], &at(0.0), &q, &v, &[]);
        rec.record_substep(1e-6, &[1e-6], &at(10.0), &q, &v);
        rec.record_substep(3e-6, &[2e-6], &at(20.0), &q, &v);
        // the same instant again (a cut's right limit): it replaces the state before
        rec.record_event(3e-6, &[2e-6], &at(30.0), &q, &v);
        rec.record(1, 4e-6, 1e-5, &[-1e-6], &at(0.0), &q, &v, &[]);
        let e = rec.extremes[0];
        // 0 for 1 us, 10 N for 2 us, 30 N for 1 us: (200 + 900) / 4 N^2
        assert!((e.weighted_time - 4e-6).abs() < 1e-18);
        assert!(
            (e.rms_force() - (1100.0f64 / 4.0).sqrt()).abs() < 1e-9,
            "{}",
            e.rms_force()
        );
        let pen = ((1e-12 + 2.0 * 1e-12 + 4e-12) / 4.0f64).sqrt();
        assert!((e.rms_penetration() - pen).abs() < 1e-15, "{}", e.rms_penetration());
    }

    #[test]
    fn the_work_of_a_linear_spring_telescopes_and_modes_sum_to_the_run() {
        // a linear spring k d over an episode up and down: no dissipation, bit for bit
        let k = 1e6;
        let ds = [-1e-6, 2e-7, 5e-7, 9e-7, 6e-7, 1e-7, -3e-7, -5e-7];
        let states: Vec<_> = ds
            .iter()
            .map(|&d: &f64| (d, k * d.max(0.0), if d > 0.0 { 1.0 } else { -1.0 }))
            .collect();
        let e = run(&states, 1e-7, 0.0);
        assert!(e.contact_work.abs() < 1e-20, "{}", e.contact_work);
        assert_eq!(e.dissipated_energy(), e.contact_work);
        assert_eq!(e.impacts, 1);
        // 5 closed steps of 1e-7 s, speed 1 m/s, peak 9e-7 m: (5e-7 - 1e-7) * 1 <= 5 pi 9e-7
        assert_eq!((e.impact_time, e.continuous_time), (e.contact_time, 0.0));
        let total = e.free_flight_fraction() + e.impact_fraction() + e.continuous_fraction();
        assert!((total - 1.0).abs() < 1e-15 && (e.free_flight_fraction() - 2.0 / 7.0).abs() < 1e-12);
        // a spring-dashpot that ends open dissipates the loop's area: F = k d + c dd
        let c = 50.0;
        let dt = 1e-7;
        let states: Vec<_> = ds
            .iter()
            .zip(ds.iter().skip(1))
            .map(|(&d0, &d1): (&f64, &f64)| {
                let rate = (d1 - d0) / dt;
                (d1, if d1 > 0.0 { k * d1 + c * rate } else { 0.0 }, rate)
            })
            .collect();
        assert!(run(&states, dt, 0.0).dissipated_energy() > 0.0);
    }

    #[test]
    fn contact_modes_follow_the_natural_period_rule() {
        let pi5 = CONTINUOUS_PERIODS * std::f64::consts::PI;
        // an impact of peak 1e-6 m at 1 m/s: the natural period is pi 1e-6 s
        assert!(!is_continuous(pi5 * 1e-6, 1.0, 1e-6, 1e-9));
        assert!(is_continuous(pi5 * 1e-6 + 2e-9, 1.0, 1e-6, 1e-9));
        // no approach: continuous; a single step: an impact
        assert!(is_continuous(1e-9, 0.0, 1e-6, 1e-9));
        assert!(!is_continuous(1e-3, 1.0, 0.0, 1e-3));
        // a journal resting on the wall from the start: all continuous contact, and the stored
        // spring energy is not counted as dissipated
        let states = vec![(1e-6, 1.0, 0.0); 100];
        let e = run(&states, 1e-5, 0.0);
        assert_eq!(e.impacts, 0);
        assert_eq!(
            (e.free_flight_fraction(), e.impact_fraction(), e.continuous_fraction()),
            (0.0, 0.0, 1.0)
        );
        assert_eq!(e.dissipated_energy(), 0.0);
        // from `start` on: the episode entered before still classifies (continuous here), and
        // the energy stored before `start` is no dissipation
        let e = run(&states, 1e-5, 5e-4);
        assert_eq!(e.continuous_fraction(), 1.0);
        assert_eq!(e.dissipated_energy(), 0.0);
        assert_eq!(e.recorded_time, e.contact_time);
    }
}
