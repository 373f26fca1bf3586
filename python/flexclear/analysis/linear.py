"""Linear algebra of a run: a link's matrices from the engine (:meth:`flexclear.Model.matrices`),
the velocities the Newmark recurrence implies, and the energy of a state. Used by the stability
theory (:mod:`flexclear.analysis.stability`) and the energy checks
(:mod:`flexclear.analysis.accuracy`, tests). The closed-form beam matrices these used to hold are
an independent oracle in ``tests/beam_oracle.py`` now.

DOF order: ``[u, v, theta]`` per node, link frame (m, m, rad), nodes 0..elements.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class LinkMatrices:
    """Matrices of one link: mass ``M`` (kg), stiffness ``K`` (N/m) and damping ``C`` (N s/m),
    each ``3 (elements + 1)`` square."""

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
    """The engine's consistent mass (no rotary inertia), linear stiffness and Kelvin-Voigt
    damping ``C = (eta / E) K`` of a straight link of ``elements`` equal Euler-Bernoulli elements:
    :meth:`flexclear.Model.matrices` of a model holding that link alone, translating."""
    from ..model import Model

    m = Model().add_body("ground")
    m.add_link(
        "link",
        length=length,
        elements=int(elements),
        youngs_modulus=youngs_modulus,
        density=density,
        area=area,
        inertia=inertia,
        damping=eta,
    )
    # a model needs its link held; the joint is open in the matrices and adds nothing to them
    m.add_joint("hold", "link", 0, body="ground", clearance=1.0, stiffness=1.0, damping=0.0)
    M, C, K = m.matrices()
    return LinkMatrices(M, K, C)


def slider_yoke_matrices(model) -> LinkMatrices:
    """The matrices of the slider of a :func:`flexclear.scenes.slider_yoke` model (the model's
    only link: its moving-frame unknowns are the slider's nodal DOFs)."""
    M, C, K = model.matrices()
    return LinkMatrices(M, K, C)


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
