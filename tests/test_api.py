"""The Python API: building models, recording, errors, interruption."""

import signal

import flexclear
import numpy as np
import pytest
from flexclear import InvalidParameterError, Record, motion


def small_model(**joint):
    m = flexclear.Model()
    m.add_body("ground")
    m.add_link(
        "beam",
        length=0.5,
        elements=4,
        youngs_modulus=2e11,
        density=7800.0,
        area=1e-4,
        inertia=1e-9,
        motion=motion.harmonic((0.0, 0.001), 10.0),
    )
    kw = dict(clearance=1e-4, stiffness=1e6, damping=50.0, body="ground")
    kw.update(joint)
    m.add_joint("pin", "beam", 0, **kw)
    return m


def test_default_record_and_result_arrays():
    res = flexclear.scenes.slider_yoke(clearance=1e-5).simulate(0.01, 1e-5)
    j = res.joint("bearing")
    assert res.time.shape == j.penetration.shape == j.force.shape == (1001,)
    assert res.time[-1] == pytest.approx(0.01)
    assert j.penetration[0] == pytest.approx(-1e-5)  # starts centred in the bearing
    assert np.all(j.force >= 0)
    assert res.stats["steps"] == 1000 and res.stats["factorizations"] == 1


def test_record_nodes_every_and_start():
    model = flexclear.scenes.slider_yoke(clearance=1e-5)
    res = model.simulate(
        0.01, 1e-5, record=Record(nodes=[("slider", 12)], every=10, start=0.005, position=True)
    )
    assert res.time[0] >= 0.005 and res.time.size == 51
    n = res.node("slider", 12)
    assert n.v.shape == res.time.shape
    # the free end moves opposite to the yoke (pivoting about the bearing) by about 0.5 Y
    j = res.joint("bearing")
    assert j.qx.shape == res.time.shape
    with pytest.raises(InvalidParameterError):
        res.node("slider", 3)


def test_hand_built_model_runs_and_matches_scene_shape():
    res = small_model().simulate(0.05, 1e-5)
    assert res.complete and res.joint("pin").penetration.size == 5001


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(length=0.0), "length"),
        (dict(length=float("nan")), "length"),
        (dict(youngs_modulus=-1.0), "youngs_modulus"),
        (dict(density=0.0), "density"),
        (dict(area=float("inf")), "area"),
        (dict(inertia=0.0), "inertia"),
        (dict(elements=0), "elements"),
        (dict(elements=1_000_001), "elements"),
    ],
)
def test_bad_link_parameters_name_the_parameter(kwargs, name):
    base = dict(length=0.5, elements=4, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-9)
    base.update(kwargs)
    with pytest.raises(InvalidParameterError) as info:
        flexclear.Model().add_link("b", **base)
    assert isinstance(info.value, ValueError) and isinstance(info.value, flexclear.FlexclearError)
    assert name in info.value.parameter and ">" in info.value.allowed or "integer" in info.value.allowed


@pytest.mark.parametrize(
    "joint, name",
    [
        (dict(clearance=-1e-3), "clearance"),
        (dict(stiffness=-1.0), "stiffness"),
        (dict(damping=-2.0), "damping"),
    ],
)
def test_bad_joint_parameters(joint, name):
    with pytest.raises(InvalidParameterError) as info:
        small_model(**joint)
    assert name in info.value.parameter


def test_joint_on_missing_node():
    m = flexclear.Model().add_body("g")
    m.add_link("b", length=0.5, elements=4, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-9)
    with pytest.raises(InvalidParameterError, match="node") as info:
        m.add_joint("j", "b", 5, clearance=0, stiffness=1, damping=0, body="g")
    assert "0 ..= 4" in str(info.value)
    with pytest.raises(flexclear.ModelError, match="unknown link"):
        m.add_joint("j", "nope", 0, clearance=0, stiffness=1, damping=0, body="g")


@pytest.mark.parametrize(
    "args, kwargs, name",
    [
        ((0.1, 0.0), {}, "dt"),
        ((0.1, -1e-5), {}, "dt"),
        ((-0.1, 1e-5), {}, "t_end"),
        ((float("inf"), 1e-5), {}, "t_end"),
        ((0.1, 1.0), {}, "dt"),
        ((0.1, 1e-5), {"method": "explicit"}, "method"),
        ((0.1, 1e-5), {"beta": 0.0}, "beta"),
        ((0.1, 1e-5), {"record": {"every": 0}}, "every"),
    ],
)
def test_bad_run_parameters(args, kwargs, name):
    with pytest.raises(InvalidParameterError) as info:
        flexclear.scenes.slider_yoke().simulate(*args, **kwargs)
    assert name in str(info.value)


def test_scene_overrides_and_derived_defaults():
    m = flexclear.scenes.slider_yoke(clearance=1e-4, bearing_stiffness=5e6)
    p = m.parameters
    assert p["bearing_stiffness"] == 5e6
    # C_B follows the overridden K_B: 2 * 0.5 * sqrt(K_B m / 4)
    assert p["bearing_damping"] == pytest.approx(np.sqrt(5e6 * p["mass"] / 4))
    d = flexclear.scenes.slider_yoke().parameters
    assert d["bearing_stiffness"] == pytest.approx(1.21e6, rel=0.01)
    assert d["bearing_damping"] == pytest.approx(321, rel=0.01)
    assert d["youngs_modulus"] == pytest.approx(186.8e9, rel=0.001)
    with pytest.raises(InvalidParameterError):
        flexclear.scenes.slider_yoke(geometry="middle")


def test_progress_callback_and_ctrl_c_keep_partial_result():
    model = flexclear.scenes.slider_yoke(clearance=1e-5)
    seen = []

    def progress(frac):
        seen.append(frac)
        if frac > 0.3:
            signal.raise_signal(signal.SIGINT)

    with pytest.raises(flexclear.SimulationInterrupted) as info:
        model.simulate(0.5, 1e-6, progress=progress)
    assert isinstance(info.value, KeyboardInterrupt)
    r = info.value.result
    assert not r.complete and 0.1 < r.end_time < 0.5 and r.time.size > 100_000
    assert seen == sorted(seen)


def test_deterministic():
    m = flexclear.scenes.slider_yoke(clearance=1e-4)
    a = m.simulate(0.05, 1e-5).joint("bearing").penetration
    b = m.simulate(0.05, 1e-5).joint("bearing").penetration
    assert np.array_equal(a, b)


def test_tabulated_motion_matches_harmonic():
    t = np.linspace(0, 0.06, 60001)
    y = 0.01 * np.sin(2 * np.pi * 6 * t)
    w = 2 * np.pi * 6
    tab = motion.tabulated(
        t, np.c_[0 * t, y], np.c_[0 * t, 0.01 * w * np.cos(w * t)], np.c_[0 * t, -w * w * y]
    )
    h = motion.harmonic((0.0, 0.01), 6.0)
    for tt in (0.0, 0.0123, 0.05):
        for a, b in zip(tab.at(tt), h.at(tt)):
            assert a == pytest.approx(b, abs=1e-6)
    with pytest.raises(InvalidParameterError):
        motion.tabulated([0.0, 0.0], [[0, 0], [0, 1]])


def test_gap_method_and_iterated_kappa_run():
    m = flexclear.scenes.slider_yoke(clearance=1e-4)
    g = m.simulate(0.1, 1e-5, "gap")
    it = m.simulate(0.1, 1e-5, "modified", iterate=True)
    assert g.complete and it.complete and it.stats["iterations"] >= it.stats["steps"]
