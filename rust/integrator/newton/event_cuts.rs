//! Fixed steps cut at the contact events (a clearance joint's entry into or exit from contact
//! located within the step), and the restart of the accelerations after a cut.

use super::*;

impl<'a> NewtonRun<'a> {
    pub(super) fn restart_accelerations(&mut self, t: f64) -> Result<()> {
        self.update_frames(t);
        self.evaluate_contacts(true, true);
        self.ydd.fill(0.0);
        self.factorize_mass()?;
        self.mass_accelerations(t);
        self.signature.clear();
        if self.settings.newmark.is_alpha() {
            self.aa.copy_from_slice(&self.ydd); // the alpha schemes (re)start with aa = a
        }
        Ok(())
    }

    /// Puts back the state of `ev` (the start of the step at `t`, s).
    fn restore_from(&mut self, ev: &EventScratch, t: f64) {
        self.y.copy_from_slice(&ev.y);
        self.yd.copy_from_slice(&ev.yd);
        self.ydd.copy_from_slice(&ev.ydd);
        self.update_frames(t);
    }

    /// Step `k` from `t0` of size `h` with event location: the step is taken; when it changes a
    /// clearance joint's status (sign of `|q| - c`), the earliest crossing (linear
    /// interpolation, then regula falsi on the first substep's end penetration, aiming just past
    /// the circle, within 1e-3 of the step's change of penetration) places a cut; the step is
    /// redone from its start as a substep to the cut, the accelerations are restarted there with
    /// the new status ([`Self::restart_accelerations`]: the dashpot force of an entry acts from
    /// the cut on, instead of from the next step), the joints are tracked at the cut (the entry
    /// spike enters the largest force), and a second substep ends the step on the grid.
    pub(super) fn step_with_events(&mut self, t0: f64, h: f64, k: u64, ev: &mut EventScratch) -> Result<()> {
        self.penetrations(&mut ev.p0);
        ev.y.clone_from(&self.y);
        ev.yd.clone_from(&self.yd);
        ev.ydd.clone_from(&self.ydd);
        if self.settings.newmark.is_alpha() {
            ev.aa.clone_from(&self.aa);
        }
        ev.fric_z.clone_from(&self.fric_z);
        ev.fric_track.clone_from(&self.fric_track);
        self.step(t0, h, k, 0)?;
        self.penetrations(&mut ev.p1);
        let Some((theta, jstar)) = earliest_crossing(&ev.p0, &ev.p1) else {
            return Ok(());
        };
        ev.extremes.clear();
        ev.extremes
            .extend(self.track.iter().map(|j| (j.max_penetration, j.max_force)));
        ev.rec = Some(self.rec.clone());
        if self.cut_step(t0, h, k, ev, theta, jstar).is_ok() {
            self.stats.event_steps += 1;
            return Ok(());
        }
        // a substep did not converge where the whole step did: keep the whole step (and undo the
        // tracking at the cut)
        self.stats.event_fallbacks += 1;
        for (j, &(p, f)) in self.track.iter_mut().zip(&ev.extremes) {
            (j.max_penetration, j.max_force) = (p, f);
        }
        if let Some(rec) = ev.rec.take() {
            self.rec = rec;
        }
        self.fric_track.clone_from(&ev.fric_track);
        self.restore_from(ev, t0);
        self.step(t0, h, k, 0)
    }

    /// The cut of [`Self::step_with_events`] at first estimate `theta` (fraction of `h`) for
    /// joint `jstar`, from the start state in `ev`.
    fn cut_step(&mut self, t0: f64, h: f64, k: u64, ev: &mut EventScratch, mut theta: f64, jstar: usize) -> Result<()> {
        // just past the circle: the substep after the cut starts with the new status
        let mut search = CutSearch::new(ev.p0[jstar], ev.p1[jstar], true);
        let mut h1 = theta * h;
        for it in 0..EVENT_MAX_CUTS {
            h1 = theta * h;
            self.restore_from(ev, t0);
            self.step(t0, h1, k, 0)?;
            self.penetrations(&mut ev.pc);
            match search.next(theta, ev.pc[jstar], it + 1 == EVENT_MAX_CUTS) {
                Some(next) => theta = next,
                None => break,
            }
        }
        self.restart_accelerations(t0 + h1)?;
        self.track_joints(t0 + h1, None, false);
        self.step(t0 + h1, h - h1, k, 0)
    }
}
