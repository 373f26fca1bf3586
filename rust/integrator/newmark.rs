//! The Newmark family of time-integration schemes shared by every stepper: plain Newmark
//! (`beta`, `gamma`) and the generalized-alpha schemes (Chung-Hulbert, HHT) in the Arnold-Bruls
//! form, with the step coefficients and predictor constants the steppers use.

use crate::error::{Error, Result};

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
    /// (`crate::integrator::adaptive::ForceErrors`): Newmark's own, and 1/2 for the alpha
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
