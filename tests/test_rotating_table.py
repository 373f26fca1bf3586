"""In-plane frequencies of a spinning cantilever against the published Southwell-type table.

Reference: flexclear/data/rotating_cantilever_flapwise.csv (package data, the CLI plots it too;
Wright et al. 1982 / Hodges & Rutkowski
1981, flapwise). Planar motion bends in the plane of rotation, where the centrifugal softening
-Omega^2 M (M_IC) adds to the flapwise problem: w_in^2 = w_flap^2 - Omega^2. The classic tables
treat an inextensible beam without Coriolis coupling, so the comparison uses
``Model.natural_frequencies(coriolis=False)`` on a nearly inextensible beam (EA / EI = 1e8 for L = 1).
"""

from __future__ import annotations

from pathlib import Path

import flexclear as fc
import numpy as np
import pytest

DATA = Path(fc.__file__).parent / "data" / "rotating_cantilever_flapwise.csv"


def _table() -> np.ndarray:
    return np.loadtxt(DATA, delimiter=",", comments="#", skiprows=12)


def _in_plane(lam: float, elements: int) -> np.ndarray:
    """First two in-plane frequencies, in units of sqrt(EI / (rho A L^4)) (= 1 here)."""
    m = fc.Model()
    hub = fc.Frame.rotating(fc.Rotation.constant(lam))
    m.add_link(
        "beam",
        length=1.0,
        elements=elements,
        youngs_modulus=1e8,
        density=1.0,
        area=1.0,
        inertia=1e-8,
        frame=hub,
    )
    m.add_clamp("beam", 0)
    return 2 * np.pi * m.natural_frequencies(2, coriolis=False)


def test_table_has_the_rows_it_claims():
    t = _table()
    assert t.shape == (12, 3)
    assert t[0, 1] == pytest.approx(1.8751041**2, abs=5e-5)  # (beta_1 L)^2, closed form root


@pytest.mark.parametrize("row", range(12))
def test_in_plane_frequencies_match_the_flapwise_table(row):
    # EI = 1e8 * 1e-8 = 1, rho A = 1, L = 1: frequencies are already non-dimensional.
    # Tolerance: the table gives 4 decimals (half a unit: 5e-5). The FE error is O(h^2) once the
    # hub spins (the axial force is constant per element while the centrifugal tension is
    # parabolic), so 12- and 24-element results are Richardson-extrapolated, (4 w24 - w12) / 3,
    # whose remaining error was measured below 4e-6 relative; EA/EI = 1e8 changes the result by
    # about 1e-6. Hence |lambda_FE - lambda_table| <= 5e-5 + 1e-5 * lambda_table.
    lam, w1, w2 = _table()[row]
    f12, f24 = _in_plane(lam, 12), _in_plane(lam, 24)
    l12, l24 = np.sqrt(f12**2 + lam**2), np.sqrt(f24**2 + lam**2)
    flap = l24 + (l24 - l12) / 3.0
    for got, raw, want in zip(flap, l24, (w1, w2)):
        assert got == pytest.approx(want, abs=5e-5 + 1e-5 * want)
        # The 24-element value itself is within 1e-3 relative (measured at most 5.3e-4).
        assert raw == pytest.approx(want, rel=1e-3)
