"""Reference histories of Simeon's flexible slider-crank (Test Set for IVP solvers, "crank").

Model: B. Simeon, "Modelling a flexible slider crank mechanism by a mixed system of DAEs and
PDEs", Math. Modelling of Systems 2 (1996) 1-18; as published in the Test Set for IVP Solvers
(F. Mazzia, C. Magherini et al., University of Bari, problem "Slider Crank", file crank.f,
B. Simeon 18.2.98, rev. crank.F 1.2 2006/10/02). The equations below are re-expressed in numpy
from that description (linear stiffness, no damping: the test set's defaults ipar = (0, 0)):

* coordinates p = (phi1, phi2, x3): crank angle, angle of the rod chord A->B, slider position;
  q = (q1, q2, q3, q4): rod elastic coordinates in the chord frame (origin at the crank pin A,
  x axis along the chord, y axis 90 deg counter-clockwise from it):
  transverse v(x) = q1 sin(pi x/L) + q2 sin(2 pi x/L),
  axial u(x) = q3 4 xi (1 - xi) + q4 xi (2 xi - 1), xi = x/L (q4 = axial displacement at B);
* constraints: slider on the x axis, phi1 = Omega t (the crank is driven at exactly constant
  speed, as in flexclear's kineto-elastodynamics);
* data: crank L1 = 0.15 m, rod L2 = 0.30 m, 8 x 8 mm steel (E = 2e11 Pa, rho = 7870 kg/m^3),
  slider mass 0.075552 kg, Omega = 150 rad/s, no gravity. The rod matrices use the published
  pi = 3.1415927. The published axial mass block is rho A L [[8, 1], [1, 2]], 15 times the
  consistent mass of the quadratic axial ansatz (rho A L / 15 [[8, 1], [1, 2]]); it is kept as
  published (``axial_mass_factor`` = 1); ``axial_mass_factor = 1/15`` gives the consistent model.

The index-2 DAE of the test set is integrated here as the equivalent index-1 system (accelerations
and multipliers from the augmented system [[M, G^T], [G, 0]]) with scipy's DOP853 at rtol 1e-13,
from the test set's initial values (subroutine init, "close to smooth motion"), with the
velocities projected onto the velocity constraints (the published values are rounded to 9 digits;
they miss the velocity constraint by 1.2e-8 m/s; a mass-weighted projection or none moves q1(0.1 s) in
the 7th digit). The port reproduces the published initial accelerations (phi2'' to 16 digits) and
the published reference solution at t = 0.1 s: positions to >= 5.4 significant digits, q1 and q2
to 6.6-6.7. The axial velocities and accelerations of the published solution (q3', q4', q3'',
q4'', and through the constraint phi2'' and q2'') agree only to 2-3 digits: they differ by a
small oscillation in the second axial mode (22,606 rad/s with the published axial mass; velocity
amplitude ~6e-7 m/s) that neither the projection, the tolerance (DOP853
1e-12 / 1e-13, Radau 1e-6) nor the integrator changes here; we take it to be the accuracy of the
published reference in those stiff components. The damped (ipar(2) = 1) or nonlinear
(ipar(1) = 1) variants of the model do not match the reference (q1 wrong in the first digit).

``SimeonCrank(modes=N)`` extends the Ritz model to N transverse sine modes (closed-form
integrals) to measure the modal truncation of the published two-mode model.

Run ``python tests/data/simeon_slider_crank.py`` (about 5 minutes) to check the port against the
published reference solution at t = 0.1 s (subroutine solut) and to rewrite
``simeon_slider_crank.csv`` and ``simeon_slider_crank_t01.csv``.
"""

from __future__ import annotations

import pathlib

import numpy as np

# Data set of the test set.
M1, M2, M3 = 0.36, 0.151104, 0.075552
L1, L2 = 0.15, 0.30
J1, J2 = 0.002727, 0.0045339259
PI_MODEL = 3.1415927
EE, BB, HH, RHO = 0.20e12, 0.0080, 0.0080, 7870.0
OMEGA = 150.0

# Test set initial values (subroutine init): positions, velocities.
Y0 = np.array(
    [
        0.0,
        0.0,
        0.450016933,
        0.0,
        0.0,
        0.103339863e-04,
        0.169327969e-04,
        0.150000000e03,
        -0.749957670e02,
        -0.268938672e-05,
        0.444896105,
        0.463434311e-02,
        -0.178591076e-05,
        -0.268938672e-05,
    ]
)

# Published reference solution at t = 0.1 s (subroutine solut): positions, velocities,
# accelerations of (phi1, phi2, x3, q1, q2, q3, q4), then the three multipliers.
REFERENCE_T01 = np.array(
    [
        1.500000000000000e01,
        -3.311734987910881e-01,
        1.697373326718410e-01,
        1.893192460247178e-04,
        2.375751865617931e-05,
        -5.323907988763734e-06,
        -8.363283141616840e-06,
        1.500000000000000e02,
        6.025346682645789e01,
        -8.753116989887888e00,
        -3.005536801092212e-02,
        -5.500488291932075e-03,
        4.978243404809343e-04,
        1.104933470696396e-03,
        0.0,
        6.488722210234531e03,
        2.167924253080623e03,
        3.391435115267547e01,
        1.699107480197843e-01,
        -1.415799354959001e00,
        9.903251655235532e-01,
        -6.232893262533717e01,
        -1.637910131687472e02,
        2.529853213732781e01,
    ]
)
NAMES = ["phi1", "phi2", "x3", "q1", "q2", "q3", "q4"]


class SimeonCrank:
    """Simeon's slider-crank: mass matrix, forces and constraints of the test set's model.

    ``modes`` transverse sine modes (2 in the published model; more are the same Ritz model
    extended, to measure the modal truncation), then the two axial coordinates (q3, q4 of the
    published model). The sine-mode integrals are evaluated in closed form with the published
    pi, so ``modes=2`` reproduces the published matrices.
    """

    def __init__(self, axial_mass_factor: float = 1.0, modes: int = 2):
        pi = PI_MODEL
        self.modes = nt = int(modes)
        self.n = n = nt + 2
        fm = RHO * BB * HH * L2  # rho A L
        fk = EE * BB * HH / L2  # E A / L
        fb = BB * HH * L2  # A L
        k = np.arange(1, nt + 1)
        kp = k * pi
        sgn = (-1.0) ** k
        i0 = (1.0 - sgn) / kp  # int_0^1 sin(k pi xi)
        i1 = -sgn / kp  # int_0^1 xi sin(k pi xi)
        i2 = -sgn / kp + 2.0 * (sgn - 1.0) / kp**3  # int_0^1 xi^2 sin(k pi xi)
        # Axial ansatz N3 = 4 xi (1 - xi) (mid-node), N4 = xi (2 xi - 1) (end node, q4 = u(L)).
        sv_n3 = 4.0 * (i1 - i2)  # int sin(k pi xi) N3
        sv_n4 = 2.0 * i2 - i1  # int sin(k pi xi) N4
        self.mq = np.zeros((n, n))
        self.mq[:nt, :nt] = 0.5 * fm * np.eye(nt)
        self.mq[nt:, nt:] = axial_mass_factor * fm * np.array([[8.0, 1.0], [1.0, 2.0]])
        self.kq = np.zeros((n, n))
        # E I (k pi / L)^4 L / 2 with I = B H^3 / 12.
        self.kq[:nt, :nt] = np.diag(fk * kp**4 / 24.0 * (HH / L2) ** 2)
        self.kq[nt:, nt:] = fk * np.array([[16.0, -8.0], [-8.0, 7.0]]) / 3.0
        # Skew coupling of transverse and axial velocities (Coriolis), without rho:
        # B[v_k, u_j] = -A L int N_vk N_uj.
        self.bq = np.zeros((n, n))
        self.bq[:nt, nt] = -fb * sv_n3
        self.bq[:nt, nt + 1] = -fb * sv_n4
        self.bq[nt:, :nt] = -self.bq[:nt, nt:].T
        # Shape-function integrals (without rho): c1 = int N_u, c2 = int N_v, c12 = int x N_u,
        # c21 = int x N_v.
        self.c1 = np.zeros(n)
        self.c1[nt:] = [fb * 2.0 / 3.0, fb / 6.0]
        self.c2 = np.zeros(n)
        self.c2[:nt] = fb * i0
        self.c12 = np.zeros(n)
        self.c12[nt:] = [L2 * fb / 3.0, L2 * fb / 6.0]
        self.c21 = np.zeros(n)
        self.c21[:nt] = L2 * fb * i1
        # Mid-span values of the transverse modes: v(L/2) = sum_k q_k sin(k pi / 2).
        self.mid = np.zeros(n)
        self.mid[:nt] = np.sin(k * np.pi / 2.0).round()

    def split(self, y: np.ndarray):
        """(p, q, p-dot, q-dot) of a state ``y`` = positions (3 + n), velocities (3 + n)."""
        nc = 3 + self.n
        return y[:3], y[3:nc], y[nc : nc + 3], y[nc + 3 : 2 * nc]

    def system(self, y: np.ndarray):
        """Mass matrix, force vector, constraint Jacobian and the velocity part of the
        acceleration constraints (G w + gamma = 0) at state ``y`` (positions, velocities)."""
        nc = 3 + self.n
        p, q, pd, qd = self.split(y)
        p1, p2 = p[0], p[1]
        v1, v2 = pd[0], pd[1]
        s1, c1, s2, c2 = np.sin(p1), np.cos(p1), np.sin(p2), np.cos(p2)
        s12, c12 = np.sin(p1 - p2), np.cos(p1 - p2)
        mqq = self.mq @ q
        am = np.zeros((nc, nc))
        am[0, 0] = J1 + M2 * L1 * L1
        am[0, 1] = 0.5 * L1 * L2 * M2 * c12 + RHO * L1 * (s12 * (self.c2 @ q) + c12 * (self.c1 @ q))
        am[1, 1] = J2 + q @ mqq + 2.0 * RHO * (self.c12 @ q)
        am[2, 2] = M3
        am[0, 3:] = RHO * L1 * (-s12 * self.c1 + c12 * self.c2)
        am[1, 3:] = RHO * self.c21 + RHO * (self.bq.T @ q)
        am[3:, 3:] = self.mq
        am = np.triu(am) + np.triu(am, 1).T
        f = np.zeros(nc)
        c1q, c2q = self.c1 @ q, self.c2 @ q
        c1qd, c2qd = self.c1 @ qd, self.c2 @ qd
        f[0] = (
            -0.5 * L1 * L2 * M2 * v2 * v2 * s12
            + RHO * L1 * v2 * v2 * (-s12 * c1q + c12 * c2q)
            - 2.0 * RHO * L1 * v2 * (c12 * c1qd + s12 * c2qd)
        )
        bqd = self.bq @ qd
        f[1] = (
            0.5 * L1 * L2 * M2 * v1 * v1 * s12
            + RHO * L1 * v1 * v1 * (s12 * c1q - c12 * c2q)
            - 2.0 * RHO * v2 * (self.c12 @ qd)
            - 2.0 * v2 * (qd @ mqq)
            - RHO * (qd @ bqd)
        )
        f[3:] = (
            v2 * v2 * mqq
            + RHO * (v2 * v2 * self.c12 + L1 * v1 * v1 * (c12 * self.c1 + s12 * self.c2) + 2.0 * v2 * bqd)
            - self.kq @ q
        )
        # The slider pin B is the rod end (L + q_end, 0) in the chord frame; q_end = u(L).
        lq = L2 + q[-1]
        g = np.zeros((3, nc))
        g[0, 0], g[0, 1], g[0, -1] = L1 * c1, lq * c2, s2
        g[1, 0], g[1, 1], g[1, 2], g[1, -1] = L1 * s1, lq * s2, 1.0, -c2
        g[2, 0] = 1.0
        gamma = np.array(
            [
                -L1 * s1 * v1 * v1 - lq * s2 * v2 * v2 + 2.0 * v2 * c2 * qd[-1],
                L1 * c1 * v1 * v1 + lq * c2 * v2 * v2 + 2.0 * v2 * s2 * qd[-1],
                0.0,
            ]
        )
        return am, f, g, gamma

    def accelerations(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations w (3 + n) and multipliers lambda (3): M w + G^T lambda = f, G w = -gamma."""
        am, f, g, gamma = self.system(y)
        nc = am.shape[0]
        a = np.zeros((nc + 3, nc + 3))
        a[:nc, :nc], a[:nc, nc:], a[nc:, :nc] = am, g.T, g
        sol = np.linalg.solve(a, np.concatenate([f, -gamma]))
        return sol[:nc], sol[nc:]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        w, _ = self.accelerations(y)
        return np.concatenate([y[3 + self.n :], w])

    def constraints(self, t: float, y: np.ndarray) -> np.ndarray:
        """Position and velocity constraint residuals (6)."""
        p, q, _, _ = self.split(y)
        lq = L2 + q[-1]
        pos = [
            L1 * np.sin(p[0]) + lq * np.sin(p[1]),
            p[2] - L1 * np.cos(p[0]) - lq * np.cos(p[1]),
            p[0] - OMEGA * t,
        ]
        _, _, g, _ = self.system(y)
        vel = g @ y[3 + self.n :] - np.array([0.0, 0.0, OMEGA])
        return np.concatenate([pos, vel])

    def midspan(self, y: np.ndarray) -> np.ndarray:
        """Transverse deflection at mid-length relative to the chord, v(L/2) (m), of states
        ``y`` (..., 2 (3 + n)); q1 for the published model (sin(pi) = 0)."""
        return y[..., 3 : 3 + self.n] @ self.mid


def initial_state(model: SimeonCrank) -> np.ndarray:
    """The test set's initial values (extra sine modes at rest), with the velocities projected
    (least change) onto the velocity constraints G v = (0, 0, Omega)."""
    nt = model.modes
    y = np.zeros(2 * (3 + model.n))
    for half in (0, 1):
        o, src = half * (3 + model.n), Y0[7 * half : 7 * half + 7]
        y[o : o + 3] = src[:3]
        y[o + 3 : o + 3 + min(nt, 2)] = src[3 : 3 + min(nt, 2)]
        y[o + 3 + nt : o + 5 + nt] = src[5:7]
    _, _, g, _ = model.system(y)
    v = y[3 + model.n :]
    r = g @ v - np.array([0.0, 0.0, OMEGA])
    v -= g.T @ np.linalg.solve(g @ g.T, r)
    return y


def integrate(
    t_end: float = 0.1,
    n_out: int = 10001,
    axial_mass_factor: float = 1.0,
    rtol: float = 1e-13,
    modes: int = 2,
):
    """Integrates the model from the test set's initial state; returns (t, y (n_out, 2 (3 + n)),
    model)."""
    from scipy.integrate import solve_ivp

    model = SimeonCrank(axial_mass_factor, modes)
    y0 = initial_state(model)
    t_eval = np.linspace(0.0, t_end, n_out)
    sol = solve_ivp(model.rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=1e-16, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.t, sol.y.T, model


def digits(value: float, reference: float) -> float:
    """Number of correct significant digits, -log10 of the relative error."""
    if value == reference:
        return 16.0
    return -np.log10(abs(value - reference) / max(abs(reference), 1e-300))


def main() -> None:
    here = pathlib.Path(__file__).resolve().parent
    t, y, model = integrate()
    yend = y[-1]
    w, lam = model.accelerations(yend)
    full = np.concatenate([yend, w, lam])
    labels = NAMES + ["v" + n for n in NAMES] + ["a" + n for n in NAMES] + ["lambda1", "lambda2", "lambda3"]
    print(f"{'component':>10} {'published t=0.1':>24} {'this port':>24} {'digits':>7}")
    dig = {}
    for lab, ref, val in zip(labels, REFERENCE_T01, full):
        dig[lab] = digits(val, ref)
        print(f"{lab:>10} {ref:24.16e} {val:24.16e} {dig[lab]:7.2f}")
    nonzero = [dig[lab] for lab, ref in zip(labels, REFERENCE_T01) if ref != 0.0]
    positions = [dig[lab] for lab in NAMES]
    print("min digits, positions:", min(positions), " all nonzero components:", min(nonzero))
    print("constraint residuals at 0.1 s:", model.constraints(t[-1], yend))
    mid = model.midspan(y)

    # Integration tolerance: a 10x looser run.
    _, y2, _ = integrate(rtol=1e-12)
    print("max |midspan(rtol 1e-13) - midspan(rtol 1e-12)|:", np.max(np.abs(mid - model.midspan(y2))))

    # Consistent axial mass (1/15 of the published block): how much the midspan moves.
    _, y3, m3 = integrate(axial_mass_factor=1.0 / 15.0)
    mid3 = m3.midspan(y3)
    print("consistent axial mass: max |d midspan| =", np.max(np.abs(mid3 - mid)), "of", np.max(np.abs(mid)))

    # Eight sine modes and the consistent axial mass: the converged Ritz model of the same rod.
    _, y8, m8 = integrate(axial_mass_factor=1.0 / 15.0, modes=8, rtol=1e-11)
    mid8 = m8.midspan(y8)
    print("8 sine modes, consistent axial mass: max |d midspan| =", np.max(np.abs(mid8 - mid)))

    keep = slice(None, None, 25)  # 401 rows, every 2.5e-5 s
    cols = [t[keep], mid[keep], mid3[keep], mid8[keep]] + [y[keep, k] for k in range(3, 7)]
    header = "\n".join(
        [
            "Flexible slider-crank of Simeon (1996): Test Set for IVP Solvers (F. Mazzia et al., Univ. of",
            "Bari), problem 'Slider Crank' (crank.f, B. Simeon 1998), linear stiffness, no damping.",
            "Crank 0.15 m driven at exactly 150 rad/s, rod 0.30 m 8x8 mm steel E = 2e11 Pa",
            "rho = 7870 kg/m^3, slider 0.075552 kg, no gravity. Rod: 2 transverse sine modes (q1, q2)",
            "and a quadratic axial ansatz (q3 mid-node, q4 = u(L)) in the chord frame A->B.",
            "Computed by integrating the published equations (tests/data/simeon_slider_crank.py: index-1",
            "form, scipy DOP853, rtol 1e-13) from the test set's initial values (subroutine init, the",
            "velocities projected onto the constraints: a 1.2e-8 m/s residual).",
            f"Check against the published reference solution at t = 0.1 s: q1 to {dig['q1']:.1f} significant",
            f"digits ({REFERENCE_T01[3]:.15e} m published, {yend[3]:.15e} m here), q2 to",
            f"{dig['q2']:.1f}, all positions to >= {min(positions):.1f}, all nonzero components to >= "
            f"{min(nonzero):.1f}",
            "(the axial velocities and accelerations of the reference differ by a small high-frequency",
            "axial oscillation; see simeon_slider_crank.py).",
            "midspan_m: v(L/2) relative to the chord = q1 (m; positive 90 deg counter-clockwise from A->B).",
            "midspan_axial15_m: the same with the consistent axial mass (the published block / 15).",
            "midspan_8modes_m: the same Ritz model with 8 transverse sine modes (modes 3-8 start at rest)",
            "and the consistent axial mass (rtol 1e-11): not published, the converged rod of the same model.",
            "columns: time_s, midspan_m, midspan_axial15_m, midspan_8modes_m, q1_m, q2_m, q3_m, q4_m",
        ]
    )
    np.savetxt(
        here / "simeon_slider_crank.csv",
        np.column_stack(cols),
        delimiter=",",
        header=header,
        fmt="%.12e",
        comments="# ",
    )
    labels_pub = NAMES + ["v" + n for n in NAMES]
    with open(here / "simeon_slider_crank_t01.csv", "w") as fh:
        fh.write(
            "# Published reference solution at t = 0.1 s of the Test Set for IVP Solvers problem\n"
            "# 'Slider Crank' (Simeon; crank.f, subroutine solut), positions and velocities of\n"
            "# (phi1 rad, phi2 rad, x3 m, q1..q4 m), and this port's values (simeon_slider_crank.py).\n"
            "# columns: name, published, port\n"
        )
        for lab, ref, val in zip(labels_pub, REFERENCE_T01, full):
            fh.write(f"{lab},{ref:.16e},{val:.16e}\n")


if __name__ == "__main__":
    main()
