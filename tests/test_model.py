"""One model class for every mechanism: the builder moves itself to the moving-frame formulation
when it must, one simulate, one Result (picklable, pandas), natural frequencies in Hz everywhere,
the same exception class for the same mistake."""

from __future__ import annotations

import math
import pickle

import flexclear as fc
import numpy as np
import pytest
from flexclear import Frame, Model, Record, Rotation, motion, scenes

STEEL = dict(youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-9)


def translating_model() -> Model:
    # a beam and a body ("ground", the bearing) shaken together by 1 mm at 10 Hz
    m = Model()
    m.add_body("ground", motion=motion.harmonic((0.0, 1e-3), 10.0))
    m.add_link("beam", length=0.5, elements=4, motion=motion.harmonic((0.0, 1e-3), 10.0), **STEEL)
    m.add_joint("pin", "beam", 0, body="ground", clearance=1e-4, stiffness=1e6, damping=50.0)
    return m


def test_scenes_all_return_models():
    for build in (
        scenes.slider_yoke,
        scenes.slider_yoke_stiff,
        scenes.spin_up,
        scenes.slider_crank,
        scenes.four_bar,
    ):
        assert isinstance(build(), Model)
    assert not hasattr(fc, "Mechanism") and not hasattr(fc, "MechanismResult")


def test_engine_follows_the_features_used():
    m = translating_model()
    assert m.engine == "translating"
    m.add_gravity(0.0, -9.81)  # only the moving-frame formulation has gravity
    assert m.engine == "moving-frame"
    assert m.body_names == ["ground"] and m.joint_names == ["pin"]
    # the body built before the move keeps working for joints added after it
    m.add_link("arm", length=0.2, elements=2, motion=motion.harmonic((0.0, 1e-3), 10.0), **STEEL)
    m.add_pin("root", "arm", 0, body="ground", point=(0.0, 0.0))
    res = m.simulate(0.002, 1e-5)
    assert res.stats["engine"] == "moving-frame" and res.complete


def test_moving_the_model_keeps_its_dynamics():
    # The same translating model written twice (the second with a term switch that changes
    # nothing: inertia_load=True is what the automatic choice gives a moving frame) plans as
    # constant both times; run by the Newton stepper on the moving-frame equations, it keeps the
    # motion of the constant stepper.
    a = translating_model()
    b = Model()
    b.add_body("ground", motion=motion.harmonic((0.0, 1e-3), 10.0))
    b.add_link(
        "beam", length=0.5, elements=4, motion=motion.harmonic((0.0, 1e-3), 10.0), inertia_load=True, **STEEL
    )
    b.add_joint("pin", "beam", 0, body="ground", clearance=1e-4, stiffness=1e6, damping=50.0)
    assert (a.engine, b.engine) == ("translating", "translating")
    ra = a.simulate(0.02, 1e-5, iterate=False)
    rb = b.simulate(0.02, 1e-5, iterate=False, stepper="newton")
    assert (ra.stats["stepper"], rb.stats["stepper"]) == ("constant", "newton")
    pa, pb = ra.joint("pin").penetration, rb.joint("pin").penetration
    assert ra.joint("pin").impacts == rb.joint("pin").impacts > 0
    np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-9 * np.max(np.abs(pa)))


def test_one_result_type_with_the_same_joint_fields():
    r1 = scenes.slider_yoke(clearance=1e-4).simulate(0.01, 1e-5)
    r2 = scenes.slider_crank(clearance_at="crank_pin").simulate(0.002, 1e-5)
    assert type(r1) is type(r2) is fc.Result
    j1, j2 = r1.joint("bearing"), r2.joint("crank_pin")
    assert type(j1) is type(j2) is fc.JointResult
    assert j2.penetration.shape == r2.time.shape
    assert r1.stats["engine"] == "translating" and r2.stats["engine"] == "moving-frame"
    for key in ("steps", "factorizations", "iterations", "event_steps", "iterate", "iter_tol", "max_iter"):
        assert key in r1.stats and key in r2.stats


def test_iterate_default_is_implicit_only_where_a_joint_rotates():
    assert not scenes.slider_yoke(clearance=1e-4).simulate(0.001, 1e-5).stats["iterate"]
    assert scenes.slider_crank(clearance_at="crank_pin").simulate(0.001, 1e-5).stats["iterate"]
    assert (
        not scenes.slider_crank(clearance_at="crank_pin")
        .simulate(1e-4, 1e-5, method="force")
        .stats["iterate"]
    )
    # the validated defaults of each engine, recorded
    assert scenes.slider_yoke().simulate(0.001, 1e-5).stats["iter_tol"] == 1e-10
    assert scenes.slider_crank().simulate(0.001, 1e-5).stats["iter_tol"] == 1e-8


def test_result_pickles_and_goes_to_pandas():
    r = scenes.slider_yoke(clearance=1e-4).simulate(
        0.005, 1e-5, record=Record(nodes=[("slider", 6)], position=True, impact_log=True)
    )
    back = pickle.loads(pickle.dumps(r))
    np.testing.assert_array_equal(back.joint("bearing").force, r.joint("bearing").force)
    assert back.joint("bearing").max_force == r.joint("bearing").max_force
    df = r.to_pandas()
    assert df.index.name == "time" and len(df) == r.time.size
    np.testing.assert_array_equal(df["bearing.penetration"].to_numpy(), r.joint("bearing").penetration)
    np.testing.assert_array_equal(df["slider[6].v"].to_numpy(), r.node("slider", 6).v)
    # a partial result of a failed run pickles too, with its error's class and message
    fail = scenes.spin_up(geometric=False).simulate(20.0, 1e-2, raise_on_failure=False)
    assert not fail.complete
    back = pickle.loads(pickle.dumps(fail))
    assert isinstance(back.error, fc.SimulationDivergedError) and str(back.error) == str(fail.error)


def test_link_channels_of_a_translating_model():
    # The translating slider: its frame translates with the yoke (angle 0, rate 0); the link's
    # displacements are the node histories; the axial force is E A du/dx per element.
    m = scenes.slider_yoke(clearance=1e-4)
    r = m.simulate(0.005, 1e-5, record=Record(displacements=True, midspan=True, axial_force=True))
    lr = r.link("slider")
    p = m.parameters
    assert lr.u.shape == (r.time.size, 13) and lr.axial_force.shape == (r.time.size, 12)
    y = p["amplitude"] * np.sin(2 * np.pi * p["frequency"] * r.time)
    np.testing.assert_allclose(lr.frame[:, 1], y, atol=1e-15)
    assert np.all(lr.frame[:, 2:] == 0.0)
    np.testing.assert_array_equal(lr.v[:, 6], r.node("slider", 6).v)
    ea, le = p["youngs_modulus"] * p["area"], p["length"] / 12
    np.testing.assert_allclose(lr.axial_force[:, 3], ea * (lr.u[:, 4] - lr.u[:, 3]) / le, rtol=1e-12)
    # 12 elements: mid-length is node 6, so the midspan deflection is v6 - (v0 + v12) / 2
    np.testing.assert_allclose(lr.midspan, lr.v[:, 6] - 0.5 * (lr.v[:, 0] + lr.v[:, 12]), atol=1e-18)


@pytest.mark.parametrize(
    "build",
    [
        lambda: scenes.slider_yoke(clearance=1e-4),
        lambda: scenes.spin_up(),
        lambda: scenes.slider_crank(),
        lambda: scenes.slider_crank(clearance_at="crank_pin"),
        lambda: scenes.slider_crank(clearance_at="slider_pin"),
        lambda: scenes.four_bar(),
        lambda: scenes.four_bar(clearance_at="crank_pin"),
        lambda: scenes.four_bar(clearance_at="rocker_pin"),
        lambda: scenes.four_bar(flexible_rocker=True, clearance_at="rocker_pin"),
    ],
)
def test_natural_frequencies_in_hz_on_every_scene(build):
    f = build().natural_frequencies(3)
    assert f.shape == (3,) and np.all(np.isfinite(f)) and np.all(np.diff(f) > 0) and f[0] > 0


def test_natural_frequencies_are_hz_in_both_engines():
    # Clamped-free cantilever (10 elements): first bending frequency (1.8751^2 / 2 pi) sqrt(EI /
    # rho A L^4) Hz, from above within 1e-5 (h^4 convergence); the moving-frame model at rest.
    m = scenes.spin_up(elements=10, rotation=Rotation.constant(0.0))
    p = m.parameters
    w_ref = math.sqrt(p["youngs_modulus"] * p["inertia"] / (p["density"] * p["area"] * p["length"] ** 4))
    exact = 1.875104068711961**2 * w_ref / (2 * math.pi)
    assert m.natural_frequencies(1)[0] == pytest.approx(exact, rel=1e-5)
    # the slider-yoke's first free-free frequency is its design value, 880 Hz
    assert scenes.slider_yoke().natural_frequencies(1)[0] == pytest.approx(880.0, rel=1e-3)


def test_same_mistake_same_exception_class():
    m = translating_model()
    for call in (
        lambda: m.add_joint("j2", "nope", 0, body="ground", clearance=0.0, stiffness=1.0, damping=0.0),
        lambda: m.add_joint("j2", "beam", 0, body="nope", clearance=0.0, stiffness=1.0, damping=0.0),
        lambda: m.add_link("beam", length=1.0, elements=1, **STEEL),
        lambda: m.simulate(0.001, 1e-5).joint("nope"),
        lambda: m.simulate(0.001, 1e-5).link("nope"),
    ):
        with pytest.raises(fc.ModelError):
            call()
    mech = scenes.slider_crank()
    for call in (
        lambda: mech.add_clamp("nope", 0),
        lambda: mech.add_link("rod", length=1.0, elements=1, **STEEL),
        lambda: mech.simulate(0.001, 1e-5).joint("nope"),
        lambda: mech.simulate(0.001, 1e-5).link("nope"),
    ):
        with pytest.raises(fc.ModelError):
            call()
    with pytest.raises(fc.InvalidParameterError, match="method"):
        mech.simulate(0.001, 1e-5, method="gap")
    with pytest.raises(fc.InvalidParameterError, match="step_halving"):
        m.simulate(0.001, 1e-5, step_halving=2)


def test_a_stop_fixed_in_space_beside_a_moving_link():
    # The translating link oscillates 1 mm against a stop fixed in space 0.5 mm away (in the
    # translating formulation, which has always allowed different nominal motions).
    m = Model()
    m.add_body("stop", motion=motion.fixed((0.0, 0.0)))
    m.add_link("beam", length=0.5, elements=4, motion=motion.harmonic((0.0, 1e-3), 10.0), **STEEL)
    m.add_joint("hit", "beam", 0, body="stop", clearance=5e-4, stiffness=1e7, damping=10.0)
    r = m.simulate(0.05, 1e-5)
    j = r.joint("hit")
    assert j.impacts >= 1 and j.max_penetration > 0


def test_four_bar_clearance_at_a_coupler_pin():
    fb = scenes.four_bar(clearance_at="rocker_pin")
    assert fb.joint_names == ["rocker_pin"]
    p = fb.parameters
    assert p["bearing_stiffness"] > 0 and p["bearing_damping"] > 0 and p["clearance"] == 2.5e-4
    r = fb.simulate(0.01, 1e-5)
    j = r.joint("rocker_pin")
    assert r.complete and j.impacts >= 1 and np.isfinite(j.max_force)
    with pytest.raises(fc.InvalidParameterError, match="clearance_at"):
        scenes.four_bar(clearance_at="piston")


def test_frames_and_rotations_are_public():
    f = Frame.rotating(Rotation.constant(2.0))
    assert f.rotates and not Frame.rotating(Rotation.fixed(0.3)).rotates


def test_moving_frame_joints_report_every_field_from_their_own_histories():
    # The slider-crank's crank pin (moving frames): the extremes the shared recorder adds agree
    # with the recorded histories of the same run (every step recorded).
    r = scenes.slider_crank(clearance_at="crank_pin").simulate(
        0.01, 1e-5, record=Record(position=True, impact_log=True)
    )
    j = r.joint("crank_pin")
    pen, force = j.penetration, j.force
    assert j.rms_force == pytest.approx(np.sqrt(np.mean(force**2)), rel=1e-12)
    assert j.rms_penetration == pytest.approx(np.sqrt(np.mean(pen**2)), rel=1e-12)
    assert j.contact_time == pytest.approx(1e-5 * np.count_nonzero(pen[1:] > 0), rel=1e-9)
    assert j.time_of_max_penetration == r.time[np.argmax(pen)]
    assert len(j.impact_log) == j.impacts > 0 and np.all(np.diff(j.impact_log.time) > 0)
    np.testing.assert_allclose(np.hypot(j.qx, j.qy) - 5e-4, pen, rtol=0, atol=1e-15)  # clearance 0.5 mm
    assert 0 < j.max_impact_velocity <= j.max_velocity
    # extremes from a later start count fewer impacts; histories can be switched off
    late = scenes.slider_crank(clearance_at="crank_pin").simulate(
        0.01, 1e-5, record=Record(start=0.005, histories=False)
    )
    lj = late.joint("crank_pin")
    assert lj.impacts < j.impacts and not lj.recorded("penetration")
    with pytest.raises(fc.RecordingError, match=r"Record\(histories=False\)"):
        _ = lj.penetration


def _stop_model(moving: bool) -> Model:
    # A beam shaken 1 mm at 10 Hz; its end node strikes a stop fixed in space 0.5 mm away.
    m = Model()
    m.add_body("stop", motion=motion.fixed((0.0, 0.0)))
    terms = {"inertia_load": True} if moving else {}
    m.add_link("beam", length=0.5, elements=4, motion=motion.harmonic((0.0, 1e-3), 10.0), **terms, **STEEL)
    m.add_joint("hit", "beam", 0, body="stop", clearance=5e-4, stiffness=1e7, damping=10.0)
    return m


def test_a_stop_fixed_in_space_beside_a_moving_link_in_both_steppers():
    # The two sides have different nominal motions: the moving-frame stepper measures the full
    # relative position (nominal + elastic) as the translating one always has. Same coupling
    # settings: the penetration histories agree to 1e-9 of their peak, impacts are equal.
    a, b = _stop_model(False), _stop_model(True)
    assert (a.engine, b.engine) == ("translating", "translating")
    ja = a.simulate(0.05, 1e-5, iterate=False).joint("hit")
    jb = b.simulate(0.05, 1e-5, iterate=False, stepper="newton").joint("hit")
    assert ja.impacts == jb.impacts >= 1 and ja.max_penetration > 0
    err = np.max(np.abs(ja.penetration - jb.penetration)) / np.max(np.abs(ja.penetration))
    assert err <= 1e-9, err


def test_a_rocking_link_meets_a_fixed_bearing_when_the_geometry_says():
    # A 0.5 m link rocking about its clamped root, phi = 0.01 sin(2 pi 5 t) rad; its tip sits in
    # a bearing fixed in space at the tip's rest position (0.5, 0) m with 1 mm radial clearance.
    # The tip's nominal distance from the bearing centre is 2 L sin(phi / 2), so contact starts
    # where phi = 2 asin(c / 2 L), at t = asin(phi / 0.01) / (2 pi 5). The link is stiff (I = 1e-7
    # m^4): the inertial bending at the tip is about rho A a L^4 / (8 E I) = 0.3 um, 2 us of its
    # 0.15 m/s approach (with I = 1e-9 it is 30 um and the contact comes 40 us early).
    m = Model()
    m.add_body("bearing", motion=motion.fixed((0.5, 0.0)))
    rock = Rotation.harmonic(0.01, 5.0)
    m.add_link("arm", length=0.5, elements=4, frame=Frame.rotating(rock), **{**STEEL, "inertia": 1e-7})
    m.add_clamp("arm", 0)
    m.add_joint("tip", "arm", 4, body="bearing", clearance=1e-3, stiffness=1e8, damping=100.0)
    r = m.simulate(0.03, 1e-5, record=Record(impact_log=True))
    log = r.joint("tip").impact_log
    assert len(log) >= 1
    first = np.arcsin(2 * np.arcsin(1e-3 / (2 * 0.5)) / 0.01) / (2 * np.pi * 5.0)
    assert log.time[0] == pytest.approx(first, abs=1.5e-5)  # within the step and a half


def test_natural_frequencies_leave_every_clearance_joint_open():
    # A clamped cantilever whose tip sits 1 mm from a stiff bearing's centre with 0.5 mm
    # clearance (nominally pressed in): its frequencies are the cantilever's alone.
    def cantilever(with_joint: bool) -> Model:
        m = Model()
        m.add_link("beam", length=0.5, elements=6, frame=Frame.rotating(Rotation.fixed(0.0)), **STEEL)
        m.add_clamp("beam", 0)
        if with_joint:
            m.add_body("stop", motion=motion.fixed((0.5, 1e-3)))
            m.add_joint("tip", "beam", 6, body="stop", clearance=5e-4, stiffness=1e9, damping=0.0)
        return m

    np.testing.assert_allclose(
        cantilever(True).natural_frequencies(3), cantilever(False).natural_frequencies(3), rtol=1e-12
    )


def test_one_output_layout_for_both_steppers():
    # the same model through both steppers: the same stats keys, the stepper named, and the final
    # state of the moving-frame run is its unknowns (dof_map order), equal to the last record
    a = translating_model()
    b = translating_model()
    b.add_gravity(0.0, 0.0)  # moves it to the moving-frame formulation, same dynamics
    ra, rb = a.simulate(0.002, 1e-5), b.simulate(0.002, 1e-5, stepper="newton")
    # left to itself the plan runs b on the constant stepper: nothing in it needs Newton
    assert b.simulate(0.002, 1e-5).stats["stepper"] == "constant"
    assert set(ra.stats) == set(rb.stats)
    assert (ra.stats["stepper"], rb.stats["stepper"]) == ("constant", "newton")
    assert ra.stats["unknowns"] == 15 and ra.stats["bandwidth"] == 0
    dofs = b.dof_map()
    assert rb.stats["unknowns"] == len(dofs) and rb.stats["bandwidth"] > 0
    beam = rb.link("beam")
    last = {"u": beam.u[-1], "v": beam.v[-1], "theta": beam.theta[-1]}  # per node, link frame
    for i, (link, node, comp) in enumerate(dofs):
        assert link == 0 and comp in last
        assert rb.state[0][i] == last[comp][node]
    # the two steppers agree on the end state (same equations, other round-off)
    assert np.allclose(rb.state[0], ra.state[0][[3 * n + "uvt".index(c[0]) for _, n, c in dofs]], atol=1e-12)


def test_rotary_inertia_runs_on_the_constant_stepper_in_either_form():
    def build(rotary_inertia: bool = True) -> Model:
        m = Model()
        m.add_body("ground", motion=motion.harmonic((0.0, 1e-3), 10.0))
        m.add_link("beam", length=0.5, elements=4, rotary_inertia=rotary_inertia, **STEEL)
        m.add_joint(
            "pin", "beam", 4, body="ground", point=(0.5, 0.0), clearance=1e-4, stiffness=1e6, damping=50.0
        )
        return m

    a, b = build(), build()
    b.add_gravity(0.0, 0.0)  # the moving-frame form of the same model
    ra, rb = a.simulate(0.005, 1e-5), b.simulate(0.005, 1e-5)
    assert (ra.stats["stepper"], rb.stats["stepper"]) == ("constant", "constant")
    assert np.array_equal(ra.joint("pin").penetration, rb.joint("pin").penetration)
    # rotary inertia changes the dynamics (the check above is not vacuous)
    rc = build(rotary_inertia=False).simulate(0.005, 1e-5)
    assert not np.array_equal(ra.joint("pin").penetration, rc.joint("pin").penetration)
    b.add_gravity(0.0, -9.81)  # now only the Newton stepper can run it, which has no rotary inertia
    with pytest.raises(fc.ModelError, match='link "beam" has rotary inertia.*constant stepper'):
        b.simulate(0.005, 1e-5)


def test_energies_of_a_translating_model_come_from_the_newton_stepper():
    # energies need the velocities, which the constant stepper does not record: asked for, the
    # model runs on the moving-frame equations (the constant-rate stepper: its frames translate
    # at a fixed angle, so their Jacobian is constant); at t = 0 the link moves rigidly with its
    # frame (v = A w = 2 pi 10 Hz x 1 mm), so its kinetic energy is m v^2 / 2 exactly
    m = translating_model()
    res = m.simulate(0.01, 1e-5, record=Record(energy=True))
    assert m.engine == "translating" and res.stats["stepper"] == "constant-rate"
    beam = res.link("beam")
    mass = STEEL["density"] * STEEL["area"] * 0.5
    assert beam.kinetic[0] == pytest.approx(0.5 * mass * (2 * math.pi * 10 * 1e-3) ** 2, rel=1e-12)
    assert np.all(np.isfinite(beam.kinetic)) and np.all(np.isfinite(beam.strain))
    with pytest.raises(fc.InvalidParameterError, match="record.energy"):
        m.simulate(0.01, 1e-5, record=Record(energy=True), stepper="constant")


def _spinning_beam_without_stiffening():
    # a link turning at a constant rate without geometric terms: the constant-rate stepper
    m = fc.Model()
    frame = fc.Frame.rotating(fc.Rotation.constant(10.0))
    m.add_link(
        "L", length=0.5, elements=4, youngs_modulus=2e11, density=7800, area=1e-4, inertia=1e-9,
        frame=frame, geometric=False,
    )  # fmt: skip
    m.add_support("L", 0)
    return m


def test_the_engine_follows_the_planned_stepper():
    # Model.engine reads the core's `translates` (the model's translating form alone) instead of
    # compiling a plan for `stepper` at every simulate call (0.25 ms of a short slider-crank
    # run); the two agree: the plan runs a model on the constant stepper exactly when it
    # translates
    models = [
        fc.scenes.slider_yoke(),
        fc.scenes.slider_yoke_stiff(),
        fc.scenes.slider_crank(),
        fc.scenes.slider_crank(clearance_at="crank_pin"),
        fc.scenes.four_bar(clearance_at="rocker_pin"),
        fc.scenes.flores_slider_crank(),
        fc.scenes.spin_up(),
        _spinning_beam_without_stiffening(),
    ]
    kinds = [(m._core.translates, m._core.stepper) for m in models]
    assert all(t == (s == "constant") for t, s in kinds)
    assert {s for _, s in kinds} >= {"constant", "newton", "constant-rate"}
    assert [m.engine for m in models[:3]] == ["translating", "translating", "moving-frame"]
