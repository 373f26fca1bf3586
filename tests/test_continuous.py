"""The continuous-contact (massless-link) model, ``simulate(method="continuous")`` (issue 16
item 2; Earles & Wu 1977, Haines 1980): the journal held on the bearing circle by a Lagrange
multiplier while that normal force is compressive.

- A rigid bar hinged at node 0, its tip in a fixed bearing of clearance c, pushed by a constant
  transverse tip load F: the tip starts centred at rest and reaches the wall at
  ``t = sqrt(2 c J0 / (F L^2))`` (uniform angular acceleration ``F L / J0``); there it stops
  (plastic impact) and the wall carries the load: ``N = F`` (the bar's moment balance about the
  hinge, ``J0 theta'' = (F - N) L = 0``).
- The slider-yoke (Table 1 clearance 0.01 Y) against the penalty model with a very stiff
  (1e3 and 1e4 x K_B), critically damped, tension-free bearing on the Newton stepper: while both
  hold the journal on the wall the journal positions differ by the penalty's compliance (measured:
  the largest difference equals the largest ``F / K``, 1.6e-9 and 1.6e-10 m; asserted: at most
  twice it), the normal forces agree in the mean (1e-4 relative) with a ripple that falls as
  ``1/K`` (23 % and 2.4 % of the mean force), and the penalty's departure from the wall converges
  on the continuous model's loss instant as K grows (51 us and 6.5 us later, the continuous model at
  dt 1e-6 s).
"""

from __future__ import annotations

import flexclear as M
import numpy as np
import pytest
from flexclear import scenes
from flexclear.contact import Hertz
from flexclear.errors import InvalidParameterError

L, RHO, A = 0.5, 7800.0, 1e-4
MASS = RHO * A * L
INERTIA = MASS * L**2 / 12.0
J0 = INERTIA + MASS * (L / 2) ** 2
F = 2.0
C = 1e-4


def _pushed_bar(clearance: float = C) -> M.Model:
    model = M.Model().add_rigid_link("bar", length=L, mass=MASS, inertia=INERTIA)
    model.add_body("ground")
    model.add_pin("hinge", "bar", 0, body="ground")
    model.add_load("bar", 1, fv=F)
    model.add_joint("tip", "bar", 1, clearance=clearance, law=Hertz(1e9), body="ground", point=(L, 0.0))
    return model


def test_a_pushed_bar_reaches_the_wall_when_the_closed_form_says_and_the_wall_carries_the_load():
    t_hit = np.sqrt(2 * C * J0 / (F * L**2))
    dt = t_hit / 400.37  # the wall between two steps
    res = _pushed_bar().simulate(
        3 * t_hit, dt, method="continuous", record=M.Record(position=True, impact_log=True)
    )
    assert res.stats["stepper"] == "newton"
    tip = res.joint("tip")
    log = tip.impact_log
    # one attachment, in the first step that ends beyond the wall, never lost
    assert log.time.size == 1 and np.isnan(log.duration[0])
    assert t_hit < log.time[0] <= t_hit + dt
    on = res.time >= log.time[0]
    # on the wall: |q| = c, the recorded penetration the smallest positive double (closed), N = F
    r = np.hypot(tip.qx, tip.qy)
    np.testing.assert_allclose(r[on], C, rtol=1e-12)
    assert np.all(tip.penetration[on] > 0.0) and np.all(tip.penetration[on] < 1e-300)
    np.testing.assert_allclose(tip.force[on], F, rtol=1e-9)
    # before: free flight from the centre, no force
    assert np.all(tip.force[~on] == 0.0) and np.all(tip.penetration[~on] < 0.0)
    # the plastic impact stopped the bar
    np.testing.assert_allclose(res.link("bar").v[on][-1, 1], C, rtol=1e-12)


AMP = 0.01
CLEARANCE = 0.01 * AMP
T_END = 0.1


def _long_contacts(res, shortest: float = 1e-3):
    """Entries and exits (s) of the bearing's contact episodes of at least ``shortest`` s, from the
    penetration history (an impact's log entry spans its rebounds too)."""
    closed = res.joint("bearing").penetration > 0
    edges = np.diff(np.r_[0, closed.astype(np.int8), 0])
    t = np.r_[res.time, res.time[-1]]
    entries, exits = t[np.flatnonzero(edges == 1)], t[np.flatnonzero(edges == -1)]
    keep = exits - entries >= shortest
    return entries[keep], exits[keep]


@pytest.fixture(scope="module")
def yoke_runs():
    base = scenes.slider_yoke(clearance=CLEARANCE)
    kb, m4 = base.parameters["bearing_stiffness"], base.parameters["mass"] / 4
    rec = M.Record(position=True, impact_log=True)
    cont = base.simulate(T_END, 1e-6, method="continuous", record=rec)
    pens = {}
    for factor, dt in ((1e3, 1e-6), (1e4, 5e-7)):
        k = factor * kb
        model = scenes.slider_yoke(
            clearance=CLEARANCE, bearing_stiffness=k, bearing_damping=2 * np.sqrt(k * m4), no_tension=True
        )
        pens[factor] = (
            k,
            model.simulate(
                T_END,
                dt,
                stepper="newton",
                iterate=True,
                record=M.Record(position=True, impact_log=True, every=int(round(1e-6 / dt))),
            ),
        )
    return cont, pens


def test_the_continuous_model_equals_a_stiff_damped_penalty_bearing_while_in_contact(yoke_runs):
    cont, pens = yoke_runs
    jc = cont.joint("bearing")
    ent_c, ex_c = _long_contacts(cont)
    assert ent_c.size >= 1 and ex_c[-1] < T_END
    ripple = {}
    for factor, (k, pen) in pens.items():
        jp = pen.joint("bearing")
        ent_p, ex_p = _long_contacts(pen)
        # the long contact that ends the first cycle's continuous phase: same entry within 0.1 ms
        assert abs(ent_p[0] - ent_c[0]) < 1e-4
        # common window of the last long contact, away from its ends
        lo, hi = max(ent_c[-1], ent_p[-1]) + 1e-3, min(ex_c[-1], ex_p[-1]) - 1e-3
        assert hi - lo > 0.03
        w = (cont.time > lo) & (cont.time < hi)
        qx = np.interp(cont.time[w], pen.time, jp.qx)
        qy = np.interp(cont.time[w], pen.time, jp.qy)
        dq = np.hypot(qx - jc.qx[w], qy - jc.qy[w])
        fmax = jc.force[w].max()
        # positions: the penalty's compliance, |q| - c = F/K, and no more
        assert dq.max() <= 2 * fmax / k, (factor, dq.max(), fmax / k)
        # forces: the same mean load on the wall (the penalty's dashpot and the unresolved
        # bearing oscillation add zero-mean ripple)
        fp = np.interp(cont.time[w], pen.time, jp.force)
        fc = jc.force[w].mean()
        assert abs(fp.mean() - fc) < 1e-3 * fc, (fp.mean(), fc)
        ripple[factor] = np.abs(fp - jc.force[w]).max() / fc
    # and the ripple goes as the compliance: 23 % of the mean force at 1e3 K_B, 2.4 % at 1e4 K_B
    assert ripple[1e4] < 0.05 and ripple[1e4] < ripple[1e3] / 4, ripple


def test_the_penalty_departure_converges_on_the_continuous_loss_instant(yoke_runs):
    cont, pens = yoke_runs
    _, ex_c = _long_contacts(cont)
    lags = {}
    for factor, (_k, pen) in pens.items():
        _, ex_p = _long_contacts(pen)
        lags[factor] = ex_p[-1] - ex_c[-1]
    # the stiffer bearing leaves the wall later than the rigid one by its compliance, less so as
    # K grows: within 10 steps (10 us) of the continuous model's instant at 1e4 K_B
    assert 0.0 <= lags[1e4] < lags[1e3] / 4, lags
    assert lags[1e4] <= 1e-5, lags


def test_a_translating_model_runs_on_newton_and_other_steppers_are_refused():
    model = _pushed_bar()
    res = scenes.slider_yoke(clearance=CLEARANCE).simulate(1e-3, 1e-5, method="continuous")
    assert res.stats["stepper"] == "newton"
    with pytest.raises(InvalidParameterError, match="stepper"):
        scenes.slider_yoke(clearance=CLEARANCE).simulate(1e-3, 1e-5, method="continuous", stepper="constant")
    with pytest.raises(InvalidParameterError, match="events"):
        model.simulate(1e-3, 1e-5, method="continuous", events=True)
    with pytest.raises(InvalidParameterError, match="method"):
        model.simulate(1e-3, method="continuous", tol=1e-3)


def test_a_zero_clearance_is_an_ideal_pin_and_is_refused():
    with pytest.raises(InvalidParameterError, match="clearance"):
        _pushed_bar(clearance=0.0).simulate(1e-3, 1e-5, method="continuous")


def test_continuous_loss_gives_the_runs_loss_instants_as_interval_starts():
    from flexclear.design import continuous_loss

    model = scenes.slider_yoke(clearance=CLEARANCE)
    pred = continuous_loss(model, "bearing", T_END, 1e-6, every=10)
    log = pred.result.joint("bearing").impact_log
    # the journal starts at the centre: free until the first attachment
    assert pred.intervals[0] == (0.0, log.time[0])
    exits = (log.time + log.duration)[np.isfinite(log.duration)]
    np.testing.assert_array_equal(pred.starts()[1:], exits)
    # the normal force is defined (and compressive) exactly where the run holds the journal
    np.testing.assert_array_equal(np.isfinite(pred.normal_force), pred.in_contact)
    assert np.all(pred.normal_force[pred.in_contact] >= 0.0)
    # the force vector points into the bearing centre: -N n
    j = pred.result.joint("bearing")
    on = pred.in_contact
    radial = (pred.force[on, 0] * j.qx[on] + pred.force[on, 1] * j.qy[on]) / CLEARANCE
    np.testing.assert_allclose(radial, -pred.normal_force[on], rtol=1e-9, atol=1e-12)
    with pytest.raises(InvalidParameterError, match="method"):
        continuous_loss(model, "bearing", T_END, 1e-6, method="modified")


def test_continuous_refuses_a_joint_with_friction():
    # the friction law reads the penalty contact's normal force, which the multiplier replaces
    from flexclear import contact

    m = M.scenes.flores_slider_crank(friction=contact.Coulomb(0.1))
    with pytest.raises(InvalidParameterError, match="friction"):
        m.simulate(0.001, 1e-6, method="continuous")
