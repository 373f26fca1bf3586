"""Event-aware stepping (issue 5, item 6): a step that changes a joint's contact status is redone as
two substeps cut at the crossing. A step without a status change must be bitwise the fixed-step
one, and the cut must move the solution towards the converged one."""

from __future__ import annotations

import flexclear
import numpy as np
import pytest
from flexclear import Record


def _run(model, t_end, dt, **kw):
    return model.simulate(t_end, dt, record=Record(), divergence_limit=1.0, **kw)


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.mark.parametrize("kw", [{}, {"iterate": True}, {"method": "gap"}])
def test_no_status_change_is_bitwise_the_fixed_step_run(kw):
    # a 10 cm clearance is never reached (tests/test_extremes.py): no step is cut
    model = flexclear.scenes.slider_yoke(clearance=0.1)
    fixed, ev = _run(model, 0.01, 1e-5, **kw), _run(model, 0.01, 1e-5, events=True, **kw)
    assert ev.stats["event_steps"] == 0
    for x, y in zip(fixed.state, ev.state):
        assert _same(x, y)
    jf, je = fixed.joint("bearing"), ev.joint("bearing")
    assert _same(jf.penetration, je.penetration) and _same(jf.force, je.force)


@pytest.mark.parametrize("kw", [{}, {"iterate": True}])
def test_bitwise_until_the_first_status_change(kw):
    model = flexclear.scenes.slider_yoke(clearance=1e-4)
    fixed, ev = _run(model, 0.015, 1e-5, **kw), _run(model, 0.015, 1e-5, events=True, **kw)
    pf, pe = fixed.joint("bearing").penetration, ev.joint("bearing").penetration
    first = int(np.flatnonzero(np.diff(pf > 0))[0]) + 1  # first sample whose status differs
    assert first > 100 and ev.stats["event_steps"] >= 1
    assert _same(pf[:first], pe[:first])
    assert not _same(pf[first:], pe[first:])  # the cut step (and what follows) changed
    assert np.all(np.isfinite(pe)) and ev.complete


def test_events_cut_the_trajectory_error_of_iterated_kappa():
    # Table 1 scene, clearance 1e-4 m, 30 ms (5 contact entries/exits), against iterated kappa at
    # dt = 1e-7 s. Fixed steps smear the dashpot force jump at entry over a step (first order);
    # cutting the step at the crossing and restarting the acceleration there removes that.
    # Measured (fig6_std, the paper's error density, against 1e-8 s): 0.14 -> 0.011 at 3e-5 s,
    # 0.053 -> 0.0031 at 1e-5 s; asserted: at least 3x lower.
    from flexclear.accuracy import errors_against

    model = flexclear.scenes.slider_yoke(clearance=1e-4)

    def hist(dt, **kw):
        r = _run(model, 0.03, dt, iterate=True, **kw)
        j = r.joint("bearing")
        return r.time, j.penetration, j.force

    ref = hist(1e-7)
    for dt in (3e-5, 1e-5):
        fixed = errors_against(ref, hist(dt))["fig6_std"]
        ev = errors_against(ref, hist(dt, events=True))["fig6_std"]
        assert ev < fixed / 3, (dt, fixed, ev)


def _approach_speed(model_kw, clearance, t_end):
    """Radial speed (m/s) of the journal where it first reaches ``|q| = clearance`` in a
    contact-free run (a 1 mm clearance is never reached before ``t_end``): a cubic fit of the
    recorded positions at 1e-7 s around the crossing."""
    free = flexclear.scenes.slider_yoke(clearance=1e-3, **model_kw)
    r = free.simulate(t_end, 1e-7, record=Record(position=True), divergence_limit=1.0)
    j = r.joint("bearing")
    dr = np.hypot(j.qx, j.qy)
    k = int(np.flatnonzero(dr > clearance)[0])
    tc = r.time[k - 1] + (clearance - dr[k - 1]) / (dr[k] - dr[k - 1]) * (r.time[k] - r.time[k - 1])
    return np.polyfit(r.time[k - 4 : k + 4] - tc, dr[k - 4 : k + 4], 3)[-2], tc


@pytest.mark.parametrize(
    "kw",
    [{"iterate": True}, {}, {"method": "gap"}],
    ids=["iterated kappa", "lagged kappa", "gap"],
)
def test_entry_spike_is_the_dashpot_force_at_the_approach_speed(kw):
    # At contact entry the spring force is zero and the viscous dashpot force jumps to
    # C_B |qdot|: the largest force of the first impact of the Table 1 scene (clearance 1e-4 m,
    # entry at t = 10.41 ms, purely radial approach) is C_B times the contact-free approach speed.
    # Event-aware stepping cuts the step at the crossing, so the first substep must follow the
    # open trajectory up to it, whatever the coupling (before the status was held open there,
    # iterated kappa switched open/closed until its iteration cap and lost 3.7 % of the speed).
    # Tolerance 1e-3: the cut lands within 1e-3 of the step's penetration change of the circle.
    model = flexclear.scenes.slider_yoke(clearance=1e-4)
    cb = model.parameters["bearing_damping"]
    speed, tc = _approach_speed({}, 1e-4, 0.0105)
    assert 0.0104 < tc < 0.0105
    if kw.get("method") == "gap":
        kw = {**kw, "gap_stiffness": model.parameters["bearing_stiffness"], "gap_damping": cb}
    for dt in (1e-4, 1e-5):
        r = model.simulate(
            0.0125, dt, events=True, record=Record(histories=False), divergence_limit=1.0, **kw
        )
        assert r.stats["event_steps"] >= 1
        assert r.stats["unconverged_steps"] == 0, r.stats
        assert r.joint("bearing").max_force == pytest.approx(cb * speed, rel=1e-3), dt
