//! The step's Jacobian (the effective matrix `M + gamma h C + beta h^2 K` with its moving-frame and
//! geometric terms): whether it changed since the last factorization, its assembly into the band
//! and its factorization.

use super::*;

impl<'a> NewtonRun<'a> {
    /// Builds the signature of the Jacobian and returns true when it differs from the factorized
    /// one (or, with `geometric`, when a link carries geometric terms: their axial forces move
    /// with every step).
    pub(super) fn jacobian_changed(&mut self, h: f64, geometric: bool) -> bool {
        let mut s = std::mem::take(&mut self.sig_new);
        self.frame_signature(h, &mut s);
        self.frame_sig_len = s.len();
        if self.implicit_contact {
            for (k, c) in &self.contact_tan {
                s.extend([k[0][0], k[0][1], k[1][0], k[1][1], c[0][0], c[0][1], c[1][0], c[1][1]]);
            }
        } else if !matches!(self.settings.coupling, Coupling::Force) {
            for c in &self.contact {
                s.extend([
                    c.k[0][0], c.k[0][1], c.k[1][0], c.k[1][1], c.c[0][0], c.c[0][1], c.c[1][0], c.c[1][1],
                ]);
            }
        }
        if self.friction {
            s.extend(self.fric.iter().flat_map(|f| [f.kf, f.kn]));
        }
        let fl = self.frame_sig_len;
        let changed = if self.signature.len() != s.len() {
            true
        } else if s[fl..] != self.signature[fl..] {
            // the contact or friction terms moved: the whole Jacobian again
            true
        } else {
            let frame_moved = (geometric && self.nonlinear_geometric) || s[..fl] != self.signature[..fl];
            if frame_moved && geometric && self.may_reuse(s[0] == self.signature[0]) {
                // the first iteration of a step on the factor of an earlier one
                self.reusing = true;
                false
            } else {
                // later iterations on a reused factor look at the contact part only
                frame_moved && !self.reusing
            }
        };
        self.sig_new = s;
        changed
    }

    /// Whether the step being started may solve with the factor of an earlier step
    /// ([`NewtonSettings::jacobian_age`](crate::run::NewtonSettings::jacobian_age)): the same
    /// step size (`same_step`), younger than the age limit, the last step converged within
    /// [`JACOBIAN_REUSE_ITERATIONS`] iterations, and not a step redone on the whole Jacobian.
    pub(super) fn may_reuse(&self, same_step: bool) -> bool {
        same_step
            && !self.direct
            && self.reuse_ok
            && self.steps_begun - self.factor_made < u64::from(self.settings.newton.jacobian_age)
    }

    /// The part of the Jacobian's signature that does not depend on the contact (the step `h`,
    /// s, and the frame rates, accelerations and angles the element terms use), into `s`
    /// (cleared first).
    pub(super) fn frame_signature(&self, h: f64, s: &mut Vec<f64>) {
        s.clear();
        s.push(h);
        for (li, (ld, f)) in self.links.iter().zip(&self.frames).enumerate() {
            if ld.active.coriolis || ld.active.coupling || ld.active.transformed {
                s.push(f.rate);
                s.push(f.accel);
            }
            if ld.active.transformed {
                s.push(f.angle);
            }
            if ld.rigid_moment.is_some() {
                s.push(self.a_ref(li, 0.0)[0]);
            }
        }
    }

    /// A singular pivot of the band LU with the unknown named (link, node and direction).
    pub(super) fn name_pivot(&self, e: Error) -> Error {
        match e {
            Error::Singular { what, index, .. } => Error::Singular {
                dof: self.describe(index),
                what,
                index,
            },
            e => e,
        }
    }

    /// Assembles and factorizes the Jacobian `d r / d a` at the current iterate.
    pub(super) fn factorize(&mut self, h: f64) -> Result<()> {
        std::mem::swap(&mut self.signature, &mut self.sig_new);
        self.factor_made = self.steps_begun;
        self.reusing = false;
        let (bh2, gh) = self.settings.newmark.coefficients(h);
        let mut lu = std::mem::replace(&mut self.lu, BandLu::new(0, 0));
        self.assemble(bh2, gh, &mut lu, true, true);
        let what = if h == 0.0 {
            "mass matrix of the mechanism (with the transforms)"
        } else {
            "effective matrix of the mechanism"
        };
        let res = lu.factorize(what);
        self.lu = lu;
        self.stats.factorizations += 1;
        res.map_err(|e| self.name_pivot(e))
    }

    /// The constant and axial-force parts of the Jacobian of an element of link `li` on its own
    /// unknowns (`T = I`): `base = M + gh C0 + bh2 K0` with the frame's rate and acceleration
    /// (`C0 = D1 + 2 w G`, `K0 = K1 + a G - w^2 MT`, each term as the link carries it) and `geo =
    /// bh2 (K2 + K3) + gh eta K2`, so that the element's is `base + fax geo` at axial force `fax`
    /// (N) plus the tangent of the axial force.
    #[inline(always)]
    fn link_jacobian_terms(&self, li: usize, bh2: f64, gh: f64) -> (Mat6, Mat6) {
        let ld = &self.links[li];
        let f = &self.frames[li];
        let mut base = ld.m + ld.d1 * gh + ld.k1 * bh2;
        let mut g_coef = 0.0;
        if ld.active.coriolis {
            g_coef += 2.0 * f.rate * gh;
        }
        if ld.active.coupling {
            g_coef += f.accel * bh2;
            base -= ld.mt * (f.rate * f.rate * bh2);
        }
        if g_coef != 0.0 {
            base += ld.g * g_coef;
        }
        let geo = if ld.active.geometric {
            ld.k23 * bh2 + ld.k2u * (ld.eta_e * gh)
        } else {
            Mat6::zeros()
        };
        (base, geo)
    }

    /// Assembles `A + gh B + bh2 K` into `lu`, where the Jacobian of the residual with respect
    /// to the accelerations is that with `gh = gamma dt`, `bh2 = beta dt^2`.
    ///
    /// With `tangent` (the step Jacobian), `K` is the tangent: it includes the dependence of the
    /// axial force in K2, K3, D2 on the axial displacements, `(K23 Q + D2 Qd) dF/dQ`, and, with
    /// implicit contact, the tangent of the contact force instead of its secant `kappa K_B`.
    /// Without (the linearization), `K` holds the secant terms at the state's axial forces.
    /// Without `contacts`, the clearance joints' terms are left out (the constant-rate stepper's
    /// contact-free Jacobian).
    pub(super) fn assemble(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has AVX2 and FMA (`linalg::avx2_fma_available`)
            return unsafe { self.assemble_avx2(bh2, gh, lu, tangent, contacts) };
        }
        self.assemble_body(bh2, gh, lu, tangent, contacts)
    }

    /// [`Self::assemble`] compiled with AVX2 enabled: bitwise the baseline's.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn assemble_avx2(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        self.assemble_body(bh2, gh, lu, tangent, contacts)
    }

    #[inline(always)]
    fn assemble_body(&self, bh2: f64, gh: f64, lu: &mut BandLu, tangent: bool, contacts: bool) {
        lu.clear();
        for li in 0..self.links.len() {
            let ld = &self.links[li];
            // The element Jacobian of a link is an affine function of a few scalars: with the
            // link's terms combined once here, an element on its own unknowns (T = I) takes
            // `base + fax geo` and the axial-force tangent's two columns, no 6 x 6 product.
            let (base, geo) = self.link_jacobian_terms(li, bh2, gh);
            let rigid_kk = ld.rigid_moment.map(|mc| -mc * self.a_ref(li, 0.0)[0] * bh2);
            let mut prev = self.nt(li, 0);
            // the nodes' local states (the axial forces' inputs), each node's once
            let local_state = |nt: &NodeT| {
                if ld.active.geometric {
                    Self::local(nt, &self.y, &self.yd, &self.ydd)
                } else {
                    [[0.0; 3]; 3]
                }
            };
            let mut wprev = local_state(prev);
            for e in 0..self.mech.links[li].section.elements {
                let next = self.nt(li, e + 1);
                let wnext = local_state(next);
                let (w0, w1) = (wprev, wnext);
                wprev = wnext;
                if let Some(pos) = &self.elem_pos[li][e] {
                    let mut je = base;
                    if ld.active.geometric {
                        let fax = ld.ea_l * (w1[0][0] - w0[0][0]);
                        je += geo * fax;
                        if tangent {
                            // d/dQ of F(Q) (K23 Q + D2 Qd), F = EA/l (u2 - u1): bh2 g dF/dQ^T,
                            // non-zero in the columns of u1 and u2 only
                            let (q, qd) = (element_vec(&w0, &w1, 0), element_vec(&w0, &w1, 1));
                            let g = ld.k23 * q + ld.k2u * (qd * ld.eta_e);
                            let s = ld.ea_l * bh2;
                            for r in 0..6 {
                                je[(r, 0)] -= s * g[r];
                                je[(r, 3)] += s * g[r];
                            }
                        }
                    }
                    if let Some(v) = rigid_kk {
                        je[(2, 2)] += v;
                    }
                    for (&p, &v) in pos.iter().zip(je.as_slice()) {
                        if p != NONE && v != 0.0 {
                            lu.add_at(p, v);
                        }
                    }
                    prev = next;
                    continue;
                }
                let mut kg = None;
                let fax = if ld.active.geometric {
                    if tangent {
                        // d/dQ of F(Q) (K23 Q + D2 Qd), F = EA/l (u2 - u1): a rank-1 term.
                        let (q, qd) = (element_vec(&w0, &w1, 0), element_vec(&w0, &w1, 1));
                        let g = ld.k23 * q + ld.k2u * (qd * ld.eta_e);
                        let mut dfax = Vec6::zeros();
                        dfax[0] = -ld.ea_l;
                        dfax[3] = ld.ea_l;
                        kg = Some(g * dfax.transpose());
                    }
                    ld.ea_l * (w1[0][0] - w0[0][0])
                } else {
                    0.0
                };
                let (c, mut k) = self.element_ck(li, fax);
                if let Some(kg) = kg {
                    k += kg;
                }
                if let Some(mc) = ld.rigid_moment {
                    k[(2, 2)] -= mc * self.a_ref(li, 0.0)[0];
                }
                let idx = [
                    prev.idx[0],
                    prev.idx[1],
                    prev.idx[2],
                    next.idx[0],
                    next.idx[1],
                    next.idx[2],
                ];
                // T^T (M Ta + C Tv + bh2 K T) with T = diag(T0, T1) block by block: a node on
                // its own unknowns has T = I, Ta = I, Tv = gh I
                let mut x = Mat6::zeros();
                for (o, nt) in [(0, &prev), (3, &next)] {
                    if nt.plain {
                        for r in 0..6 {
                            for cc in o..o + 3 {
                                x[(r, cc)] = ld.m[(r, cc)] + gh * c[(r, cc)] + bh2 * k[(r, cc)];
                            }
                        }
                        continue;
                    }
                    for cc in 0..3 {
                        let ta = [0, 1, 2].map(|q| nt.t[q][cc] + 2.0 * gh * nt.td[q][cc] + bh2 * nt.tdd[q][cc]);
                        let tv = [0, 1, 2].map(|q| gh * nt.t[q][cc] + bh2 * nt.td[q][cc]);
                        let tk = [0, 1, 2].map(|q| bh2 * nt.t[q][cc]);
                        for r in 0..6 {
                            let mut v = 0.0;
                            for q in 0..3 {
                                v += ld.m[(r, o + q)] * ta[q] + c[(r, o + q)] * tv[q] + k[(r, o + q)] * tk[q];
                            }
                            x[(r, o + cc)] = v;
                        }
                    }
                }
                let mut je = x;
                for (o, nt) in [(0, &prev), (3, &next)] {
                    if nt.plain {
                        continue;
                    }
                    for cc in 0..6 {
                        for r in 0..3 {
                            je[(o + r, cc)] = (0..3).map(|q| nt.t[q][r] * x[(o + q, cc)]).sum();
                        }
                    }
                }
                for a in 0..6 {
                    if idx[a] == NONE {
                        continue;
                    }
                    for b in 0..6 {
                        if idx[b] != NONE && je[(a, b)] != 0.0 {
                            lu.add(idx[a], idx[b], je[(a, b)]);
                        }
                    }
                }
                prev = next;
            }
            // Point masses: m [ (T + 2 gh Td + bh2 Tdd) + 2 om S (gh T + bh2 Td) + (al S - om^2) bh2 T ].
            let f = self.frames[li];
            for nd in 0..ld.nodes.len() {
                let m = ld.point_mass[nd];
                if m == 0.0 {
                    continue;
                }
                let nt = self.nt(li, nd);
                let (om, al) = (f.rate, f.accel);
                let mut blk = [[0.0; 3]; 2];
                for c in 0..3 {
                    let ta = [0, 1].map(|r| nt.t[r][c] + 2.0 * gh * nt.td[r][c] + bh2 * nt.tdd[r][c]);
                    let tv = [0, 1].map(|r| gh * nt.t[r][c] + bh2 * nt.td[r][c]);
                    let tk = [0, 1].map(|r| bh2 * nt.t[r][c]);
                    blk[0][c] = m * (ta[0] - 2.0 * om * tv[1] - al * tk[1] - om * om * tk[0]);
                    blk[1][c] = m * (ta[1] + 2.0 * om * tv[0] + al * tk[0] - om * om * tk[1]);
                }
                for a in 0..3 {
                    if nt.idx[a] == NONE {
                        continue;
                    }
                    for c in 0..3 {
                        if nt.idx[c] == NONE {
                            continue;
                        }
                        let v = nt.t[0][a] * blk[0][c] + nt.t[1][a] * blk[1][c];
                        if v != 0.0 {
                            lu.add(nt.idx[a], nt.idx[c], v);
                        }
                    }
                }
            }
        }
        for (s, sl) in self.mech.sliders.iter().enumerate() {
            let i = self.slider_dof[s];
            if i != NONE && sl.mass > 0.0 {
                lu.add(i, i, sl.mass);
            }
        }
        if contacts && !matches!(self.settings.coupling, Coupling::Force) {
            for j in 0..self.mech.joints.len() {
                let mut ct = self.contact[j];
                if tangent && self.implicit_contact {
                    (ct.k, ct.c) = self.contact_tan[j];
                    if ct.k == [[0.0; 2]; 2] && ct.c == [[0.0; 2]; 2] {
                        continue;
                    }
                } else if !ct.active() {
                    continue;
                }
                let jt = &self.mech.joints[j];
                let a = self.endpoint_jac(&jt.journal);
                let b = self
                    .endpoint_jac(&jt.bearing)
                    .map(|(i, c, v)| (i, [-c[0], -c[1]], [-v[0], -v[1]]));
                let all = [a[0], a[1], a[2], b[0], b[1], b[2]];
                for (i, gi, _) in all {
                    if i == NONE {
                        continue;
                    }
                    for (jj, gj, vj) in all {
                        if jj == NONE {
                            continue;
                        }
                        // d(-f)/da with f = -k q - c qd: k bh2 G + c (gh G + bh2 Gv)
                        let mut v = 0.0;
                        for p in 0..2 {
                            for qq in 0..2 {
                                v += gi[p] * (ct.k[p][qq] * bh2 * gj[qq] + ct.c[p][qq] * (gh * gj[qq] + bh2 * vj[qq]));
                            }
                        }
                        if v != 0.0 {
                            lu.add(i, jj, v);
                        }
                    }
                }
            }
        }
        if contacts && tangent && self.friction {
            self.assemble_friction(bh2, gh, lu);
        }
    }
}
