//! The engine's error type. Every failure a caller can provoke is a value of [`Error`]; the
//! Python bindings map each variant to one exception class in one place (`python/errors.rs`).

use std::fmt;

/// Everything that can go wrong in the engine.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A parameter is outside its allowed range. `name` is the parameter as the caller spells it
    /// (for example `links[0].length`), `allowed` says the range in words with units.
    InvalidParameter {
        /// Dotted path of the parameter.
        name: String,
        /// The offending value, formatted.
        value: String,
        /// The allowed range, in words and units.
        allowed: String,
    },
    /// The model refers to something that does not exist (a joint on a missing node, an unknown
    /// link or body).
    InvalidModel {
        /// What is wrong, in words.
        message: String,
    },
    /// The run blew up: a state became non-finite or exceeded the divergence limit.
    Diverged {
        /// Simulated time of the step where it was detected, s.
        time: f64,
        /// Index of that step (1-based count of completed steps).
        step: u64,
        /// Which degree of freedom went first, in words.
        dof: String,
        /// Why the state was judged divergent.
        reason: String,
    },
    /// A matrix that must be positive definite was not (for example a mass matrix with zero
    /// density, or an effective matrix made indefinite by a negative stiffness).
    Singular {
        /// Which matrix.
        what: String,
        /// Pivot index where the factorization failed.
        index: usize,
        /// The unknown of that pivot in the user's terms ("theta of node 5000 of link \"rod\""),
        /// empty where the factorization does not know the model.
        dof: String,
    },
    /// The nonlinear iterations of a step (geometric stiffness, iterated contact) did not converge
    /// within the iteration cap, and step halving was not asked for or did not help.
    NotConverged {
        /// Simulated time at the start of the step, s.
        time: f64,
        /// Index of the step (1-based).
        step: u64,
        /// Iterations done.
        iterations: usize,
        /// Infinity norm of the last residual, N (or N m).
        residual: f64,
        /// Last displacement correction relative to the displacement scale.
        correction: f64,
    },
    /// The caller asked the run to stop (Ctrl-C from Python).
    Interrupted {
        /// Simulated time reached, s.
        time: f64,
        /// Steps completed.
        step: u64,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidParameter`].
    pub fn param(name: impl Into<String>, value: impl fmt::Display, allowed: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name: name.into(),
            value: short_number(value.to_string()),
            allowed: allowed.into(),
        }
    }
}

/// A number printed the way `%g` would: `1e-300`, not `0.000...001` with three hundred digits.
/// Anything that is not a long plain number is kept as it is.
fn short_number(text: String) -> String {
    let long = text.len() > 16 && text.bytes().all(|b| b.is_ascii_digit() || b == b'.' || b == b'-');
    match text.parse::<f64>() {
        Ok(x) if long && x.is_finite() => format!("{x:e}"),
        _ => text,
    }
}

/// `x` as C's `%g` prints it (6 significant digits, trailing zeros dropped; `inf`, `nan`), the
/// form of the numbers in messages.
pub(crate) fn g6(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0".into() } else { "0".into() };
    }
    let sci = format!("{x:.5e}");
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (-4..6).contains(&exp) {
        trim(format!("{x:.*}", (5 - exp) as usize))
    } else {
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", trim(mantissa.to_string()), exp.abs())
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidParameter { name, value, allowed } => {
                write!(f, "invalid parameter `{name}` = {value}: allowed {allowed}")
            }
            Error::InvalidModel { message } => write!(f, "invalid model: {message}"),
            Error::Diverged {
                time,
                step,
                dof,
                reason,
            } => write!(
                f,
                "simulation diverged at t = {time:.6e} s (step {step}): {reason}; first at {dof}"
            ),
            Error::Singular { what, index, dof } if dof.is_empty() => {
                write!(f, "{what} is not positive definite (pivot {index})")
            }
            Error::Singular { what, index, dof } => {
                write!(f, "{what} is not positive definite at {dof} (pivot {index})")
            }
            Error::NotConverged {
                time,
                step,
                iterations,
                residual,
                correction,
            } => write!(
                f,
                "iterations did not converge in step {step} at t = {time:.6e} s: {iterations} iterations, residual {residual:.3e}, relative correction {correction:.3e} (raise max_iter, lower dt or allow step halving)"
            ),
            Error::Interrupted { time, step } => {
                write!(f, "interrupted at t = {time:.6e} s (step {step})")
            }
        }
    }
}

impl std::error::Error for Error {}

/// Result alias for the engine.
pub type Result<T> = std::result::Result<T, Error>;

/// Largest magnitude a model parameter may have (in SI units, whatever its unit): far beyond
/// anything physical, and small enough that the products a run forms (a damping times a speed, a
/// mass times a squared rate, a stiffness times a length) stay finite in double precision. A
/// parameter of 1e300 would otherwise run and return an infinite force or energy.
pub const MAX_MAGNITUDE: f64 = 1e75;

/// True when `value` is finite and at most [`MAX_MAGNITUDE`] in magnitude.
#[inline]
pub fn in_range(value: f64) -> bool {
    value.is_finite() && value.abs() <= MAX_MAGNITUDE
}

/// Checks that `value` is finite, strictly positive and at most [`MAX_MAGNITUDE`].
pub fn check_positive(name: &str, value: f64, unit: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 && value <= MAX_MAGNITUDE {
        Ok(())
    } else {
        Err(Error::param(
            name,
            value,
            format!("finite and > 0 {unit} (at most 1e75)"),
        ))
    }
}

/// Checks that `value` is finite, not negative and at most [`MAX_MAGNITUDE`].
pub fn check_non_negative(name: &str, value: f64, unit: &str) -> Result<()> {
    if (0.0..=MAX_MAGNITUDE).contains(&value) {
        Ok(())
    } else {
        Err(Error::param(
            name,
            value,
            format!("finite and >= 0 {unit} (at most 1e75)"),
        ))
    }
}

/// Checks that `value` is finite and at most [`MAX_MAGNITUDE`] in magnitude.
pub fn check_finite(name: &str, value: f64, unit: &str) -> Result<()> {
    if in_range(value) {
        Ok(())
    } else {
        Err(Error::param(
            name,
            value,
            format!("finite {unit} (|value| at most 1e75)"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_values_print_like_percent_g() {
        let shown = |v: f64| match Error::param("x", v, "") {
            Error::InvalidParameter { value, .. } => value,
            _ => unreachable!(),
        };
        assert_eq!(shown(-1e-300), "-1e-300");
        assert_eq!(shown(1e300), "1e300");
        assert_eq!(shown(0.5), "0.5");
        assert_eq!(shown(1.2e6), "1200000");
        assert_eq!(shown(f64::NAN), "NaN");
        assert!(Error::param("x", -1e-300, "").to_string().len() < 60);
    }

    #[test]
    fn g6_prints_as_percent_g() {
        for (x, s) in [
            (0.35, "0.35"),
            (1e-300, "1e-300"),
            (2.5e-4, "0.00025"),
            (1.0e-5, "1e-05"),
            (123456789.0, "1.23457e+08"),
            (100000.0, "100000"),
            (0.0, "0"),
            (f64::INFINITY, "inf"),
            (6.451599999e-5, "6.4516e-05"),
        ] {
            assert_eq!(g6(x), s, "{x}");
        }
    }

    #[test]
    fn numbers_in_messages_read_as_percent_g() {
        assert_eq!(g6(0.0), "0");
        assert_eq!(g6(0.0125), "0.0125");
        assert_eq!(g6(1e20), "1e+20");
        assert_eq!(g6(1e-5), "1e-05");
        assert_eq!(g6(123456.7), "123457");
        assert_eq!(g6(1.5e300), "1.5e+300");
        assert_eq!(g6(f64::INFINITY), "inf");
    }
}
