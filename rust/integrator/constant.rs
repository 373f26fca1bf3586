//! Newmark (beta, gamma) at a fixed step, in acceleration form:
//!
//! ```text
//! u~ = u_n + dt v_n + dt^2 (1/2 - beta) a_n,      v~ = v_n + dt (1 - gamma) a_n
//! (M + gamma dt C + beta dt^2 K) a_{n+1} = F(t_{n+1}) - C v~ - K u~ + contact
//! u_{n+1} = u~ + beta dt^2 a_{n+1},               v_{n+1} = v~ + gamma dt a_{n+1}
//! ```
//!
//! The generalized-alpha family ([`Newmark`]: Chung-Hulbert, HHT, in the Arnold-Bruls form)
//! runs the same step with `beta`, `gamma` replaced by [`Newmark::coefficients`] and predictors
//! that carry the acceleration-like variable; plain Newmark keeps the code above, bitwise.
//!
//! The contact-free effective matrix `A0 = M + gamma dt C + beta dt^2 K` is factorized once. A
//! clearance joint adds `P^T (beta dt^2 k + gamma dt c) P` on its 2 (or 4) DOFs (modified and gap
//! couplings); that is solved with the `A0` factorization and a Sherman-Morrison-Woodbury
//! correction `a = z + Z (h - s)`, `z = A0^-1 r`, `Z = A0^-1 P^T`, `s = (I + G W)^-1 G (P z + W h)`,
//! `W = P Z`: an open contact has `G = 0` and costs nothing extra, and iterating the contact within
//! a step needs no further sparse solve. The loop does not allocate.
//!
//! **Lockstep.** Runs whose `A0` is the same (same M, C, K, dt, beta, gamma: e.g. samples of a
//! study that differ only in clearance or bearing law) share that factorization and can step
//! together: [`Lockstep`] advances `L` such runs ("lanes") at once, with the global vectors stored
//! lane-fastest (`u[dof][lane]`), so the banded substitution and the band product load each matrix
//! entry once and run `L` independent dependency chains side by side (the single substitution is
//! latency-bound). The joint work (contact law, Woodbury correction, iterations, recording,
//! divergence checks) is per lane. Every lane does exactly the floating-point operations of a
//! single run, in the same order, so its result is bitwise that of [`NewmarkRun`] (which is the
//! one-lane case of the same code). A lane that fails (divergence, a contact matrix that is not
//! positive definite) is finished with its own error and what it recorded, and the others go on.
//!
//! **Event-aware stepping** ([`Settings::events`], one-lane runs only). A step that changes a
//! joint's contact status (sign of the penetration `delta = |q| - c`) is redone from its start as
//! two substeps cut at `theta dt` (first estimate `theta = delta_0 / (delta_0 - delta_1)`, linear
//! interpolation between the step's ends, earliest joint; refined by regula falsi on the first
//! substep's end penetration so that it ends just short of the circle), the acceleration restarted
//! at the cut with the new status, each with the contact-free factorization of its own
//! size (numeric refactorization on the shared analysis; the Woodbury columns are rebuilt). The
//! next step is at the nominal size again, so output stays on the `dt` grid; of the state at the
//! cut only the contact force enters the running largest force (it is the peak of an entry with
//! contact damping). A step without a status change is bitwise the fixed-step one.
//!
//! **Adaptive steps** ([`Settings::adaptive`](crate::run::Settings::adaptive), one-lane runs
//! only; the `tol=` runs of Python on translating models): the controller of the Newton stepper
//! (`integrator/newton.rs`, "Adaptive steps") on this stepper. Steps are `h_max / 2^m` (the
//! level `m`; `Adaptive::h_max`), independent of the output grid `dt`, chosen by the
//! Zienkiewicz-Xie estimate `|beta - 1/6| h^2 |a_(n+1) - a_n|` against `atol + rtol |u|`; a
//! rejected step goes up by the levels the `h^3` law asks, an easy one (below a tenth of the
//! tolerance) lets the next go down one level; a step that changes a joint's status is cut just
//! short of the circle (the cut substep keeping the start's statuses, as above) and the
//! accelerations restart there with the crossing joint on its new side (the right limit,
//! recorded). `A0` depends on the step only, so the step constants (`A0`'s numeric factorization
//! on the shared analysis and its Woodbury columns) of up to `FACTOR_CACHE` recent step sizes are
//! kept besides the one in use: a level that comes back swaps its constants in and costs no
//! refactorization; a miss refills the least recently used slot in place (an odd length in
//! use, a cut's, is refilled in place and evicts no level). Every factorization counts in
//! `stats.factorizations`. A step whose cubic Hermite joint path passes through a clearance
//! circle between open ends is redone shorter, so no contact is stepped over. Accepted steps'
//! ends enter the joints' extremes (largest force and penetration, impacts), and so does a
//! smooth contact peak within a step (the cubic Hermite interpolant of the joint's relative
//! displacement sampled at 7 points, as on Newton); an output instant inside a step records the
//! interpolated state (Hermite displacements and joint paths, linear accelerations), in time
//! order with the steps' ends.
//! Nothing is allocated in the time loop besides the cache's first fills.
//!
//! **Divergence checks**: the one rule of [`super::divergence`]. Every step, each joint's
//! penetration `delta` (positive = overlap; an open gap of any width passes) is compared with the
//! divergence limit (one comparison per joint, which is also the finite check); every
//! `CHECK_STRIDE` steps and at the last step the whole state is checked for finiteness and the
//! translational DOFs against the limit.

use super::adaptive::{self, Levels};
use super::divergence;
use super::events::{earliest_crossing, penetration_rate, CutSearch, EVENT_MAX_CUTS};
use super::run_loop::{self, Stepper};
use super::{norm2, same_instant};
use crate::contact::{evaluation, ContactTerms, Coupling, Mat2};
use crate::error::{Error, Result};
use crate::linalg::{capacitance_solve, subtract_ws, Analysis, AnalysisCache, Cholesky, LowRankBlocks};
use crate::model::NODE_DOFS;
use crate::plan::assembly::{shares_factor, Frames, Pattern, System};
use crate::plan::translating::Model;
use crate::record::Recorder;
use crate::run::{RunFailure, RunOutput, RunStats, Settings, SolverMode};
use std::sync::Arc;

/// Parameters of the Newmark family of schemes: plain Newmark (beta, gamma), and the
/// generalized-alpha family (Chung & Hulbert 1993; HHT-alpha, Hilber, Hughes & Taylor 1977, as
/// its `alpha_m = 0` member) in the form of Arnold & Bruls (2007) with an acceleration-like
/// variable `aa`:
///
/// ```text
/// y_{n+1} = y_n + h v_n + h^2 (1/2 - beta) aa_n + h^2 beta aa_{n+1}
/// v_{n+1} = v_n + h (1 - gamma) aa_n + h gamma aa_{n+1}
/// (1 - alpha_m) aa_{n+1} + alpha_m aa_n = (1 - alpha_f) a_{n+1} + alpha_f a_n,   aa_0 = a_0
/// ```
///
/// where `a_{n+1}` is the true acceleration, which satisfies the equations of motion at
/// `t_{n+1}` (contact, frames and geometric terms evaluated there as for Newmark). Each step
/// still solves for `a_{n+1}`: `y = y~ + beta' h^2 a`, `v = v~ + gamma' h a` with
/// `beta' = beta (1 - alpha_f)/(1 - alpha_m)`, `gamma' = gamma (1 - alpha_f)/(1 - alpha_m)`
/// ([`Newmark::coefficients`]) and predictors `y~`, `v~` that carry `aa_n` and
/// `b = (alpha_f a_n - alpha_m aa_n)/(1 - alpha_m)`. On linear problems this is the
/// Chung-Hulbert scheme (same spectral radius, second order when
/// `gamma = 1/2 - alpha_m + alpha_f`). With `alpha_m = alpha_f = 0`, `aa = a` and the step is
/// plain Newmark, bitwise.
///
/// Default: average acceleration (beta 1/4, gamma 1/2, no alpha), unconditionally stable for
/// linear systems and without numerical damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Newmark {
    /// beta: in (0, 1/2] for plain Newmark; `(1 - alpha_m + alpha_f)^2 / 4` for the alpha schemes.
    pub beta: f64,
    /// gamma: in [1/2, 1] for plain Newmark; `1/2 - alpha_m + alpha_f` for the alpha schemes.
    pub gamma: f64,
    /// alpha_m (Chung-Hulbert convention; 0 for Newmark and HHT): in [-1, 1/2].
    pub alpha_m: f64,
    /// alpha_f (Chung-Hulbert convention; 0 for Newmark, `-alpha` for HHT): in [alpha_m, 1/2].
    pub alpha_f: f64,
}

impl Default for Newmark {
    fn default() -> Self {
        Newmark {
            beta: 0.25,
            gamma: 0.5,
            alpha_m: 0.0,
            alpha_f: 0.0,
        }
    }
}

impl Newmark {
    /// Chung-Hulbert generalized-alpha with spectral radius `rho_inf` at infinite frequency
    /// (in [0, 1]; 1 = average acceleration, no dissipation; 0 = asymptotic annihilation):
    /// `alpha_m = (2 rho - 1)/(rho + 1)`, `alpha_f = rho/(rho + 1)`,
    /// `gamma = 1/2 - alpha_m + alpha_f`, `beta = (1 - alpha_m + alpha_f)^2 / 4`.
    /// `rho_inf = 1` (`alpha_m = alpha_f = 1/2`, for which `aa = a` at every step) is returned
    /// as the plain average-acceleration Newmark it is, which runs bitwise as the default.
    pub fn generalized_alpha(rho_inf: f64) -> Result<Self> {
        if !(0.0..=1.0).contains(&rho_inf) {
            return Err(Error::param("rho_inf", rho_inf, "in [0, 1]"));
        }
        if rho_inf == 1.0 {
            return Ok(Newmark::default());
        }
        let alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
        let alpha_f = rho_inf / (rho_inf + 1.0);
        Ok(Self::alpha(alpha_m, alpha_f))
    }

    /// HHT-alpha (Hilber, Hughes & Taylor 1977) with `alpha` in [-1/3, 0] (0 = average
    /// acceleration): `alpha_m = 0`, `alpha_f = -alpha`, `gamma = 1/2 - alpha`,
    /// `beta = (1 - alpha)^2 / 4`; spectral radius at infinite frequency
    /// `(1 + alpha)/(1 - alpha)`. `alpha = 0` is the default Newmark.
    pub fn hht(alpha: f64) -> Result<Self> {
        if !(-1.0 / 3.0..=0.0).contains(&alpha) {
            return Err(Error::param("hht_alpha", alpha, "in [-1/3, 0]"));
        }
        if alpha == 0.0 {
            return Ok(Newmark::default());
        }
        Ok(Self::alpha(0.0, -alpha))
    }

    /// The second-order, unconditionally stable member with `alpha_m`, `alpha_f`.
    fn alpha(alpha_m: f64, alpha_f: f64) -> Self {
        let g = 0.5 - alpha_m + alpha_f;
        Newmark {
            beta: 0.25 * (g + 0.5) * (g + 0.5),
            gamma: g,
            alpha_m,
            alpha_f,
        }
    }

    /// Whether the scheme carries the acceleration-like variable (`alpha_m` or `alpha_f`
    /// nonzero); plain Newmark otherwise.
    #[inline]
    pub fn is_alpha(&self) -> bool {
        self.alpha_m != 0.0 || self.alpha_f != 0.0
    }

    /// The `gamma` of a step's first-order velocity error, `|gamma - 1/2| h |a_(n+1) - a_n|`
    /// ([`crate::integrator::adaptive::ForceErrors`]): Newmark's own, and 1/2 for the alpha
    /// schemes, which are of second order with `gamma > 1/2` (their first-order terms cancel
    /// over steps).
    #[inline]
    pub fn error_gamma(&self) -> f64 {
        if self.is_alpha() {
            0.5
        } else {
            self.gamma
        }
    }

    /// The coefficients `(bh2, gh)` of the unknown acceleration in a step of `h` (s):
    /// `y = y~ + bh2 a`, `v = v~ + gh a`, i.e. `(beta h^2, gamma h)` times
    /// `(1 - alpha_f)/(1 - alpha_m)` for the alpha schemes.
    #[inline]
    pub fn coefficients(&self, h: f64) -> (f64, f64) {
        if self.is_alpha() {
            let r = (1.0 - self.alpha_f) / (1.0 - self.alpha_m);
            (self.beta * h * h * r, self.gamma * h * r)
        } else {
            (self.beta * h * h, self.gamma * h)
        }
    }

    /// The constants of the acceleration-like update, `[alpha_f, -alpha_m, 1 - alpha_f]` over
    /// `1 - alpha_m`: `b = c0 a_n + c1 aa_n`, `aa_{n+1} = b + c2 a_{n+1}`.
    #[inline]
    pub fn alpha_constants(&self) -> [f64; 3] {
        let d = 1.0 - self.alpha_m;
        [self.alpha_f / d, -self.alpha_m / d, (1.0 - self.alpha_f) / d]
    }

    /// Checks the parameters: plain Newmark `beta` in (0, 1/2], `gamma` in [1/2, 1]; an alpha
    /// scheme needs `-1 <= alpha_m <= alpha_f <= 1/2`, `gamma = 1/2 - alpha_m + alpha_f`
    /// (second order) and `beta >= gamma/2` (unconditional stability).
    pub fn validate(&self) -> Result<()> {
        if !self.is_alpha() {
            if !(self.beta > 0.0 && self.beta <= 0.5) {
                return Err(Error::param("beta", self.beta, "in (0, 0.5]"));
            }
            if !(self.gamma >= 0.5 && self.gamma <= 1.0) {
                return Err(Error::param("gamma", self.gamma, "in [0.5, 1]"));
            }
            return Ok(());
        }
        if !(-1.0..=0.5).contains(&self.alpha_m) {
            return Err(Error::param("alpha_m", self.alpha_m, "in [-1, 0.5]"));
        }
        if !(self.alpha_m..=0.5).contains(&self.alpha_f) {
            return Err(Error::param(
                "alpha_f",
                self.alpha_f,
                format!("in [alpha_m = {}, 0.5]", self.alpha_m),
            ));
        }
        let g = 0.5 - self.alpha_m + self.alpha_f;
        let off = (self.gamma - g).abs();
        if off.is_nan() || off > 1e-12 {
            return Err(Error::param(
                "gamma",
                self.gamma,
                format!("1/2 - alpha_m + alpha_f = {g} (second order) with alpha_m, alpha_f set"),
            ));
        }
        if !(self.beta >= 0.5 * self.gamma - 1e-12 && self.beta <= 1.0) {
            return Err(Error::param(
                "beta",
                self.beta,
                format!("in [gamma/2 = {}, 1] with alpha_m, alpha_f set", 0.5 * self.gamma),
            ));
        }
        Ok(())
    }
}

/// Steps between calls of the caller's control function (progress and interruption).
const CONTROL_STRIDE: u64 = 1 << 14;
/// Steps between full finite/limit checks of the state.
/// Woodbury is abandoned for a step whose capacitance pivot ratio is below this.
const WOODBURY_RCOND: f64 = 1e-12;

/// One run's outcome: its output, or why it stopped with what it recorded until then.
pub type RunResult = std::result::Result<RunOutput, Box<RunFailure>>;

/// A run in progress: the assembled system, factorizations, state and workspace. The one-lane
/// case of [`Lockstep`].
pub struct NewmarkRun<'m> {
    inner: Lockstep<'m, 1>,
}

impl<'m> NewmarkRun<'m> {
    /// Assembles and factorizes; computes the initial acceleration. `model` and `settings` must
    /// be validated. Fails with [`Error::Singular`] if the mass or effective matrix is not
    /// positive definite.
    pub fn new(model: &'m Model, settings: &Settings) -> Result<Self> {
        Self::with_analysis(model, settings, None)
    }

    /// As [`Self::new`], taking the symbolic factorization of the model's pattern from `cache`
    /// (shared among the samples of a study) when given; otherwise the analysis is done here.
    /// One analysis serves all of the run's factorizations.
    pub fn with_analysis(model: &'m Model, settings: &Settings, cache: Option<&AnalysisCache>) -> Result<Self> {
        let mut inner = Lockstep::<1>::with_analysis(&[(model, settings)], cache)?;
        if let Some(Err(f)) = inner.lanes[0].outcome.take() {
            return Err(f.error);
        }
        Ok(NewmarkRun { inner })
    }

    /// Runs to the end. See [`crate::run::simulate`].
    pub fn run(self, control: &mut dyn FnMut(f64) -> bool) -> RunResult {
        self.inner.run(control).pop().expect("a one-lane run has one outcome")
    }
}

/// A symmetric matrix stored as a dense band (row `r` holds columns `r - w ..= r + w`), for the
/// per-step products `K x` and `C x` on lane-fastest vectors; the sums are formed in the order of
/// [`crate::plan::assembly::Band::mul`], lane by lane.
struct LaneBand {
    n: usize,
    w: usize,
    vals: Vec<f64>,
    /// The CPU has AVX2 (x86_64): products of several lanes use 256-bit registers.
    avx2: bool,
}

impl LaneBand {
    /// The band of values `a` on `pattern` ([`crate::plan::assembly::Band::from_csc`]), or `None` when
    /// the band would hold more than twice the pattern's entries.
    fn from_csc(pattern: &Pattern, a: &[f64]) -> Option<LaneBand> {
        let (n, w, vals) = crate::plan::assembly::Band::from_csc(pattern, a)?.into_parts();
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        Some(LaneBand { n, w, vals, avx2 })
    }

    fn padded_len(&self) -> usize {
        self.n + 2 * self.w
    }

    /// `y = A x` for every lane, `xpad` holding `x` at `xpad[w .. w + n]` and zeros at the ends.
    #[inline]
    fn mul<const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        let width = 2 * self.w + 1;
        assert!(xpad.len() == self.padded_len() && y.len() >= self.n);
        if width == 11 {
            #[cfg(target_arch = "x86_64")]
            if L.is_multiple_of(4) && self.avx2 {
                // SAFETY: the CPU reports AVX2.
                return unsafe { self.mul_fixed_avx2::<11, L>(xpad, y) };
            }
            return self.mul_fixed::<11, L>(xpad, y);
        }
        for (r, (row, yr)) in self.vals.chunks_exact(width).zip(y.iter_mut()).enumerate() {
            let x = &xpad[r..r + width];
            for l in 0..L {
                let mut s = [0.0; 4];
                let (rc, xc) = (row.chunks_exact(4), x.chunks_exact(4));
                let (rr, xr) = (rc.remainder(), xc.remainder());
                for (a, b) in rc.zip(xc) {
                    for k in 0..4 {
                        s[k] += a[k] * b[k][l];
                    }
                }
                let mut t = (s[0] + s[1]) + (s[2] + s[3]);
                for (a, b) in rr.iter().zip(xr) {
                    t += a * b[l];
                }
                yr[l] = t;
            }
        }
    }

    /// [`Self::mul_fixed`] for `L` a multiple of 4 with explicit 256-bit vectors across lanes
    /// (left to itself, the compiler vectorizes across rows instead, with shuffles and spills).
    /// The same IEEE additions and multiplications in the same order, so bitwise the same.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn mul_fixed_avx2<const W: usize, const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        use std::arch::x86_64::{
            _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
        };
        assert!(L.is_multiple_of(4) && xpad.len() >= self.n + W - 1 && y.len() >= self.n);
        for (r, (row, yr)) in self.vals.chunks_exact(W).zip(y.iter_mut()).enumerate() {
            let x = &xpad[r..r + W];
            let mut c = 0;
            while c < L {
                // SAFETY: c + 4 <= L, so every load and the store stay within one [f64; L].
                unsafe {
                    macro_rules! term {
                        ($k:expr) => {
                            _mm256_mul_pd(
                                _mm256_set1_pd(row[$k]),
                                _mm256_loadu_pd(x[$k].as_ptr().add(c)),
                            )
                        };
                    }
                    let (mut a0, mut a1, mut b0, mut b1) = (
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                        _mm256_setzero_pd(),
                    );
                    let mut k = 0;
                    while k + 4 <= W {
                        a0 = _mm256_add_pd(a0, term!(k));
                        a1 = _mm256_add_pd(a1, term!(k + 1));
                        b0 = _mm256_add_pd(b0, term!(k + 2));
                        b1 = _mm256_add_pd(b1, term!(k + 3));
                        k += 4;
                    }
                    while k + 2 <= W {
                        a0 = _mm256_add_pd(a0, term!(k));
                        a1 = _mm256_add_pd(a1, term!(k + 1));
                        k += 2;
                    }
                    let mut t = _mm256_add_pd(_mm256_add_pd(a0, b0), _mm256_add_pd(a1, b1));
                    if k < W {
                        t = _mm256_add_pd(t, term!(k));
                    }
                    _mm256_storeu_pd(yr.as_mut_ptr().add(c), t);
                }
                c += 4;
            }
        }
    }

    #[inline(always)]
    fn mul_fixed<const W: usize, const L: usize>(&self, xpad: &[[f64; L]], y: &mut [[f64; L]]) {
        for (r, (row, yr)) in self.vals.chunks_exact(W).zip(y.iter_mut()).enumerate() {
            let row: &[f64; W] = row.try_into().expect("chunk of width W");
            let x: &[[f64; L]; W] = xpad[r..r + W].try_into().expect("window of width W");
            // the accumulators and order of `Band::mul_fixed`, lane by lane
            let (mut a0, mut a1, mut b0, mut b1) = ([0.0f64; L], [0.0f64; L], [0.0f64; L], [0.0f64; L]);
            let mut k = 0;
            while k + 4 <= W {
                for l in 0..L {
                    a0[l] += row[k] * x[k][l];
                    a1[l] += row[k + 1] * x[k + 1][l];
                    b0[l] += row[k + 2] * x[k + 2][l];
                    b1[l] += row[k + 3] * x[k + 3][l];
                }
                k += 4;
            }
            while k + 2 <= W {
                for l in 0..L {
                    a0[l] += row[k] * x[k][l];
                    a1[l] += row[k + 1] * x[k + 1][l];
                }
                k += 2;
            }
            for l in 0..L {
                let mut t = (a0[l] + b0[l]) + (a1[l] + b1[l]);
                if k < W {
                    t += row[k] * x[k][l];
                }
                yr[l] = t;
            }
        }
    }
}

/// `y = A x` on every lane through the band when there is one, else lane by lane on the pattern.
#[inline]
#[allow(clippy::too_many_arguments)]
fn matvec<const L: usize>(
    pattern: &Pattern,
    band: Option<&LaneBand>,
    a: &[f64],
    x: &[[f64; L]],
    xpad: &mut [[f64; L]],
    y: &mut [[f64; L]],
    col_x: &mut [f64],
    col_y: &mut [f64],
) {
    match band {
        Some(b) => {
            let w = b.w;
            xpad[w..w + x.len()].copy_from_slice(x);
            b.mul(xpad, y);
        }
        None if L == 1 => pattern.mul(a, x.as_flattened(), y.as_flattened_mut()),
        None => {
            for l in 0..L {
                get_lane(x, l, col_x);
                pattern.mul(a, col_x, col_y);
                set_lane(y, l, col_y);
            }
        }
    }
}

/// Copies lane `l` of `x` into `out`.
#[inline]
fn get_lane<const L: usize>(x: &[[f64; L]], l: usize, out: &mut [f64]) {
    for (o, xi) in out.iter_mut().zip(x) {
        *o = xi[l];
    }
}

/// Copies `v` into lane `l` of `x`.
#[inline]
fn set_lane<const L: usize>(x: &mut [[f64; L]], l: usize, v: &[f64]) {
    for (xi, &o) in x.iter_mut().zip(v) {
        xi[l] = o;
    }
}

/// `P x` of joint `j` on lane `l`, with the operations of [`System::joint_project`].
#[inline]
fn project_lane<const L: usize>(j: &crate::plan::assembly::JointPlan, x: &[[f64; L]], l: usize) -> [f64; 2] {
    let mut r = [0.0; 2];
    for k in 0..j.ndof {
        let v = x[j.dofs[k]][l];
        r[0] += j.coef[0][k] * v;
        r[1] += j.coef[1][k] * v;
    }
    r
}

fn mat2_is_zero(m: &Mat2) -> bool {
    m[0][0] == 0.0 && m[0][1] == 0.0 && m[1][0] == 0.0 && m[1][1] == 0.0
}

/// What the lanes share: the contact-free matrices, their factorization, the Woodbury columns,
/// the step constants, and (when every lane has the same frame motions) the frames.
struct Shared {
    /// Lane 0's system (pattern, M, K, C, joint DOFs and projections are every lane's).
    sys: System,
    n: usize,
    m: usize,
    dt: f64,
    c1: f64,
    c2: f64,
    bdt2: f64,
    gdt: f64,
    /// `beta dt^2`, `gamma dt` (the alpha schemes' predictors).
    bdt2r: f64,
    gdtr: f64,
    /// The alpha schemes' [`Newmark::alpha_constants`]; `None` for plain Newmark.
    alpha: Option<[f64; 3]>,
    steps: u64,
    chol0: Cholesky,
    a0_values: Vec<f64>,
    /// Positions of each joint's DOF block in the pattern, `[a][b]`.
    joint_pos: Vec<[[usize; 4]; 4]>,
    zcols: Vec<f64>,
    wmat: Vec<f64>,
    /// Banded copies of K and C for the per-step products, when the pattern is banded.
    k_band: Option<LaneBand>,
    c_band: Option<LaneBand>,
    translational: Vec<bool>,
    /// Every lane has lane 0's link and body motions and inertia loads: frames are evaluated
    /// once per step into `frames` and the inertia load is the same on every lane.
    frames_shared: bool,
    frames: Frames,
    /// The mass matrix factorization (initial and event restart accelerations).
    mchol: Cholesky,
    /// The output grid's step, s (`settings.dt`; `dt` above is the step in use).
    grid_dt: f64,
    /// The longest step of adaptive steps, s (`Adaptive::h_max`; the levels are `h_max / 2^m`),
    /// `grid_dt` without them.
    h_max: f64,
    /// Adaptive steps: the step constants of recent step sizes besides the one in use
    /// ([`FactorCache`]); empty otherwise.
    cache: FactorCache,
}

/// Adaptive steps' small cache of factorizations: the constants ([`StepConsts`]: `A0`'s numeric
/// factorization on the shared analysis and its Woodbury columns) of up to [`FACTOR_CACHE`]
/// recent step sizes besides the one in [`Shared`], so that a step size that comes back costs no
/// refactorization. A step of another size swaps its constants in (a hit), or refills the least
/// recently used slot in place (a miss; slots holding a cut's odd length go first); an odd
/// length in use is refilled in place by the next odd length.
#[derive(Default)]
struct FactorCache {
    slots: Vec<StepConsts>,
    /// When each slot's constants were last in use (a counter).
    used: Vec<u64>,
    clock: u64,
}

/// Step sizes whose factorizations adaptive steps keep besides the one in use: levels
/// `h_max / 2^m` come back as the controller moves one level at a time, and into a contact it
/// spans a factor of 100 or more in step (eight levels with the one in use: a factor of 128).
/// A cut's odd lengths are refilled in place of the one in use and evict no level.
pub(crate) const FACTOR_CACHE: usize = 7;

/// The step-size-dependent part of [`Shared`]: the Newmark constants for a step `dt`, the
/// contact-free effective matrix `A0 = M + gamma dt C + beta dt^2 K`, its factorization and the
/// Woodbury columns `Z = A0^-1 P^T`, `W = P Z`. Event-aware stepping swaps in those of a substep.
struct StepConsts {
    dt: f64,
    c1: f64,
    c2: f64,
    bdt2: f64,
    gdt: f64,
    bdt2r: f64,
    gdtr: f64,
    chol0: Cholesky,
    a0_values: Vec<f64>,
    zcols: Vec<f64>,
    wmat: Vec<f64>,
}

impl StepConsts {
    /// The constants of step `dt` (s) for `sys` under the scheme `nm` (`bdt2`, `gdt` its
    /// [`Newmark::coefficients`], `bdt2r = beta dt^2`, `gdtr = gamma dt`); factorizes `A0` with
    /// `chol` (its analysis must be that of `sys.pattern`).
    fn new(sys: &System, dt: f64, nm: &Newmark, chol: Cholesky) -> Result<Self> {
        let mut c = StepConsts {
            dt: 0.0,
            c1: 0.0,
            c2: 0.0,
            bdt2: 0.0,
            gdt: 0.0,
            bdt2r: 0.0,
            gdtr: 0.0,
            chol0: chol,
            a0_values: vec![0.0; sys.pattern.nnz()],
            zcols: Vec::new(),
            wmat: Vec::new(),
        };
        c.refill(sys, dt, nm)?;
        Ok(c)
    }

    /// Makes these the constants of step `dt` (s) in place, as [`Self::new`] builds them (the
    /// same operations): a numeric refactorization on the same analysis, the Woodbury columns
    /// rebuilt in their storage (nothing is allocated once they have their size).
    fn refill(&mut self, sys: &System, dt: f64, nm: &Newmark) -> Result<()> {
        let (bdt2, gdt) = nm.coefficients(dt);
        let (beta, gamma) = (nm.beta, nm.gamma);
        for (p, x) in self.a0_values.iter_mut().enumerate() {
            *x = sys.mass[p] + gdt * sys.damping[p] + bdt2 * sys.stiffness[p];
        }
        self.chol0
            .factorize(&self.a0_values, "the effective matrix M + gamma dt C + beta dt^2 K")?;
        // Z = A0^-1 P^T, W = P Z (as `Woodbury::new`, in this storage)
        let p = sys.joints.as_slice();
        let n = sys.n();
        let m = 2 * LowRankBlocks::blocks(p);
        self.zcols.clear();
        self.zcols.resize(n * m, 0.0);
        for b in 0..p.blocks() {
            for r in 0..2 {
                let col = &mut self.zcols[(2 * b + r) * n..(2 * b + r + 1) * n];
                p.scatter(b, r, col);
                self.chol0.solve_in_place(col);
            }
        }
        self.wmat.clear();
        self.wmat.resize(m * m, 0.0);
        for b in 0..p.blocks() {
            for c in 0..m {
                let pz = p.project(b, &self.zcols[c * n..(c + 1) * n]);
                self.wmat[(2 * b) * m + c] = pz[0];
                self.wmat[(2 * b + 1) * m + c] = pz[1];
            }
        }
        self.dt = dt;
        self.c1 = dt * dt * (0.5 - beta);
        self.c2 = dt * (1.0 - gamma);
        self.bdt2 = bdt2;
        self.gdt = gdt;
        self.bdt2r = beta * dt * dt;
        self.gdtr = gamma * dt;
        Ok(())
    }
}

impl Shared {
    /// Exchanges the step constants in use with `o`.
    fn swap_step(&mut self, o: &mut StepConsts) {
        std::mem::swap(&mut self.dt, &mut o.dt);
        std::mem::swap(&mut self.c1, &mut o.c1);
        std::mem::swap(&mut self.c2, &mut o.c2);
        std::mem::swap(&mut self.bdt2, &mut o.bdt2);
        std::mem::swap(&mut self.gdt, &mut o.gdt);
        std::mem::swap(&mut self.bdt2r, &mut o.bdt2r);
        std::mem::swap(&mut self.gdtr, &mut o.gdtr);
        std::mem::swap(&mut self.chol0, &mut o.chol0);
        std::mem::swap(&mut self.a0_values, &mut o.a0_values);
        std::mem::swap(&mut self.zcols, &mut o.zcols);
        std::mem::swap(&mut self.wmat, &mut o.wmat);
    }
}

/// The start-of-step state of a one-lane run, kept by event-aware stepping to redo the step.
#[derive(Default)]
struct Snapshot {
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    aa: Vec<f64>,
    q: Vec<[f64; 2]>,
    qd: Vec<[f64; 2]>,
    pen: Vec<f64>,
    force: Vec<[f64; 2]>,
    gap_closed: Vec<bool>,
    gap_normal: Vec<[f64; 2]>,
    pa_old: Vec<f64>,
    episode: Vec<Option<f64>>,
}

/// State of adaptive steps (one-lane runs): the start of the trial step, the penetrations at
/// its start and end, the tolerance, the level `m` of the next step `h_max / 2^m`, and the
/// dense output's bookkeeping and scratch.
struct AdaptiveSteps {
    /// The time of the integrated state (s: the end of the last accepted step, at or past the
    /// last output instant), the start of that step (s), and the run's end (s).
    t: f64,
    t_start: f64,
    t_end: f64,
    /// The end of the last accepted step when no output instant took it yet: `Some(true)` at
    /// a cut (its right limit, an event for the recorder), `Some(false)` otherwise.
    pending: Option<bool>,
    /// Whether the output instant being recorded lies inside the last accepted step (its state
    /// interpolated).
    interpolated: bool,
    /// Scratch of an interpolated output: displacements, and per joint the relative
    /// displacement and velocity, penetration and force.
    out_u: Vec<f64>,
    out_q: Vec<[f64; 2]>,
    out_qd: Vec<[f64; 2]>,
    out_pen: Vec<f64>,
    out_force: Vec<[f64; 2]>,
    /// The start of the trial step (after acceptance: of the last accepted step).
    snap: Snapshot,
    p0: Vec<f64>,
    p1: Vec<f64>,
    tol: crate::run::Adaptive,
    levels: Levels,
    /// Calls of the caller's control function between output instants.
    control: adaptive::ControlTicker,
    /// The achieved-accuracy estimate of the joints' largest forces.
    forces: adaptive::ForceErrors,
    /// Accepted steps since the last divergence check.
    accepted: divergence::AcceptedSteps,
    /// Per unknown, the length (m) its error is measured in: 1 for a displacement,
    /// [`adaptive::rotation_lever`] of its link's element length for a rotation (as the Newton
    /// stepper's error norm).
    err_scale: Vec<f64>,
}

/// Per unknown of `sys` (`n` of them), the length (m) by which the adaptive steps' error norm
/// weighs it: 1 for a displacement, [`adaptive::rotation_lever`] of the link's element length for
/// a node's rotation (every third unknown of a link: `u`, `v`, `theta` per node).
fn rotation_scales(model: &Model, sys: &System, n: usize) -> Vec<f64> {
    let mut scale = vec![1.0; n];
    for (link, plan) in model.links.iter().zip(&sys.links) {
        let lever = adaptive::rotation_lever(link.element_length());
        for k in (NODE_DOFS - 1..plan.ndof).step_by(NODE_DOFS) {
            scale[plan.offset + k] = lever;
        }
    }
    scale
}

/// Scratch of event-aware stepping (one-lane runs): the start-of-step snapshot.
#[derive(Default)]
struct Events {
    snap: Snapshot,
    /// Penetrations at the end of the trial step, m.
    pen1: Vec<f64>,
}

/// What each lane has of its own: its model and settings (clearances, contact laws, coupling,
/// recording), its contact state, the small Woodbury system, counters and recorder.
struct Lane<'m> {
    model: &'m Model,
    settings: Settings,
    sys: System,
    frames: Frames,
    chol_c: Option<Cholesky>,
    ac_values: Vec<f64>,
    /// Full right-hand side, for refactorized steps.
    rb: Vec<f64>,
    /// This lane's solution of a refactorized step; also scratch for lane extraction.
    sol: Vec<f64>,
    col: Vec<f64>,
    terms: Vec<ContactTerms>,
    g: Vec<Mat2>,
    g_factored: Vec<Mat2>,
    h: Vec<f64>,
    yb: Vec<f64>,
    s: Vec<f64>,
    pa: Vec<f64>,
    pa_old: Vec<f64>,
    cap: Vec<f64>,
    q: Vec<[f64; 2]>,
    qd: Vec<[f64; 2]>,
    qt: Vec<[f64; 2]>,
    qdt: Vec<[f64; 2]>,
    pen: Vec<f64>,
    force: Vec<[f64; 2]>,
    gap_closed: Vec<bool>,
    gap_normal: Vec<[f64; 2]>,
    gap_k: Vec<f64>,
    /// Joints whose law depends on the approach speed of the contact episode.
    needs_v0: Vec<bool>,
    /// Some joint's law does (one test per step for the laws that do not).
    any_v0: bool,
    /// Approach speed of each joint's current episode, m/s (`None` while open).
    episode: Vec<Option<f64>>,
    /// Event-aware stepping's first substep: each joint's contact status held at its
    /// start-of-step value (`Some(closed)`), so that the substep follows the old-status
    /// trajectory up to the crossing; empty otherwise.
    frozen: Vec<bool>,
    /// Contact status switches of each joint within the current step's iteration.
    switches: Vec<u8>,
    /// The previous iteration's change of the joint accelerations (stagnation test).
    prev_change: f64,
    limit: f64,
    stats: RunStats,
    rec: Recorder,
    /// The last step of this lane was solved by refactorization (solution in `sol`).
    refactored: bool,
    /// The recorder reads node displacements (needs this lane's `u`).
    reads_u: bool,
    /// Set when the lane has finished (failed, or at the end of the run).
    outcome: Option<RunResult>,
    /// The error of a lane failing in the current step, until it is retired.
    pending: Option<Error>,
}

/// `L` runs stepped together on one shared contact-free factorization (see the module
/// documentation). Build it with [`Lockstep::with_analysis`] from 1 to `L` runs for which
/// [`shares_factor`] holds; missing lanes are idle.
pub struct Lockstep<'m, const L: usize> {
    sh: Shared,
    lanes: Vec<Lane<'m>>,
    active: [bool; L],
    u: Vec<[f64; L]>,
    v: Vec<[f64; L]>,
    a: Vec<[f64; L]>,
    /// The alpha schemes' acceleration-like variable (empty for plain Newmark).
    aa: Vec<[f64; L]>,
    r: Vec<[f64; L]>,
    tmp: Vec<[f64; L]>,
    xpad: Vec<[f64; L]>,
    col_y: Vec<f64>,
    t: f64,
    step: u64,
}

impl<'m> Lane<'m> {
    fn new(model: &'m Model, settings: &Settings, sys: System) -> Self {
        let n = sys.n();
        let nj = sys.joints.len();
        let m = 2 * nj;
        let needs_refactor = nj > 0 && !matches!(settings.coupling, Coupling::Force);
        let limit = settings
            .divergence_limit
            .unwrap_or_else(|| 10.0 * model.links.iter().map(|l| l.section.length).fold(0.0, f64::max));
        let gap_k = sys
            .joints
            .iter()
            .map(|j| match settings.coupling {
                Coupling::Gap { stiffness, .. } => stiffness.unwrap_or(1000.0 * j.element_stiffness),
                _ => 0.0,
            })
            .collect();
        let mut terms_desc = vec!["M (consistent mass)".to_string(), "K1 (linear stiffness)".to_string()];
        if sys.damping.iter().any(|&c| c != 0.0) {
            terms_desc.push(match sys.proportional_damping {
                Some(c) => format!("D1 = (eta/E) K1, eta/E = {c:.4e} s (one matrix-vector product)"),
                None => "D1 (material damping, per-link eta/E)".to_string(),
            });
        }
        for (l, plan) in model.links.iter().zip(&sys.links) {
            if plan.inertia_load.is_some() {
                terms_desc.push(format!("M_R a_R (nominal translation inertia) on link {:?}", l.name));
            }
        }
        if nj > 0 {
            terms_desc.push(format!(
                "clearance contact, {} coupling, on {nj} joint(s)",
                settings.coupling.name()
            ));
        }
        let node_dof = |l: usize, node: usize| sys.links[l].offset + 3 * node;
        let clearances: Vec<f64> = sys.joints.iter().map(|j| j.clearance).collect();
        let mut rec = Recorder::new(&settings.record, &clearances, node_dof, settings.steps());
        if settings.adaptive.is_some() {
            rec.weigh_by_time();
        }
        let reads_u = settings.record.histories && !settings.record.nodes.is_empty();
        Lane {
            model,
            settings: settings.clone(),
            frames: sys.frames(),
            chol_c: None,
            ac_values: if needs_refactor {
                vec![0.0; sys.pattern.nnz()]
            } else {
                Vec::new()
            },
            rb: vec![0.0; n],
            sol: vec![0.0; n],
            col: vec![0.0; n],
            terms: vec![ContactTerms::default(); nj],
            g: vec![[[0.0; 2]; 2]; nj],
            g_factored: vec![[[f64::NAN; 2]; 2]; nj],
            h: vec![0.0; m],
            yb: vec![0.0; m],
            s: vec![0.0; m],
            pa: vec![0.0; m],
            pa_old: vec![0.0; m],
            cap: vec![0.0; m * m],
            q: vec![[0.0; 2]; nj],
            qd: vec![[0.0; 2]; nj],
            qt: vec![[0.0; 2]; nj],
            qdt: vec![[0.0; 2]; nj],
            pen: vec![0.0; nj],
            force: vec![[0.0; 2]; nj],
            gap_closed: vec![false; nj],
            gap_normal: vec![[1.0, 0.0]; nj],
            gap_k,
            needs_v0: model.joints.iter().map(|j| j.law.needs_approach_speed()).collect(),
            any_v0: model.joints.iter().any(|j| j.law.needs_approach_speed()),
            episode: vec![None; nj],
            frozen: Vec::new(),
            switches: vec![0; nj],
            prev_change: f64::INFINITY,
            limit,
            stats: RunStats {
                terms: terms_desc,
                stepper: "constant",
                unknowns: n,
                ..Default::default()
            },
            rec,
            refactored: false,
            reads_u,
            outcome: None,
            pending: None,
            sys,
        }
    }

    /// Initial state from the links' initial conditions and the initial acceleration from
    /// `M a0 = F(0) - K u0 - C v0 + contact(u0, v0)`, into `u`, `v`, `a` (this lane's vectors).
    fn initialize(
        &mut self,
        mchol: &mut Cholesky,
        translational: &[bool],
        u: &mut [f64],
        v: &mut [f64],
        a: &mut [f64],
    ) -> Result<()> {
        for (l, plan) in self.model.links.iter().zip(&self.sys.links) {
            if let Some(u0) = &l.initial_displacement {
                u[plan.offset..plan.offset + plan.ndof].copy_from_slice(u0);
            }
            if let Some(v0) = &l.initial_velocity {
                v[plan.offset..plan.offset + plan.ndof].copy_from_slice(v0);
            }
        }
        let pat = &self.sys.pattern;
        let r = a;
        pat.mul(&self.sys.stiffness, u, r);
        pat.mul(&self.sys.damping, v, &mut self.col);
        for (r, t) in r.iter_mut().zip(&self.col) {
            *r = -*r - t;
        }
        self.sys.frames_at(0.0, &mut self.frames);
        self.sys.add_inertia_load(&self.frames, r);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, &self.frames);
            let pu = System::joint_project(j, u);
            let pv = System::joint_project(j, v);
            self.q[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qd[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
            let q = self.q[jj];
            let dr = norm2(q);
            self.pen[jj] = dr - j.clearance;
            if self.needs_v0[jj] {
                self.episode[jj] = crate::contact::next_episode(q, self.qd[jj], self.pen[jj], None);
            }
            self.gap_closed[jj] = self.pen[jj] > 0.0;
            if dr > 0.0 {
                self.gap_normal[jj] = [q[0] / dr, q[1] / dr];
            }
            let terms = self.contact_terms(jj, q, self.qd[jj]);
            let f = terms.force(q, self.qd[jj]);
            self.force[jj] = f;
            let j = &self.sys.joints[jj];
            for k in 0..j.ndof {
                r[j.dofs[k]] += j.coef[0][k] * f[0] + j.coef[1][k] * f[1];
            }
        }
        mchol.solve_in_place(r);
        self.check_state(&*u, &*v, translational, 0.0, 0)?;
        let dt = self.settings.dt;
        self.rec
            .record(0, 0.0, dt, &self.pen, &self.force, &self.q, &self.qd, u);
        Ok(())
    }

    /// Contact terms of joint `jj` at state `(q, qd)` under the lane's coupling (the gap coupling
    /// uses its status and normal instead of the law).
    #[inline]
    fn contact_terms(&self, jj: usize, q: [f64; 2], qd: [f64; 2]) -> ContactTerms {
        let j = &self.sys.joints[jj];
        match self.settings.coupling {
            Coupling::Gap { damping, .. } => {
                let pen = norm2(q) - j.clearance;
                if !self.gap_closed[jj] {
                    return ContactTerms {
                        penetration: pen,
                        ..Default::default()
                    };
                }
                let n = self.gap_normal[jj];
                let k = self.gap_k[jj];
                let nn = [[n[0] * n[0], n[0] * n[1]], [n[1] * n[0], n[1] * n[1]]];
                ContactTerms {
                    penetration: pen,
                    k: [[k * nn[0][0], k * nn[0][1]], [k * nn[1][0], k * nn[1][1]]],
                    c: [
                        [damping * nn[0][0], damping * nn[0][1]],
                        [damping * nn[1][0], damping * nn[1][1]],
                    ],
                    f_explicit: [k * j.clearance * n[0], k * j.clearance * n[1]],
                }
            }
            _ => evaluation::law_terms(
                &*j.law,
                self.any_v0 && self.needs_v0[jj],
                q,
                qd,
                j.clearance,
                self.episode[jj],
            ),
        }
    }

    /// Before the shared solve: predicted joint states, contact terms from the last state
    /// (lagged), the loads `h` and `G`, and the full right-hand side when refactorizing.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn pre_solve<const L: usize>(
        &mut self,
        frames: &Frames,
        u: &[[f64; L]],
        v: &[[f64; L]],
        r: &[[f64; L]],
        l: usize,
        bdt2: f64,
        gdt: f64,
    ) {
        let nj = self.sys.joints.len();
        for jj in 0..nj {
            let j = &self.sys.joints[jj];
            let (qo, qdo) = self.sys.joint_offset(j, frames);
            let pu = project_lane(j, u, l);
            let pv = project_lane(j, v, l);
            self.qt[jj] = [qo[0] + pu[0], qo[1] + pu[1]];
            self.qdt[jj] = [qdo[0] + pv[0], qdo[1] + pv[1]];
        }
        for jj in 0..nj {
            self.terms[jj] = self.contact_terms(jj, self.q[jj], self.qd[jj]);
        }
        if matches!(self.settings.coupling, Coupling::Force) {
            for jj in 0..nj {
                let f = self.terms[jj].force(self.q[jj], self.qd[jj]);
                self.h[2 * jj] = f[0];
                self.h[2 * jj + 1] = f[1];
                self.g[jj] = [[0.0; 2]; 2];
            }
        } else {
            self.load_implicit_terms(bdt2, gdt);
        }
        // the right-hand side is kept only where a full solve needs it; a Woodbury fallback
        // rebuilds it from z (rb = A0 z) instead of copying it every step
        if self.settings.solver == SolverMode::Refactor {
            get_lane(r, l, &mut self.rb);
        }
    }

    /// After the shared solve (`z` = lane `l` of `r`): the joints' accelerations, iterating the
    /// contact terms when asked; leaves `h - s` for the Woodbury correction or, when the step
    /// was refactorized, the solution in `sol`.
    #[inline]
    fn post_solve<const L: usize>(&mut self, sh: &Shared, z: &[[f64; L]], l: usize, t: f64, step: u64) -> Result<()> {
        let m = sh.m;
        for jj in 0..self.sys.joints.len() {
            let p = project_lane(&self.sys.joints[jj], z, l);
            self.yb[2 * jj] = p[0];
            self.yb[2 * jj + 1] = p[1];
        }
        let (iterate, tol, max_iter) = match self.settings.coupling {
            Coupling::Force => (false, 0.0, 1),
            Coupling::Modified { iterate, tol, max_iter } => (iterate, tol, max_iter),
            Coupling::Gap { max_iter, .. } => (true, 1e-12, max_iter),
            // rejected by `Settings::validate` (the Newton stepper's coupling)
            Coupling::Continuous => (false, 0.0, 1),
        };
        let mut rb_valid = self.settings.solver == SolverMode::Refactor;
        let mut refactored;
        let mut iters = 0u64;
        if iterate {
            // state of `update_iterated_terms` within this step
            self.switches.fill(0);
            self.prev_change = f64::INFINITY;
        }
        loop {
            iters += 1;
            let closed = self.g.iter().any(|g| !mat2_is_zero(g));
            refactored =
                closed && (self.settings.solver == SolverMode::Refactor || !self.woodbury_joint_solve(&sh.wmat, m));
            if refactored {
                if !rb_valid {
                    get_lane(z, l, &mut self.col);
                    self.sys.pattern.mul(&sh.a0_values, &self.col, &mut self.rb);
                    rb_valid = true;
                }
                self.refactor_joint_solve(sh, t, step)?;
            } else if !closed {
                // pa = yb + W h
                for r in 0..m {
                    let mut s = self.yb[r];
                    for c in 0..m {
                        s += sh.wmat[r * m + c] * self.h[c];
                    }
                    self.pa[r] = s;
                    self.s[r] = 0.0;
                }
            }
            if !iterate || iters as usize >= max_iter {
                if iterate && iters as usize >= max_iter && max_iter > 1 {
                    self.stats.unconverged_steps += 1;
                }
                break;
            }
            if self.update_iterated_terms(tol, sh.bdt2, sh.gdt, m) {
                break;
            }
        }
        self.stats.iterations += iters;
        self.stats.max_iterations = self.stats.max_iterations.max(iters);
        self.refactored = refactored;
        if !refactored && self.g.iter().any(|g| !mat2_is_zero(g)) {
            self.stats.woodbury_steps += 1;
        }
        Ok(())
    }

    /// Builds `G_j = beta dt^2 k + gamma dt c` and `h_j = -k q~ - c qd~ + f_explicit` from the
    /// current terms.
    #[inline]
    fn load_implicit_terms(&mut self, bdt2: f64, gdt: f64) {
        for jj in 0..self.sys.joints.len() {
            let t = &self.terms[jj];
            let mut g = [[0.0; 2]; 2];
            for r in 0..2 {
                for c in 0..2 {
                    g[r][c] = bdt2 * t.k[r][c] + gdt * t.c[r][c];
                }
            }
            self.g[jj] = g;
            let f = t.force(self.qt[jj], self.qdt[jj]);
            self.h[2 * jj] = f[0];
            self.h[2 * jj + 1] = f[1];
        }
    }

    /// Woodbury solve for the joints' accelerations `pa` and the correction `s`. Returns false
    /// when the capacitance is too ill-conditioned to trust.
    #[inline]
    fn woodbury_joint_solve(&mut self, wmat: &[f64], m: usize) -> bool {
        // y = yb + W h (kept in pa), cap = I + G W, s = G y
        let rcond = capacitance_solve(
            wmat,
            m,
            &self.g,
            &self.yb,
            &self.h,
            &mut self.pa,
            &mut self.cap,
            &mut self.s,
        );
        if rcond.is_nan() || rcond < WOODBURY_RCOND {
            self.stats.woodbury_fallbacks += 1;
            return false;
        }
        // pa = y - W s
        subtract_ws(wmat, m, &self.s, &mut self.pa);
        true
    }

    /// Full solve with the contact terms in the matrix (numeric refactorization when they
    /// changed); the solution goes to `sol`, the joints' accelerations to `pa`.
    fn refactor_joint_solve(&mut self, sh: &Shared, t: f64, step: u64) -> Result<()> {
        let chol = self
            .chol_c
            .get_or_insert_with(|| Cholesky::with_analysis(Arc::clone(sh.chol0.analysis())));
        if self.g != self.g_factored {
            self.ac_values.copy_from_slice(&sh.a0_values);
            for (jj, j) in self.sys.joints.iter().enumerate() {
                let g = &self.g[jj];
                for a in 0..j.ndof {
                    for b in 0..j.ndof {
                        let mut x = 0.0;
                        for r in 0..2 {
                            for c in 0..2 {
                                x += j.coef[r][a] * g[r][c] * j.coef[c][b];
                            }
                        }
                        self.ac_values[sh.joint_pos[jj][a][b]] += x;
                    }
                }
            }
            chol.factorize(&self.ac_values, "the effective matrix with contact terms")
                .map_err(|e| match e {
                    Error::Singular { what, index, .. } => Error::Diverged {
                        time: t + self.settings.dt,
                        step: step + 1,
                        dof: format!("{} (pivot {index})", self.sys.describe_dof(self.model, index)),
                        reason: format!("{what} is not positive definite"),
                    },
                    e => e,
                })?;
            self.g_factored.clone_from(&self.g);
        }
        self.sol.copy_from_slice(&self.rb);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            for k in 0..j.ndof {
                self.sol[j.dofs[k]] += j.coef[0][k] * self.h[2 * jj] + j.coef[1][k] * self.h[2 * jj + 1];
            }
        }
        chol.solve_in_place(&mut self.sol);
        for (jj, j) in self.sys.joints.iter().enumerate() {
            let p = System::joint_project(j, &self.sol);
            self.pa[2 * jj] = p[0];
            self.pa[2 * jj + 1] = p[1];
        }
        Ok(())
    }

    /// Re-evaluates the contact terms at the end-of-step state implied by `pa`; returns true
    /// when converged (kappa: relative change of `pa` below `tol`; gap: status unchanged and the
    /// normal settled).
    fn update_iterated_terms(&mut self, tol: f64, bdt2: f64, gdt: f64, m: usize) -> bool {
        let nj = self.sys.joints.len();
        let mut converged = true;
        let is_gap = matches!(self.settings.coupling, Coupling::Gap { .. });
        let mut scale = 0.0f64;
        let mut change = 0.0f64;
        for r in 0..m {
            scale = scale.max(self.pa[r].abs());
            change = change.max((self.pa[r] - self.pa_old[r]).abs());
        }
        for jj in 0..nj {
            let q1 = [
                self.qt[jj][0] + bdt2 * self.pa[2 * jj],
                self.qt[jj][1] + bdt2 * self.pa[2 * jj + 1],
            ];
            let qd1 = [
                self.qdt[jj][0] + gdt * self.pa[2 * jj],
                self.qdt[jj][1] + gdt * self.pa[2 * jj + 1],
            ];
            let frozen = self.frozen.get(jj).copied();
            if is_gap {
                let dr = norm2(q1);
                let closed = frozen.unwrap_or(dr - self.sys.joints[jj].clearance > 0.0);
                if closed != self.gap_closed[jj] {
                    converged = false;
                    self.gap_closed[jj] = closed;
                }
                if closed && dr > 0.0 {
                    let n = [q1[0] / dr, q1[1] / dr];
                    let old = self.gap_normal[jj];
                    if (n[0] - old[0]).abs().max((n[1] - old[1]).abs()) > tol {
                        converged = false;
                    }
                    self.gap_normal[jj] = n;
                }
            } else {
                let mut t = self.contact_terms(jj, q1, qd1);
                if t.active() {
                    let j = &self.sys.joints[jj];
                    evaluation::linearize_spring(&mut t, j.law.spring_tangent(q1, j.clearance), q1);
                }
                match frozen {
                    // held open: no force whatever the end state
                    Some(false) => self.terms[jj] = ContactTerms::default(),
                    // held closed: the law's terms while the end state is inside the circle; past
                    // it (a trial cut beyond the crossing) the last terms from inside are kept
                    Some(true) => {
                        if t.active() {
                            self.terms[jj] = t;
                        }
                    }
                    None => {
                        let (t, changed) =
                            evaluation::iterated_terms(t, self.terms[jj].active(), &mut self.switches[jj]);
                        converged &= !changed;
                        self.terms[jj] = t;
                    }
                }
            }
        }
        if !is_gap {
            // Converged when the change is below `tol` relative, or when it has stopped falling
            // while below sqrt(tol): the round-off floor. A stiff bearing's force is a difference
            // of terms ~K_B |q| (1e6 N at 1e10 N/m and 0.1 mm) that cancel to a few N, so the
            // joint accelerations are only known to ~1e-16 K_B |q| / m, which can exceed `tol`
            // times their size.
            let stagnated = change <= tol.sqrt() * scale && change >= 0.5 * self.prev_change;
            converged &= change <= tol * scale || stagnated;
            self.prev_change = change;
        }
        self.pa_old.copy_from_slice(&self.pa);
        if !converged {
            if is_gap {
                for jj in 0..nj {
                    self.terms[jj] = self.contact_terms(jj, self.qt[jj], self.qdt[jj]);
                }
            }
            self.load_implicit_terms(bdt2, gdt);
        }
        converged
    }

    /// After the state update: the joints' positions, forces and penetrations from the new
    /// acceleration (lane `l` of `a`). Fails when a joint's penetration is not finite or exceeds
    /// the divergence limit (an open gap of any width passes; checked every step: one
    /// comparison per joint).
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x <= limit)` is deliberately true for NaN
    fn complete_joints<const L: usize>(
        &mut self,
        a: &[[f64; L]],
        l: usize,
        bdt2: f64,
        gdt: f64,
        t1: f64,
        step: u64,
    ) -> Result<()> {
        let explicit = matches!(self.settings.coupling, Coupling::Force);
        for jj in 0..self.sys.joints.len() {
            let j = &self.sys.joints[jj];
            let pu = project_lane(j, a, l);
            let q = [self.qt[jj][0] + bdt2 * pu[0], self.qt[jj][1] + bdt2 * pu[1]];
            let qd = [self.qdt[jj][0] + gdt * pu[0], self.qdt[jj][1] + gdt * pu[1]];
            let f = if explicit {
                [self.h[2 * jj], self.h[2 * jj + 1]]
            } else {
                evaluation::recorded_force(&self.terms[jj], q, qd)
            };
            self.q[jj] = q;
            self.qd[jj] = qd;
            self.pen[jj] = norm2(q) - j.clearance;
            self.force[jj] = f;
            // one comparison per joint and step: false for NaN, so it is also the finite check
            // the penetration itself: an open gap wider than the limit is no divergence
            if !(self.pen[jj] <= self.limit) {
                return Err(self.joint_diverged(jj, t1, step + 1));
            }
            if let Coupling::Gap { .. } = self.settings.coupling {
                // the status for the next step follows the state just reached
                let dr = norm2(q);
                self.gap_closed[jj] = self.pen[jj] > 0.0;
                if dr > 0.0 {
                    self.gap_normal[jj] = [q[0] / dr, q[1] / dr];
                }
            }
        }
        if self.any_v0 {
            self.track_episodes();
        }
        Ok(())
    }

    /// The contact episodes after an accepted state, for the laws that need the approach speed.
    #[cold]
    fn track_episodes(&mut self) {
        for jj in 0..self.sys.joints.len() {
            if self.needs_v0[jj] {
                self.episode[jj] =
                    crate::contact::next_episode(self.q[jj], self.qd[jj], self.pen[jj], self.episode[jj]);
            }
        }
    }

    /// The divergence error of joint `jj` whose penetration is not finite or beyond the limit.
    #[cold]
    fn joint_diverged(&self, jj: usize, time: f64, step: u64) -> Error {
        divergence::joint_diverged(&self.model.joints[jj].name, self.pen[jj], self.limit, time, step)
    }

    /// Finite and within-limit check of this lane's state (`u`, `v` give the lane's entries).
    fn check_state(&self, u: impl DofAt, v: impl DofAt, translational: &[bool], t: f64, step: u64) -> Result<()> {
        let bad = match (u.slice(), v.slice()) {
            // contiguous (one lane): the vectorized pass first
            (Some(us), Some(vs)) => divergence::first_bad_in(us, vs, translational, self.limit),
            _ => divergence::first_bad(
                translational.len(),
                |i| translational[i],
                |i| u.at(i),
                |i| v.at(i),
                self.limit,
            ),
        };
        if let Some(d) = bad {
            let reason = divergence::reason(u.at(d), v.at(d), translational[d], self.limit);
            return Err(Error::Diverged {
                time: t,
                step,
                dof: self.sys.describe_dof(self.model, d),
                reason,
            });
        }
        Ok(())
    }
}

/// Read access to one lane's entries of a global vector.
trait DofAt: Copy {
    fn at(&self, i: usize) -> f64;
    /// The entries as one contiguous slice, where they are.
    fn slice(&self) -> Option<&[f64]> {
        None
    }
}

impl DofAt for &[f64] {
    #[inline]
    fn at(&self, i: usize) -> f64 {
        self[i]
    }
    #[inline]
    fn slice(&self) -> Option<&[f64]> {
        Some(self)
    }
}

/// Lane `.1` of lane-fastest vector `.0`.
#[derive(Clone, Copy)]
struct LaneOf<'a, const L: usize>(&'a [[f64; L]], usize);

impl<const L: usize> DofAt for LaneOf<'_, L> {
    #[inline]
    fn at(&self, i: usize) -> f64 {
        self.0[i][self.1]
    }
}

impl<'m, const L: usize> Lockstep<'m, L> {
    /// Assembles and factorizes once for all `runs` (1 to `L` pairs of a validated model and
    /// validated settings, every pair sharing the factor of the first: [`shares_factor`]; an
    /// event-aware run only with `L = 1`), and
    /// initializes every lane. Fails (for every lane) when the runs do not share the factor or
    /// when the mass or the contact-free effective matrix is not positive definite; a lane whose
    /// initial state fails its check is finished at once with that error and an empty output.
    pub fn with_analysis(runs: &[(&'m Model, &Settings)], cache: Option<&AnalysisCache>) -> Result<Self> {
        if runs.is_empty() || runs.len() > L {
            return Err(Error::InvalidModel {
                message: format!("a lockstep run takes 1 to {L} runs, not {}", runs.len()),
            });
        }
        if L > 1 && runs.iter().any(|(_, s)| s.events || s.adaptive.is_some()) {
            return Err(Error::InvalidModel {
                message: "an event-aware or adaptive run (events = true, adaptive steps) steps alone, not as a \
                          lockstep lane"
                    .into(),
            });
        }
        let systems: Vec<System> = runs.iter().map(|(m, _)| System::assemble(m)).collect();
        for (k, (sys, (_, s))) in systems.iter().zip(runs).enumerate().skip(1) {
            if !shares_factor((&systems[0], runs[0].1), (sys, s)) {
                return Err(Error::InvalidModel {
                    message: format!("lockstep lane {k} does not share lane 0's effective matrix and step"),
                });
            }
        }
        let sys = systems[0].clone();
        let settings = runs[0].1;
        let n = sys.n();
        let nj = sys.joints.len();
        let m = 2 * nj;
        let dt = settings.dt;
        let nm = settings.newmark;
        let analysis = match cache {
            Some(c) => c.get(&sys.pattern)?,
            None => Analysis::new(&sys.pattern)?,
        };
        let StepConsts {
            dt,
            c1,
            c2,
            bdt2,
            gdt,
            bdt2r,
            gdtr,
            chol0,
            a0_values,
            zcols,
            wmat,
        } = StepConsts::new(&sys, dt, &nm, Cholesky::with_analysis(Arc::clone(&analysis)))
            .map_err(|e| sys.name_pivot(runs[0].0, e))?;
        let joint_pos = sys
            .joints
            .iter()
            .map(|j| {
                let mut p = [[0usize; 4]; 4];
                for (a, row) in p.iter_mut().enumerate().take(j.ndof) {
                    for (b, cell) in row.iter_mut().enumerate().take(j.ndof) {
                        *cell = sys.pattern.position(j.dofs[a], j.dofs[b]);
                    }
                }
                p
            })
            .collect();
        let mut translational = vec![true; n];
        for (i, t) in translational.iter_mut().enumerate() {
            // every link has 3 DOFs per node and starts at a multiple of 3
            *t = i % 3 != 2;
        }
        let k_band = LaneBand::from_csc(&sys.pattern, &sys.stiffness);
        let c_band = if sys.proportional_damping.is_some() {
            None
        } else {
            LaneBand::from_csc(&sys.pattern, &sys.damping)
        };
        let frames_shared = systems.iter().skip(1).all(|s| {
            s.bodies == sys.bodies
                && s.body_as_link == sys.body_as_link
                && s.links
                    .iter()
                    .zip(&sys.links)
                    .all(|(x, y)| x.motion == y.motion && x.rotation == y.rotation && x.inertia_load == y.inertia_load)
        });
        let mut mchol = Cholesky::with_analysis(Arc::clone(&analysis));
        mchol
            .factorize(&sys.mass, "the mass matrix")
            .map_err(|e| sys.name_pivot(runs[0].0, e))?;
        let mut run = Lockstep {
            sh: Shared {
                frames: sys.frames(),
                n,
                m,
                dt,
                c1,
                c2,
                bdt2,
                gdt,
                bdt2r,
                gdtr,
                alpha: nm.is_alpha().then(|| nm.alpha_constants()),
                steps: settings.steps(),
                chol0,
                a0_values,
                joint_pos,
                zcols,
                wmat,
                k_band,
                c_band,
                translational,
                frames_shared,
                sys,
                mchol,
                grid_dt: settings.dt,
                h_max: settings.adaptive.map_or(settings.dt, |a| a.h_max),
                cache: FactorCache::default(),
            },
            lanes: Vec::with_capacity(L),
            active: [false; L],
            u: vec![[0.0; L]; n],
            v: vec![[0.0; L]; n],
            a: vec![[0.0; L]; n],
            aa: Vec::new(),
            r: vec![[0.0; L]; n],
            tmp: vec![[0.0; L]; n],
            xpad: Vec::new(),
            col_y: vec![0.0; n],
            t: 0.0,
            step: 0,
        };
        let pad = run.sh.k_band.as_ref().map_or(0, LaneBand::padded_len);
        run.xpad = vec![[0.0; L]; pad];
        let (mut u0, mut v0, mut a0) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (l, ((model, settings), sys)) in runs.iter().zip(systems).enumerate() {
            let mut lane = Lane::new(model, settings, sys);
            u0.fill(0.0);
            v0.fill(0.0);
            a0.fill(0.0);
            match lane.initialize(&mut run.sh.mchol, &run.sh.translational, &mut u0, &mut v0, &mut a0) {
                Ok(()) => {
                    set_lane(&mut run.u, l, &u0);
                    set_lane(&mut run.v, l, &v0);
                    set_lane(&mut run.a, l, &a0);
                    run.active[l] = true;
                }
                Err(error) => lane.outcome = Some(Err(RunFailure::before_start(error))),
            }
            run.lanes.push(lane);
        }
        if run.sh.alpha.is_some() {
            run.aa.clone_from(&run.a); // aa_0 = a_0
        }
        Ok(run)
    }

    /// Runs every lane to the end (or to its failure) and returns the lanes' outcomes in order.
    /// `control(fraction_done)` is called every few thousand steps; when it returns `false`
    /// every running lane stops with [`Error::Interrupted`].
    pub fn run(self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        #[cfg(target_arch = "x86_64")]
        if L > 1 && crate::linalg::avx2_fma_available() {
            // SAFETY: the CPU reports AVX2 and FMA.
            return unsafe { self.run_avx2(control) };
        }
        self.run_body(control)
    }

    /// [`Self::run`] compiled for AVX2, so that the lane loops use 256-bit vectors. Enabling the
    /// feature changes no result: Rust never fuses a multiply and an add on its own.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn run_avx2(self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        self.run_body(control)
    }

    #[inline(always)]
    fn run_body(mut self, control: &mut dyn FnMut(f64) -> bool) -> Vec<RunResult> {
        let settings = &self.lanes[0].settings;
        let adaptive = (L == 1).then_some(settings.adaptive).flatten().map(|tol| {
            let nj = self.sh.sys.joints.len();
            let n = self.sh.n;
            let dt = self.sh.grid_dt;
            AdaptiveSteps {
                t: 0.0,
                t_start: 0.0,
                t_end: self.sh.steps as f64 * dt,
                pending: None,
                interpolated: false,
                out_u: vec![0.0; n],
                out_q: vec![[0.0; 2]; nj],
                out_qd: vec![[0.0; 2]; nj],
                out_pen: vec![0.0; nj],
                out_force: vec![[0.0; 2]; nj],
                snap: Snapshot::default(),
                p0: Vec::with_capacity(nj),
                p1: Vec::with_capacity(nj),
                tol,
                levels: Levels::new(tol.h_max, tol.h_min, dt),
                control: Default::default(),
                forces: adaptive::ForceErrors::new(nj),
                accepted: Default::default(),
                err_scale: rotation_scales(self.lanes[0].model, &self.sh.sys, n),
            }
        });
        let events = (L == 1 && settings.events && adaptive.is_none()).then(Events::default);
        run_loop::run(
            &mut LockstepLoop {
                ls: &mut self,
                events,
                adaptive,
            },
            control,
        );
        self.lanes
            .into_iter()
            .map(|lane| lane.outcome.expect("every lane has finished"))
            .collect()
    }

    /// Finishes lane `l` at `step`, time `t` (s): with `error`, as a failure keeping what it
    /// recorded; without, as a completed run. Its vectors are zeroed (an idle lane).
    fn retire(&mut self, l: usize, error: Option<Error>, step: u64, t: f64) {
        let lane = &mut self.lanes[l];
        let n = self.sh.n;
        let (mut u, mut v, mut a) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        get_lane(&self.u, l, &mut u);
        get_lane(&self.v, l, &mut v);
        get_lane(&self.a, l, &mut a);
        for x in [&mut self.u, &mut self.v, &mut self.a, &mut self.r] {
            for xi in x.iter_mut() {
                xi[l] = 0.0;
            }
        }
        let mut stats = std::mem::take(&mut lane.stats);
        stats.steps = step;
        stats.factorizations = self.sh.chol0.factorizations
            + self.sh.cache.slots.iter().map(|c| c.chol0.factorizations).sum::<u64>()
            + lane.chol_c.as_ref().map_or(0, |c| c.factorizations);
        let output = RunOutput {
            record: std::mem::take(&mut lane.rec),
            stats,
            state: [u, v, a],
            time: t,
        };
        lane.outcome = Some(match error {
            None => Ok(output),
            Some(error) => Err(Box::new(RunFailure { error, output })),
        });
        self.active[l] = false;
    }

    /// Retires every lane with a pending error (see [`Self::retire`]).
    #[cold]
    fn retire_pending(&mut self, step: u64, t: f64) {
        for l in 0..self.lanes.len() {
            if let Some(e) = self.lanes[l].pending.take() {
                self.retire(l, Some(e), step, t);
            }
        }
    }

    /// One step of every active lane to `t1`.
    #[inline(always)]
    fn advance(&mut self, t1: f64) {
        let sh = &mut self.sh;
        let (dt, c1, c2) = (sh.dt, sh.c1, sh.c2);
        let pat = &sh.sys.pattern;
        let alpha = sh.alpha.is_some();
        if let Some([k0, k1, _]) = sh.alpha {
            // the alpha schemes' predictors (Newmark::coefficients): b = k0 a_n + k1 aa_n,
            // u~ = u + dt v + c1 aa + beta dt^2 b, v~ = v + c2 aa + gamma dt b; aa holds b until
            // `complete`
            let (bdt2r, gdtr) = (sh.bdt2r, sh.gdtr);
            for (((u, v), &a), aa) in self
                .u
                .as_flattened_mut()
                .iter_mut()
                .zip(self.v.as_flattened_mut().iter_mut())
                .zip(self.a.as_flattened())
                .zip(self.aa.as_flattened_mut().iter_mut())
            {
                let b = k0 * a + k1 * *aa;
                *u += dt * *v + c1 * *aa + bdt2r * b;
                *v += c2 * *aa + gdtr * b;
                *aa = b;
            }
        }
        match sh.sys.proportional_damping {
            Some(c) => {
                if alpha {
                    // w = -(u~ + c v~) (the alpha predictors above already applied)
                    for ((u, v), w) in self
                        .u
                        .as_flattened()
                        .iter()
                        .zip(self.v.as_flattened())
                        .zip(self.tmp.as_flattened_mut().iter_mut())
                    {
                        *w = -(*u + c * *v);
                    }
                } else {
                    // predictors (in place: u, v hold u~, v~ until `complete`) and w = -(u~ + c v~)
                    // in one pass (lane by lane the same operations; flat, the loop vectorizes
                    // across lanes)
                    for ((u, v), (&a, w)) in self
                        .u
                        .as_flattened_mut()
                        .iter_mut()
                        .zip(self.v.as_flattened_mut().iter_mut())
                        .zip(self.a.as_flattened().iter().zip(self.tmp.as_flattened_mut().iter_mut()))
                    {
                        *u += dt * *v + c1 * a;
                        *v += c2 * a;
                        *w = -(*u + c * *v); // negated here so that r = K w needs no extra pass
                    }
                }
                // r = K w
                matvec(
                    pat,
                    sh.k_band.as_ref(),
                    &sh.sys.stiffness,
                    &self.tmp,
                    &mut self.xpad,
                    &mut self.r,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
            }
            None => {
                if !alpha {
                    for ((u, v), &a) in self
                        .u
                        .as_flattened_mut()
                        .iter_mut()
                        .zip(self.v.as_flattened_mut().iter_mut())
                        .zip(self.a.as_flattened())
                    {
                        *u += dt * *v + c1 * a;
                        *v += c2 * a;
                    }
                }
                matvec(
                    pat,
                    sh.k_band.as_ref(),
                    &sh.sys.stiffness,
                    &self.u,
                    &mut self.xpad,
                    &mut self.r,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
                matvec(
                    pat,
                    sh.c_band.as_ref(),
                    &sh.sys.damping,
                    &self.v,
                    &mut self.xpad,
                    &mut self.tmp,
                    &mut self.lanes[0].col,
                    &mut self.col_y,
                );
                for (x, t) in self.r.as_flattened_mut().iter_mut().zip(self.tmp.as_flattened()) {
                    *x = -*x - t;
                }
            }
        }
        if sh.frames_shared {
            sh.sys.frames_at(t1, &mut sh.frames);
            // -M_R a_R, the same on every lane (System::add_inertia_load, lane by lane)
            for (lp, k) in sh.sys.links.iter().zip(&sh.frames.links) {
                if let Some([bx, by]) = &lp.inertia_load {
                    let acc = k.acc;
                    let rot = &lp.rotation;
                    let ax = rot[0][0] * acc[0] + rot[1][0] * acc[1];
                    let ay = rot[0][1] * acc[0] + rot[1][1] * acc[1];
                    let seg = &mut self.r[lp.offset..lp.offset + lp.ndof];
                    for ((fi, x), y) in seg.iter_mut().zip(bx).zip(by) {
                        let f = ax * x + ay * y;
                        for l in 0..L {
                            fi[l] -= f;
                        }
                    }
                }
            }
        } else {
            for (l, lane) in self.lanes.iter_mut().enumerate() {
                if !self.active[l] {
                    continue;
                }
                lane.sys.frames_at(t1, &mut lane.frames);
                get_lane(&self.r, l, &mut lane.col);
                lane.sys.add_inertia_load(&lane.frames, &mut lane.col);
                set_lane(&mut self.r, l, &lane.col);
            }
        }
        let nj = sh.sys.joints.len();
        if nj == 0 {
            sh.chol0.solve_lanes(&mut self.r);
            std::mem::swap(&mut self.a, &mut self.r);
            return self.complete(t1);
        }
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if sh.frames_shared {
                    lane.pre_solve(&sh.frames, &self.u, &self.v, &self.r, l, sh.bdt2, sh.gdt);
                } else {
                    let frames = std::mem::take(&mut lane.frames);
                    lane.pre_solve(&frames, &self.u, &self.v, &self.r, l, sh.bdt2, sh.gdt);
                    lane.frames = frames;
                }
            }
        }
        sh.chol0.solve_lanes(&mut self.r); // r = z = A0^-1 rhs
        let mut failed = false;
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if let Err(e) = lane.post_solve(sh, &self.r, l, self.t, self.step) {
                    lane.pending = Some(e);
                    failed = true;
                }
            }
        }
        if failed {
            // the failed lanes keep their predictors and the last acceleration
            self.retire_pending(self.step, self.t);
        }
        // a = z + Z (h - s) on the Woodbury lanes; z is not needed after this step
        std::mem::swap(&mut self.a, &mut self.r);
        let sh = &self.sh;
        let (n, m) = (sh.n, sh.m);
        for c in 0..m {
            let mut w = [0.0f64; L];
            let mut any = false;
            for (l, lane) in self.lanes.iter().enumerate() {
                if self.active[l] && !lane.refactored {
                    w[l] = lane.h[c] - lane.s[c];
                    any |= w[l] != 0.0;
                }
            }
            if any {
                let col = &sh.zcols[c * n..(c + 1) * n];
                for (ai, &zi) in self.a.iter_mut().zip(col) {
                    for l in 0..L {
                        ai[l] = if w[l] != 0.0 { ai[l] + w[l] * zi } else { ai[l] };
                    }
                }
            }
        }
        for (l, lane) in self.lanes.iter().enumerate() {
            if self.active[l] && lane.refactored {
                set_lane(&mut self.a, l, &lane.sol);
            }
        }
        self.complete(t1)
    }

    /// Updates the state from the new acceleration and evaluates the joints at `t1` (a lane
    /// failing there is retired).
    #[inline(always)]
    fn complete(&mut self, t1: f64) {
        let (bdt2, gdt) = (self.sh.bdt2, self.sh.gdt);
        for ((u, v), &a) in self
            .u
            .as_flattened_mut()
            .iter_mut()
            .zip(self.v.as_flattened_mut().iter_mut())
            .zip(self.a.as_flattened())
        {
            *u += bdt2 * a;
            *v += gdt * a;
        }
        if let Some([_, _, k2]) = self.sh.alpha {
            // aa_{n+1} = b + k2 a_{n+1}
            for (aa, &a) in self.aa.as_flattened_mut().iter_mut().zip(self.a.as_flattened()) {
                *aa += k2 * a;
            }
        }
        let mut failed = false;
        for (l, lane) in self.lanes.iter_mut().enumerate() {
            if self.active[l] {
                if let Err(e) = lane.complete_joints(&self.a, l, bdt2, gdt, t1, self.step) {
                    lane.pending = Some(e);
                    failed = true;
                }
            }
        }
        if failed {
            self.retire_pending(self.step, self.t);
        }
    }

    /// One step of the (single) lane to `t1` with event location: the step is taken; when it
    /// changes a joint's contact status (sign of the penetration), the earliest crossing (linear
    /// interpolation of the penetration, then regula falsi on the first substep's end) places a
    /// cut, the step is redone from its start as two substeps, each with the contact-free
    /// factorization of its own size, and the acceleration is restarted at the cut
    /// ([`Self::restart_at_event`]). A step without a status change, or whose cut would leave a
    /// substep shorter than `EVENT_MIN_FRACTION dt`, is kept as taken: bitwise the fixed-step
    /// result.
    fn advance_with_events(&mut self, t1: f64, ev: &mut Events) {
        debug_assert!(L == 1);
        let t0 = self.t;
        let snap = &mut ev.snap;
        self.snapshot(snap);
        self.advance(t1);
        if !self.active[0] {
            return;
        }
        let Some((mut theta, jstar)) = earliest_crossing(&snap.pen, &self.lanes[0].pen) else {
            return;
        };
        ev.pen1.clone_from(&self.lanes[0].pen);
        let dt = self.sh.dt;
        let settings = &self.lanes[0].settings;
        let nm = settings.newmark;
        let analysis = Arc::clone(self.sh.chol0.analysis());
        let consts =
            |sys: &System, h: f64| StepConsts::new(sys, h, &nm, Cholesky::with_analysis(Arc::clone(&analysis)));
        self.lanes[0].stats.event_steps += 1;
        let nan = [[f64::NAN; 2]; 2];
        // the crossing of joint `jstar` by regula falsi (Illinois) on the first substep's end
        // penetration, bracketed by the step's ends; the trial step's end (contact forces acting
        // over the whole step) gives only a first estimate
        // aim just short of the circle (on the old side, within `tol`): a first substep that ended
        // across it would carry the new status (for an entry, the dashpot force) over its length
        let mut search = CutSearch::new(snap.pen[jstar], ev.pen1[jstar], false);
        let mut factorizations = 0;
        let mut h1 = theta * dt;
        // the first substep keeps every joint's start-of-step status: it follows the old-status
        // trajectory to the crossing (with the status iterated, an end state near the circle has
        // no consistent status when the dashpot force jumps there, and the iteration would switch
        // between the two until its cap)
        let lane = &mut self.lanes[0];
        lane.frozen.clear();
        lane.frozen.extend(snap.pen.iter().map(|&p| p > 0.0));
        for it in 0..EVENT_MAX_CUTS {
            h1 = theta * dt;
            let Ok(mut s1) = consts(&self.sh.sys, h1) else {
                self.lanes[0].frozen.clear();
                return; // cannot happen for h > 0 (M is positive definite)
            };
            factorizations += 1;
            self.restore(snap);
            self.lanes[0].g_factored.fill(nan);
            self.sh.swap_step(&mut s1);
            self.advance(t0 + h1);
            self.sh.swap_step(&mut s1);
            if !self.active[0] {
                self.lanes[0].frozen.clear();
                self.sh.chol0.factorizations += factorizations;
                return;
            }
            match search.next(theta, self.lanes[0].pen[jstar], it + 1 == EVENT_MAX_CUTS) {
                Some(next) => theta = next,
                None => break,
            }
        }
        self.lanes[0].frozen.clear();
        self.restart_at_event(t0 + h1, &snap.pen, &ev.pen1, true);
        let Ok(mut s2) = consts(&self.sh.sys, dt - h1) else {
            return;
        };
        factorizations += 1;
        self.lanes[0].g_factored.fill(nan);
        self.sh.swap_step(&mut s2);
        self.advance(t1);
        self.sh.swap_step(&mut s2);
        self.lanes[0].g_factored.fill(nan);
        self.sh.chol0.factorizations += factorizations;
    }

    /// Keeps the single lane's state in `snap` (the start of a step that may be redone).
    fn snapshot(&self, snap: &mut Snapshot) {
        let lane = &self.lanes[0];
        snap.u.resize(self.sh.n, 0.0);
        snap.v.resize(self.sh.n, 0.0);
        snap.a.resize(self.sh.n, 0.0);
        get_lane(&self.u, 0, &mut snap.u);
        get_lane(&self.v, 0, &mut snap.v);
        get_lane(&self.a, 0, &mut snap.a);
        if self.sh.alpha.is_some() {
            snap.aa.resize(self.sh.n, 0.0);
            get_lane(&self.aa, 0, &mut snap.aa);
        }
        snap.q.clone_from(&lane.q);
        snap.qd.clone_from(&lane.qd);
        snap.pen.clone_from(&lane.pen);
        snap.force.clone_from(&lane.force);
        snap.gap_closed.clone_from(&lane.gap_closed);
        snap.gap_normal.clone_from(&lane.gap_normal);
        snap.episode.clone_from(&lane.episode);
        snap.pa_old.clone_from(&lane.pa_old);
    }

    /// Puts the constants of step `h` (s) in use for the single lane: nothing to do when they
    /// are; a hit in the [`FactorCache`] swaps them in; a miss refills the least recently used
    /// slot (a cut's odd length first) in place, or fills a new slot while there are fewer than
    /// [`FACTOR_CACHE`] (the only allocation of adaptive steps); an odd length in use (not a
    /// level `h_max / 2^m`) is refilled in place, evicting no level.
    fn use_step(&mut self, h: f64) -> Result<()> {
        let sh = &mut self.sh;
        if sh.dt.to_bits() == h.to_bits() {
            return Ok(());
        }
        let is_level = |x: f64| {
            let r = sh.h_max / x;
            r >= 1.0 && r.fract() == 0.0 && (r as u64).is_power_of_two()
        };
        let nm = self.lanes[0].settings.newmark;
        let cache = &mut sh.cache;
        cache.clock += 1;
        let hit = cache.slots.iter().position(|c| c.dt.to_bits() == h.to_bits());
        if hit.is_none() && !is_level(sh.dt) && !cache.slots.is_empty() {
            // the odd length in use (a cut's) will not come back: its constants are refilled in
            // place (through slot 0, whose constants are put back), no cached level is evicted
            let mut slots = std::mem::take(&mut sh.cache.slots);
            sh.swap_step(&mut slots[0]);
            let refilled = slots[0].refill(&sh.sys, h, &nm);
            sh.swap_step(&mut slots[0]);
            sh.cache.slots = slots;
            self.lanes[0].g_factored.fill([[f64::NAN; 2]; 2]);
            return refilled;
        }
        let slot = match hit {
            Some(k) => k,
            None if cache.slots.len() < FACTOR_CACHE => {
                let analysis = Arc::clone(sh.chol0.analysis());
                cache
                    .slots
                    .push(StepConsts::new(&sh.sys, h, &nm, Cholesky::with_analysis(analysis))?);
                cache.used.push(0);
                cache.slots.len() - 1
            }
            None => {
                // the least recently used slot, one holding an odd length first
                let k = (0..cache.slots.len())
                    .min_by_key(|&k| (is_level(cache.slots[k].dt), cache.used[k]))
                    .expect("a full cache has slots");
                cache.slots[k].refill(&sh.sys, h, &nm)?;
                k
            }
        };
        // the constants in use go to the slot, marked as just used
        let mut slots = std::mem::take(&mut sh.cache.slots);
        sh.swap_step(&mut slots[slot]);
        sh.cache.slots = slots;
        sh.cache.used[slot] = sh.cache.clock;
        // a refactorized contact matrix (Woodbury fallback) was made on the old A0
        self.lanes[0].g_factored.fill([[f64::NAN; 2]; 2]);
        Ok(())
    }

    /// The Zienkiewicz-Xie estimate of the local displacement error of the step of length `h`
    /// (s) just taken from accelerations `a0` (the single lane), over the tolerance, largest
    /// over the unknowns (infinite when not finite): as the Newton stepper's (`NewtonRun`'s
    /// `local_error`), `c |a_(n+1) - a_n| h^2 / (atol + rtol |u|)` with `c = |beta - 1/6|` (at
    /// least 1/24); with the absolute error and the largest `|u|` ([`adaptive::LocalError`]).
    /// Each unknown counts as a displacement, a rotation times its `scale` (m,
    /// [`rotation_scales`]).
    fn local_error(&self, h: f64, a0: &[f64], scale: &[f64], tol: &crate::run::Adaptive) -> adaptive::LocalError {
        let unknowns = self
            .a
            .iter()
            .zip(a0)
            .zip(&self.u)
            .zip(scale)
            .map(|(((a1, &a0), u), &s)| (a1[0] * s, a0 * s, u[0] * s));
        adaptive::local_error(self.lanes[0].settings.newmark.beta, h, unknowns, tol)
    }

    /// Adaptive steps of the single lane until its integrated state (at `ad.t`, s) reaches the
    /// output instant `t1` (s), with the controller of the Newton stepper
    /// (`NewtonRun::adaptive_advance`): trial steps of `h_max / 2^m`; a step whose error
    /// estimate ([`Self::local_error`]) exceeds the tolerance is redone shorter (`m` raised by
    /// what the `h^3` law asks); a step that changes a clearance joint's status is cut at the
    /// located crossing (regula falsi from the crossing of the joint's cubic Hermite path, the
    /// substep keeping the start's statuses and ending just short of the circle, as
    /// [`Self::advance_with_events`]) and the accelerations restart there with the crossing
    /// joints on their new side ([`Self::restart_at_event`]: the right limit, recorded); a step
    /// whose interpolated joint path passes through a clearance circle between open ends is
    /// redone shorter ([`adaptive::enters_within`]); after a step whose error is below a tenth
    /// of the tolerance the next is twice as long, up to `h_max`. Each step size takes its
    /// constants from the [`FactorCache`] ([`Self::use_step`]). Steps do not stop at output
    /// instants: the last may end past `t1`, whose state the output interpolates
    /// ([`Self::record_interpolated`]). Accepted steps' ends enter the joints' extremes
    /// ([`Recorder::record_substep`]) in time order with the output instants. A lane that fails
    /// (divergence, a matrix that is not positive definite) is retired as in a fixed step.
    fn adaptive_advance(&mut self, t1: f64, ad: &mut AdaptiveSteps, control: &mut dyn FnMut(f64) -> bool) {
        debug_assert!(L == 1);
        let eps = same_instant(self.sh.grid_dt);
        let tol = ad.tol;
        ad.interpolated = false;
        while t1 - ad.t > eps {
            self.record_pending(ad);
            if !ad.control.tick(control, ad.t / ad.t_end) {
                // at the last accepted step, recorded above
                let e = Error::Interrupted {
                    time: ad.t,
                    step: self.step,
                };
                self.retire(0, Some(e), self.step, ad.t);
                return;
            }
            let t = ad.t;
            let rest = ad.t_end - t;
            let mut h = ad.levels.step();
            // the last step of the run: to `t_end`, at the level's length where it is that up
            // to rounding (its constants are cached), else at the rest
            let last = h >= rest || rest - h < 1e-3 * h;
            if last {
                // the level's length, or a shorter level's (after the level went down), where it
                // is the rest up to rounding: its constants are cached
                let mut hk = h;
                for _ in 0..5 {
                    if (rest - hk).abs() <= eps {
                        break;
                    }
                    hk *= 0.5;
                }
                h = if (rest - hk).abs() <= eps { hk } else { rest };
            }
            self.snapshot(&mut ad.snap);
            ad.p0.clone_from(&self.lanes[0].pen);
            let at_floor = ad.levels.at_floor();
            if !self.adaptive_step(t, h) {
                return;
            }
            let mut err = self.local_error(h, &ad.snap.a, &ad.err_scale, &tol);
            let mut taken = h;
            let mut cut = false;
            if let Some((mut theta, jstar)) = earliest_crossing(&ad.p0, &self.lanes[0].pen) {
                // a step that changes a joint's status is cut at the crossing first: the error
                // of the substep to it is the one to judge
                ad.p1.clone_from(&self.lanes[0].pen);
                let mut search = CutSearch::new(ad.p0[jstar], ad.p1[jstar], false);
                let lane = &mut self.lanes[0];
                // the first try where the joint's interpolated path crosses (half the search's
                // tolerance short of the circle), the linear estimate where it shows no crossing
                let (start, end) = ((ad.snap.q[jstar], ad.snap.qd[jstar]), (lane.q[jstar], lane.qd[jstar]));
                let radius = lane.sys.joints[jstar].clearance + search.target();
                theta = CutSearch::cuttable_estimate(adaptive::hermite_crossing(start, end, h, radius, theta));
                lane.frozen.clear();
                lane.frozen.extend(ad.p0.iter().map(|&p| p > 0.0));
                for it in 0..EVENT_MAX_CUTS {
                    taken = theta * h;
                    self.restore(&ad.snap);
                    if !self.adaptive_step(t, taken) {
                        return;
                    }
                    let lane = &self.lanes[0];
                    let rate = h * penetration_rate(lane.q[jstar], lane.qd[jstar]);
                    match search.next_with_rate(theta, lane.pen[jstar], rate, it + 1 == EVENT_MAX_CUTS) {
                        Some(next) => theta = next,
                        None => break,
                    }
                }
                self.lanes[0].frozen.clear();
                err = self.local_error(taken, &ad.snap.a, &ad.err_scale, &tol);
                cut = true;
            } else if !at_floor && self.passes_through_a_circle(h, &ad.snap) {
                // a contact within the step, open at both ends: shorter steps locate it
                self.restore(&ad.snap);
                self.lanes[0].stats.rejected_steps += 1;
                ad.levels.reject(8.0);
                continue;
            }
            if err.ratio > 1.0 && !at_floor {
                self.restore(&ad.snap);
                self.lanes[0].stats.rejected_steps += 1;
                ad.levels.reject(err.ratio);
                continue;
            }
            if ad.levels.count_floor(err.ratio > 1.0) {
                let e = adaptive::floor_error(t, self.step, h);
                self.retire(0, Some(e), self.step, t);
                return;
            }
            if let Some((mean, limit)) = ad.levels.count_crawl(taken) {
                let e = adaptive::crawl_error(t, self.step, mean, limit, ad.t_end);
                self.retire(0, Some(e), self.step, t);
                return;
            }
            let stats = &mut self.lanes[0].stats;
            if err.ratio > 1.0 {
                stats.floor_steps += 1;
            }
            if cut {
                stats.event_steps += 1;
            } else {
                ad.levels.accept(err.ratio, h);
            }
            adaptive::count_step(stats, taken, &err);
            // the joints' local displacement and velocity errors (the restart at a cut changes
            // `a`)
            let nm = self.lanes[0].settings.newmark;
            for (jj, j) in self.lanes[0].sys.joints.iter().enumerate() {
                let mut d = [0.0; 2];
                for k in 0..j.ndof {
                    let da = self.a[j.dofs[k]][0] - ad.snap.a[j.dofs[k]];
                    d[0] += j.coef[0][k] * da;
                    d[1] += j.coef[1][k] * da;
                }
                ad.forces.add_joint(jj, d, taken, (nm.beta, nm.error_gamma()), cut);
            }
            let reached = if last && !cut { ad.t_end } else { t + taken };
            ad.t_start = t;
            if cut {
                // the right limit at the cut (recorded with the step's end)
                self.restart_at_event(reached, &ad.p0, &ad.p1, false);
            } else {
                self.peaks_within_step(t, taken, &ad.snap);
            }
            ad.pending = Some(cut);
            self.track_peak_errors(&mut ad.forces);
            ad.t = reached;
            // the divergence limits every few accepted steps and at the last (as Newton's
            // `track_step_end`): a run that diverged between output instants stops there
            if ad.accepted.check_due(reached >= ad.t_end) {
                if let Err(e) = self.check_lane(0, reached, self.step) {
                    self.retire(0, Some(e), self.step, reached);
                    return;
                }
            }
        }
        if (ad.t - t1).abs() <= eps {
            // the step ended at the output instant, whose record takes its end (a cut's right
            // limit is an event: recorded first)
            if ad.pending == Some(true) {
                self.record_pending(ad);
            }
            ad.pending = None;
        } else {
            ad.interpolated = true;
        }
    }

    /// Records the end of the last accepted adaptive step, past the output instants recorded
    /// since, when it is still to be recorded: a cut's right limit as an event
    /// ([`Recorder::record_event`]), another end as a substep ([`Recorder::record_substep`]).
    fn record_pending(&mut self, ad: &mut AdaptiveSteps) {
        let Some(event) = ad.pending.take() else {
            return;
        };
        let lane = &mut self.lanes[0];
        if event {
            lane.rec.record_event(ad.t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        } else {
            lane.rec.record_substep(ad.t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        }
    }

    /// Whether a joint open at both ends of the trial step of length `h` (s) just taken from
    /// `snap` passes through its clearance circle in between ([`adaptive::enters_within`]).
    fn passes_through_a_circle(&self, h: f64, snap: &Snapshot) -> bool {
        let lane = &self.lanes[0];
        (lane.sys.joints.iter().enumerate()).any(|(jj, j)| {
            adaptive::enters_within((snap.q[jj], snap.qd[jj]), (lane.q[jj], lane.qd[jj]), h, j.clearance)
        })
    }

    /// Records the output instant `t` (s), step `step`, inside the last accepted adaptive step
    /// (from `ad.t_start` to `ad.t`): each joint's relative displacement and velocity on the
    /// cubic Hermite path of the step's ends, the penetration and the law's force there, and
    /// the displacements likewise where the node histories read them.
    fn record_interpolated(&mut self, step: u64, t: f64, ad: &mut AdaptiveSteps) {
        let h = ad.t - ad.t_start;
        let s = ((t - ad.t_start) / h).clamp(0.0, 1.0);
        let (u1, v1) = (self.u.as_flattened(), self.v.as_flattened());
        let uo = &mut ad.out_u;
        let snap = &ad.snap;
        let lane = &mut self.lanes[0];
        if lane.reads_u {
            adaptive::interpolate_displacements((&snap.u, &snap.v), (u1, v1), h, s, uo);
        }
        for jj in 0..lane.sys.joints.len() {
            let (qi, vi) = adaptive::hermite_at((snap.q[jj], snap.qd[jj]), (lane.q[jj], lane.qd[jj]), h, s);
            let terms = lane.contact_terms(jj, qi, vi);
            ad.out_q[jj] = qi;
            ad.out_qd[jj] = vi;
            ad.out_pen[jj] = terms.penetration;
            ad.out_force[jj] = evaluation::recorded_force(&terms, qi, vi);
        }
        let dt = lane.settings.dt;
        let u = if lane.reads_u { &uo[..] } else { &[] };
        lane.rec
            .record(step, t, dt, &ad.out_pen, &ad.out_force, &ad.out_q, &ad.out_qd, u);
    }

    /// After an accepted adaptive step (its peaks within and its end recorded): each joint whose
    /// largest force rose takes the estimate of that force's error ([`adaptive::ForceErrors`],
    /// the law's terms at the step's end), into the stats.
    fn track_peak_errors(&mut self, forces: &mut adaptive::ForceErrors) {
        let lane = &mut self.lanes[0];
        let mut changed = false;
        for jj in 0..lane.sys.joints.len() {
            let f = norm2(lane.force[jj]).max(lane.rec.extremes[jj].max_force);
            if forces.is_peak(jj, f) {
                let terms = lane.contact_terms(jj, lane.q[jj], lane.qd[jj]);
                forces.set_peak(jj, f, &terms);
                changed = true;
            }
        }
        if changed {
            forces.to_stats(&mut lane.stats);
        }
    }

    /// The largest penetration and contact force of each joint within the accepted adaptive step
    /// from `t` of length `h` (s), into the joint's extremes, as the Newton stepper's
    /// (`NewtonRun`'s `peaks_within_step`): the joint's relative displacement is the cubic
    /// Hermite interpolant of its values and rates at the step's ends (the start's in `snap`),
    /// sampled at 7 interior points where either end is in contact, so that a smooth peak enters
    /// at `O(h^4)` rather than the `O(h^2)` of the ends. Not for the gap coupling (its status is
    /// the iteration's), nor with a recording start time (the end values only, as on Newton).
    fn peaks_within_step(&mut self, t: f64, h: f64, snap: &Snapshot) {
        let lane = &mut self.lanes[0];
        if lane.settings.record.start > 0.0 || matches!(lane.settings.coupling, Coupling::Gap { .. }) {
            return;
        }
        for jj in 0..lane.sys.joints.len() {
            let (q0, v0) = (snap.q[jj], snap.qd[jj]);
            let (q1, v1) = (lane.q[jj], lane.qd[jj]);
            let c = lane.sys.joints[jj].clearance;
            if norm2(q0) <= c && norm2(q1) <= c {
                continue;
            }
            for (s, q, qd) in adaptive::hermite_points((q0, v0), (q1, v1), h) {
                let terms = lane.contact_terms(jj, q, qd);
                if terms.penetration <= 0.0 {
                    continue;
                }
                let f = evaluation::recorded_force(&terms, q, qd);
                lane.rec.record_peak_within(jj, t + s * h, terms.penetration, norm2(f));
            }
        }
    }

    /// One trial step of the single lane from `t` of length `h` (s) with the constants of `h`;
    /// false when the lane failed (it is then retired with its error).
    fn adaptive_step(&mut self, t: f64, h: f64) -> bool {
        if let Err(e) = self.use_step(h) {
            self.retire(0, Some(e), self.step, t);
            return false;
        }
        self.t = t;
        self.advance(t + h);
        self.active[0]
    }

    /// Puts the single lane back to the start-of-step state `snap`.
    fn restore(&mut self, snap: &Snapshot) {
        set_lane(&mut self.u, 0, &snap.u);
        set_lane(&mut self.v, 0, &snap.v);
        set_lane(&mut self.a, 0, &snap.a);
        if self.sh.alpha.is_some() {
            set_lane(&mut self.aa, 0, &snap.aa);
        }
        let lane = &mut self.lanes[0];
        lane.q.clone_from(&snap.q);
        lane.qd.clone_from(&snap.qd);
        lane.pen.clone_from(&snap.pen);
        lane.force.clone_from(&snap.force);
        lane.gap_closed.clone_from(&snap.gap_closed);
        lane.gap_normal.clone_from(&snap.gap_normal);
        lane.episode.clone_from(&snap.episode);
        lane.pa_old.clone_from(&snap.pa_old);
    }

    /// At the cut `t` (s) of an event step (one lane): each joint whose status changed over the
    /// trial step (`pen0`, `pen1`: penetrations at its start and end, m) is put on the new side of the clearance
    /// circle (its position projected radially to `|delta| = 1e-6 |delta_0 - delta_1|`), so that
    /// the next substep starts with the new status, and the acceleration is recomputed from
    /// `M a = F(t) - K u - C v + contact(u, v)`: the right limit at a force discontinuity (the
    /// dashpot force jumps at entry), without which average acceleration integrates the jump
    /// over the next substep at first order.
    #[cold]
    fn restart_at_event(&mut self, t: f64, pen0: &[f64], pen1: &[f64], record: bool) {
        let sh = &mut self.sh;
        let lane = &mut self.lanes[0];
        let is_gap = matches!(lane.settings.coupling, Coupling::Gap { .. });
        for jj in 0..lane.sys.joints.len() {
            // the trial step's end status is in `pen1`; the cut state `q` lies near the circle
            let (p0, p1) = (pen0[jj], pen1[jj]);
            if (p0 > 0.0) == (p1 > 0.0) {
                continue;
            }
            let entering = p1 > 0.0;
            let c = lane.sys.joints[jj].clearance;
            let q = lane.q[jj];
            let dr = norm2(q);
            let eps = 1e-6 * (p1 - p0).abs();
            let target = if entering { c + eps } else { c - eps };
            if dr > 0.0 && target > 0.0 {
                lane.q[jj] = [q[0] * target / dr, q[1] * target / dr];
                lane.pen[jj] = target - c;
                if is_gap {
                    lane.gap_closed[jj] = entering;
                    lane.gap_normal[jj] = [q[0] / dr, q[1] / dr];
                }
            }
        }
        // (the one lane's vectors; `rb` is free between steps)
        let (u, v) = (self.u.as_flattened(), self.v.as_flattened());
        let mut r = std::mem::take(&mut lane.rb);
        let pat = &lane.sys.pattern;
        pat.mul(&lane.sys.stiffness, u, &mut r);
        pat.mul(&lane.sys.damping, v, &mut lane.col);
        for (r, t) in r.iter_mut().zip(&lane.col) {
            *r = -*r - t;
        }
        lane.sys.frames_at(t, &mut lane.frames);
        lane.sys.add_inertia_load(&lane.frames, &mut r);
        for jj in 0..lane.sys.joints.len() {
            let (q, qd) = (lane.q[jj], lane.qd[jj]);
            let f = lane.contact_terms(jj, q, qd).force(q, qd);
            lane.force[jj] = f;
            let j = &lane.sys.joints[jj];
            for k in 0..j.ndof {
                r[j.dofs[k]] += j.coef[0][k] * f[0] + j.coef[1][k] * f[1];
            }
        }
        // the right-limit force at the cut (the dashpot spike at entry) lies between output steps
        // (adaptive steps record it later, in time order with the output instants)
        if record {
            lane.rec.record_event(t, &lane.pen, &lane.force, &lane.q, &lane.qd);
        }
        sh.mchol.solve_in_place(&mut r);
        set_lane(&mut self.a, 0, &r);
        if sh.alpha.is_some() {
            set_lane(&mut self.aa, 0, &r); // the alpha schemes restart with aa = a
        }
        lane.rb = r;
    }

    /// The divergence check of lane `l`'s state at `t` (s), step `step`.
    #[inline(always)]
    fn check_lane(&self, l: usize, t: f64, step: u64) -> Result<()> {
        let lane = &self.lanes[l];
        if L == 1 {
            lane.check_state(
                self.u.as_flattened(),
                self.v.as_flattened(),
                &self.sh.translational,
                t,
                step,
            )
        } else {
            lane.check_state(LaneOf(&self.u, l), LaneOf(&self.v, l), &self.sh.translational, t, step)
        }
    }

    /// Records every active lane after the step to `t` (s).
    #[inline(always)]
    fn record(&mut self) {
        let (step, t) = (self.step, self.t);
        for l in 0..self.lanes.len() {
            if !self.active[l] {
                continue;
            }
            let lane = &mut self.lanes[l];
            let dt = lane.settings.dt;
            if L == 1 {
                lane.rec.record(
                    step,
                    t,
                    dt,
                    &lane.pen,
                    &lane.force,
                    &lane.q,
                    &lane.qd,
                    self.u.as_flattened(),
                );
            } else if lane.reads_u {
                get_lane(&self.u, l, &mut lane.col);
                lane.rec
                    .record(step, t, dt, &lane.pen, &lane.force, &lane.q, &lane.qd, &lane.col);
            } else {
                lane.rec
                    .record(step, t, dt, &lane.pen, &lane.force, &lane.q, &lane.qd, &[]);
            }
        }
    }
}

/// The lockstep in the one run loop ([`run_loop`]), with the scratch of event-aware stepping
/// (one lane only).
struct LockstepLoop<'a, 'm, const L: usize> {
    ls: &'a mut Lockstep<'m, L>,
    events: Option<Events>,
    /// Adaptive steps (one lane only), `None` for the fixed step.
    adaptive: Option<AdaptiveSteps>,
}

impl<const L: usize> Stepper for LockstepLoop<'_, '_, L> {
    const CONTROL_STRIDE: u64 = CONTROL_STRIDE;

    #[inline(always)]
    fn steps(&self) -> u64 {
        self.ls.sh.steps
    }

    #[inline(always)]
    #[allow(clippy::misnamed_getters)] // the output grid's step, not the step in use
    fn dt(&self) -> f64 {
        self.ls.sh.grid_dt
    }

    #[inline(always)]
    fn running(&self) -> bool {
        self.ls.active.iter().any(|&a| a)
    }

    #[inline(always)]
    fn advance(&mut self, k: u64, t1: f64, control: &mut dyn FnMut(f64) -> bool) {
        debug_assert_eq!(k, self.ls.step + 1);
        match (self.adaptive.as_mut(), self.events.as_mut()) {
            (Some(ad), _) => self.ls.adaptive_advance(t1, ad, control),
            (None, None) => self.ls.advance(t1),
            (None, Some(ev)) => self.ls.advance_with_events(t1, ev),
        }
        self.ls.step = k;
        self.ls.t = t1;
    }

    #[inline(always)]
    fn check(&mut self, k: u64, t1: f64) {
        let ls = &mut *self.ls;
        for l in 0..ls.lanes.len() {
            if ls.active[l] {
                if let Err(e) = ls.check_lane(l, t1, k) {
                    ls.retire(l, Some(e), k, t1);
                }
            }
        }
    }

    #[inline(always)]
    fn record(&mut self, k: u64, t1: f64) {
        match self.adaptive.as_mut() {
            Some(ad) if ad.interpolated => {
                if self.ls.active[0] {
                    self.ls.record_interpolated(k, t1, ad);
                }
            }
            _ => self.ls.record(),
        }
    }

    #[cold]
    fn stop_all(&mut self, error: Error, k: u64, t: f64) {
        for l in 0..self.ls.lanes.len() {
            if self.ls.active[l] {
                self.ls.retire(l, Some(error.clone()), k, t);
            }
        }
    }

    fn end(&mut self, k: u64, t: f64) {
        for l in 0..self.ls.lanes.len() {
            if self.ls.active[l] {
                self.ls.retire(l, None, k, t);
            }
        }
    }
}
