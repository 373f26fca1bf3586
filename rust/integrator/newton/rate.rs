//! The clearance joints' terms as a low-rank update of the contact-free factor (Woodbury): the rows
//! `P` of each joint's relative displacement over its unknowns, the solver that keeps the
//! contact-free factor (and factors of other step sizes), and the prepare, block and solve of each
//! iteration. Also the constant-rate stepper's test and setup, which is this solver with the factor
//! made once.

use super::*;

/// The rows of `P` for the constant-rate stepper's Woodbury update: per clearance joint, the
/// derivative of the relative displacement `q` (journal minus bearing, global axes turned by
/// `-angle` of the joint's reference frame) with respect to its up to four unknowns. Constant over
/// the run when the joint's unknowns all turn with the reference frame (the plan's rule).
#[derive(Debug, Clone, Default)]
pub(super) struct JointRows {
    /// Per joint: (unknown, `[d q_x / d y_i, d q_y / d y_i]`), `NONE` for an unused slot.
    cols: Vec<[(usize, [f64; 2]); 6]>,
    /// Per joint: the link whose frame angle the rows are expressed in (`None`: global axes, every
    /// unknown of the joint on a frame that does not rotate).
    axes: Vec<Option<usize>>,
    /// Per joint: the rate (rad/s) of its unknowns' frames; the velocity of `q` has the position
    /// dependence `rate S dq/dy`. 0 for a joint whose sides turn at different rates (`split`).
    rate: Vec<f64>,
    /// Per joint: whether its two sides' unknowns turn at different rates (a slider pin on a
    /// turning rod, the pin between a four-bar's coupler and rocker): the velocity of `q` then
    /// depends on the positions through `vel`, not through a multiple of the rows.
    pub(super) split: Vec<bool>,
    /// Per joint, per slot of `cols`: `d qd / d y` at fixed velocities, in the same axes (the
    /// frames' rotation; zeros unless `split`).
    vel: Vec<[[f64; 2]; 6]>,
}

/// The velocity rows of [`JointRows`] (`V`, the right factor of the Woodbury update's second
/// term: [`Woodbury::solve_with`]) on the same unknowns as its rows.
struct VelocityRows<'a>(&'a JointRows);

impl LowRankBlocks for VelocityRows<'_> {
    fn blocks(&self) -> usize {
        self.0.cols.len()
    }
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
        for (&(i, _), v) in self.0.cols[b].iter().zip(&self.0.vel[b]) {
            if i != NONE {
                col[i] += v[r];
            }
        }
    }
    #[inline]
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
        let mut p = [0.0; 2];
        for (&(i, _), v) in self.0.cols[b].iter().zip(&self.0.vel[b]) {
            if i != NONE {
                p[0] += v[0] * x[i];
                p[1] += v[1] * x[i];
            }
        }
        p
    }
}

impl LowRankBlocks for JointRows {
    fn blocks(&self) -> usize {
        self.cols.len()
    }
    fn scatter(&self, b: usize, r: usize, col: &mut [f64]) {
        for &(i, g) in &self.cols[b] {
            if i != NONE {
                col[i] += g[r];
            }
        }
    }
    #[inline]
    fn project(&self, b: usize, x: &[f64]) -> [f64; 2] {
        let mut p = [0.0; 2];
        for &(i, g) in &self.cols[b] {
            if i != NONE {
                p[0] += g[0] * x[i];
                p[1] += g[1] * x[i];
            }
        }
        p
    }
}

/// The contact-free factor and the Woodbury update of the contact terms on it (`J = J0 + P^T G
/// P`, one 2 x 2 block of `G` per clearance joint, linalg/woodbury.rs): the constant-rate
/// stepper's solver (the contact-free Jacobian factorized once), and the Newton stepper's with
/// the Woodbury solver (refactorized when the contact-free Jacobian changes, never for a change
/// of the contact terms).
#[derive(Debug, Clone)]
pub(super) struct RateSolver {
    /// The constant-rate stepper: the step (s) `lu0` is kept for (other steps, halved or event
    /// substeps, take the refactorizing path). `None`: the Newton stepper, which refactorizes
    /// `lu0` whenever the contact-free Jacobian changes (every step with geometric terms).
    pub(super) fixed_step: Option<f64>,
    pub(super) lu0: BandLu,
    /// Whether `lu0`, `wb` and `rows` hold a factorized Jacobian.
    ready: bool,
    /// The frame signature `lu0` was assembled with (refactorized if it ever changes).
    signature: Vec<f64>,
    sig_new: Vec<f64>,
    pub(super) rows: JointRows,
    /// The rows at the current frames, compared with `rows` (the Woodbury columns are rebuilt
    /// when they differ).
    rows_new: JointRows,
    wb: Woodbury,
    /// `G`, per joint, in its reference axes.
    g: Vec<Mat2>,
    /// `H`, per joint, in its reference axes: `beta h^2 C` of a joint whose sides turn at
    /// different rates ([`JointRows::split`]), else zero.
    hv: Vec<Mat2>,
    /// `V Z` of the velocity rows ([`Woodbury::project_z`]) when some joint is split.
    wv: Vec<f64>,
    /// With split joints ([`NewtonRun::split_joints`]), whose rows turn against their axes at
    /// every step: `A0^-1 e_i` for the unknown `i` of each slot of [`JointRows::cols`] (`n` values
    /// per slot, joint by joint, zeros for an unused slot), made with `lu0`; the Woodbury
    /// columns are their combinations ([`Woodbury::rebuild_with`]).
    basis: Vec<f64>,
    /// Whether `basis` was made with the current `lu0`.
    basis_ready: bool,
    /// Whether some block of `H` is non-zero in this iteration.
    pub(super) any_split: bool,
    /// Whether some block of `G` is non-zero in this iteration.
    pub(super) any: bool,
    scratch: WoodburyScratch,
    /// The right-hand side kept for a fallback solve.
    rhs: Vec<f64>,
    /// [`NewtonRun::steps_begun`] when `lu0` was factorized (its age in steps).
    made: u64,
}

impl RateSolver {
    /// The Woodbury columns for `lu0` and `rows`: solved anew ([`Woodbury::rebuild`]), or with
    /// `split_joints` ([`NewtonRun::split_joints`]: rows that turn against their axes at every
    /// step) as combinations of `basis`, made first where `lu0` is new.
    fn rebuild_columns(&mut self, split_joints: bool) {
        let RateSolver {
            lu0,
            rows,
            wb,
            basis,
            basis_ready,
            ..
        } = self;
        if !split_joints {
            wb.rebuild(lu0, rows);
            return;
        }
        let n = lu0.n();
        if !*basis_ready {
            // one solve per slot's unknown (the unknowns of a joint are fixed)
            basis.clear();
            basis.resize(rows.cols.len() * 6 * n, 0.0);
            for (slot, col) in rows.cols.iter().flatten().zip(basis.chunks_exact_mut(n)) {
                if slot.0 != NONE {
                    col[slot.0] = 1.0;
                    lu0.solve_in_place(col);
                }
            }
            *basis_ready = true;
        }
        wb.rebuild_with(n, rows, |c, z| {
            let (b, r) = (c / 2, c % 2);
            for (k, &(i, g)) in rows.cols[b].iter().enumerate() {
                if i != NONE {
                    let e = &basis[(6 * b + k) * n..(6 * b + k + 1) * n];
                    for (zi, ei) in z.iter_mut().zip(e) {
                        *zi += g[r] * ei;
                    }
                }
            }
        });
    }
}

impl<'a> NewtonRun<'a> {
    /// Why the constant-rate stepper cannot run this model with these settings (`None`: it can).
    /// Its Jacobian without the contact terms must be the same at every step: every link frame at
    /// rest or turning at a constant rate ([`crate::kinematics::FrameKinematics::constant_rate`]),
    /// no geometric terms (their axial forces move), no node pinned or on a slider in a link that
    /// rotates (its transform turns with the link), and, with contact terms in the Jacobian
    /// (`method="modified"`), the unknowns of both sides of each clearance joint turning at one
    /// rate (so that the contact block is `P^T G P` with a constant `P` in the joint's axes), and
    /// the Woodbury solver (`solver="refactor"` asks for refactorization).
    pub fn constant_rate_obstacle(&self) -> Option<String> {
        let rate = match links_rate_obstacle(self.mech, self.links.iter().map(|ld| ld.active)) {
            Ok(rate) => rate,
            Err(why) => return Some(why),
        };
        if matches!(self.settings.coupling, Coupling::Force) || self.mech.joints.is_empty() {
            return None;
        }
        if self.settings.coupling == Coupling::Continuous {
            return Some("the continuous-contact model (method=\"continuous\") runs on the Newton stepper".into());
        }
        if self.settings.solver == SolverMode::Refactor {
            return Some("the run asks for solver=\"refactor\"".into());
        }
        if let Some(j) = self.mech.joints.iter().find(|j| j.friction.is_some()) {
            return Some(format!(
                "clearance joint {:?} has friction, whose tangent couples the rotations and is unsymmetric",
                j.name
            ));
        }
        let turn = |e: &Endpoint| self.endpoint_turn(e).map(|(_, l)| l.map_or(0.0, |l| rate[l]));
        for j in &self.mech.joints {
            if let (Some(a), Some(b)) = (turn(&j.journal), turn(&j.bearing)) {
                if a != b {
                    return Some(format!(
                        "the two sides of clearance joint {:?} turn at different rates ({a} and {b} rad/s)",
                        j.name
                    ));
                }
            }
        }
        None
    }

    /// A contact-free solver for `n` unknowns and the joints of this run; `fixed_step` as
    /// [`RateSolver::fixed_step`].
    pub(super) fn contact_free_solver(&self, fixed_step: Option<f64>) -> Box<RateSolver> {
        let nj = if matches!(self.settings.coupling, Coupling::Force) {
            0
        } else {
            self.mech.joints.len()
        };
        let rows = JointRows {
            cols: vec![[(NONE, [0.0; 2]); 6]; nj],
            axes: vec![None; nj],
            rate: vec![0.0; nj],
            split: vec![false; nj],
            vel: vec![[[0.0; 2]; 6]; nj],
        };
        Box::new(RateSolver {
            fixed_step,
            lu0: {
                let mut lu = BandLu::new(self.n, self.lu.bandwidth());
                lu.set_avx2(self.avx2);
                lu
            },
            ready: false,
            signature: Vec::new(),
            sig_new: Vec::new(),
            rows_new: rows.clone(),
            rows,
            wb: Woodbury::default(),
            g: vec![[[0.0; 2]; 2]; nj],
            hv: vec![[[0.0; 2]; 2]; nj],
            wv: Vec::new(),
            basis: Vec::new(),
            basis_ready: false,
            any_split: false,
            any: false,
            scratch: WoodburyScratch::for_rank(2 * nj),
            rhs: vec![0.0; self.n],
            made: 0,
        })
    }

    /// Makes this run the constant-rate stepper: the contact-free Jacobian at the step
    /// [`Settings::dt`] factorized once, the contact terms by Woodbury on it (steps of another
    /// length, halved or cut at an event, take the Newton path). Fails with
    /// [`Error::InvalidParameter`] naming `stepper` when [`Self::constant_rate_obstacle`] finds
    /// the model unfit (the message says why).
    pub fn use_constant_rate(&mut self) -> Result<()> {
        if let Some(why) = self.constant_rate_obstacle() {
            return Err(Error::param(
                "stepper",
                "\"constant-rate\"",
                format!("\"newton\" or None for this model ({why})"),
            ));
        }
        self.stats.stepper = "constant-rate";
        self.rate = Some(self.contact_free_solver(Some(self.settings.dt)));
        Ok(())
    }

    /// The rows of `P` in each joint's reference axes at the current frames (see
    /// [`JointRows`]), into `rows` (sized for the joints; nothing allocated). A node with local
    /// unknowns on the reference link gets the exact unit columns, so the rows of a joint that
    /// turns with its link are bitwise the same at every step. With `SPLIT` (the run has
    /// [`Self::split_joints`]), also which joints are split and their velocity rows.
    fn fill_joint_rows<const SPLIT: bool>(&self, rows: &mut JointRows) {
        for j in 0..rows.cols.len() {
            let jt = &self.mech.joints[j];
            let turns = (self.endpoint_turn(&jt.journal), self.endpoint_turn(&jt.bearing));
            let (rate, axes) = match turns {
                (Some((r, Some(l))), _) if r != 0.0 => (r, Some(l)),
                (_, Some((r, Some(l)))) if r != 0.0 => (r, Some(l)),
                _ => (0.0, None),
            };
            let split = SPLIT && matches!(turns, (Some((a, _)), Some((b, _))) if a != b);
            let rt = axes.map(|l| self.rots[l]);
            let mut cols = [(NONE, [0.0; 2]); 6];
            let mut vel = [[0.0; 2]; 6];
            for (side, (slot, e, sgn)) in [(0, &jt.journal, 1.0), (3, &jt.bearing, -1.0)].into_iter().enumerate() {
                let on_axes = match e {
                    Endpoint::Node { link, node } => {
                        Some(*link) == axes && matches!(self.links[*link].nodes[*node].trans, Trans::Local(_))
                    }
                    _ => false,
                };
                for (k, &(i, g, v)) in self.joint_jacs[j][side].iter().enumerate() {
                    if split {
                        // the frame rotation's velocity term, in the same axes
                        let v = rt.map_or(v, |r| {
                            [r[0][0] * v[0] + r[1][0] * v[1], r[0][1] * v[0] + r[1][1] * v[1]]
                        });
                        vel[slot + k] = [sgn * v[0], sgn * v[1]];
                    }
                    let g = if on_axes && k < 2 {
                        // R^T R e_k = e_k exactly
                        if k == 0 {
                            [1.0, 0.0]
                        } else {
                            [0.0, 1.0]
                        }
                    } else if let Some(r) = rt {
                        // R^T g
                        [r[0][0] * g[0] + r[1][0] * g[1], r[0][1] * g[0] + r[1][1] * g[1]]
                    } else {
                        g
                    };
                    cols[slot + k] = (i, [sgn * g[0], sgn * g[1]]);
                }
            }
            rows.cols[j] = cols;
            rows.axes[j] = axes;
            if SPLIT {
                rows.rate[j] = if split { 0.0 } else { rate };
                rows.split[j] = split;
                rows.vel[j] = vel;
            } else {
                rows.rate[j] = rate;
            }
        }
    }

    /// Before the first iteration of a step of length `h` (s) solved on the contact-free factor:
    /// factorizes the contact-free Jacobian when it changed (the frames' signature, or the axial
    /// forces of geometric terms, which are taken at the step's start as in the Newton path) and
    /// rebuilds the Woodbury columns when the factor or the rows of `P` changed. For the
    /// constant-rate stepper that is once per run. Fails as [`Self::factorize`].
    pub(super) fn rate_prepare(&mut self, h: f64, force: bool) -> Result<()> {
        let mut rs = self.rate.take().expect("contact-free solver");
        if rs.fixed_step.is_none() && rs.ready && rs.signature.first() != Some(&h) && !self.rate_kept.is_empty() {
            // another step size: its kept factor if there is one, else the oldest kept slot
            // (refactorized below) while the factor in use is kept
            let k = self
                .rate_kept
                .iter()
                .position(|c| c.ready && c.signature.first() == Some(&h))
                .unwrap_or_else(|| {
                    (0..self.rate_kept.len())
                        .min_by_key(|&k| (self.rate_kept[k].ready, self.rate_kept[k].made))
                        .unwrap_or(0)
                });
            std::mem::swap(&mut *rs, &mut self.rate_kept[k]);
            if rs.ready {
                self.factor_made = rs.made;
            }
        }
        let mut sig = std::mem::take(&mut rs.sig_new);
        // with geometric terms the axial forces move the Jacobian at every step: the signature
        // is made only to be kept with a new factor (below)
        let moved = self.nonlinear_geometric || {
            self.frame_signature(h, &mut sig);
            sig != rs.signature
        };
        let newton = rs.fixed_step.is_none();
        let same_step = rs.signature.first() == Some(&h);
        let reuse = rs.ready && !force && moved && newton && self.may_reuse(same_step);
        self.reusing = reuse;
        let refactor = !rs.ready || force || (moved && !reuse);
        if refactor {
            self.factor_made = self.steps_begun;
            rs.made = self.steps_begun;
        }
        let mut res = Ok(());
        if refactor {
            if self.nonlinear_geometric {
                self.frame_signature(h, &mut sig);
            }
            std::mem::swap(&mut rs.signature, &mut sig);
            let (bh2, gh) = self.settings.newmark.coefficients(h);
            self.assemble(bh2, gh, &mut rs.lu0, true, false);
            self.stats.factorizations += 1;
            rs.ready = false;
            res = rs
                .lu0
                .factorize("effective matrix of the mechanism")
                .map_err(|e| self.name_pivot(e));
        }
        if res.is_ok() {
            if self.split_joints {
                self.fill_joint_rows::<true>(&mut rs.rows_new);
            } else {
                self.fill_joint_rows::<false>(&mut rs.rows_new);
            }
            if refactor {
                rs.basis_ready = false;
            }
            let rebuild = refactor || rs.rows_new.cols != rs.rows.cols;
            // the new rows replace the old by a swap, not a copy: `fill_joint_rows` wrote every
            // entry of `rows_new` (without split joints all but `split` and `vel`, which then
            // keep the values of the clone both started from); the old rows are overwritten at
            // the next step
            std::mem::swap(&mut rs.rows, &mut rs.rows_new);
            if rebuild {
                rs.rebuild_columns(self.split_joints);
            }
            if self.split_joints && rs.rows.split.contains(&true) {
                // the velocity rows move with the rates: V Z at every step
                let RateSolver { rows, wb, wv, .. } = &mut *rs;
                wb.project_z(&VelocityRows(rows), wv);
            }
            rs.ready = true;
        }
        rs.sig_new = sig;
        self.rate = Some(rs);
        res
    }

    /// The blocks of `G` for the current contact terms (the step's `bh2 = beta h^2`,
    /// `gh = gamma h`): the contact part of the Jacobian of [`Self::assemble`] is
    /// `P^T (bh2 k + gh c + bh2 rate c S) P`, turned into each joint's reference axes.
    #[inline(always)]
    pub(super) fn rate_blocks(&mut self, bh2: f64, gh: f64) {
        let Some(rs) = self.rate.as_deref_mut() else {
            return;
        };
        rs.any = false;
        rs.any_split = false;
        if matches!(self.settings.coupling, Coupling::Force) {
            return;
        }
        // R^T A R for the joint's reference axes (the identity without)
        let turn = |a: Mat2, axes: Option<usize>| {
            let Some(l) = axes else {
                return a;
            };
            let r = self.rots[l];
            let mut ar = [[0.0; 2]; 2];
            for p in 0..2 {
                for q in 0..2 {
                    ar[p][q] = a[p][0] * r[0][q] + a[p][1] * r[1][q];
                }
            }
            let mut out = [[0.0; 2]; 2];
            for p in 0..2 {
                for q in 0..2 {
                    out[p][q] = r[0][p] * ar[0][q] + r[1][p] * ar[1][q];
                }
            }
            out
        };
        for j in 0..self.mech.joints.len() {
            let (k, c) = if self.implicit_contact {
                self.contact_tan[j]
            } else if self.contact[j].active() {
                (self.contact[j].k, self.contact[j].c)
            } else {
                ([[0.0; 2]; 2], [[0.0; 2]; 2])
            };
            if k == [[0.0; 2]; 2] && c == [[0.0; 2]; 2] {
                rs.g[j] = [[0.0; 2]; 2];
                rs.hv[j] = [[0.0; 2]; 2];
                continue;
            }
            rs.any = true;
            let axes = rs.rows.axes[j];
            if self.split_joints && rs.rows.split[j] {
                // G = bh2 k + gh c on the rows, H = bh2 c on the velocity rows
                let mut g = [[0.0; 2]; 2];
                let mut hv = [[0.0; 2]; 2];
                for p in 0..2 {
                    for q in 0..2 {
                        g[p][q] = bh2 * k[p][q] + gh * c[p][q];
                        hv[p][q] = bh2 * c[p][q];
                    }
                }
                rs.g[j] = turn(g, axes);
                rs.hv[j] = turn(hv, axes);
                rs.any_split = true;
                continue;
            }
            let w = rs.rows.rate[j] * bh2;
            // c S, S = [[0, -1], [1, 0]]
            let mut g = [[0.0; 2]; 2];
            for p in 0..2 {
                let cs = [c[p][1], -c[p][0]];
                for q in 0..2 {
                    g[p][q] = bh2 * k[p][q] + gh * c[p][q] + w * cs[q];
                }
            }
            rs.g[j] = turn(g, axes);
            rs.hv[j] = [[0.0; 2]; 2];
        }
    }

    /// Solves the constant-rate step's Newton system `J dx = r` in place: with the contact-free
    /// factor alone while every contact is open, by Woodbury otherwise; a capacitance below
    /// [`WOODBURY_RCOND`] falls back to the whole Jacobian, refactorized by the Newton path.
    pub(super) fn rate_solve(&mut self, h: f64, dx: &mut [f64]) -> Result<()> {
        let mut rs = self.rate.take().expect("contact-free solver");
        if !rs.any {
            rs.lu0.solve_in_place(dx);
            self.rate = Some(rs);
            return Ok(());
        }
        rs.rhs.copy_from_slice(dx);
        let RateSolver {
            lu0,
            rows,
            wb,
            g,
            hv,
            wv,
            any_split,
            scratch,
            ..
        } = &mut *rs;
        let rcond = if *any_split {
            wb.solve_with(lu0, rows, &VelocityRows(rows), g, hv, wv, dx, scratch)
        } else {
            wb.solve(lu0, rows, g, dx, scratch)
        };
        let fallback = rcond.is_nan() || rcond < WOODBURY_RCOND;
        if fallback {
            dx.copy_from_slice(&rs.rhs);
        }
        self.rate = Some(rs);
        if fallback {
            self.stats.woodbury_fallbacks += 1;
            if self.jacobian_changed(h, false) {
                self.factorize(h)?;
            }
            self.lu.solve_in_place(dx);
        }
        Ok(())
    }
}
