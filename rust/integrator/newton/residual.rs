//! The residual of a step's equations at an iterate, N: each node's state in its link's axes, the
//! element forces (a run of plain elements in SIMD lanes, `element_lanes.rs`), the frames' inertia
//! loads, and the forces of the clearance joints and of friction added on.

use super::*;

impl<'a> NewtonRun<'a> {
    /// Local displacement, velocity and acceleration (u, v, th) of a node from global unknowns.
    #[inline(always)]
    pub(super) fn local(nt: &NodeT, y: &[f64], yd: &[f64], ydd: &[f64]) -> [[f64; 3]; 3] {
        let [i, j, k] = nt.idx;
        if nt.plain && i != NONE && j != NONE && k != NONE {
            // T the identity on the node's three unknowns
            return [[y[i], y[j], y[k]], [yd[i], yd[j], yd[k]], [ydd[i], ydd[j], ydd[k]]];
        }
        let g = |v: &[f64], i: usize| if i == NONE { 0.0 } else { v[i] };
        let (q, qd, qdd) = (
            [g(y, nt.idx[0]), g(y, nt.idx[1]), g(y, nt.idx[2])],
            [g(yd, nt.idx[0]), g(yd, nt.idx[1]), g(yd, nt.idx[2])],
            [g(ydd, nt.idx[0]), g(ydd, nt.idx[1]), g(ydd, nt.idx[2])],
        );
        if nt.plain {
            // T the identity on the node's own unknowns, Td = Tdd = 0
            return [q, qd, qdd];
        }
        // `T`'s structure ([`node_t`]): row 2 is `[0, 0, 1]`, and `Td`, `Tdd` have neither row 2
        // nor column 2, so only the translations' 2 x 2 blocks and `T`'s column 2 (a rigid link's
        // lever) enter. The terms left out are exact zeros (finite unknowns) added to sums that
        // start at +0: the same values as the whole 3 x 3 products.
        let mut w = [[0.0; 3]; 3];
        for r in 0..2 {
            for c in 0..2 {
                w[0][r] += nt.t[r][c] * q[c];
                w[1][r] += nt.t[r][c] * qd[c] + nt.td[r][c] * q[c];
                w[2][r] += nt.t[r][c] * qdd[c] + 2.0 * nt.td[r][c] * qd[c] + nt.tdd[r][c] * q[c];
            }
            let l = nt.t[r][2];
            w[0][r] += l * q[2];
            w[1][r] += l * qd[2];
            w[2][r] += l * qdd[2];
        }
        w[0][2] += q[2];
        w[1][2] += qd[2];
        w[2][2] += qdd[2];
        w
    }

    /// Local displacement (u, v, th) of a node from global unknowns: [`Self::local`]'s first
    /// row alone (the same operations).
    #[inline]
    pub(super) fn local_displacement(nt: &NodeT, y: &[f64]) -> [f64; 3] {
        let g = |i: usize| if i == NONE { 0.0 } else { y[i] };
        let q = [g(nt.idx[0]), g(nt.idx[1]), g(nt.idx[2])];
        if nt.plain {
            return q;
        }
        // as in `local`: `T`'s row 2 is `[0, 0, 1]`
        let mut w = [0.0; 3];
        for r in 0..2 {
            for c in 0..3 {
                w[r] += nt.t[r][c] * q[c];
            }
        }
        w[2] += q[2];
        w
    }

    /// Adds `T^T f` (f: local generalized force of a node) into `r`.
    #[inline(always)]
    fn project(nt: &NodeT, f: [f64; 3], r: &mut [f64]) {
        if nt.plain {
            // T the identity on the node's own unknowns
            for c in 0..3 {
                let i = nt.idx[c];
                if i != NONE {
                    r[i] += f[c];
                }
            }
            return;
        }
        for c in 0..3 {
            let i = nt.idx[c];
            if i != NONE {
                r[i] += nt.t[0][c] * f[0] + nt.t[1][c] * f[1] + nt.t[2][c] * f[2];
            }
        }
    }

    /// Element matrices (C, K) of element `e` of link `li` at axial force `fax`.
    #[inline(always)]
    pub(super) fn element_ck(&self, li: usize, fax: f64) -> (Mat6, Mat6) {
        let ld = &self.links[li];
        let f = &self.frames[li];
        let mut c = ld.d1;
        let mut k = ld.k1;
        if ld.active.geometric && fax != 0.0 {
            k += ld.k2u * fax + ld.k3u * fax;
            if ld.eta_e > 0.0 {
                c += ld.k2u * (fax * ld.eta_e);
            }
        }
        if ld.active.coriolis {
            c += ld.g * (2.0 * f.rate);
        }
        if ld.active.coupling {
            k += ld.g * f.accel - ld.mt * (f.rate * f.rate);
        }
        (c, k)
    }

    /// Nominal acceleration `a_R` of the point at `x` in link-frame components, gravity removed.
    pub(super) fn a_ref(&self, li: usize, x: f64) -> [f64; 2] {
        let f = &self.frames[li];
        let r = self.rots[li];
        let g = self.mech.gravity;
        let a = [f.origin_acc[0] - g[0], f.origin_acc[1] - g[1]];
        let a0 = [r[0][0] * a[0] + r[1][0] * a[1], r[0][1] * a[0] + r[1][1] * a[1]];
        [a0[0] - f.rate * f.rate * x, a0[1] + f.accel * x]
    }

    /// Residual at the state (y, yd, ydd); contact forces by the coupling (`explicit` = force
    /// method terms frozen from the step start).
    pub(super) fn residual(&mut self, h: f64, t: f64) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            unsafe { self.residual_avx2(h, t) };
            return;
        }
        self.residual_body(h, t);
    }

    /// [`Self::residual`] compiled with AVX2 enabled: a beam link's elements four at a time, one
    /// per lane ([`element_lanes`]), the rest in vector registers twice as wide as the
    /// baseline's. The same operations in the same order (Rust does not contract a multiply and
    /// an add into an FMA), so bitwise the baseline's result
    /// (`the_avx2_residual_equals_the_baseline_one_bitwise`). The ideal slider-crank's residual
    /// 3788 -> 2936 instructions a call with the lanes (`examples/profile_newton ideal 0.1`).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn residual_avx2(&mut self, h: f64, t: f64) {
        self.residual_body(h, t);
    }

    /// The forces of link `li`'s beam elements added into `r` (the residual's element part):
    /// four at a time in AVX2 lanes, element by element otherwise; `SWAPPED` for a link
    /// numbered from its last node ([`Self::elem_swapped`]), whose element slices hold node
    /// `e + 1`'s unknowns before node `e`'s.
    #[inline(always)]
    fn link_element_forces<const SWAPPED: bool>(&self, li: usize, r: &mut [f64], qs: &mut [element_lanes::Lanes; 3]) {
        let ld = &self.links[li];
        let mut prev = self.nt(li, 0);
        // the local state of `prev` where the last element computed it
        let mut wprev = None;
        // the nominal acceleration of the frame origin and the frame's rates: the same for
        // every element of the link (one rotation per link, not per element)
        let fr = self.frames[li];
        let lf = element_lanes::LinkForces {
            ld,
            ck: &self.link_ck[li],
            fs: if ld.active.load { self.a_ref(li, 0.0) } else { [0.0; 2] },
            rate: fr.rate,
            accel: fr.accel,
        };
        let first = &self.elem_first[li];
        let elements = self.mech.links[li].section.elements;
        // a beam link's elements four at a time, one per lane (AVX2), or eight (AVX-512)
        let lanes = cfg!(target_arch = "x86_64") && self.avx2 && ld.rigid_moment.is_none();
        let wide = lanes && self.avx512;
        let w = if wide { 8 } else { 4 };
        let mut e = 0;
        while e < elements {
            let width = if lanes { w.min(elements - e) } else { 1 };
            // each element's vectors and its nodes (lanes past `width` keep what an earlier
            // group left: their forces are not read)
            let mut ends = [(prev, prev); element_lanes::MAX_LANES];
            // a register's elements on consecutive unknowns, node after node: their vectors in
            // one go (their nodes are not read: each adds its force to its slice)
            let s0 = first[e];
            let run = !SWAPPED && width == w && s0 != NONE && (1..w).all(|l| first[e + l] == s0 + 3 * l);
            #[cfg(target_arch = "x86_64")]
            if run {
                let vs = [&self.y[..], &self.yd, &self.ydd];
                if wide {
                    // SAFETY: `wide` is set only where the CPU has AVX-512F, AVX2 and FMA
                    unsafe { element_lanes::avx512::gather_run(vs, s0, qs) };
                } else {
                    // SAFETY: `lanes` is set only where the CPU has AVX2 and FMA
                    unsafe { element_lanes::avx2::gather_run(vs, s0, qs) };
                }
                prev = self.nt(li, e + w);
                wprev = None;
            }
            for l in 0..if run { 0 } else { width } {
                let next = self.nt(li, e + l + 1);
                ends[l] = (prev, next);
                // an element on six consecutive unknowns reads its vectors as slices (the
                // same values as through its nodes' local states, T = I)
                let s0 = first[e + l];
                if s0 != NONE {
                    wprev = None;
                    for (qc, v) in qs.iter_mut().zip([&self.y, &self.yd, &self.ydd]) {
                        let v = &v[s0..s0 + 6];
                        if SWAPPED {
                            // node e + 1's unknowns first
                            for j in 0..3 {
                                qc[j][l] = v[j + 3];
                                qc[j + 3][l] = v[j];
                            }
                        } else {
                            for j in 0..6 {
                                qc[j][l] = v[j];
                            }
                        }
                    }
                } else {
                    let w0 = wprev.unwrap_or_else(|| Self::local(prev, &self.y, &self.yd, &self.ydd));
                    let wn = Self::local(next, &self.y, &self.yd, &self.ydd);
                    wprev = Some(wn);
                    for (c, qc) in qs.iter_mut().enumerate() {
                        let v = element_vec(&w0, &wn, c);
                        for j in 0..6 {
                            qc[j][l] = v[j];
                        }
                    }
                }
                prev = next;
            }
            let f: element_lanes::Lanes = if lanes {
                #[cfg(target_arch = "x86_64")]
                {
                    if wide {
                        // SAFETY: `avx512` is set only where the CPU has AVX-512F, AVX2 and FMA
                        // (`linalg::avx512_available`)
                        unsafe { element_lanes::avx512::forces(&lf, e, &qs[0], &qs[1], &qs[2]) }
                    } else {
                        // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA
                        // (`linalg::avx2_fma_available`)
                        unsafe { element_lanes::avx2::forces(&lf, e, &qs[0], &qs[1], &qs[2]) }
                    }
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!("lanes are an AVX2 path")
            } else {
                let v = |c: usize| Vec6::from_fn(|j, _| qs[c][j][0]);
                let (q, qd, qdd) = (v(0), v(1), v(2));
                let mut f = element_lanes::element_force(&lf, e, &q, &qd, &qdd);
                if let Some(mc) = ld.rigid_moment {
                    f[2] -= mc * self.a_ref(li, 0.0)[0] * q[2];
                }
                std::array::from_fn(|j| std::array::from_fn(|l| if l == 0 { f[j] } else { 0.0 }))
            };
            // the leading elements on consecutive unknowns (node after node): each node's
            // entries loaded and stored once, the forces of the element before it and then of
            // the one after it added in turn (the element-by-element order, entry by entry), so
            // that no load of an entry waits on the overlapping store of the element before
            let mut plain = 0;
            let s0 = first[e];
            if !SWAPPED && s0 != NONE {
                plain = 1;
                while plain < width && first[e + plain] == s0 + 3 * plain {
                    plain += 1;
                }
                let rr = &mut r[s0..s0 + 3 * plain + 3];
                for i in 0..3 {
                    rr[i] += f[i][0];
                }
                for k in 1..plain {
                    for i in 0..3 {
                        rr[3 * k + i] = rr[3 * k + i] + f[3 + i][k - 1] + f[i][k];
                    }
                }
                for i in 0..3 {
                    rr[3 * plain + i] += f[3 + i][plain - 1];
                }
            }
            // the rest added element by element, in order
            for (l, &(p, nx)) in ends.iter().enumerate().take(width).skip(plain) {
                let s0 = first[e + l];
                if s0 != NONE {
                    if SWAPPED {
                        for (j, ri) in r[s0..s0 + 6].iter_mut().enumerate() {
                            *ri += f[(j + 3) % 6][l];
                        }
                    } else {
                        for (j, ri) in r[s0..s0 + 6].iter_mut().enumerate() {
                            *ri += f[j][l];
                        }
                    }
                } else {
                    Self::project(p, [f[0][l], f[1][l], f[2][l]], r);
                    Self::project(nx, [f[3][l], f[4][l], f[5][l]], r);
                }
            }
            e += width;
        }
    }

    #[inline(always)]
    pub(super) fn residual_body(&mut self, _h: f64, t: f64) {
        let mut r = std::mem::take(&mut self.r);
        r.fill(0.0);
        let mut qs = self
            .lane_vectors
            .take()
            .expect("lane vectors put back by the last residual");
        for li in 0..self.links.len() {
            // the beam elements' forces; a link numbered from its last node (dofs::number)
            // reads its elements' slices with the nodes swapped
            if self.elem_swapped[li] {
                self.link_element_forces::<true>(li, &mut r, &mut qs);
            } else {
                self.link_element_forces::<false>(li, &mut r, &mut qs);
            }
            let ld = &self.links[li];
            let le = self.mech.links[li].element_length();
            // Point masses and nodal loads.
            for &nd in &ld.loaded_nodes {
                let (m, fl) = (ld.point_mass[nd], ld.nodal_load[nd]);
                let nt = self.nt(li, nd);
                let w = Self::local(nt, &self.y, &self.yd, &self.ydd);
                let fr = &self.frames[li];
                let ar = self.a_ref(li, nd as f64 * le);
                let (om, al) = (fr.rate, fr.accel);
                // m [wdd + 2 om S wd + (al S - om^2) w + a_R]
                let fx = m * (w[2][0] - 2.0 * om * w[1][1] - al * w[0][1] - om * om * w[0][0] + ar[0]);
                let fy = m * (w[2][1] + 2.0 * om * w[1][0] + al * w[0][0] - om * om * w[0][1] + ar[1]);
                Self::project(nt, [fx - fl[0], fy - fl[1], -fl[2]], &mut r);
            }
        }
        // Sliders: m (sdd + e . a_nominal) along the guide.
        for (s, sl) in self.mech.sliders.iter().enumerate() {
            let i = self.slider_dof[s];
            if i == NONE || sl.mass == 0.0 {
                continue;
            }
            // the guide's frame of the current frames (the residual of a step is at its end)
            let fs = if t == self.t_frames {
                self.slider_frames[s]
            } else {
                sl.path.frame(t)
            };
            let e = self.slider_dir[s];
            let g = self.mech.gravity;
            r[i] += sl.mass * (self.ydd[i] + e[0] * (fs.origin_acc[0] - g[0]) + e[1] * (fs.origin_acc[1] - g[1]));
        }
        // Clearance joints: the force on the journal is external (moved to the left: minus).
        let fresh = std::mem::take(&mut self.jstate_fresh);
        for j in 0..self.mech.joints.len() {
            let (q, qd) = if fresh {
                self.jstate[j]
            } else {
                self.joint_state(j, &self.y, &self.yd)
            };
            let f = self.contact[j].force(q, qd);
            self.apply_joint_force(j, [-f[0], -f[1]], &mut r);
        }
        if self.friction {
            self.apply_friction(_h, &mut r);
        }
        self.lane_vectors = Some(qs);
        self.r = r;
    }
}
