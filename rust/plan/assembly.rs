//! Sparse assembly: the DOF numbering, one fixed sparsity pattern (CSC, both triangles) shared by
//! the mass, stiffness, damping and effective matrices for the whole run, and the scatter of
//! element matrices into it through precomputed positions.

use std::sync::Arc;

use super::translating::{JointTarget, Model};
use crate::contact::ContactLaw;
use crate::element::Mat6;
use crate::model::{Kinematics, Motion, NODE_DOFS};
use crate::run::Settings;

/// A square sparsity pattern in compressed sparse column form (row indices sorted per column).
#[derive(Debug, Clone)]
pub struct Pattern {
    /// Matrix size.
    pub n: usize,
    /// Column pointers, length n + 1.
    pub col_ptr: Vec<usize>,
    /// Row indices, length nnz.
    pub row_idx: Vec<usize>,
}

impl Pattern {
    /// Builds the pattern from `(row, col)` entries, in any order (duplicates merged): one sort
    /// by column and row.
    pub fn from_entries(n: usize, entries: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut by_col: Vec<(usize, usize)> = entries.into_iter().map(|(r, c)| (c, r)).collect();
        by_col.sort_unstable();
        by_col.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        for &(c, _) in &by_col {
            col_ptr[c + 1] += 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let row_idx = by_col.into_iter().map(|(_, r)| r).collect();
        Pattern { n, col_ptr, row_idx }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Position of entry `(row, col)` in the value array. Panics if it is not in the pattern
    /// (a programming error: every entry ever written is declared when the pattern is built).
    pub fn position(&self, row: usize, col: usize) -> usize {
        let (a, b) = (self.col_ptr[col], self.col_ptr[col + 1]);
        a + self.row_idx[a..b]
            .binary_search(&row)
            .unwrap_or_else(|_| panic!("entry ({row}, {col}) not in pattern"))
    }

    /// `y = A x` for values `a` on this pattern; `A` must be symmetric (column c is read as row
    /// c). Panics if the slices are shorter than the pattern.
    #[inline]
    pub fn mul(&self, a: &[f64], x: &[f64], y: &mut [f64]) {
        let n = self.n;
        assert!(a.len() >= self.nnz() && x.len() >= n && y.len() >= n);
        for c in 0..n {
            let (lo, hi) = (self.col_ptr[c], self.col_ptr[c + 1]);
            // two accumulators: the column sums are latency-bound chains otherwise
            let (mut s0, mut s1) = (0.0, 0.0);
            let mut p = lo;
            while p + 1 < hi {
                // SAFETY: row indices are < n by construction (`from_entries`), x.len() >= n,
                // p + 1 < hi <= nnz <= a.len().
                unsafe {
                    s0 += a.get_unchecked(p) * x.get_unchecked(*self.row_idx.get_unchecked(p));
                    s1 += a.get_unchecked(p + 1) * x.get_unchecked(*self.row_idx.get_unchecked(p + 1));
                }
                p += 2;
            }
            if p < hi {
                s0 += a[p] * x[self.row_idx[p]];
            }
            let s = s0 + s1;
            y[c] = s;
        }
    }
}

/// A symmetric matrix stored as a dense band (row `r` holds columns `r - w ..= r + w`), for a
/// matrix-vector product of contiguous dot products instead of indexed gathers. A chain of beam
/// elements numbered along the chain has half-bandwidth `w = 5`. Built by [`Band::from_csc`]
/// only when the band is at most twice the sparse storage.
#[derive(Debug, Clone)]
pub struct Band {
    n: usize,
    w: usize,
    vals: Vec<f64>,
}

impl Band {
    /// The band of the matrix with values `a` on `pattern`, or `None` when the band would hold
    /// more than twice the pattern's entries (far-apart couplings: use [`Pattern::mul`]).
    pub fn from_csc(pattern: &Pattern, a: &[f64]) -> Option<Band> {
        let n = pattern.n;
        let mut w = 0;
        for c in 0..n {
            for p in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                w = w.max(pattern.row_idx[p].abs_diff(c));
            }
        }
        let width = 2 * w + 1;
        if n * width > 2 * pattern.nnz().max(1) {
            return None;
        }
        let mut vals = vec![0.0; n * width];
        for c in 0..n {
            for p in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                let r = pattern.row_idx[p];
                vals[r * width + (c + w - r)] = a[p];
            }
        }
        Some(Band { n, w, vals })
    }

    /// The order `n`, half-bandwidth `w` and row-major values (`n x (2 w + 1)`) of the band.
    pub(crate) fn into_parts(self) -> (usize, usize, Vec<f64>) {
        (self.n, self.w, self.vals)
    }

    /// Length of the padded input [`Self::mul`] takes: `n + 2 w`.
    pub fn padded_len(&self) -> usize {
        self.n + 2 * self.w
    }

    /// `y = A x`, where `xpad` holds `x` at `xpad[w .. w + n]` and zeros in the `w` entries at
    /// each end (see [`Self::padded_len`]). Panics on wrong lengths.
    #[inline]
    pub fn mul(&self, xpad: &[f64], y: &mut [f64]) {
        let width = 2 * self.w + 1;
        assert!(xpad.len() == self.padded_len() && y.len() >= self.n);
        if width == 11 {
            // the width of a chain of beam elements: a fixed-size, fully unrolled dot product
            return self.mul_fixed::<11>(xpad, y);
        }
        for (r, (row, yr)) in self.vals.chunks_exact(width).zip(y.iter_mut()).enumerate() {
            let x = &xpad[r..r + width];
            // four accumulators: independent chains the compiler can keep in registers
            let mut s = [0.0; 4];
            let (rc, xc) = (row.chunks_exact(4), x.chunks_exact(4));
            let (rr, xr) = (rc.remainder(), xc.remainder());
            for (a, b) in rc.zip(xc) {
                for k in 0..4 {
                    s[k] += a[k] * b[k];
                }
            }
            let mut t = (s[0] + s[1]) + (s[2] + s[3]);
            for (a, b) in rr.iter().zip(xr) {
                t += a * b;
            }
            *yr = t;
        }
    }

    #[inline]
    fn mul_fixed<const W: usize>(&self, xpad: &[f64], y: &mut [f64]) {
        for (r, (row, yr)) in self.vals.chunks_exact(W).zip(y.iter_mut()).enumerate() {
            let row: &[f64; W] = row.try_into().expect("chunk of width W");
            let x: &[f64; W] = xpad[r..r + W].try_into().expect("window of width W");
            // two 2-lane accumulators: the shape packed SSE2 multiply/add instructions take
            let (mut a, mut b) = ([0.0f64; 2], [0.0f64; 2]);
            let mut k = 0;
            while k + 4 <= W {
                a[0] += row[k] * x[k];
                a[1] += row[k + 1] * x[k + 1];
                b[0] += row[k + 2] * x[k + 2];
                b[1] += row[k + 3] * x[k + 3];
                k += 4;
            }
            while k + 2 <= W {
                a[0] += row[k] * x[k];
                a[1] += row[k + 1] * x[k + 1];
                k += 2;
            }
            let mut t = (a[0] + b[0]) + (a[1] + b[1]);
            if k < W {
                t += row[k] * x[k];
            }
            *yr = t;
        }
    }

    /// Half-bandwidth w.
    pub fn half_bandwidth(&self) -> usize {
        self.w
    }
}

/// Where a link's DOFs sit, and its nominal-motion load.
#[derive(Debug, Clone)]
pub struct LinkPlan {
    /// First global DOF of the link.
    pub offset: usize,
    /// Number of DOFs.
    pub ndof: usize,
    /// Frame rotation (columns = frame axes in global coordinates).
    pub rotation: [[f64; 2]; 2],
    /// Prescribed frame translation.
    pub motion: Motion,
    /// `rho A int N^T e_x dx` and `.. e_y ..` assembled over the link (kg), link-frame axes;
    /// empty when the frame does not accelerate.
    pub inertia_load: Option<[Vec<f64>; 2]>,
}

/// A clearance joint mapped onto global DOFs: `q = q_offset(t) + sum_k coef[.][k] U[dofs[k]]`.
#[derive(Debug, Clone)]
pub struct JointPlan {
    /// Global DOFs involved (2 for a node-to-body joint, 4 for node-to-node).
    pub dofs: [usize; 4],
    /// How many of `dofs` are used.
    pub ndof: usize,
    /// `dq/dU`, 2 x 4 (global axes).
    pub coef: [[f64; 4]; 2],
    /// Journal link index and node reference position in global axes relative to the link frame
    /// origin, m.
    pub journal: (usize, [f64; 2]),
    /// The bearing side.
    pub bearing: Bearing,
    /// Radial clearance, m.
    pub clearance: f64,
    /// Contact law.
    pub law: Arc<dyn ContactLaw>,
    /// Bending stiffness scale `12 E I / l^3` of the journal's adjacent element, N/m.
    pub element_stiffness: f64,
}

/// Bearing side of a joint plan.
#[derive(Debug, Clone)]
pub enum Bearing {
    /// Rigid body index and bearing-centre offset, m.
    Body(usize, [f64; 2]),
    /// Link index and node reference position relative to the link frame origin, m.
    Node(usize, [f64; 2]),
}

/// Kinematics of every link frame and rigid body at one time (see [`System::frames_at`]).
#[derive(Debug, Clone, Default)]
pub struct Frames {
    /// Link frame origins, indexed like the links.
    pub links: Vec<Kinematics>,
    /// Rigid bodies' reference points, indexed like the bodies.
    pub bodies: Vec<Kinematics>,
}

/// The assembled system: one pattern, values of M, K and C, link and joint plans.
#[derive(Debug, Clone)]
pub struct System {
    /// The fixed sparsity pattern.
    pub pattern: Pattern,
    /// Mass matrix values, kg.
    pub mass: Vec<f64>,
    /// Stiffness matrix values, N/m.
    pub stiffness: Vec<f64>,
    /// Damping matrix values, N s/m.
    pub damping: Vec<f64>,
    /// `Some(c)` when `C = c K` exactly (one damping ratio eta/E for every link), s.
    pub proportional_damping: Option<f64>,
    /// Link plans.
    pub links: Vec<LinkPlan>,
    /// Joint plans.
    pub joints: Vec<JointPlan>,
    /// Rigid bodies' motions.
    pub bodies: Vec<Motion>,
    /// For each body, a link whose frame has the very same motion (evaluated once per step).
    pub body_as_link: Vec<Option<usize>>,
}

fn rot(r: &[[f64; 2]; 2], v: [f64; 2]) -> [f64; 2] {
    [r[0][0] * v[0] + r[0][1] * v[1], r[1][0] * v[0] + r[1][1] * v[1]]
}

impl System {
    /// Assembles a validated model (call [`Model::validate`] first).
    pub fn assemble(model: &Model) -> Self {
        let mut offset = 0;
        let mut offsets = Vec::with_capacity(model.links.len());
        for l in &model.links {
            offsets.push(offset);
            offset += l.dofs();
        }
        let n = offset;
        let mut entries = Vec::new();
        for (l, &o) in model.links.iter().zip(&offsets) {
            for e in 0..l.section.elements {
                let base = o + NODE_DOFS * e;
                for i in 0..6 {
                    for j in 0..6 {
                        entries.push((base + i, base + j));
                    }
                }
            }
        }
        let node_dof = |link: usize, node: usize| offsets[link] + NODE_DOFS * node;
        let mut joints = Vec::with_capacity(model.joints.len());
        for j in &model.joints {
            let la = &model.links[j.link];
            let ra = la.rotation();
            let da = node_dof(j.link, j.node);
            let mut plan = JointPlan {
                dofs: [da, da + 1, 0, 0],
                ndof: 2,
                coef: [[ra[0][0], ra[0][1], 0.0, 0.0], [ra[1][0], ra[1][1], 0.0, 0.0]],
                journal: (j.link, rot(&ra, [la.element_length() * j.node as f64, 0.0])),
                bearing: Bearing::Body(0, [0.0; 2]),
                clearance: j.clearance,
                law: j.law.clone(),
                element_stiffness: 12.0 * la.section.youngs_modulus * la.section.inertia / la.element_length().powi(3),
            };
            match j.target {
                JointTarget::Body { body, point } => plan.bearing = Bearing::Body(body, point),
                JointTarget::Node { link, node } => {
                    let lb = &model.links[link];
                    let rb = lb.rotation();
                    let db = node_dof(link, node);
                    plan.dofs[2] = db;
                    plan.dofs[3] = db + 1;
                    plan.ndof = 4;
                    for r in 0..2 {
                        plan.coef[r][2] = -rb[r][0];
                        plan.coef[r][3] = -rb[r][1];
                    }
                    plan.bearing = Bearing::Node(link, rot(&rb, [lb.element_length() * node as f64, 0.0]));
                }
            }
            for a in 0..plan.ndof {
                for b in 0..plan.ndof {
                    entries.push((plan.dofs[a], plan.dofs[b]));
                }
            }
            joints.push(plan);
        }
        let pattern = Pattern::from_entries(n, entries);
        let nnz = pattern.nnz();
        let (mut mass, mut stiffness, mut damping) = (vec![0.0; nnz], vec![0.0; nnz], vec![0.0; nnz]);
        let mut links = Vec::with_capacity(model.links.len());
        let ratio0 = model.links[0].section.damping / model.links[0].section.youngs_modulus;
        let mut proportional = true;
        for (l, &o) in model.links.iter().zip(&offsets) {
            let el = l.element();
            let (me, ke) = (el.mass(), el.stiffness());
            let ratio = l.section.damping / l.section.youngs_modulus;
            proportional &= ratio == ratio0;
            let ce: Mat6 = ke * ratio;
            let accelerates = !l.motion.is_fixed();
            let mut load = accelerates.then(|| [vec![0.0; l.dofs()], vec![0.0; l.dofs()]]);
            for e in 0..l.section.elements {
                let base = o + NODE_DOFS * e;
                for j in 0..6 {
                    for i in 0..6 {
                        let p = pattern.position(base + i, base + j);
                        mass[p] += me[(i, j)];
                        stiffness[p] += ke[(i, j)];
                        damping[p] += ce[(i, j)];
                    }
                }
                if let Some(load) = load.as_mut() {
                    let [bx, by, _, _] = el.inertia_load_vectors(e as f64 * el.length);
                    for i in 0..6 {
                        load[0][NODE_DOFS * e + i] += bx[i];
                        load[1][NODE_DOFS * e + i] += by[i];
                    }
                }
            }
            links.push(LinkPlan {
                offset: o,
                ndof: l.dofs(),
                rotation: l.rotation(),
                motion: l.motion.clone(),
                inertia_load: load,
            });
        }
        System {
            pattern,
            mass,
            stiffness,
            damping,
            proportional_damping: proportional.then_some(ratio0),
            links,
            joints,
            bodies: model.bodies.iter().map(|b| b.motion.clone()).collect(),
            body_as_link: model
                .bodies
                .iter()
                .map(|b| model.links.iter().position(|l| l.motion == b.motion))
                .collect(),
        }
    }

    /// Number of DOFs.
    pub fn n(&self) -> usize {
        self.pattern.n
    }

    /// Evaluates every link frame's and rigid body's prescribed motion at time `t` (s) into
    /// `frames`, once per step; [`Self::add_inertia_load`] and [`Self::joint_offset`] read them.
    #[inline]
    pub fn frames_at(&self, t: f64, frames: &mut Frames) {
        for (k, l) in frames.links.iter_mut().zip(&self.links) {
            *k = l.motion.at(t);
        }
        for ((k, b), same) in frames.bodies.iter_mut().zip(&self.bodies).zip(&self.body_as_link) {
            *k = match same {
                Some(l) => frames.links[*l],
                None => b.at(t),
            };
        }
    }

    /// Buffers for [`Self::frames_at`], sized for this system.
    pub fn frames(&self) -> Frames {
        Frames {
            links: vec![Kinematics::default(); self.links.len()],
            bodies: vec![Kinematics::default(); self.bodies.len()],
        }
    }

    /// Adds the nominal-motion inertia load `-M_R a_R` to `f`, with the frames' accelerations.
    #[inline]
    pub fn add_inertia_load(&self, frames: &Frames, f: &mut [f64]) {
        for (l, k) in self.links.iter().zip(&frames.links) {
            if let Some([bx, by]) = &l.inertia_load {
                let a = k.acc;
                let r = &l.rotation;
                // frame axes: a' = R^T a
                let ax = r[0][0] * a[0] + r[1][0] * a[1];
                let ay = r[0][1] * a[0] + r[1][1] * a[1];
                let seg = &mut f[l.offset..l.offset + l.ndof];
                for ((fi, x), y) in seg.iter_mut().zip(bx).zip(by) {
                    *fi -= ax * x + ay * y;
                }
            }
        }
    }

    /// Position (m) and velocity (m/s) of `q` for zero elastic displacement, from the frames of
    /// the current time: the journal node's nominal position minus the bearing centre's.
    #[inline]
    pub fn joint_offset(&self, j: &JointPlan, frames: &Frames) -> ([f64; 2], [f64; 2]) {
        let a = &frames.links[j.journal.0];
        let (b, pb) = match j.bearing {
            Bearing::Body(body, point) => (&frames.bodies[body], point),
            Bearing::Node(link, x) => (&frames.links[link], x),
        };
        let x = j.journal.1;
        (
            [a.pos[0] + x[0] - b.pos[0] - pb[0], a.pos[1] + x[1] - b.pos[1] - pb[1]],
            [a.vel[0] - b.vel[0], a.vel[1] - b.vel[1]],
        )
    }

    /// `P U` for joint `j`: the elastic part of `q` from the global vector `u`.
    #[inline]
    pub fn joint_project(j: &JointPlan, u: &[f64]) -> [f64; 2] {
        let mut r = [0.0; 2];
        for k in 0..j.ndof {
            let x = u[j.dofs[k]];
            r[0] += j.coef[0][k] * x;
            r[1] += j.coef[1][k] * x;
        }
        r
    }

    /// `e` with the unknown of a [`Error::Singular`](crate::error::Error::Singular) pivot named in the user's terms.
    pub fn name_pivot(&self, model: &Model, e: crate::error::Error) -> crate::error::Error {
        use crate::error::Error;
        match e {
            Error::Singular { what, index, .. } => Error::Singular {
                dof: self.describe_dof(model, index),
                what,
                index,
            },
            e => e,
        }
    }

    /// Describes global DOF `d` in words, for error messages.
    pub fn describe_dof(&self, model: &Model, d: usize) -> String {
        for (l, plan) in model.links.iter().zip(&self.links) {
            if d >= plan.offset && d < plan.offset + plan.ndof {
                let local = d - plan.offset;
                let name = ["u (axial)", "v (transverse)", "theta (rotation)"][local % NODE_DOFS];
                return format!("link {:?} node {} dof {}", l.name, local / NODE_DOFS, name);
            }
        }
        format!("dof {d}")
    }
}

/// The joints' projection `P` (2 rows per joint, `dq/dU`) as the low-rank operator of the
/// Woodbury contact update.
impl crate::linalg::LowRankBlocks for [JointPlan] {
    #[inline]
    fn blocks(&self) -> usize {
        self.len()
    }
    #[inline]
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
        let j = &self[b];
        for k in 0..j.ndof {
            col[j.dofs[k]] += j.coef[r][k];
        }
    }
    #[inline]
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
        System::joint_project(&self[b], x)
    }
}

/// True when two validated runs have the same contact-free effective matrix and step, so that
/// they can run as lanes of one [`Lockstep`](crate::integrator::constant::Lockstep): same pattern, bitwise equal M, K and C (and the
/// same proportional-damping ratio), the same joint DOFs and projections, the same dt, Newmark
/// (and alpha) parameters and number of steps. Clearances, contact laws, couplings, motions, initial
/// conditions and what is recorded may differ. Event-aware and adaptive runs step alone.
pub fn shares_factor(a: (&System, &Settings), b: (&System, &Settings)) -> bool {
    let ((sa, ta), (sb, tb)) = (a, b);
    let bits = |x: &[f64], y: &[f64]| x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
    !ta.events
        && !tb.events
        && ta.adaptive.is_none()
        && tb.adaptive.is_none()
        && ta.dt.to_bits() == tb.dt.to_bits()
        && ta.newmark.beta.to_bits() == tb.newmark.beta.to_bits()
        && ta.newmark.gamma.to_bits() == tb.newmark.gamma.to_bits()
        && ta.newmark.alpha_m.to_bits() == tb.newmark.alpha_m.to_bits()
        && ta.newmark.alpha_f.to_bits() == tb.newmark.alpha_f.to_bits()
        && ta.steps() == tb.steps()
        && sa.pattern.n == sb.pattern.n
        && sa.pattern.col_ptr == sb.pattern.col_ptr
        && sa.pattern.row_idx == sb.pattern.row_idx
        && bits(&sa.mass, &sb.mass)
        && bits(&sa.stiffness, &sb.stiffness)
        && bits(&sa.damping, &sb.damping)
        && sa.proportional_damping.map(f64::to_bits) == sb.proportional_damping.map(f64::to_bits)
        && sa.links.len() == sb.links.len()
        && sa
            .links
            .iter()
            .zip(&sb.links)
            .all(|(x, y)| x.offset == y.offset && x.ndof == y.ndof)
        && sa.joints.len() == sb.joints.len()
        && sa
            .joints
            .iter()
            .zip(&sb.joints)
            .all(|(x, y)| x.ndof == y.ndof && x.dofs == y.dofs && bits(x.coef.as_flattened(), y.coef.as_flattened()))
}
