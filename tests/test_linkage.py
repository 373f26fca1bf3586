"""Linkages of one's own (flexclear.linkage.Linkage): the loop closures solved for the links'
frames, checked against the closed-form frames of the four-bar and the slider-crank, and a
six-bar of two four-bars in series (a ternary rocker) run with a clearance joint."""

from __future__ import annotations

import math

import flexclear as fc
import numpy as np
import pytest
from flexclear import Frame, Rotation
from flexclear.linkage import Linkage

DRIVER = Rotation.constant(100.0)  # rad/s
#: The flexible links' section (aluminium, m^2, m^4) and the clearance joints' bearing (m, N/m,
#: N s/m) of the models below, hand-built and from Linkage.model alike.
SECTION = dict(elements=6, youngs_modulus=7.1e10, density=2710.0, area=8.06e-5, inertia=6.78e-11)
BEARING = dict(clearance=2.5e-4, stiffness=5e7, damping=500.0)


def _four_bar(near_b=(0.15, 0.26)) -> Linkage:
    """The README's four-bar (Grashof crank-rocker, m): ground 0.254, crank 0.0508, coupler and
    rocker 0.2794, open form (B above the ground line)."""
    lk = Linkage()
    lk.ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    lk.crank("crank", "O2", "A", length=0.0508, driver=DRIVER)
    lk.point("B", near=near_b)
    lk.link("coupler", "A", "B", length=0.2794)
    lk.link("rocker", "O4", "B", length=0.2794)
    return lk


def _state(frame: Frame, t: float) -> np.ndarray:
    o, v, a, angle, rate, accel = frame.at(t)
    return np.array([*o, *v, *a, angle, rate, accel])


def _worst(frames, closed, names, times) -> np.ndarray:
    """Per component (origin, its velocity, its acceleration, angle, rate, acceleration), the
    largest difference between the linkage's frames and the closed-form ones over ``times``."""
    worst = np.zeros(9)
    for name in names:
        for t in times:
            d = np.abs(_state(frames[name], t) - _state(closed(name), t))
            d[6] = abs((d[6] + math.pi) % (2 * math.pi) - math.pi)  # angles modulo 2 pi
            worst = np.maximum(worst, d)
    return worst


def test_the_four_bars_frames_are_its_closed_form_ones():
    # At the samples the solved positions, velocities and accelerations are the closed form's to
    # round-off (Newton to 1e-13 of the size, rates from the constraints' derivatives, not
    # differences); between the samples (1e-3 s, 0.1 rad of crank) the quintic interpolation is
    # O(h^6) in the positions: measured 1.1e-12 m and 1.3e-10 rad, rates 3.8e-9 m/s and 4.6e-7
    # rad/s, accelerations 2.6e-5 m/s^2 and 3.1e-3 rad/s^2 (of about 500 and 5000)
    frames = _four_bar().frames(0.1)
    closed = lambda link: Frame.four_bar(0.254, 0.0508, 0.2794, 0.2794, DRIVER, link)  # noqa: E731
    names = ("crank", "coupler", "rocker")
    at_samples = _worst(frames, closed, names, np.arange(0.0, 0.1, 1e-3)[::7])
    assert np.all(at_samples[[0, 1, 6]] < 1e-14) and np.all(
        at_samples < 1e-9 * np.array([1, 1, 1e2, 1e2, 1e4, 1e4, 1, 1e2, 1e4])
    )
    between = _worst(frames, closed, names, np.linspace(0.0, 0.1, 389))
    assert np.all(between < np.array([1e-11, 1e-11, 1e-7, 1e-7, 1e-4, 1e-4, 1e-9, 5e-6, 3e-2])), between


def test_the_table_ends_at_t_end():
    # 0.0105 s at 1e-3 s: samples 0, 1e-3, ..., 1e-2 and 0.0105 (a shorter last interval); a
    # spacing longer than the run gives the two ends (0.5 rad of crank apart here)
    frames = _four_bar().frames(0.0105)
    closed = Frame.four_bar(0.254, 0.0508, 0.2794, 0.2794, DRIVER, "coupler")
    assert np.all(np.abs(_state(frames["coupler"], 0.0105) - _state(closed, 0.0105))[[0, 1, 6]] < 1e-14)
    far = _four_bar().frames(0.005, spacing=1e300)
    assert np.all(np.isfinite(_state(far["coupler"], 0.0025)))


def test_the_other_branch_is_the_crossed_four_bar():
    # B guessed below the ground line: the crossed form, the closed form's branch -1
    frames = _four_bar(near_b=(0.2, -0.25)).frames(0.05)
    closed = lambda link: Frame.four_bar(0.254, 0.0508, 0.2794, 0.2794, DRIVER, link, branch=-1.0)  # noqa: E731
    assert np.all(_worst(frames, closed, ("coupler", "rocker"), np.linspace(0, 0.05, 51))[:7] < 1e-9)


def test_an_offset_slider_crank_with_its_slider():
    # The slider's pin on a guide at height 0.02 m: the closed form Frame.slider_crank(offset=)
    lk = Linkage().ground("O", (0.0, 0.0))
    lk.crank("crank", "O", "A", length=0.15, driver=Rotation.constant(150.0))
    lk.point("B", near=(0.45, 0.02)).link("rod", "A", "B", length=0.3)
    lk.slider("slider", "B", through=(0.0, 0.02), angle=0.0)
    frames = lk.frames(0.05, spacing=5e-4)
    closed = lambda link: Frame.slider_crank(0.15, 0.3, Rotation.constant(150.0), link, offset=0.02)  # noqa: E731
    worst = _worst(frames, closed, ("crank", "rod", "slider"), np.linspace(0.0, 0.05, 173))
    # interpolation at 5e-4 s, 0.075 rad of crank: measured 1.5e-11 m, 1.1e-7 m/s, 1.4e-3 m/s^2
    # (of 3400), 3.9e-11 rad, 2.9e-7 rad/s, 3.7e-3 rad/s^2
    assert np.all(worst < np.array([5e-11, 5e-11, 5e-7, 5e-7, 1e-2, 1e-2, 1e-9, 1e-5, 1e-1])), worst


def _flexible(frames, bodies, link, length, joint, pin) -> fc.Model:
    """A model on ``frames``: rigid ``bodies``, the flexible ``link`` of ``length`` (m; 6
    elements, aluminium), a clearance joint ``(name, body, point)`` at its node 0 and a pin
    ``(name, body, point)`` at its node 6 (points in the bodies' frames, m)."""
    m = fc.Model()
    for body in bodies:
        m.add_body(body, frame=frames[body])
    m.add_link(link, length=length, frame=frames[link], **SECTION)
    name, body, point = joint
    m.add_joint(name, link, 0, body=body, point=point, **BEARING)
    m.add_pin(pin[0], link, SECTION["elements"], body=pin[1], point=pin[2])
    return m


def _model(frames) -> fc.Model:
    """The README's four-bar model (flexible coupler, clearance at the crank pin) on ``frames``."""
    return _flexible(
        frames, ("crank", "rocker"), "coupler", 0.2794, ("crank_pin", "crank", (0.0508, 0.0)),
        ("rocker_pin", "rocker", (0.2794, 0.0)),
    )  # fmt: skip


def test_a_four_bar_run_on_the_linkages_frames_is_the_closed_forms_run():
    # 20 ms, 21 impacts that magnify small differences: with tables every 5e-4 s the peak force
    # is within 1e-6 of the closed-form frames' run (measured 2.6e-7 with the closed form's own
    # frames tabulated: the linkage's are the same to round-off)
    closed = {
        k: Frame.four_bar(0.254, 0.0508, 0.2794, 0.2794, DRIVER, k) for k in ("crank", "coupler", "rocker")
    }
    ref = _model(closed).simulate(0.02, 1e-5).joint("crank_pin")
    own = _model(_four_bar().frames(0.02, spacing=5e-4)).simulate(0.02, 1e-5).joint("crank_pin")
    assert ref.impacts > 10 and own.impacts == ref.impacts
    assert own.max_force == pytest.approx(ref.max_force, rel=1e-6)


def _watt_six_bar() -> Linkage:
    """Two four-bars in series (a Watt II six-bar): the four-bar above, whose rocker is a ternary
    link O4-B-C, drives a second one C-D-O6 (m); the six-bar of the study file of
    benches/studies/watt_six_bar.py, at the crank speed of DRIVER."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parent.parent / "benches" / "studies" / "watt_six_bar.py"
    spec = importlib.util.spec_from_file_location("_watt_six_bar_study", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.linkage(DRIVER.at(0.0)[1])


def test_a_six_bar_keeps_its_lengths_and_runs_with_a_clearance_joint():
    six = _watt_six_bar()
    times = np.linspace(0.0, 0.1, 257)
    sol = six.solve(times)
    dist = lambda p, q: np.hypot(*(sol[p][0] - sol[q][0]).T)  # noqa: E731
    lengths = (
        ("A", "B", 0.2794), ("O4", "B", 0.2794), ("O4", "C", math.hypot(0.1, 0.08)),
        ("B", "C", math.hypot(0.1794, 0.08)), ("C", "D", 0.25), ("O6", "D", 0.15),
    )  # fmt: skip
    for p, q, length in lengths:
        assert np.max(np.abs(dist(p, q) - length)) < 1e-13
    # velocities and accelerations are the positions' derivatives (central differences of the
    # solved positions at 1e-6 s: truncation about 1e-12 relative)
    h = 1e-6
    s = six.solve([0.0371 - h, 0.0371, 0.0371 + h])
    v_fd = (s["D"][0][2] - s["D"][0][0]) / (2 * h)
    a_fd = (s["D"][0][2] - 2 * s["D"][0][1] + s["D"][0][0]) / h**2
    assert np.allclose(v_fd, s["D"][1][1], rtol=0, atol=1e-7) and np.allclose(
        a_fd, s["D"][2][1], rtol=0, atol=2e-2
    )
    # a flexible rod C-D with a clearance joint at C on the ternary rocker, pinned to the output
    frames = six.frames(0.03)
    m = _flexible(
        frames, ("crank", "coupler", "rocker", "output"), "rod", 0.25, ("rocker_pin", "rocker", (0.1, 0.08)),
        ("output_pin", "output", (0.15, 0.0)),
    )  # fmt: skip
    res = m.simulate(0.03, 1e-5)
    j = res.joint("rocker_pin")
    assert res.complete and j.impacts > 0 and 0 < j.max_force < 1e4
    # the rod's ends follow the pins: node 6 on the output's D within the rod's elastic motion
    x, y = res.link("rod").global_positions()
    d = np.array([frames["output"].at(t)[0] for t in res.time]) + np.array(
        [
            [0.15 * math.cos(frames["output"].at(t)[3]), 0.15 * math.sin(frames["output"].at(t)[3])]
            for t in res.time
        ]
    )
    assert np.max(np.hypot(x[:, -1] - d[:, 0], y[:, -1] - d[:, 1])) < 1e-4


def test_a_linkage_that_cannot_move_or_close_says_so():
    short = Linkage().ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    short.crank("crank", "O2", "A", length=0.0508, driver=DRIVER).point("B", near=(0.15, 0.1))
    short.link("coupler", "A", "B", length=0.1).link("rocker", "O4", "B", length=0.05)
    with pytest.raises(fc.ModelError, match=r"does not assemble at t = 0 s"):
        short.frames(0.01)
    # a non-Grashof four-bar driven past its dead point: the crank 0.2 cannot turn fully
    stuck = Linkage().ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    stuck.crank("crank", "O2", "A", length=0.2, driver=Rotation.constant(10.0)).point("B", near=(0.35, 0.2))
    stuck.link("coupler", "A", "B", length=0.25).link("rocker", "O4", "B", length=0.2)
    with pytest.raises(fc.ModelError, match=r"(does not assemble|dead point) at t = 0\.\d+ s"):
        stuck.frames(0.7)
    loose = Linkage().ground("O", (0.0, 0.0)).point("P", near=(1.0, 0.0))
    with pytest.raises(fc.ModelError, match="belong to no link"):
        loose.frames(0.1)
    # a driver whose angle overflows within the table (fuzz case 71:157221: 1e20 rad/s)
    fast = Linkage().ground("O", (0.0, 0.0)).crank("c", "O", "A", length=0.1, driver=Rotation.constant(1e20))
    with pytest.raises(fc.ModelError, match="crank 'c'.s driver gives angle"):
        fast.solve([0.0, 1e300])
    # a crank too short for its angle to be resolved (fuzz case 73:13747: 1e-300 m; the
    # tabulated angle's rate came out NaN and was refused as the table's `rate[0]`)
    tiny = Linkage().ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    tiny.crank("crank", "O2", "A", length=1e-300, driver=DRIVER).point("B", near=(0.15, 0.26))
    tiny.link("coupler", "A", "B", length=0.2794).link("rocker", "O4", "B", length=0.2794)
    with pytest.raises(fc.ModelError, match=r"link 'crank' has no finite frame at t = 0 s"):
        tiny.frames(0.01)
    over = _four_bar().link("extra", "O2", "B", length=0.3)
    with pytest.raises(fc.ModelError, match="3 constraints for 1 moving points"):
        over.frames(0.1)


@pytest.mark.parametrize(
    "build, parameter",
    [
        (lambda: Linkage().ground("O", (0.0, math.nan)), "ground 'O' at"),
        (lambda: Linkage().ground("O", (0, 0)).ground("O", (1, 0)), "point name"),
        (
            lambda: Linkage().ground("O", (0, 0)).crank("c", "X", "A", length=1.0, driver=DRIVER),
            "crank 'c' pivot",
        ),
        (
            lambda: Linkage().ground("O", (0, 0)).crank("c", "O", "A", length=0.0, driver=DRIVER),
            "crank 'c' length",
        ),
        (
            lambda: Linkage().ground("O", (0, 0)).crank("c", "O", "A", length=1.0, driver=1.0),
            "crank 'c' driver",
        ),
        (lambda: Linkage().ground("O", (0, 0)).link("l", "O", "Q", length=1.0), "body 'l' point"),
        (lambda: _four_bar().slider("s", "B", angle=math.inf), "slider 's' angle"),
        (lambda: _four_bar().link("coupler", "A", "B", length=0.2794), "link name"),
        (lambda: _four_bar().frames(0.1, spacing=0.0), "spacing"),
        (lambda: _four_bar().frames(0.1, spacing=0.02), "spacing"),  # 2 rad of crank a sample
        (lambda: _four_bar().frames(0.1, spacing=5e-324), "spacing"),  # fuzz case 71:27521
        (lambda: _four_bar().plot("x.png", 0.1, spacing=5e-324), "spacing"),
        (lambda: _four_bar().frames(-1.0), "t_end"),
        (lambda: _four_bar().solve([0.0, 0.0]), "times"),
        (lambda: _four_bar().slot("s", "B", "O2", "O4"), "slot 's' b"),
        (lambda: _four_bar().link("l", "A", "A", length=0.1), "link 'l' b"),
        (
            lambda: _four_bar().body("t", {"A": (0.0, 0.0), "B": (0.1, 0.0), "O4": (0.1, 0.0)}),
            "body 't' points",
        ),
        (lambda: _four_bar().slot("s", "B", "A", "B"), "slot 's' point"),
    ],
)
def test_bad_input_names_the_parameter(build, parameter):
    with pytest.raises(fc.InvalidParameterError) as e:
        build()
    assert e.value.parameter == parameter


def test_the_linkage_is_drawn(tmp_path):
    path = _watt_six_bar().plot(tmp_path / "six.png", 0.063, poses=4)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    with pytest.raises(fc.InvalidParameterError) as e:
        _four_bar().plot(tmp_path / "x.png", 0.01, poses=0)
    assert e.value.parameter == "poses"


def _crank_shaper(rate: float = 20.0) -> Linkage:
    """A crank-shaper (m): the crank O2-A turns a slotted lever O4-B through a block at A sliding
    in its slot; the rod B-C drives the ram C on a guide at height 0.35."""
    lk = Linkage().ground("O4", (0.0, 0.0)).ground("O2", (0.0, 0.1))
    lk.crank("crank", "O2", "A", length=0.05, driver=Rotation.constant(rate))
    lk.point("B", near=(0.13, 0.27)).body("lever", {"O4": (0.0, 0.0), "B": (0.3, 0.0)})
    lk.slot("block", "A", "O4", "B")
    lk.point("C", near=(0.05, 0.35)).link("rod", "B", "C", length=0.25)
    lk.slider("ram", "C", through=(0.0, 0.35), angle=0.0)
    return lk


def _shaper_model(frames) -> fc.Model:
    """The crank-shaper's model by hand: its rod flexible, a clearance joint at the lever's tip
    B, pinned to the ram (2 kg)."""
    m = fc.Model()
    for body in ("crank", "lever"):
        m.add_body(body, frame=frames[body])
    m.add_slider("ram", mass=2.0, path=frames["ram"])
    m.add_link("rod", length=0.25, frame=frames["rod"], **SECTION)
    m.add_joint("lever_pin", "rod", 0, body="lever", point=(0.3, 0.0), **dict(BEARING, clearance=2e-4))
    m.add_pin("ram_pin", "rod", SECTION["elements"], slider="ram")
    return m


def test_a_slotted_lever_follows_its_block_and_a_crank_shaper_runs():
    # The lever's angle is that of the block's pin A = O2 + r (cos wt, sin wt) seen from O4:
    # theta = atan2(0.1 + r sin wt, r cos wt), rate (A x A') / |A|^2; the block turns with the
    # lever, its origin at A. Tables every 1e-3 s at 20 rad/s: measured within 4e-10.
    w = 20.0
    frames = _crank_shaper(w).frames(0.4)
    for t in np.linspace(0.0, 0.4, 301):
        a = np.array([0.05 * math.cos(w * t), 0.1 + 0.05 * math.sin(w * t)])
        ad = 0.05 * w * np.array([-math.sin(w * t), math.cos(w * t)])
        _, _, _, angle, rate, _ = frames["lever"].at(t)
        block = frames["block"].at(t)
        assert abs((angle - math.atan2(a[1], a[0]) + math.pi) % (2 * math.pi) - math.pi) < 1e-9
        assert rate == pytest.approx((a[0] * ad[1] - a[1] * ad[0]) / (a @ a), abs=1e-8)
        assert abs(block[3] - angle) < 1e-12 and np.max(np.abs(np.array(block[0]) - a)) < 1e-10
    # the shaper's rod, flexible, with a clearance joint at the lever's tip B and pinned to the ram
    m = _shaper_model(frames)
    res = m.simulate(0.35, 1e-5, record=fc.Record(histories=False))
    j = res.joint("lever_pin")
    assert res.complete and j.impacts > 0 and 0 < j.max_force < 1e5


def test_a_block_in_a_slot_along_a_crank():
    # an inverted slider-crank: the rocker O4-P (0.35 m) ends in a block sliding along the crank's
    # line O2-A; P stays on the line and at the rocker's length, and its velocity and acceleration
    # are the differences of its positions (1e-6 s: truncation and round-off about 1e-5 m/s^2)
    lk = Linkage().ground("O2", (0.0, 0.0)).ground("O4", (0.3, 0.0))
    lk.crank("crank", "O2", "A", length=0.1, driver=Rotation.constant(10.0))
    lk.point("P", near=(-0.05, 0.01)).link("rocker", "O4", "P", length=0.35)
    lk.slot("block", "P", "O2", "A")
    s = lk.solve(np.linspace(0.0, 0.6, 61))
    p, a = s["P"][0], s["A"][0]
    assert np.max(np.abs(p[:, 0] * a[:, 1] - p[:, 1] * a[:, 0])) < 1e-15
    assert np.max(np.abs(np.hypot(p[:, 0] - 0.3, p[:, 1]) - 0.35)) < 1e-13
    h = 1e-6
    q = lk.solve([0.3 - h, 0.3, 0.3 + h])["P"]
    assert np.allclose((q[0][2] - q[0][0]) / (2 * h), q[1][1], rtol=0, atol=1e-8)
    assert np.allclose((q[0][2] - 2 * q[0][1] + q[0][0]) / h**2, q[2][1], rtol=0, atol=1e-4)


def test_a_linkage_builds_the_model_one_would_build_by_hand():
    # the same links, frames, pins and clearance joints as the hand-built models above, so the
    # same run bit for bit: the four-bar's coupler (clearance at the crank pin A, pinned to the
    # rocker at B) and the crank-shaper's rod (clearance at the lever's tip B, the ram at C)
    frames = _four_bar().frames(0.02, spacing=5e-4)
    ref = _model(frames).simulate(0.02, 1e-5)
    m = _four_bar().model(0.02, flexible={"coupler": SECTION}, clearances={"A": BEARING}, spacing=5e-4)
    assert m.joint_names == ["A"] and m.pin_names == ["B"]
    res = m.simulate(0.02, 1e-5)
    assert res.joint("A").impacts == ref.joint("crank_pin").impacts > 10
    assert res.joint("A").max_force == ref.joint("crank_pin").max_force
    for h in ("u", "v", "theta"):
        assert np.array_equal(getattr(res.link("coupler"), h), getattr(ref.link("coupler"), h))
    ref = _shaper_model(_crank_shaper().frames(0.05)).simulate(0.05, 1e-5)
    shaper = _crank_shaper().model(
        0.05,
        flexible={"rod": SECTION},
        clearances={"B": dict(BEARING, clearance=2e-4)},
        slider_masses={"ram": 2.0},
    )
    res = shaper.simulate(0.05, 1e-5)
    assert (shaper.joint_names, shaper.pin_names, shaper.slider_names) == (["B"], ["C"], ["ram"])
    assert res.joint("B").max_force == ref.joint("lever_pin").max_force > 0
    assert np.array_equal(res.slider("ram").position, ref.slider("ram").position)


def test_flexible_links_meeting_at_a_point_and_on_the_ground():
    # the four-bar with its coupler and rocker both flexible: the rocker's node 0 on the ground
    # pivot O4, the coupler's last node its bearing at B (joint "B:rocker"); ideal pins share
    # the translations, so the two links' ends at B coincide to the tables' interpolation
    # between samples (each link's frame is its own table; measured 2.6e-11 m)
    m = _four_bar().model(0.01, flexible={"coupler": SECTION, "rocker": SECTION}, clearances={"A": BEARING})
    assert m.joint_names == ["A"] and sorted(m.pin_names) == ["B:rocker", "O4"]
    res = m.simulate(0.01, 1e-5)
    assert res.complete and res.joint("A").impacts > 0
    cx, cy = res.link("coupler").global_positions()
    rx, ry = res.link("rocker").global_positions()
    assert np.max(np.hypot(cx[:, -1] - rx[:, -1], cy[:, -1] - ry[:, -1])) < 1e-9
    assert np.max(np.hypot(rx[:, 0] - 0.254, ry[:, 0])) < 1e-12


def test_a_linkage_model_refuses_what_it_cannot_build():
    six = _watt_six_bar()
    with pytest.raises(fc.InvalidParameterError, match="a binary link made by Linkage.link"):
        six.model(0.01, flexible={"rocker": SECTION})  # a ternary link
    # a two-point body with B off its x axis: a beam along the axis would not reach B
    off_axis = Linkage().ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    off_axis.crank("crank", "O2", "A", length=0.0508, driver=DRIVER).point("B", near=(0.15, 0.26))
    off_axis.body("coupler", {"A": (0.0, 0.0), "B": (0.2794, 0.01)}).link("rocker", "O4", "B", length=0.2794)
    with pytest.raises(fc.InvalidParameterError, match="a binary link made by Linkage.link"):
        off_axis.model(0.01, flexible={"coupler": SECTION})
    with pytest.raises(fc.InvalidParameterError, match=r"flexible\['rod'\]\['length'\]"):
        six.model(0.01, flexible={"rod": dict(SECTION, length=0.25)})
    with pytest.raises(fc.InvalidParameterError, match="a point at a flexible link's end"):
        six.model(0.01, flexible={"rod": SECTION}, clearances={"B": BEARING})
    with pytest.raises(fc.InvalidParameterError, match="a mass for slider 'ram'"):
        _crank_shaper().model(0.01, flexible={"rod": SECTION})
    with pytest.raises(fc.InvalidParameterError, match="elements"):
        six.model(0.01, flexible={"rod": dict(SECTION, elements=0)})
    # a misspelt keyword is named, not a TypeError
    with pytest.raises(fc.InvalidParameterError, match=r"flexible\['rod'\]\['elemnts'\]"):
        six.model(0.01, flexible={"rod": dict(SECTION, elemnts=6)})
    with pytest.raises(fc.InvalidParameterError, match=r"clearances\['C'\]\['stifness'\]"):
        six.model(0.01, flexible={"rod": SECTION}, clearances={"C": dict(BEARING, stifness=1.0)})
    with pytest.raises(fc.InvalidParameterError, match="a slider of the linkage"):
        _crank_shaper().model(0.01, flexible={"rod": SECTION}, slider_masses={"rams": 2.0})


def test_simeons_slider_crank_made_with_a_linkage_is_the_scene():
    # the scene's crank-pin slider-crank (analytic frames) against the same mechanism from
    # Linkage.model (tabulated frames), 20 ms: the difference is the tables' interpolation and
    # falls as a high power of the spacing (measured peak force +3.2e-8, +1.7e-9 relative and
    # rod nodes 6.3e-10, 2.3e-11 m at 1e-3 and 5e-4 s)
    scene = fc.scenes.slider_crank(clearance_at="crank_pin")
    p = scene.parameters
    ref = scene.simulate(0.02, 1e-5)
    lk = Linkage().ground("O", (0.0, 0.0))
    lk.crank("crank", "O", "A", length=p["crank_length"], driver=Rotation.constant(p["crank_speed"]))
    lk.point("B", near=(p["crank_length"] + p["rod_length"], 0.0))
    lk.link("rod", "A", "B", length=p["rod_length"]).slider("slider", "B", through=(0.0, p["offset"]))
    rod = {k: p[k] for k in ("elements", "youngs_modulus", "density", "area", "inertia", "damping")}
    pin = dict(clearance=p["clearance"], stiffness=p["bearing_stiffness"], damping=p["bearing_damping"])
    xr, yr = ref.link("rod").global_positions()
    force, nodes = [], []
    for spacing in (1e-3, 5e-4):
        m = lk.model(
            0.02,
            spacing=spacing,
            flexible={"rod": rod},
            clearances={"A": pin},
            slider_masses={"slider": p["slider_mass"]},
        )
        res = m.simulate(0.02, 1e-5)
        assert res.joint("A").impacts == ref.joint("crank_pin").impacts == 3
        force.append(abs(res.joint("A").max_force / ref.joint("crank_pin").max_force - 1))
        x, y = res.link("rod").global_positions()
        nodes.append(np.max(np.hypot(x - xr, y - yr)))
    assert force[0] < 1e-7 and nodes[0] < 2e-9
    assert force[1] < force[0] / 8 and nodes[1] < nodes[0] / 8
