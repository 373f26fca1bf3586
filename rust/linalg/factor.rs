//! The interface every factorization offers to the code that only solves with it (the Woodbury
//! contact update, [`super::Woodbury`]).

use super::{BandLu, Cholesky};

/// A factorized square matrix `A` (n x n) that solves `A x = b` in place.
///
/// Implemented by [`Cholesky`] (faer LDL^T, the constant stepper's symmetric effective matrix)
/// and [`BandLu`] (the moving-frame effective matrix or Jacobian). Generic code takes
/// `F: Factor` (monomorphized, no dynamic dispatch in a step).
pub trait Factor {
    /// The dimension `n` of the factorized matrix.
    fn dim(&self) -> usize;
    /// Overwrites `x` (length [`Factor::dim`]) with `A^-1 x`.
    fn solve_in_place(&mut self, x: &mut [f64]);
    /// Solves for two right-hand sides, each result bitwise that of [`Factor::solve_in_place`]
    /// (a factor may interleave the two substitutions).
    fn solve_pair_in_place(&mut self, x: &mut [f64], y: &mut [f64]) {
        self.solve_in_place(x);
        self.solve_in_place(y);
    }
}

impl Factor for Cholesky {
    #[inline]
    fn dim(&self) -> usize {
        self.analysis().n()
    }
    #[inline]
    fn solve_in_place(&mut self, x: &mut [f64]) {
        Cholesky::solve_in_place(self, x);
    }
}

impl Factor for BandLu {
    #[inline]
    fn dim(&self) -> usize {
        self.n()
    }
    #[inline]
    fn solve_in_place(&mut self, x: &mut [f64]) {
        BandLu::solve_in_place(self, x);
    }
    #[inline]
    fn solve_pair_in_place(&mut self, x: &mut [f64], y: &mut [f64]) {
        BandLu::solve_pair_in_place(self, x, y);
    }
}
