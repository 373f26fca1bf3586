"""flexclear.design (issue 16): contact-loss prediction, tolerance allocation, optimization.

Runtime: about 10 s on 2 cores (the clearance runs of the slider-yoke are 0.2 s of simulated
time at dt = 1e-6, ~0.2 s of wall time each in a release build)."""

from __future__ import annotations

import math

import flexclear as fc
import numpy as np
import pytest
from flexclear import design
from flexclear.design.contact_loss import agreement, continuous_contact, zero_clearance_force

# --------------------------------------------------------------------------------------------
# 1. Contact loss from a zero-clearance run
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def yoke():
    return fc.scenes.slider_yoke(clearance=1e-4)


def test_zero_clearance_force_follows_the_yoke_inertia(yoke):
    """With zero clearance the bearing carries the slider's inertia force: the free-free slider
    pinned at its end needs F = (m/4) Y'' at the pin, i.e. F_y = -(m/4) Y (2 pi f)^2 sin(2 pi f t),
    along y only, changing sign each half cycle."""
    p = yoke.parameters
    m_eff, w, amp = p["mass"] / 4, 2 * math.pi * p["frequency"], p["amplitude"]
    t, f, res, info = zero_clearance_force(yoke, "bearing", 0.5, 1e-5)
    assert info["stiffness"] == pytest.approx(100 * p["bearing_stiffness"])
    analytic = -m_eff * amp * w**2 * np.sin(w * t)
    scale = m_eff * amp * w**2  # 1.21 N
    # The run starts with the rigid steady motion; the slider's bending modes (880 Hz, 1 %
    # damping) and the stiff bearing's start-up add 0.5 % of the amplitude at first, < 0.1 % later.
    assert np.max(np.abs(f[:, 1] - analytic)) < 0.01 * scale
    late = t > 0.1
    assert np.max(np.abs(f[late, 1] - analytic[late])) < 1e-3 * scale
    assert np.max(np.abs(f[:, 0])) < 1e-9 * scale  # a translating model: no axial force
    # one sign change per half cycle: 6 in 0.5 s at 6 Hz (t = k/12 s, k = 1..5, not counting t = 0)
    big = np.abs(f[:, 1]) > 0.05 * scale
    signs = np.sign(f[big, 1])
    assert int(np.sum(signs[1:] != signs[:-1])) == 5


def test_stiff_bearing_force_converges_in_stiffness(yoke):
    """The zero-clearance force converges as the bearing stiffness grows: 3e-3 of the peak
    between 10 and 100 x K_B, below 2e-3 between 100 and 1000 x (the default is 100 x)."""
    k0 = yoke.parameters["bearing_stiffness"]
    forces = {
        r: zero_clearance_force(yoke, "bearing", 0.2, 1e-5, stiffness=r * k0)[1] for r in (10, 100, 1000)
    }
    peak = np.max(np.abs(forces[1000]))
    d1 = np.max(np.abs(forces[10] - forces[100])) / peak
    d2 = np.max(np.abs(forces[100] - forces[1000])) / peak
    assert d2 < 2e-3
    assert d2 < d1


def test_table1_scene_predicted_loss_meets_every_departure(yoke):
    """The issue's test. Table 1 scene (clearance 1e-4 m) over 0.2 s: the clearance run (iterated
    kappa, events, dt 1e-6) leaves the wall after a continuous contact (>= 5 ms; short rebounds
    are impacts, not continuous contact) twice, at 83.6 and 166.9 ms; each has a predicted loss
    interval starting within 4 ms (measured: 0.27 ms), and the prediction covers < 3/4 of the run
    (measured 18 %: the first 10 ms of free flight from the centre and two 13 ms flights)."""
    pred = design.contact_loss(yoke, "bearing", 0.2, 1e-5)
    run = yoke.simulate(0.2, 1e-6, iterate=True, events=True, record=fc.Record(impact_log=True, every=100))
    departures = design.wall_departures(run, "bearing", min_contact=5e-3)
    assert departures.size == 2
    a = agreement(pred, departures, 4e-3)
    assert a["matched"] == departures.size, (a, pred.intervals, departures)
    assert a["false"] == 0
    assert a["max_offset"] < 1e-3
    assert pred.loss_fraction < 0.75
    # the predicted flights end where the run's journal reaches the other wall (the first impact
    # after each departure): 96.5 and 179.8 ms, within 0.1 ms
    log = run.joint("bearing").impact_log
    for s, e in pred.intervals[1:]:
        nxt = log.time[log.time > s][0]
        assert abs(e - nxt) < 1e-4


def test_margin_and_continuous_contact_agree_in_the_small_clearance_limit():
    """A load turning at a steady rate keeps the journal on the wall (it presses it harder); a load
    that swings round through a small magnitude lifts it: the quasi-static margin and the
    continuous-contact model say the same. Load F = (eps, sin(2 pi 6 t)) N on a journal of
    m c = 1e-5 kg m (m = 0.1 kg, c = 0.1 mm)."""
    t = np.linspace(0.0, 0.2, 20001)
    m, c = 0.1, 1e-4
    margin_of = design.contact_loss.__globals__["direction_margin"]
    # steady rotation at 50 rad/s, |F| = 1 N: never lost, N = |F| + m c w^2
    f = np.column_stack([np.cos(50 * t), np.sin(50 * t)])
    normal, contact, intervals = continuous_contact(t, f, m, c, start="wall")
    assert intervals == [] and contact.all()
    assert np.nanmin(normal) > 0.99
    assert margin_of(t, f, m, c).min() > 0.99
    w = 2 * np.pi * 6
    # eps = 1 N: the direction swings +-45 degrees slowly (|psi''| ~ 1e3 << |F|/(m c) = 1e5)
    f = np.column_stack([np.ones_like(t), np.cos(w * t)])
    normal, contact, intervals = continuous_contact(t, f, m, c, start="wall")
    assert intervals == [] and margin_of(t, f, m, c).min() > 0
    # eps = 0.02 N: the direction turns by ~pi within ~1 ms around the zero of F_y at t = 1/24 s.
    # (Only the first event is checked: the model has no tangential damping, so the swing the
    # journal keeps after a re-contact decides the later ones.)
    f = np.column_stack([np.full_like(t, 0.02), np.cos(w * t)])
    normal, contact, intervals = continuous_contact(t, f, m, c, start="wall")
    margin = margin_of(t, f, m, c)
    assert intervals and abs(intervals[0][0] - 1 / 24) < 2e-3
    assert margin[np.abs(t - 1 / 24) < 5e-3].min() < 0  # the margin flags the same place
    assert margin[t < 1 / 24 - 0.01].min() > 0
    assert np.all(normal[contact] >= -1e-9) and np.all(np.isnan(normal[~contact]))


def test_contact_loss_errors(yoke):
    hand = fc.Model()
    hand.add_body("b")
    hand.add_link("l", length=0.2, elements=2, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-9)
    hand.add_joint("j", "l", 0, body="b", clearance=1e-4, stiffness=1e6, damping=10.0)
    with pytest.raises(fc.ModelError, match="builder"):
        design.contact_loss(hand, "j", 0.01, 1e-5)
    with pytest.raises(fc.ModelError, match="unknown joint"):
        design.contact_loss(yoke, "nope", 0.01, 1e-5)
    with pytest.raises(fc.InvalidParameterError, match="restitution") as e:
        design.contact_loss(yoke, "bearing", 0.01, 1e-5, restitution=1.5)
    assert e.value.parameter == "restitution"
    with pytest.raises(fc.InvalidParameterError, match="stiffness"):
        design.contact_loss(yoke, "bearing", 0.01, 1e-5, stiffness=-1.0)
    # a scene name and a builder work like the model
    by_name = design.contact_loss("slider_yoke", "bearing", 0.1, 1e-5, parameters={"clearance": 1e-4})
    by_model = design.contact_loss(yoke, "bearing", 0.1, 1e-5)
    assert by_name.intervals == by_model.intervals


def test_contact_loss_plot(yoke):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pred = design.contact_loss(yoke, "bearing", 0.1, 1e-5)
    fig = pred.plot()
    assert len(fig.axes) == 2
    plt.close(fig)
    assert "intervals=" in repr(pred)
