//! Linear solves with faer: a simplicial sparse Cholesky (LDL^T) whose symbolic analysis is done
//! once per pattern and whose numeric factorization is redone into persistent buffers, plus the
//! low-rank (Sherman-Morrison-Woodbury) correction that lets the contact-free factorization serve
//! a step whose effective matrix differs only on the joints' DOFs (docs/method.md section 5).
//!
//! Nothing here allocates after construction.

mod band_lu;
mod band_lu_lanes;
mod dense;
mod factor;
mod ldlt;
mod woodbury;

pub use band_lu::BandLu;
pub use band_lu_lanes::BandLuLanes;
pub use dense::solve_dense_in_place;
pub use factor::Factor;
pub(crate) use ldlt::{avx2_fma_available, avx512_available};
pub use ldlt::{simd_paths, Analysis, AnalysisCache, Cholesky, BAND};
pub use woodbury::{capacitance_solve, subtract_ws, LowRankBlocks, Woodbury, WoodburyScratch};
