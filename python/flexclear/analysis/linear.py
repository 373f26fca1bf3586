"""Linear algebra of one straight link in numpy: the beam matrices of ``rust/element/beam.rs`` in
closed form (docs/method.md section 2), assembled for a chain of equal elements, and the energy of a
state. Used by the stability theory (:mod:`flexclear.analysis.stability`) and the energy checks
(:mod:`flexclear.analysis.accuracy`, tests); the engine itself never calls this.

DOF order: ``[u, v, theta]`` per node, link frame (m, m, rad), nodes 0..elements.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class LinkMatrices:
    """Assembled matrices of one link: mass ``M`` (kg), stiffness ``K1`` (N/m) and material damping
    ``C = (eta/E) K1`` (N s/m), each ``3 (elements + 1)`` square."""

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray


def link_matrices(
    length: float,
    elements: int,
    youngs_modulus: float,
    density: float,
    area: float,
    inertia: float,
    eta: float = 0.0,
) -> LinkMatrices:
    """Consistent mass (no rotary inertia), linear stiffness and Kelvin-Voigt damping of a
    straight link of ``elements`` equal Euler-Bernoulli elements (closed forms; the Rust tests
    check the engine's quadrature against the same forms)."""
    n = 3 * (elements + 1)
    le = length / elements
    ra, ea, ei = density * area, youngs_modulus * area, youngs_modulus * inertia
    me = np.zeros((6, 6))
    ke = np.zeros((6, 6))
    ax = [0, 3]
    me[np.ix_(ax, ax)] = ra * le / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
    ke[np.ix_(ax, ax)] = ea / le * np.array([[1.0, -1.0], [-1.0, 1.0]])
    tr = [1, 2, 4, 5]
    l_ = le
    me[np.ix_(tr, tr)] = (
        ra
        * le
        / 420
        * np.array(
            [
                [156, 22 * l_, 54, -13 * l_],
                [22 * l_, 4 * l_**2, 13 * l_, -3 * l_**2],
                [54, 13 * l_, 156, -22 * l_],
                [-13 * l_, -3 * l_**2, -22 * l_, 4 * l_**2],
            ]
        )
    )
    ke[np.ix_(tr, tr)] = (
        ei
        / le**3
        * np.array(
            [
                [12, 6 * l_, -12, 6 * l_],
                [6 * l_, 4 * l_**2, -6 * l_, 2 * l_**2],
                [-12, -6 * l_, 12, -6 * l_],
                [6 * l_, 2 * l_**2, -6 * l_, 4 * l_**2],
            ]
        )
    )
    M = np.zeros((n, n))
    K = np.zeros((n, n))
    for e in range(elements):
        s = slice(3 * e, 3 * e + 6)
        M[s, s] += me
        K[s, s] += ke
    return LinkMatrices(M, K, (eta / youngs_modulus) * K)


def slider_yoke_matrices(model) -> LinkMatrices:
    """The matrices of the slider of a :func:`flexclear.scenes.slider_yoke` model (from its
    ``parameters``)."""
    p = model.parameters
    return link_matrices(
        p["length"], p["elements"], p["youngs_modulus"], p["density"], p["area"], p["inertia"], p["eta"]
    )


def newmark_velocities(u: np.ndarray, v0: np.ndarray, dt: float) -> np.ndarray:
    """Velocities of a run from its displacement history ``u`` (steps x DOFs, every step) under
    average-acceleration Newmark, which gives ``u_{n+1} - u_n = dt (v_n + v_{n+1}) / 2`` exactly:
    ``v_{n+1} = 2 (u_{n+1} - u_n) / dt - v_n`` from ``v_0 = v0``."""
    v = np.empty_like(u)
    v[0] = v0
    du = 2.0 * np.diff(u, axis=0) / dt
    for i in range(1, u.shape[0]):
        v[i] = du[i - 1] - v[i - 1]
    return v


def mechanical_energy(mats: LinkMatrices, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Kinetic plus strain energy, J, of states ``u``, ``v`` (one per row, or a single vector)."""
    u2 = np.atleast_2d(u)
    v2 = np.atleast_2d(v)
    ke = 0.5 * np.einsum("ij,jk,ik->i", v2, mats.M, v2)
    pe = 0.5 * np.einsum("ij,jk,ik->i", u2, mats.K, u2)
    out = ke + pe
    return out if np.ndim(u) > 1 else out[0]


def contact_energy(penetration: np.ndarray, stiffness: float) -> np.ndarray:
    """Potential of the spring-dashpot bearing, ``K_B max(delta, 0)^2 / 2``, J."""
    d = np.maximum(np.asarray(penetration, dtype=float), 0.0)
    return 0.5 * stiffness * d * d


__all__ = [
    "LinkMatrices",
    "contact_energy",
    "link_matrices",
    "mechanical_energy",
    "newmark_velocities",
    "slider_yoke_matrices",
]
