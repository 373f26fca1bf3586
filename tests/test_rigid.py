"""Rigid links (``Model.add_rigid_link``, issue 15 item 5) against rigid-body closed forms.

- A bar hinged at node 0 under a constant transverse tip load F turns as ``J0 theta'' = F L``
  (``J0 = I + m c^2``): ``v_tip = F L^2 t^2 / (2 J0)``; Newmark's average acceleration is exact
  for a constant acceleration.
- The same bar with its tip in a fixed bearing of clearance c under an elastic Hertz law
  ``F_c = K d^1.5``: the tip starts centred, at rest, and is pushed into the wall; the energy
  balance at the deepest point, ``F (c + d) = (2/5) K d^2.5``, gives the largest penetration
  (the bar's kinetic energy is zero there and the Hertz law stores ``(2/5) K d^2.5``).
- A flexible bar of the same mass and length converges to the rigid one as E grows.
"""

from __future__ import annotations

import flexclear as M
import numpy as np
import pytest
from flexclear.contact import Hertz

L, RHO, A = 0.5, 7800.0, 1e-4
MASS = RHO * A * L
INERTIA = MASS * L**2 / 12.0
J0 = INERTIA + MASS * (L / 2) ** 2
F = 2.0


def _hinged(model: M.Model, link: str) -> M.Model:
    model.add_body("ground")
    model.add_pin("hinge", link, 0, body="ground")
    return model


def _rigid() -> M.Model:
    return _hinged(M.Model().add_rigid_link("bar", length=L, mass=MASS, inertia=INERTIA), "bar")


def test_a_hinged_rigid_bar_under_a_tip_load_follows_j0_theta_dd_equals_f_l():
    model = _rigid().add_load("bar", 1, fv=F)
    res = model.simulate(0.02, 1e-4)
    assert res.stats["stepper"] == "newton"
    bar = res.link("bar")
    assert bar.v.shape == (len(res.time), 2)
    exact = F * L**2 * res.time**2 / (2 * J0)
    np.testing.assert_allclose(bar.v[:, 1], exact, rtol=1e-9, atol=1e-15)
    # node 1 follows node 0 (held by the hinge) and the rotation: v1 = L theta
    np.testing.assert_allclose(bar.v[:, 1], L * bar.theta[:, 0], rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(bar.v[:, 0], 0.0)


def test_the_centroid_defaults_to_mid_length():
    at_mid = _rigid().add_load("bar", 1, fv=F).simulate(0.01, 1e-4).link("bar").v[:, 1]
    given = (
        _hinged(M.Model().add_rigid_link("bar", length=L, mass=MASS, inertia=INERTIA, centroid=L / 2), "bar")
        .add_load("bar", 1, fv=F)
        .simulate(0.01, 1e-4)
        .link("bar")
        .v[:, 1]
    )
    np.testing.assert_array_equal(at_mid, given)


def test_a_rigid_bar_pushed_into_a_clearance_bearing_penetrates_as_the_energy_balance_says():
    c, k = 1e-4, 1e9
    model = _rigid().add_load("bar", 1, fv=F)
    model.add_joint("tip", "bar", 1, clearance=c, law=Hertz(k), body="ground", point=(L, 0.0))
    # the load moves the tip's effective mass J0 / L^2 through c + d; no energy leaves
    # F (c + d) = (2/5) K d^2.5 at the deepest point: bisection
    lo, hi = 0.0, 1e-3
    for _ in range(200):
        d = 0.5 * (lo + hi)
        lo, hi = (d, hi) if F * (c + d) > 0.4 * k * d**2.5 else (lo, d)
    t_hit = np.sqrt(2 * c * J0 / (F * L**2))
    res = model.simulate(3 * t_hit, t_hit / 4000, iterate=True)
    joint = res.joint("tip")
    assert joint.impacts >= 1
    assert joint.max_penetration == pytest.approx(d, rel=2e-3)


@pytest.mark.parametrize(
    "bad", [dict(mass=0.0), dict(inertia=-1.0), dict(length=-0.1), dict(centroid=np.nan)]
)
def test_bad_rigid_link_parameters_are_refused_by_name(bad):
    kw = dict(length=L, mass=MASS, inertia=INERTIA) | bad
    name = next(iter(bad))
    with pytest.raises(M.InvalidParameterError, match=name):
        M.Model().add_rigid_link("bar", **kw)


def test_a_rigid_link_pinned_at_both_ends_with_node_0_free_is_refused():
    model = M.Model().add_rigid_link("bar", length=L, mass=MASS, inertia=INERTIA)
    model.add_body("ground")
    model.add_pin("end", "bar", 1, body="ground", point=(L, 0.0))
    with pytest.raises(M.ModelError, match='node 1 of rigid link "bar"'):
        model.simulate(0.01, 1e-4)


def test_flexible_bars_converge_to_the_rigid_bar_as_e_grows():
    rigid = _rigid().add_load("bar", 1, fv=F).simulate(0.02, 2e-5).link("bar").v[:, 1]
    errors = []
    for e in (2e11, 2e12, 2e13):
        model = M.Model().add_link(
            "bar", length=L, elements=8, youngs_modulus=e, density=RHO, area=A, inertia=1e-9
        )
        flex = _hinged(model, "bar").add_load("bar", 8, fv=F).simulate(0.02, 2e-5).link("bar").v[:, -1]
        errors.append(np.max(np.abs(flex - rigid)))
    assert errors[0] < 0.05 * abs(rigid[-1])
    assert errors[0] / errors[1] > 5 and errors[1] / errors[2] > 5, errors


def test_a_point_mass_at_node_1_adds_m_l_squared_to_the_hinge_inertia():
    mp = 0.3
    model = _rigid().add_mass("bar", 1, mp).add_load("bar", 1, fv=F)
    res = model.simulate(0.02, 1e-4)
    exact = F * L**2 * res.time**2 / (2 * (J0 + mp * L**2))
    np.testing.assert_allclose(res.link("bar").v[:, 1], exact, rtol=1e-9, atol=1e-15)


def test_a_free_rigid_bar_hanging_in_a_bearing_runs_the_same_on_both_solvers():
    # node 0 free (u0, v0 and theta unknown), node 1 in a fixed bearing, gravity: the contact
    # rows of node 1 carry the rotation's lever on the Woodbury update as on the refactorized
    # Jacobian; the two runs agree to the iteration tolerance
    def run(solver):
        model = M.Model().add_rigid_link("bar", length=L, mass=MASS, inertia=INERTIA, angle=0.3)
        model.add_body("ground")
        end = (L * np.cos(0.3), L * np.sin(0.3))
        model.add_joint("top", "bar", 1, clearance=1e-4, law=Hertz(1e9), body="ground", point=end)
        model.add_gravity(0.0, -9.81)
        return model.simulate(0.05, 2e-5, iterate=True, solver=solver, record=M.Record(position=True))

    a, b = run("woodbury"), run("refactor")
    assert a.stats["woodbury_steps"] > 0
    assert a.joint("top").impacts >= 1
    np.testing.assert_allclose(a.link("bar").v, b.link("bar").v, rtol=0, atol=1e-9)
    # the bar hangs from the bearing (its node 1 above node 0): the journal reaches the wall
    assert np.hypot(a.joint("top").qx, a.joint("top").qy).max() > 1e-4


def test_the_flexible_rod_variant_has_the_rods_mass():
    model = M.scenes.flores_slider_crank(5e-4, flexible_rod=True, rod_elements=3)
    p = model.parameters
    assert p["rod_density"] * p["rod_area"] * p["rod_length"] == pytest.approx(p["rod_mass"], rel=1e-12)
    res = model.simulate(0.001, 1e-6, iterate=True)
    assert res.link("rod").v.shape[1] == 4
    assert res.stats["unknowns"] == 3 * 4 - 2 + 1  # crank pin holds node 0's translation; slider
