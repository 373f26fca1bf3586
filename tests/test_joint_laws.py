"""The laws of flexclear.contact on a clearance joint (issue 15, item 1 in the joints), against
closed forms on a single impact.

The impactor: a free steel bar (0.1 m, 10 mm square, 4 elements) translating at 0.1 m/s towards
a stop at one end (clearance 0.1 mm); the contact point of a free rigid bar hit at its end has
the effective mass m/4, which the consistent mass matrix reproduces exactly. The contact is soft
(K = 1e6 N/m^1.5: 4.2 ms of contact against 0.19 ms for the bar's first bending period), so the
bar responds as a rigid body to within the tolerances below.

- Hertz (undamped): contact time 3.2181 (m/K)^(2/5) v0^(-1/5) and peak penetration
  (5 m v0^2 / (4 K))^(2/5) (CONTACT.md section 1), m = m_bar / 4; measured 2e-4 and 2e-4 off
  at dt 2.5e-7 s: tolerance 2e-3.
- The hysteresis laws: the effective restitution of one impact depends on chi and n only; the
  table tests/data/contact_restitution.csv (3 decimals) is met within 1.5e-3 (the rounding plus
  the bar's flexibility) on every stepper and coupling.
"""

from __future__ import annotations

from pathlib import Path

import flexclear as fc
import numpy as np
import pytest
from flexclear import contact

L, A, E, RHO = 0.1, 1e-4, 2e11, 7850.0
K, V0, C = 1e6, 0.1, 1e-4
M_EFF = RHO * A * L / 4


def bar(law=None, elements: int = 4, **joint) -> fc.Model:
    """The free bar towards its stop, the joint with `law` or (without) the spring-dashpot of
    `joint` (``stiffness=``, ``damping=``, ``damping_law=``)."""
    m = fc.Model().add_body("ground")
    v = np.zeros(3 * (elements + 1))
    v[1::3] = -V0  # every node towards -y: a rigid translation into the stop
    m.add_link(
        "bar", length=L, elements=elements, youngs_modulus=E, density=RHO, area=A, inertia=A * A / 12,
        damping=0.0, initial_velocity=v,
    )  # fmt: skip
    m.add_joint("stop", "bar", 0, body="ground", clearance=C, law=law, **joint)
    return m


def first_impact(law, dt: float = 2.5e-7, **run):
    """(restitution, impact log) of the first impact: exit over entry normal speed of the journal,
    from its position history in the free flight just before and after the contact."""
    r = bar(law).simulate(0.006, dt, record=fc.Record(impact_log=True, position=True), **run)
    j = r.joint("stop")
    log = j.impact_log
    t, qy = r.time, j.qy
    i0 = np.searchsorted(t, log.time[0])
    i1 = np.searchsorted(t, log.time[0] + log.duration[0])
    v_in = (qy[i0 - 2] - qy[i0 - 12]) / (t[i0 - 2] - t[i0 - 12])
    v_out = (qy[i1 + 12] - qy[i1 + 2]) / (t[i1 + 12] - t[i1 + 2])
    return -v_out / v_in, log


RUNS = {
    "constant, lagged kappa": {},
    "constant, iterated kappa": {"iterate": True},
    "constant, force method": {"method": "force"},
    "newton, lagged kappa": {"stepper": "newton"},
    "newton, iterated": {"stepper": "newton", "iterate": True},
}


@pytest.mark.parametrize("run", list(RUNS))
def test_hertz_impact_time_and_depth_are_the_closed_forms(run):
    e, log = first_impact(contact.Hertz(K), **RUNS[run])
    assert log.duration[0] == pytest.approx(3.2181 * (M_EFF / K) ** 0.4 * V0**-0.2, rel=2e-3)
    assert log.peak_penetration[0] == pytest.approx((5 * M_EFF * V0**2 / (4 * K)) ** 0.4, rel=2e-3)
    assert e == pytest.approx(1.0, abs=2e-3)  # elastic


def _table():
    rows = (Path(__file__).parent / "data" / "contact_restitution.csv").read_text().splitlines()
    body = [r.split(",") for r in rows if r and not r.startswith("#")][1:]
    return [(name, float(e), float(eff)) for name, e, eff in body]


@pytest.mark.parametrize("name, nominal, effective", _table())
def test_hysteresis_laws_give_their_effective_restitution_on_a_joint(name, nominal, effective):
    law = getattr(contact, name)(K, restitution=nominal)
    for run in ("constant, lagged kappa", "newton, iterated"):
        e, _ = first_impact(law, **RUNS[run])
        assert e == pytest.approx(effective, abs=1.5e-3), run


def test_a_kelvin_voigt_law_is_the_joints_own_spring_dashpot():
    # law=KelvinVoigt(...) puts the engine's spring-dashpot on the joint: bitwise the run of
    # stiffness=, damping= (the paper's law), for every damping form
    for form in ("viscous", "radial", "literal"):
        law = contact.KelvinVoigt(1e5, damping=3.0, damping_law=form)
        a = bar(law).simulate(0.004, 1e-6).joint("stop")
        b = bar(stiffness=1e5, damping=3.0, damping_law=form).simulate(0.004, 1e-6).joint("stop")
        assert a.impacts >= 1
        assert np.array_equal(a.penetration, b.penetration) and np.array_equal(a.force, b.force), form


def _link_model() -> fc.Model:
    m = fc.Model().add_body("g")
    return m.add_link(
        "l", length=1.0, elements=2, youngs_modulus=1e9, density=1e3, area=1e-4, inertia=1e-9, damping=0
    )


def test_law_errors_name_the_parameter():
    with pytest.raises(fc.InvalidParameterError, match="stiffness"):
        _link_model().add_joint("j", "l", 0, body="g", clearance=1e-3, stiffness=1e6, law=contact.Hertz(1e9))
    with pytest.raises(fc.InvalidParameterError, match="law"):
        bar("hertz")
    with pytest.raises(fc.InvalidParameterError, match="damping"):
        _link_model().add_joint("j", "l", 0, body="g", clearance=1e-3, stiffness=1e6)


def _laws(k: float, e: float) -> list:
    """Every normal law at stiffness k (N/m or N/m^n) and nominal restitution e where it applies."""
    hysteresis = (contact.HuntCrossley, contact.LankaraniNikravesh, contact.Flores, contact.Gonthier)
    return [
        contact.KelvinVoigt(k, damping=1e-3 * k),
        contact.Hertz(k),
        *[cls(k, restitution=e) for cls in hysteresis],
        contact.CarvalhoMartins(k, restitution=e),
    ]


@pytest.mark.parametrize("run", list(RUNS))
@pytest.mark.parametrize("k", [1e3, 1e13])
@pytest.mark.parametrize("e", [0.01, 1.0])
@pytest.mark.parametrize("clearance", [0.0, 1e-4, 1.0])
def test_every_law_and_coupling_at_the_extremes_ends_finite_or_names_its_error(run, k, e, clearance):
    # issue 15's extremes suite on a joint: stiffness 1e3..1e13, restitution 0.01..1, clearance
    # 0..1 m, every stepper and coupling. A run either ends with finite histories or raises one
    # of flexclear's named errors (a divergence says when and where); never NaN, never a panic.
    for law in _laws(k, e):
        m = fc.Model().add_body("ground")
        v = np.zeros(15)
        v[1::3] = -V0
        m.add_link(
            "bar", length=L, elements=4, youngs_modulus=E, density=RHO, area=A, inertia=A * A / 12,
            damping=0.0, initial_velocity=v,
        )  # fmt: skip
        m.add_joint("stop", "bar", 0, body="ground", clearance=clearance, law=law)
        try:
            r = m.simulate(2e-3, 1e-5, record=fc.Record(position=True), **RUNS[run])
        except fc.FlexclearError as err:
            assert not isinstance(err, fc.InvalidParameterError), (law, err)
            assert str(err), law
            continue
        j = r.joint("stop")
        for name, x in (("force", j.force), ("penetration", j.penetration), ("qy", j.qy)):
            assert np.isfinite(x).all(), (type(law).__name__, name)
        if clearance == 1.0:
            assert j.impacts == 0  # a 1 m gap is never crossed in 2 ms at 0.1 m/s
