//! Natural frequencies of the assembled structure with every clearance joint open: the
//! generalized eigenproblem `K phi = omega^2 M phi`, solved densely (Cholesky of M, symmetric
//! eigen-decomposition). Dense is O(n^3): fine up to a few thousand DOFs.

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::plan::assembly::System;
use crate::plan::translating::Model;

/// Eigenvalues `omega^2` below this fraction of the largest are rigid-body modes.
pub const RIGID_TOLERANCE: f64 = 1e-9;

fn dense(sys: &System, values: &[f64]) -> DMatrix<f64> {
    let n = sys.n();
    let p = &sys.pattern;
    let mut m = DMatrix::zeros(n, n);
    for c in 0..n {
        for k in p.col_ptr[c]..p.col_ptr[c + 1] {
            m[(p.row_idx[k], c)] = values[k];
        }
    }
    m
}

/// The lowest `count` natural frequencies (Hz) with clearance joints open and rigid-body modes
/// (omega^2 < 1e-9 of the largest) left out, ascending. Fewer are returned if the model has fewer
/// flexible modes. Fails if `count` is 0 or the mass matrix is not positive definite.
pub fn natural_frequencies(model: &Model, count: usize) -> Result<Vec<f64>> {
    model.validate()?;
    if count < 1 {
        return Err(Error::param("count", count, "an integer >= 1"));
    }
    let sys = System::assemble(model);
    let m = dense(&sys, &sys.mass);
    let k = dense(&sys, &sys.stiffness);
    let chol = m.cholesky().ok_or(Error::Singular {
        what: "the mass matrix".into(),
        index: 0,
        dof: String::new(),
    })?;
    let l = chol.l();
    let linv = l.clone().try_inverse().ok_or(Error::Singular {
        what: "the mass matrix".into(),
        index: 0,
        dof: String::new(),
    })?;
    let a = &linv * k * linv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let mut lam: Vec<f64> = a.symmetric_eigenvalues().iter().copied().collect();
    lam.sort_by(|x, y| x.total_cmp(y));
    let lmax = lam.last().copied().unwrap_or(0.0).max(0.0);
    Ok(lam
        .into_iter()
        .filter(|&x| x > RIGID_TOLERANCE * lmax)
        .take(count)
        .map(|x| x.sqrt() / (2.0 * std::f64::consts::PI))
        .collect())
}
