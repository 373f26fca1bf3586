"""An independent oracle of the engine's beam matrices: the closed forms of a straight
Euler-Bernoulli link in numpy (``tests/test_energy.py`` checks :meth:`flexclear.Model.matrices`
against them; the engine integrates its element matrices by quadrature in Rust)."""

from __future__ import annotations

import numpy as np


def link_matrices(
    length: float,
    elements: int,
    youngs_modulus: float,
    density: float,
    area: float,
    inertia: float,
    eta: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(M, K, C)``: consistent mass (no rotary inertia), linear stiffness and Kelvin-Voigt
    damping of a straight link of ``elements`` equal Euler-Bernoulli elements, in closed form
    (Przemieniecki 1968; DOFs ``[u, v, theta]`` per node, link frame)."""
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
    return M, K, (eta / youngs_modulus) * K
