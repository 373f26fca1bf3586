//! One Newmark step: the predictor, the Newton iterations and their stopping rules (tolerance,
//! truncation fraction, carried rate, contraction, round-off floor), and what follows a step that
//! does not converge (the refactorizing path, step halving, the error).

use super::*;

impl<'a> NewtonRun<'a> {
    /// One Newmark step from `t` of size `h`. On failure the state is restored.
    pub(super) fn step(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.step_avx2(t, h, step, depth) };
        }
        self.step_body(t, h, step, depth)
    }

    /// [`Self::step`] compiled with AVX2 enabled, as [`Self::residual_avx2`]: bitwise the
    /// baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn step_avx2(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        self.step_body(t, h, step, depth)
    }

    /// Runs the step, the residual and the band solves in their AVX2 builds where `on` (and the
    /// CPU has AVX2 and FMA), else in the baseline's (the tests compare the two).
    #[cfg(test)]
    pub(super) fn set_avx2(&mut self, on: bool) {
        self.avx2 = on && crate::linalg::avx2_fma_available();
        self.avx512 = on && crate::linalg::avx512_available();
        self.lu.set_avx2(on);
        for rs in self
            .rate
            .iter_mut()
            .map(|rs| &mut **rs)
            .chain(self.rate_kept.iter_mut())
        {
            rs.lu0.set_avx2(on);
        }
    }

    /// A fixed step `k` from `t0` of `h` (s) to the grid instant `t1` (no events, no continuous
    /// contact) and the tracking of its joints and sliders (`keep`: an output step). The step
    /// ends where it stopped: at the state its carried-rate stop evaluated, if it stopped so
    /// ([`Self::margin_state`]); the next step starts from this state and these frames.
    pub(super) fn fixed_step(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.fixed_step_avx2(t0, h, k, t1, keep) };
        }
        self.fixed_step_body(t0, h, k, t1, keep)
    }

    /// [`Self::fixed_step`] compiled with AVX2 enabled, the tracking inlined (the step itself is
    /// [`Self::step_avx2`]): bitwise the baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fixed_step_avx2(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        self.fixed_step_body(t0, h, k, t1, keep)
    }

    #[inline(always)]
    fn fixed_step_body(&mut self, t0: f64, h: f64, k: u64, t1: f64, keep: bool) -> Result<()> {
        self.step(t0, h, k, 0)?;
        self.stats.steps = k;
        let margin = std::mem::take(&mut self.margin_state);
        self.track_joints(t1, Some((k, h)), margin);
        self.tracked_state = true;
        self.track_sliders(t1, keep);
        self.track_links(t1);
        Ok(())
    }

    #[inline(always)]
    fn step_body(&mut self, t: f64, h: f64, step: u64, depth: u32) -> Result<()> {
        self.jstate_fresh = false;
        self.margin_state = false;
        let nm = self.settings.newmark;
        let (bh2, gh) = nm.coefficients(h);
        let n = self.n;
        // Contact terms from the start-of-step state (lagged kappa, force method); the implicit
        // contact's tangent is that of the first iterate (below)
        self.evaluate_contacts(true, false);
        // State at the start (kept for a retry): swapped out of the state, which the predictor
        // then overwrites (the generalized-alpha predictor reads it in place: copied)
        if nm.is_alpha() {
            self.y0.copy_from_slice(&self.y);
            self.yd0.copy_from_slice(&self.yd);
            self.ydd0.copy_from_slice(&self.ydd);
        } else {
            std::mem::swap(&mut self.y0, &mut self.y);
            std::mem::swap(&mut self.yd0, &mut self.yd);
            std::mem::swap(&mut self.ydd0, &mut self.ydd);
        }
        // the step's end: the grid instant the run loop asked for where this step ends there up
        // to rounding (its frames are then the record's and the slider tracking's), else t + h
        let t_end = match self.step_end.take() {
            Some(te) if (te - (t + h)).abs() <= same_instant(h) => te,
            _ => t + h,
        };
        self.update_frames(t_end);
        if nm.is_alpha() {
            self.alpha_predictors(h);
        } else {
            // the first iterate: `a_n`, or its extrapolation along the last step where that
            // step ended here and nothing has changed the accelerations since
            let w = self.extrapolation.start(t, h, &self.ydd0);
            // (`w = 0`: `a = a0` exactly)
            let start = [&self.y0[..n], &self.yd0[..n], &self.ydd0[..n]];
            let state = [&mut self.y[..n], &mut self.yd[..n], &mut self.ydd[..n]];
            let pred = [&mut self.y_pred[..n], &mut self.v_pred[..n], &mut self.a[..n]];
            let (a_prev, c) = (&self.extrapolation.a0[..n], [h, nm.beta, nm.gamma, bh2, gh, w]);
            #[cfg(target_arch = "x86_64")]
            if self.avx2 {
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                unsafe { predict_avx2(start, state, pred, a_prev, c) }
            } else {
                predict(start, state, pred, a_prev, c)
            }
            #[cfg(not(target_arch = "x86_64"))]
            predict(start, state, pred, a_prev, c);
        }
        let iterate_contact = self.implicit_contact;
        // friction is evaluated at every iterate (its force in the residual, its slip-speed
        // tangent in the refactorized Jacobian)
        let iterate_friction = self.friction;
        let linear = !self.nonlinear_geometric && !iterate_contact && !iterate_friction;
        // the iterations may stop on the contraction rate carried from earlier steps
        // (RATE_CARRY_DOWN; not with friction's secant switch or the continuous-contact model)
        let carried = !iterate_friction && self.cont.is_none();
        // the contact terms on the contact-free factor by Woodbury (the constant-rate stepper at
        // its step; the Newton stepper with the Woodbury solver when the joints allow it)
        let rate_step = !self.direct
            && self
                .rate
                .as_ref()
                .is_some_and(|r| r.fixed_step.is_none_or(|hh| hh == h))
            && self.woodbury_fits;
        let scale_floor = 1e-9 * self.limit / 10.0;
        // the iterations' tolerance may grow to a fraction of the step's own truncation error
        // (fixed steps only: NewtonSettings::truncation_fraction)
        let truncation = if self.settings.adaptive.is_none() {
            self.settings.newton.truncation_fraction * adaptive::zx_coefficient(nm.beta) * h * h
        } else {
            0.0
        };
        // the truncation fraction of the step's error at the last iterate
        let mut truncation_now = 0.0;
        let mut iters = 0usize;
        let mut last_res = f64::NAN;
        let mut last_corr;
        // the two corrections before the last, for the round-off floor's stall test
        let mut prev_corr = [f64::INFINITY; 2];
        // the residual of the first iteration, for the round-off floor's progress test
        let mut first_res = f64::NAN;
        self.fric_secant = false;
        let converged = loop {
            iters += 1;
            if iterate_friction && iters > FRICTION_SECANT_AFTER {
                self.fric_secant = true;
            }
            if iterate_contact {
                // Implicit contact: the force and its tangent at the current iterate.
                self.evaluate_contacts(false, true);
            }
            if iterate_friction {
                self.evaluate_friction(h);
            }
            // a step on an earlier step's factor that has not converged after
            // JACOBIAN_REUSE_ITERATIONS iterations continues on a new one, at the current iterate
            let refresh = self.reusing && iters == JACOBIAN_REUSE_ITERATIONS + 1;
            let prepared = if rate_step {
                let res = if iters == 1 || refresh {
                    self.rate_prepare(h, refresh)
                } else {
                    Ok(())
                };
                if iters == 1 || iterate_contact || refresh {
                    self.rate_blocks(bh2, gh);
                }
                res
            } else if refresh {
                self.jacobian_changed(h, false);
                self.factorize(h)
            } else if (iters == 1 || iterate_contact || iterate_friction) && self.jacobian_changed(h, iters == 1) {
                self.factorize(h)
            } else {
                Ok(())
            };
            let mut failure = prepared.err();
            let mut dx = Vec::new();
            if failure.is_none() {
                self.residual(h, t_end);
                last_res = max_abs_or_inf(&self.r);
                dx = std::mem::take(&mut self.r);
                if rate_step {
                    if iters == 1 && self.rate.as_ref().is_some_and(|r| r.any) {
                        self.stats.woodbury_steps += 1;
                    }
                    failure = self.rate_solve(h, &mut dx).err();
                } else {
                    self.lu.solve_in_place(&mut dx);
                    if self.cont.is_some() {
                        // the constraints of the attached continuous-contact joints, bordered
                        failure = self.constraint_correction(bh2, &mut dx).err();
                    }
                }
            }
            if let Some(e) = failure {
                // a factorization failed (the Jacobian, or the constant-rate stepper's fallback)
                if !dx.is_empty() {
                    self.r = dx;
                }
                let finite = self.y.iter().chain(&self.yd).chain(&self.a).all(|x| x.is_finite());
                if iters > 1 && !finite {
                    // the iterates ran away (a step too long for the contact or the frame
                    // motion): not converged, which step halving may mend
                    last_res = f64::INFINITY;
                    last_corr = f64::INFINITY;
                    break false;
                }
                self.restore();
                // a state that went non-finite between two divergence checks is reported as
                // the divergence it is, with the unknown that went first
                self.check_divergence(t, step)?;
                return Err(e);
            }
            // the largest correction and displacement, four running maxima each (no chain
            // through every unknown; the maxima are exact, so the order does not matter)
            let n = self.n;
            let state = [
                &mut self.a[..n],
                &mut self.ydd[..n],
                &mut self.y[..n],
                &mut self.yd[..n],
            ];
            let pred = [&self.y_pred[..n], &self.v_pred[..n], &dx[..n]];
            #[cfg(target_arch = "x86_64")]
            let (dmax, ymax) = if self.avx2 {
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                unsafe { correct_avx2(state, pred, bh2, gh) }
            } else {
                correct(state, pred, bh2, gh)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let (dmax, ymax) = correct(state, pred, bh2, gh);
            // f64::max skips NaN: a non-finite correction is caught here, not by dmax
            let finite = dx.iter().all(|d| d.is_finite());
            self.r = dx;
            last_corr = if finite {
                dmax / ymax.max(scale_floor)
            } else {
                f64::INFINITY
            };
            if !last_corr.is_finite() {
                break false;
            }
            if carried && iters >= 2 {
                self.iter_rate = (last_corr / prev_corr[1]).max(RATE_CARRY_DOWN * self.iter_rate);
            }
            // the tolerance of this iterate: `tol`, or the truncation fraction of the step's
            // Zienkiewicz-Xie error at this iterate where that is larger (both relative to the
            // displacement scale), not above the last accepted step's (an iterate far from the
            // solution has accelerations, and an estimate, far from the step's) nor above
            // TRUNCATION_TOL_MAX (unresolved stiff modes inflate the estimate)
            let tol = if truncation > 0.0 {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                let da = if self.avx2 {
                    unsafe { max_abs_difference_avx2(&self.ydd[..n], &self.ydd0[..n]) }
                } else {
                    max_abs_difference(&self.ydd[..n], &self.ydd0[..n])
                };
                #[cfg(not(target_arch = "x86_64"))]
                let da = max_abs_difference(&self.ydd[..n], &self.ydd0[..n]);
                truncation_now = truncation * da / ymax.max(scale_floor);
                let relaxed = truncation_now
                    .min(self.truncation_last)
                    .min(crate::run::TRUNCATION_TOL_MAX);
                self.settings.newton.tol.max(relaxed)
            } else {
                self.settings.newton.tol
            };
            if linear || last_corr <= tol {
                break true;
            }
            if carried && self.iter_rate < CONTRACTION_STOP {
                if let Some(margin) = self.carried_rate_margin() {
                    if self.iter_rate * last_corr <= margin * tol {
                        // every joint's state and terms at this (final) iterate are at hand
                        self.margin_state = true;
                        break true;
                    }
                }
            }
            if iters >= 3 {
                // the error left after this correction, bounded by the contraction of the last
                // two (`prev_corr[1]` is the one before; the first correction, which takes out
                // the predictor's error, says nothing of the iteration's rate)
                let rho = last_corr / prev_corr[1];
                if rho < CONTRACTION_STOP && rho / (1.0 - rho) * last_corr <= tol {
                    break true;
                }
            }
            if iters == 1 {
                first_res = last_res;
            }
            if last_corr <= ROUNDOFF_FLOOR
                && last_corr >= prev_corr[0].min(prev_corr[1])
                && last_res <= ROUNDOFF_RESIDUAL * first_res
            {
                // stalled: no smaller than one of the two corrections before it (round-off
                // fluctuates; a slow but converging iteration keeps decreasing and goes on), at
                // a level no result depends on: what is left is the system's round-off
                self.stats.roundoff_steps += 1;
                break true;
            }
            prev_corr = [prev_corr[1], last_corr];
            if iters >= self.settings.newton.max_iter {
                break false;
            }
        };
        self.stats.iterations += iters as u64;
        self.stats.max_iterations = self.stats.max_iterations.max(iters as u64);
        self.steps_begun += 1;
        self.reuse_ok = converged && iters <= JACOBIAN_REUSE_ITERATIONS;
        self.reusing = false;
        if converged {
            self.truncation_last = truncation_now;
            if nm.is_alpha() {
                // aa_{n+1} = b + (1 - alpha_f)/(1 - alpha_m) a_{n+1}
                let k2 = nm.alpha_constants()[2];
                for i in 0..self.n {
                    self.aa[i] += k2 * self.a[i];
                }
            } else {
                self.extrapolation.converged(t, h, &self.ydd0, &self.ydd);
            }
            if iterate_friction {
                // the bristle states of the accepted step, at its final state
                self.evaluate_friction(h);
                for (z, f) in self.fric_z.iter_mut().zip(&self.fric) {
                    *z = f.eval.z;
                }
            }
            return Ok(());
        }
        self.restore();
        self.update_frames(t);
        if rate_step && !self.direct && self.rate.as_ref().is_some_and(|r| r.fixed_step.is_none()) {
            // the Newton stepper's step on the contact-free factor did not converge: redo it
            // refactorizing the whole Jacobian when it changes (which also refreshes the
            // geometric tangent at every contact change), as the reference path does
            self.stats.woodbury_fallbacks += 1;
            self.direct = true;
            let res = self.step(t, h, step, depth);
            self.direct = false;
            return res;
        }
        if depth < self.settings.newton.step_halving {
            self.step(t, 0.5 * h, step, depth + 1)?;
            self.step(t + 0.5 * h, 0.5 * h, step, depth + 1)?;
            self.stats.halved_substeps += 2;
            return Ok(());
        }
        Err(Error::NotConverged {
            time: t,
            step,
            iterations: iters,
            residual: last_res,
            correction: last_corr,
        })
    }

    fn restore(&mut self) {
        self.jstate_fresh = false;
        self.y.copy_from_slice(&self.y0);
        self.yd.copy_from_slice(&self.yd0);
        self.ydd.copy_from_slice(&self.ydd0);
        if self.settings.newmark.is_alpha() {
            self.aa.copy_from_slice(&self.aa0);
        }
    }

    /// The alpha schemes' predictors of a step of `h` (s) from the state in `y`, `yd`, `ydd`,
    /// `aa` ([`crate::integrator::Newmark`]): `b = (alpha_f a_n - alpha_m aa_n)/(1 - alpha_m)`,
    /// `y~ = y + h v + h^2 (1/2 - beta) aa + beta h^2 b`, `v~ = v + h (1 - gamma) aa + gamma h b`;
    /// the first iterate keeps `a = a_n`. Keeps `aa_n` in `aa0` and `b` in `aa` (completed
    /// with the step's `a_{n+1}` when it converges).
    fn alpha_predictors(&mut self, h: f64) {
        let nm = self.settings.newmark;
        let (bh2, gh) = nm.coefficients(h);
        let [k0, k1, _] = nm.alpha_constants();
        let (bh2r, ghr) = (nm.beta * h * h, nm.gamma * h);
        self.aa0.copy_from_slice(&self.aa);
        for i in 0..self.n {
            let (y0, v0, a0, aa0) = (self.y[i], self.yd[i], self.ydd[i], self.aa[i]);
            let b = k0 * a0 + k1 * aa0;
            self.y_pred[i] = y0 + h * v0 + (0.5 - nm.beta) * h * h * aa0 + bh2r * b;
            self.v_pred[i] = v0 + (1.0 - nm.gamma) * h * aa0 + ghr * b;
            self.aa[i] = b;
            self.a[i] = a0;
            self.y[i] = self.y_pred[i] + bh2 * a0;
            self.yd[i] = self.v_pred[i] + gh * a0;
            self.ydd[i] = a0;
        }
    }
}
