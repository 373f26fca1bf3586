//! The planar 2-node beam element of docs/method.md section 2 (Hong & Kim 1993, eq. 9).
//!
//! Nodal vector in the element frame: `Q = [u1, v1, th1, u2, v2, th2]` (m, m, rad). Axial shape
//! functions are linear, transverse ones cubic Hermite. Every matrix is integrated with 4-point
//! Gauss-Legendre quadrature, exact for the polynomial degrees involved (at most 6); the tests
//! compare them with the textbook closed forms.

use nalgebra::{SMatrix, SVector};

/// 6 x 6 element matrix.
pub type Mat6 = SMatrix<f64, 6, 6>;
/// Element vector of 6 entries.
pub type Vec6 = SVector<f64, 6>;

/// Gauss-Legendre points on [0, 1] and weights (4 points, exact to degree 7).
const GAUSS: [(f64, f64); 4] = {
    const A: f64 = 0.339_981_043_584_856_3;
    const B: f64 = 0.861_136_311_594_052_6;
    const WA: f64 = 0.652_145_154_862_546_1;
    const WB: f64 = 0.347_854_845_137_453_9;
    [
        (0.5 * (1.0 - B), 0.5 * WB),
        (0.5 * (1.0 - A), 0.5 * WA),
        (0.5 * (1.0 + A), 0.5 * WA),
        (0.5 * (1.0 + B), 0.5 * WB),
    ]
};

/// Shape functions and their x-derivatives at `xi` for an element of length `l`.
struct Shape {
    nu: Vec6,
    nv: Vec6,
    dnu: Vec6,
    dnv: Vec6,
    ddnv: Vec6,
}

fn shape(xi: f64, l: f64) -> Shape {
    let x2 = xi * xi;
    let x3 = x2 * xi;
    Shape {
        nu: Vec6::new(1.0 - xi, 0.0, 0.0, xi, 0.0, 0.0),
        nv: Vec6::new(
            0.0,
            1.0 - 3.0 * x2 + 2.0 * x3,
            l * (xi - 2.0 * x2 + x3),
            0.0,
            3.0 * x2 - 2.0 * x3,
            l * (x3 - x2),
        ),
        dnu: Vec6::new(-1.0 / l, 0.0, 0.0, 1.0 / l, 0.0, 0.0),
        dnv: Vec6::new(
            0.0,
            (-6.0 * xi + 6.0 * x2) / l,
            1.0 - 4.0 * xi + 3.0 * x2,
            0.0,
            (6.0 * xi - 6.0 * x2) / l,
            3.0 * x2 - 2.0 * xi,
        ),
        ddnv: Vec6::new(
            0.0,
            (-6.0 + 12.0 * xi) / (l * l),
            (-4.0 + 6.0 * xi) / l,
            0.0,
            (6.0 - 12.0 * xi) / (l * l),
            (6.0 * xi - 2.0) / l,
        ),
    }
}

/// Integrates `f(shape) * l` over the element: `int_0^l f dx`.
fn integrate<T, F>(l: f64, zero: T, f: F) -> T
where
    T: std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    F: Fn(&Shape, f64) -> T,
{
    GAUSS
        .iter()
        .fold(zero, |acc, &(xi, w)| acc + f(&shape(xi, l), xi) * (w * l))
}

/// One beam element: length and section/material data (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamElement {
    /// Length l, m.
    pub length: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Cross-section area A, m^2.
    pub area: f64,
    /// Second moment of area I, m^4.
    pub inertia: f64,
    /// Kelvin-Voigt material damping eta, Pa s (the paper's C1); D1 = (eta/E) K1.
    pub damping: f64,
    /// Include the rotary inertia `rho I int Nv'^T Nv' dx` in the mass matrix.
    pub rotary_inertia: bool,
}

impl BeamElement {
    /// Consistent mass matrix `M = rho A int N^T N dx` (+ rotary inertia when enabled), kg.
    pub fn mass(&self) -> Mat6 {
        let ra = self.density * self.area;
        let ri = if self.rotary_inertia {
            self.density * self.inertia
        } else {
            0.0
        };
        integrate(self.length, Mat6::zeros(), |s, _| {
            (s.nu * s.nu.transpose() + s.nv * s.nv.transpose()) * ra + s.dnv * s.dnv.transpose() * ri
        })
    }

    /// Linear stiffness `K1 = EA int Nu'^T Nu' dx + EI int Nv''^T Nv'' dx`, N/m.
    pub fn stiffness(&self) -> Mat6 {
        let ea = self.youngs_modulus * self.area;
        let ei = self.youngs_modulus * self.inertia;
        integrate(self.length, Mat6::zeros(), |s, _| {
            s.dnu * s.dnu.transpose() * ea + s.ddnv * s.ddnv.transpose() * ei
        })
    }

    /// Material damping `D1 = (eta/E) K1`, N s/m.
    pub fn damping_matrix(&self) -> Mat6 {
        self.stiffness() * (self.damping / self.youngs_modulus)
    }

    /// Linear axial force `F = EA (u2 - u1)/l` of the nodal vector `q`, N (tension positive).
    pub fn axial_force(&self, q: &Vec6) -> f64 {
        self.youngs_modulus * self.area * (q[3] - q[0]) / self.length
    }

    /// Geometric stiffness `K2 = F int Nv'^T Nv' dx` for axial force `f` (N); the standard
    /// `F/(30 l)` matrix.
    pub fn geometric_stiffness(&self, f: f64) -> Mat6 {
        integrate(self.length, Mat6::zeros(), |s, _| s.dnv * s.dnv.transpose() * f)
    }

    /// The paper's axial-force stiffness on the axial DOFs, `K3 = F int Nu'^T Nu' dx` (N/m). It is
    /// not implied by the strain measure (which has no `u'^2/2` term): the paper's own term.
    pub fn axial_force_stiffness(&self, f: f64) -> Mat6 {
        integrate(self.length, Mat6::zeros(), |s, _| s.dnu * s.dnu.transpose() * f)
    }

    /// Nonlinear material damping `D2 = (eta/E) K2` (our reading of the paper's eq. 9f), N s/m.
    pub fn geometric_damping(&self, f: f64) -> Mat6 {
        self.geometric_stiffness(f) * (self.damping / self.youngs_modulus)
    }

    /// `rho A int N^T S N dx`, `S = [[0,-1],[1,0]]`: skew-symmetric, kg. The Coriolis matrix is
    /// `M_COR = 2 phidot` times this and `M_IC = phiddot` times this `- phidot^2 M_trans`.
    pub fn skew_mass(&self) -> Mat6 {
        let ra = self.density * self.area;
        integrate(self.length, Mat6::zeros(), |s, _| {
            (s.nv * s.nu.transpose() - s.nu * s.nv.transpose()) * ra
        })
    }

    /// Translational part of the mass, `rho A int N^T N dx` (no rotary inertia), kg.
    pub fn translational_mass(&self) -> Mat6 {
        let ra = self.density * self.area;
        integrate(self.length, Mat6::zeros(), |s, _| {
            s.nu * s.nu.transpose() + s.nv * s.nv.transpose()
        }) * ra
    }

    /// Coriolis matrix `M_COR = 2 phidot rho A int N^T S N dx` for frame rate `phidot` (rad/s).
    pub fn coriolis(&self, phidot: f64) -> Mat6 {
        self.skew_mass() * (2.0 * phidot)
    }

    /// Rigid/elastic coupling `M_IC = rho A int N^T (phiddot S - phidot^2 I) N dx`, N/m.
    pub fn inertia_coupling(&self, phidot: f64, phiddot: f64) -> Mat6 {
        self.skew_mass() * phiddot - self.translational_mass() * (phidot * phidot)
    }

    /// Load vectors of the nominal-motion inertia `M_R a_R`, for an element whose first node sits
    /// at `x0` (m) along the link: returns `(bx, by, bxx, byx)` with `bx = rho A int Nu^T dx`,
    /// `by = rho A int Nv^T dx`, `bxx = rho A int Nu^T x dx`, `byx = rho A int Nv^T x dx` (kg,
    /// kg m). With `a_R = (a0x - phidot^2 x, a0y + phiddot x)` in the link frame,
    /// `M_R a_R = a0x bx + a0y by - phidot^2 bxx + phiddot byx`.
    pub fn inertia_load_vectors(&self, x0: f64) -> [Vec6; 4] {
        let ra = self.density * self.area;
        let l = self.length;
        let z = [Vec6::zeros(); 4];
        let v = GAUSS.iter().fold(z, |acc, &(xi, w)| {
            let s = shape(xi, l);
            let x = x0 + xi * l;
            let wl = w * l * ra;
            [
                acc[0] + s.nu * wl,
                acc[1] + s.nv * wl,
                acc[2] + s.nu * (wl * x),
                acc[3] + s.nv * (wl * x),
            ]
        });
        v
    }
    /// Transverse displacement `v(xi l)` inside the element for nodal vector `q`, m.
    pub fn transverse_at(&self, xi: f64, q: &Vec6) -> f64 {
        shape(xi, self.length).nv.dot(q)
    }

    /// Kinetic energy (J) and angular momentum about the frame origin (kg m^2/s) of the element's
    /// distributed mass for an element whose first node sits at `x0` (m) in a frame moving with
    /// origin velocity `v0` (m/s, link-frame components) and rate `rate` (rad/s), with elastic
    /// displacement `q` and velocity `qd` (link frame). The absolute velocity of the point at
    /// `x` is `v0 + rate S (r0 + w) + wd`, `r0 = (x, 0)`; quadrature is exact (degree 6).
    pub fn kinetic_terms(&self, x0: f64, q: &Vec6, qd: &Vec6, v0: [f64; 2], rate: f64) -> (f64, f64) {
        let ra = self.density * self.area;
        let l = self.length;
        GAUSS.iter().fold((0.0, 0.0), |(e, h), &(xi, w)| {
            let s = shape(xi, l);
            let x = x0 + xi * l;
            let (wu, wv) = (s.nu.dot(q), s.nv.dot(q));
            let (du, dv) = (s.nu.dot(qd), s.nv.dot(qd));
            let (px, py) = (x + wu, wv);
            let vx = v0[0] - rate * py + du;
            let vy = v0[1] + rate * px + dv;
            let dm = ra * w * l;
            (e + 0.5 * dm * (vx * vx + vy * vy), h + dm * (px * vy - py * vx))
        })
    }
}
