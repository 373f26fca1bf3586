"""Differential test of the two steppers: the slider-yoke run by Newton on the moving-frame
equations (``stepper="newton"``: left to itself, the plan runs it on the constant stepper, also
when it is written with moving frames, each a rotating frame at a fixed angle translating with
the yoke, see the last tests) agrees with the constant stepper (one factorization, Woodbury
contact) on the same model.

Both integrate the same equations with the same Newmark scheme and the same contact law; they
differ in the order of the floating-point operations only (a sparse LDL^T with a low-rank contact
correction against a band LU of the full Jacobian), so the penetration histories agree to
round-off amplified by the dynamics: over the first 20 ms (the first impacts) to 1e-9 of the
peak penetration, with equal impact counts; over 0.2 s (many impacts, where round-off grows with
each one) the extremes to 1e-6. This test stays after the engine merge as the check that the
stepper kinds agree: the Newton-family runs go through both ``stepper="newton"`` and
``stepper="constant-rate"`` (the yoke's frames translate at a fixed angle: its contact-free
Jacobian is constant, factorized once, the contact by Woodbury on the band LU).
"""

from __future__ import annotations

import math

import flexclear as fc
import numpy as np
import pytest
from flexclear import motion


def both(clearance: float = 1e-4, **scene):
    """The slider-yoke scene twice: one run on the constant stepper, one on Newton."""
    a, b = (fc.scenes.slider_yoke(clearance=clearance, **scene) for _ in range(2))
    assert (a.engine, b.engine) == ("translating", "translating")
    return a, b


def by_frames(clearance: float = 1e-4) -> fc.Model:
    """The slider-yoke (geometry "end") written by hand with moving frames: the link and the
    yoke each on a rotating frame at a fixed angle 0 whose origin follows the yoke's motion, the
    inertia load of that motion asked for by name, the initial velocity of the scene."""
    p = fc.scenes.slider_yoke(clearance=clearance).parameters
    length, n, amp, freq = p["length"], p["elements"], p["amplitude"], p["frequency"]
    frame = fc.Frame.rotating(fc.Rotation.fixed(0.0), origin=motion.harmonic((0.0, amp), freq))
    rate = -1.5 * (amp * 2.0 * math.pi * freq) / length
    v0 = np.zeros(3 * (n + 1))
    for i in range(n + 1):
        v0[3 * i + 1] = rate * (length * i / n)
        v0[3 * i + 2] = rate
    m = fc.Model()
    m.add_body("yoke", frame=frame)
    m.add_link(
        "slider",
        length=length,
        elements=n,
        youngs_modulus=p["youngs_modulus"],
        density=p["density"],
        area=p["area"],
        inertia=p["inertia"],
        damping=p["eta"],
        frame=frame,
        inertia_load=True,
        initial_velocity=v0,
    )
    m.add_joint(
        "bearing",
        "slider",
        0,
        body="yoke",
        clearance=clearance,
        stiffness=p["bearing_stiffness"],
        damping=p["bearing_damping"],
    )
    return m


# the settings of both runs: the same coupling, iteration tolerance and cap
SETTINGS = {
    "modified, lagged kappa": dict(method="modified", iterate=False),
    "force": dict(method="force"),
}

# One contact evaluation (rust/contact/evaluation.rs, docs/contact.md): the recorded force is the
# force applied in the step (for lagged kappa the terms of the step start at the state reached:
# zero in the step that closes the gap), and iterate=True is one algorithm (spring and damping at
# the iterate, Newton on the spring) on both steppers.
ITERATED = dict(method="modified", iterate=True, iter_tol=1e-10, max_iter=50)


# the stepper kinds that can take the yoke besides the constant one
MOVING_STEPPERS = ["newton", "constant-rate"]


@pytest.mark.parametrize("stepper", MOVING_STEPPERS)
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_first_impacts_agree_to_1e9(setting, stepper):
    kw = SETTINGS[setting]
    a, b = both()
    rb = b.simulate(0.02, 1e-5, **kw, stepper=stepper)
    assert rb.stats["stepper"] == stepper
    if stepper == "constant-rate":
        # the mass matrix, then the contact-free effective matrix: once for the run
        assert rb.stats["factorizations"] == 2
    ja, jb = a.simulate(0.02, 1e-5, **kw).joint("bearing"), rb.joint("bearing")
    assert ja.impacts == jb.impacts >= 2
    err = np.max(np.abs(ja.penetration - jb.penetration)) / np.max(np.abs(ja.penetration))
    assert err <= 1e-9, f"{setting}: {err:.3g}"


@pytest.mark.parametrize("stepper", MOVING_STEPPERS)
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_longer_runs_agree_on_the_extremes(setting, stepper):
    kw = SETTINGS[setting]
    a, b = both()
    rec = fc.Record(histories=False)
    ja = a.simulate(0.2, 1e-5, record=rec, **kw).joint("bearing")
    jb = b.simulate(0.2, 1e-5, record=rec, **kw, stepper=stepper).joint("bearing")
    assert ja.impacts == jb.impacts
    assert ja.max_penetration == pytest.approx(jb.max_penetration, rel=1e-6)


def test_both_ends_geometry_agrees():
    # two bearings (one per end) exercise joints on several nodes of one link
    a, b = both(geometry="both_ends")
    ra, rb = a.simulate(0.02, 1e-5), b.simulate(0.02, 1e-5, stepper="newton")
    for name in ("bearing", "bearing_2"):
        pa, pb = ra.joint(name).penetration, rb.joint(name).penetration
        assert np.max(np.abs(pa - pb)) <= 1e-9 * np.max(np.abs(pa))


def test_recorded_forces_agree():
    a, b = both()
    kw = SETTINGS["modified, lagged kappa"]
    fa, fb = (
        a.simulate(0.02, 1e-5, **kw).joint("bearing").force,
        b.simulate(0.02, 1e-5, **kw, stepper="newton").joint("bearing").force,
    )
    assert np.max(np.abs(fa - fb)) <= 1e-9 * np.max(fa)


@pytest.mark.parametrize("stepper", MOVING_STEPPERS)
def test_iterated_contact_agrees(stepper):
    a, b = both()
    pa = a.simulate(0.02, 1e-5, **ITERATED).joint("bearing").penetration
    pb = b.simulate(0.02, 1e-5, **ITERATED, stepper=stepper).joint("bearing").penetration
    assert np.max(np.abs(pa - pb)) <= 1e-9 * np.max(np.abs(pa))


def test_left_to_itself_the_moving_model_runs_on_the_constant_stepper_bitwise():
    # the stepper is chosen from the model, not from how it was built
    a, b = fc.scenes.slider_yoke(clearance=1e-4), by_frames()
    assert (a.engine, b.engine) == ("translating", "translating")
    rec = fc.Record(displacements=True, midspan=True, axial_force=True)
    ra, rb = a.simulate(0.02, 1e-5, record=rec), b.simulate(0.02, 1e-5, record=rec)
    assert (ra.stats["stepper"], rb.stats["stepper"]) == ("constant", "constant")
    ja, jb = ra.joint("bearing"), rb.joint("bearing")
    assert np.array_equal(ja.penetration, jb.penetration) and np.array_equal(ja.force, jb.force)
    assert ja.max_force == jb.max_force and ja.impacts == jb.impacts
    # the link channels come in the moving-frame layout, equal to the translating ones
    la, lb = ra.link(a.link_names[0]), rb.link(b.link_names[0])
    assert la.v.shape == (ra.time.size, 13)
    for channel in ("u", "v", "theta", "frame", "midspan"):
        assert np.array_equal(getattr(la, channel), getattr(lb, channel)), channel
    # the axial force E A du / l: the same numbers up to the order of the product (1 ulp)
    assert np.allclose(la.axial_force, lb.axial_force, rtol=1e-15, atol=1e-9 * np.abs(la.axial_force).max())
    # asked for, the constant stepper is refused where the model needs Newton, saying why;
    # with gravity the yoke's Jacobian is still constant: the constant-rate stepper runs it
    b.add_gravity(0.0, -9.81)
    with pytest.raises(fc.InvalidParameterError, match="stepper.*gravity"):
        b.simulate(0.002, 1e-5, stepper="constant")
    assert b.simulate(0.002, 1e-5).stats["stepper"] == "constant-rate"
    assert b.simulate(0.002, 1e-5, stepper="newton").stats["stepper"] == "newton"


def test_the_gap_element_and_the_refactor_solver_run_on_a_moving_model_planned_as_constant():
    # the gap element and the refactorizing solver are the constant stepper's: a moving-frame
    # model that plans as constant takes them, bitwise as its translating form; one that needs
    # Newton refuses the gap element by name
    a, b = fc.scenes.slider_yoke(clearance=1e-4), by_frames()
    for kw in (dict(method="gap"), dict(solver="refactor")):
        ja = a.simulate(0.02, 1e-5, **kw).joint("bearing")
        jb = b.simulate(0.02, 1e-5, **kw).joint("bearing")
        assert np.array_equal(ja.penetration, jb.penetration) and ja.impacts == jb.impacts > 0
    b.add_gravity(0.0, -9.81)
    with pytest.raises(fc.InvalidParameterError, match="gap"):
        b.simulate(0.002, 1e-5, method="gap")
