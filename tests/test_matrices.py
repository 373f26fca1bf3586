"""Model.matrices against an independent oracle: the engine integrates its beam element matrices
by quadrature in Rust; tests/beam_oracle.py writes the closed forms in numpy. They agree to
round-off (1e-14 relative: a few ulps of the largest entry, summed over the assembly)."""

from __future__ import annotations

import flexclear as fc
import numpy as np
import pytest
from beam_oracle import link_matrices as oracle
from flexclear.analysis.linear import link_matrices


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize(
    "geometry",
    [
        (0.3, 8, 2.0e11, 7870.0, 6.4e-5, 3.413e-10, 0.0),  # Simeon's rod, undamped
        (0.269, 12, 1.87e11, 7850.0, 1.6129e-4, 2.1677e-9, 676.0),  # the paper's slider
        (1.0, 1, 7.0e10, 2700.0, 1e-4, 1e-9, 1e3),  # one element: the element matrices themselves
        (8.0, 40, 2.1e11, 7800.0, 1e-3, 1e-7, 0.0),  # a long chain
    ],
)
def test_link_matrices_are_the_closed_forms(geometry):
    eng = link_matrices(*geometry)
    M, K, C = oracle(*geometry)
    assert _rel(eng.M, M) <= 1e-14 and _rel(eng.K, K) <= 1e-14
    if geometry[-1] > 0:
        assert _rel(eng.C, C) <= 1e-14
    else:
        assert not np.any(eng.C)


def test_the_slider_yoke_matrices_are_its_slider_link():
    m = fc.scenes.slider_yoke()
    p = m.parameters
    M, C, K = m.matrices()
    Mo, Ko, Co = oracle(
        p["length"], p["elements"], p["youngs_modulus"], p["density"], p["area"], p["inertia"], p["eta"]
    )
    assert _rel(M, Mo) <= 1e-14 and _rel(K, Ko) <= 1e-14 and _rel(C, Co) <= 1e-14


def test_a_spinning_link_carries_the_frame_terms():
    # Kane's beam at its final rate (4 rad/s): the Coriolis term 2 Omega rho A int N^T S N makes C
    # skew (gyroscopic) and the centrifugal term -Omega^2 rho A int N^T N softens K, each of the
    # order of Omega (or Omega^2) times the mass matrix; at rest neither is there.
    spin = fc.scenes.spin_up()
    omega = spin.parameters["final_rate"]
    M, C, K = spin.matrices(2 * spin.parameters["ramp_time"])
    M0, C0, K0 = spin.matrices(0.0)
    assert not np.any(C0) and np.array_equal(M, M0)
    m = np.max(np.abs(M))
    assert 0.1 < np.max(np.abs(C - C.T)) / (2 * omega * m) < 10
    assert 0.1 < np.max(np.abs(K - K0)) / (omega**2 * m) < 10


def test_matrices_refuse_a_bad_state():
    m = fc.scenes.slider_yoke()
    with pytest.raises(fc.InvalidParameterError, match="state"):
        m.matrices(state=np.zeros(3))
    with pytest.raises(fc.InvalidParameterError, match="t"):
        m.matrices(t=-1.0)
