"""Conservation and passivity (issue 5, item 4) on a free rattling problem with no external work:
the slider-yoke's slider with a fixed yoke, thrown at the bearing with a uniform transverse
velocity. Energy = kinetic + strain (the engine's matrices, Model.matrices, checked against the
closed forms of tests/beam_oracle.py in tests/test_matrices.py) + bearing potential K_B max(delta, 0)^2 / 2.

The bound (derived in docs/stability.md, section "Energy"): average-acceleration Newmark changes
M- and K-energy by exactly the trapezoidal work of the contact force, minus the dissipation
dt v_avg^T C v_avg >= 0. For the piecewise-linear spring along a fixed normal (the motion here
is purely transverse) that work equals minus the potential change in every step that is wholly
open or wholly closed; a step that crosses delta = 0 is off by K_B d_n d_{n+1} / 2, at most
K_B (v dt)^2 / 8 in magnitude (entries lose, exits gain energy). So with kappa iterated,
|E_n - E_0| <= N_crossings K_B (v_max dt)^2 / 8 without damping, and E_n - E_0 <= the same with
damping."""

from __future__ import annotations

import flexclear
import numpy as np
import pytest
from flexclear.analysis.accuracy import free_rattle, rattle_energy

P = flexclear.scenes.slider_yoke().parameters
ELEMENTS = 6
V0 = 0.05  # m/s


def rattle(clearance=1e-4, stiffness=1e7, damping=0.0, eta=0.0):
    return free_rattle(clearance, stiffness, damping, eta, elements=ELEMENTS, speed=V0)


def energy_history(model, mats, v0, stiffness, t_end, dt, **kw):
    res, v, e = rattle_energy(model, mats, v0, stiffness, t_end, dt, **kw)
    # the velocity recurrence is exact for average acceleration: it must end at the engine's state
    assert np.max(np.abs(v[-1] - res.state[1])) <= 1e-8 * np.max(np.abs(v)), np.max(
        np.abs(v[-1] - res.state[1])
    )
    j = res.joint("bearing")
    crossings = int(np.count_nonzero(np.diff(np.sign(j.penetration)) != 0))
    bound = crossings * stiffness * (j.max_velocity * dt) ** 2 / 8
    return res, e, bound, crossings


def test_matrices_match_the_engine():
    m, mats, _ = rattle()
    import scipy.linalg

    w = scipy.linalg.eigh(mats.K, mats.M, eigvals_only=True)
    f = np.sqrt(w[w > 1.0]) / (2 * np.pi)
    assert f[:3] == pytest.approx(m.natural_frequencies(3), rel=1e-9)


@pytest.mark.parametrize("clearance", [1e-4, 0.0])
def test_iterated_kappa_conserves_energy_within_the_crossing_bound(clearance):
    kb = 1e7
    m, mats, v0 = rattle(clearance=clearance, stiffness=kb)
    res, e, bound, crossings = energy_history(m, mats, v0, kb, 0.02, 1e-6, method="modified", iterate=True)
    e0 = 0.5 * V0**2 * P["density"] * P["area"] * P["length"]
    assert e[0] == pytest.approx(e0, rel=1e-12)
    if clearance > 0:
        assert crossings >= 2 and res.joint("bearing").impacts >= 1
    else:
        # delta_c = 0: always "in contact", the force -K_B q is linear and only the first step (from
        # delta = 0) can cost energy
        assert crossings <= 1  # the start at delta = 0 counts as one entry
    drift = np.max(np.abs(e - e0))
    assert drift <= bound + 1e-9 * e0, (drift / e0, bound / e0)
    # the bound itself is small: the crossings cost a small fraction of the energy at this step
    assert bound < 0.05 * e0


def test_damped_rattle_is_passive():
    kb = 1e7
    m, mats, v0 = rattle(stiffness=kb, damping=50.0, eta=P["eta"])
    res, e, bound, _ = energy_history(m, mats, v0, kb, 0.02, 1e-6, method="modified", iterate=True)
    assert np.max(e - e[0]) <= bound + 1e-9 * e[0]
    assert e[-1] < 0.9 * e[0]  # and it does dissipate


def measured_energy_error(method: str, dt: float, **kw) -> float:
    """Relative energy change over 20 ms of the undamped rattle (for the report)."""
    kb = 1e7
    m, mats, v0 = rattle(stiffness=kb)
    _, e, _, _ = energy_history(m, mats, v0, kb, 0.02, dt, method=method, **kw)
    return float(e[-1] / e[0] - 1)


def test_lagged_variants_inject_energy_measured():
    # Not a conservation claim: the lagged force and lagged kappa gain energy in contact (the SDOF
    # theory gives ~ +pi Omega per contact half-period). Check only the direction and that the
    # iterated variant is far better, so the report's numbers mean what they say.
    # measured here (20 ms, dt 1e-6): force +2.7 %, lagged kappa +2.6 %, iterated -2.6e-6; at 1e-5:
    # +59 %, +60 %, -1.5e-3
    force = measured_energy_error("force", 1e-6)
    lagged = measured_energy_error("modified", 1e-6)
    iterated = measured_energy_error("modified", 1e-6, iterate=True)
    assert force > 0 and lagged > 0
    assert abs(iterated) < 0.1 * min(force, lagged)
