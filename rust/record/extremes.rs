//! A joint's running extremes (peaks, RMS sums, impact counts, contact-mode times, work), O(1)
//! memory whatever the run length, and the contact episodes that classify its contact modes.

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
    /// last state before the step that closes (see [`Impact`](super::Impact)).
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
    /// Time the sums cover, s, where they are weighted by time ([`Recorder::weigh_by_time`](super::Recorder::weigh_by_time):
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
pub(super) const DOWN: f64 = 2.409_919_865_102_884e-181; // 2^-600

/// Adds `x^2` to `sum` (scaled per `scaled`, see [`SQUARE_SCALE_FROM`]).
#[inline(always)]
pub(super) fn add_square(sum: &mut f64, scaled: &mut bool, x: f64) {
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
pub(super) fn root_mean(sum: f64, scaled: bool, n: f64) -> f64 {
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
pub(super) fn weigh(e: &mut JointExtremes, last: &mut [f64; 3], t: f64, pen: f64, force: f64) {
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
    pub(super) fn impact_opened(&mut self) {
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
    pub(super) fn work_to(&mut self, pen: f64, f: [f64; 2], q: [f64; 2], counted: bool) {
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
    pub(super) fn end_episode(&mut self) {
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

impl Episode {
    /// An episode entered at `t` (s) at approach speed `speed` (m/s) with penetration `pen` (m),
    /// on steps of `dt` (s).
    #[inline]
    pub(super) fn new(t: f64, speed: f64, pen: f64, dt: f64) -> Self {
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
