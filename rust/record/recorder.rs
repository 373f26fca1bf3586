//! The recorder of a run: it takes each recorded state into the histories, the extremes and the
//! impact logs, and reserves the histories' memory up front.

use super::impacts::*;
use super::*;

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
