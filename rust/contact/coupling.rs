//! How a clearance joint's force enters the Newmark step.

use crate::error::{check_non_negative, check_positive, Result};

/// The couplings of docs/method.md section 4, and the continuous-contact model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coupling {
    /// Force reaction method: the contact force is evaluated from the last state and applied
    /// on the right-hand side (explicit in the contact). The paper's reference.
    Force,
    /// Modified stiffness/damping matrix method (the paper's): `kappa K_B` and `C_B` are added
    /// to the effective matrix on the joint's DOFs with `kappa` from the last state; with
    /// `iterate`, `kappa` is iterated to convergence within the step (relative change of the
    /// joint's acceleration below `tol`, at most `max_iter` passes).
    Modified {
        /// Iterate kappa within the step.
        iterate: bool,
        /// Relative tolerance of the iteration.
        tol: f64,
        /// Iteration cap per step; the step is accepted at the cap and counted.
        max_iter: usize,
    },
    /// Gap element with status iteration (commercial-code style): closed, a radial spring of
    /// stiffness `stiffness` (default `1000 x 12 E I / l^3` of the element at the joint node) and
    /// optional radial damping; open, nothing. The status is iterated within the step.
    Gap {
        /// Gap stiffness, N/m; `None` = 1000 x 12EI/l^3 of the adjacent element.
        stiffness: Option<f64>,
        /// Gap damping, N s/m (radial).
        damping: f64,
        /// Status iteration cap per step.
        max_iter: usize,
    },
    /// The continuous-contact (massless-link) model (Earles & Wu 1977; Haines 1980): no contact
    /// law. While the journal is on the wall the joint is the constraint `|q| = c` with the
    /// normal force `lambda` (N, compressive > 0) an unknown of the step; the joint leaves the
    /// wall at the instant `lambda` turns tensile (the predicted loss of contact, interpolated
    /// within the step) and flies free until it reaches the wall again, where it attaches by a
    /// perfectly plastic impact (the normal relative velocity removed, mass-weighted). Newton
    /// stepper only ([`crate::integrator::newton`], `continuous.rs`).
    Continuous,
}

impl Default for Coupling {
    fn default() -> Self {
        Coupling::Modified {
            iterate: false,
            tol: 1e-10,
            max_iter: 50,
        }
    }
}

impl Coupling {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Coupling::Force | Coupling::Continuous => Ok(()),
            Coupling::Modified { tol, max_iter, .. } => {
                check_positive("tol", tol, "(relative)")?;
                crate::run::check_max_iter(max_iter)?;
                Ok(())
            }
            Coupling::Gap {
                stiffness,
                damping,
                max_iter,
            } => {
                if let Some(k) = stiffness {
                    check_positive("gap_stiffness", k, "N/m")?;
                }
                check_non_negative("gap_damping", damping, "N s/m")?;
                crate::run::check_max_iter(max_iter)?;
                Ok(())
            }
        }
    }

    /// Short name: `"force"`, `"modified"`, `"gap"` or `"continuous"`.
    pub fn name(&self) -> &'static str {
        match self {
            Coupling::Force => "force",
            Coupling::Modified { .. } => "modified",
            Coupling::Gap { .. } => "gap",
            Coupling::Continuous => "continuous",
        }
    }
}
