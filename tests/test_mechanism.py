"""Models in moving frames (kineto-elastodynamics) through the one Model API: scenes, building, errors
and the command line. Short runs only (each test well under 2 s on a dev-opt build); the engine's
physics is tested in Rust (tests/engine.rs); the checks here are cheap ones against closed forms."""

from __future__ import annotations

import math
from pathlib import Path

import flexclear as fc
import numpy as np
import pytest
from flexclear import scenes
from flexclear.cli import main
from flexclear.frames import Frame, Rotation

# ---------------------------------------------------------------------------------------------
# Scenes build and run
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "build, t_end, dt, link",
    [
        (lambda: scenes.spin_up(), 1.0, 1e-2, "beam"),
        (lambda: scenes.spin_up(data="simo", geometric=False), 1.0, 1e-2, "beam"),
        (lambda: scenes.slider_crank(), 0.005, 5e-5, "rod"),
        (lambda: scenes.slider_crank(clearance_at="crank_pin"), 0.005, 1e-5, "rod"),
        (lambda: scenes.slider_crank(clearance_at="slider_pin"), 0.005, 1e-5, "rod"),
        (lambda: scenes.four_bar(), 0.02, 1e-4, "coupler"),
        (lambda: scenes.four_bar(flexible_rocker=True, rocker_elements=4), 0.02, 1e-4, "rocker"),
    ],
)
def test_scene_builds_and_runs(build, t_end, dt, link):
    mech = build()
    assert isinstance(mech, fc.Model) and mech.engine == "moving-frame"
    assert mech.parameters
    res = mech.simulate(t_end, dt, record=fc.Record(axial_force=True, midspan=True))
    assert res.complete and res.error is None
    assert res.time[-1] == pytest.approx(t_end)
    lr = res.link(link)
    n = len(res.time)
    nodes = mech.parameters.get("rocker_elements" if link == "rocker" else "elements") + 1
    assert lr.u.shape == lr.v.shape == lr.theta.shape == (n, nodes)
    assert lr.axial_force.shape == (n, nodes - 1)
    assert lr.midspan.shape == (n,)
    for a in (lr.u, lr.v, lr.theta, lr.axial_force, lr.midspan):
        assert np.all(np.isfinite(a))


def test_scene_parameters_are_keywords_with_defaults():
    import inspect

    for f in (scenes.spin_up, scenes.slider_crank, scenes.four_bar):
        for p in inspect.signature(f).parameters.values():
            assert p.kind is p.KEYWORD_ONLY and p.default is not p.empty, (f.__name__, p.name)
    assert {"spin_up", "slider_crank", "four_bar"} <= set(scenes.__all__)


def test_simo_data_products():
    # Simo & Vu-Quoc give only EI = 1.4e4 N m^2, rho A = 1.2 kg/m, EA = 2.8e7 N (and L = 10 m).
    p = scenes.spin_up(data="simo").parameters
    assert p["youngs_modulus"] * p["inertia"] == pytest.approx(1.4e4)
    assert p["density"] * p["area"] == pytest.approx(1.2)
    assert p["youngs_modulus"] * p["area"] == pytest.approx(2.8e7)
    assert (p["length"], p["final_rate"]) == (10.0, 6.0)


def test_slider_crank_derived_bearing():
    m = scenes.slider_crank(clearance_at="slider_pin")
    p = m.parameters
    assert m.joint_names == ["slider_pin"]
    # Hertz secant: K_h = 4/3 E* sqrt(R (R + c) / c), E* = E / (2 (1 - nu^2)); K_B = K_h sqrt(1e-5).
    e_star = 2.0e11 / (2 * (1 - 0.3**2))
    k_h = 4 / 3 * e_star * math.sqrt(5e-3 * 5.5e-3 / 5e-4)
    assert p["bearing_stiffness"] == pytest.approx(k_h * math.sqrt(1e-5), rel=1e-12)
    m_eff = (p["rod_mass"] / 2) * 0.075552 / (p["rod_mass"] / 2 + 0.075552)
    assert p["bearing_damping"] == pytest.approx(2 * 0.2 * math.sqrt(p["bearing_stiffness"] * m_eff))
    # Given values win over derived ones.
    q = scenes.slider_crank(clearance_at="crank_pin", bearing_stiffness=1e7, bearing_damping=50.0).parameters
    assert (q["bearing_stiffness"], q["bearing_damping"]) == (1e7, 50.0)


# ---------------------------------------------------------------------------------------------
# Bad input: clear exceptions naming the parameter
# ---------------------------------------------------------------------------------------------


def _frame():
    return fc.Frame.rotating(fc.Rotation.fixed(0.0))


def _one_link(**kw):
    m = fc.Model()
    args = dict(
        length=1.0, elements=2, youngs_modulus=1e9, density=1e3, area=1e-4, inertia=1e-9, frame=_frame()
    )
    args.update(kw)
    m.add_link("a", **args)
    return m


@pytest.mark.parametrize(
    "call, parameter",
    [
        (lambda: scenes.slider_crank(rod_length=0.1), "rod_length"),
        (lambda: scenes.slider_crank(crank_length=0.2, offset=0.15), "rod_length"),
        (lambda: scenes.slider_crank(clearance_at="piston"), "clearance_at"),
        (lambda: scenes.slider_crank(clearance_at="crank_pin", clearance=-1e-4), "clearance"),
        (lambda: scenes.slider_crank(side=-0.008), "side"),
        (lambda: scenes.slider_crank(elements=0), "elements"),
        (lambda: scenes.slider_crank(elements=True), "elements"),
        (lambda: scenes.slider_crank(side="x"), "side"),
        (lambda: scenes.slider_crank(clearance_at="slider_pin", bearing_stiffness=-1), "joints[0].stiffness"),
        (lambda: scenes.spin_up(length=-8.0), "length"),
        (lambda: scenes.spin_up(elements=0), "elements"),
        (lambda: scenes.spin_up(data="nasa"), "data"),
        (lambda: scenes.four_bar(branch=0), "branch"),
        (lambda: scenes.four_bar(coupler_length=0.0), "coupler_length"),
        (lambda: _one_link(length=-1.0), "links[0].length"),
        (lambda: _one_link(elements=0), "links[0].elements"),
        (lambda: _one_link(density=float("nan")), "links[0].density"),
        (lambda: _one_link().add_body("g", frame=_frame()).add_pin("p", "a", 3, body="g"), "node"),
        (lambda: _one_link().add_clamp("a", 0).simulate(0.1, 1e-2, method="implicit"), "method"),
        (lambda: _one_link().add_clamp("a", 0).simulate(-0.1, 1e-2), "t_end"),
        (lambda: _one_link().add_clamp("a", 0).simulate(0.1, 0.0), "dt"),
    ],
)
def test_bad_parameter(call, parameter):
    with pytest.raises(fc.InvalidParameterError) as e:
        call()
    assert e.value.parameter == parameter
    assert parameter in str(e.value) and e.value.allowed


def test_four_bar_that_does_not_close():
    # s + l = 0.4 + 0.2794 > p + q = 0.254 + 0.2794: non-Grashof, the crank cannot turn fully.
    with pytest.raises(fc.ModelError, match="does not close") as e:
        scenes.four_bar(crank_length=0.4)
    assert "crank_length=0.4" in str(e.value)


def test_link_with_no_joint():
    m = _one_link()
    with pytest.raises(fc.ModelError, match='link "a" has no joint'):
        m.validate(1.0)
    with pytest.raises(fc.ModelError, match='link "a" has no joint'):
        m.simulate(0.1, 1e-2)


def test_unknown_names():
    m = _one_link()
    with pytest.raises(fc.ModelError, match="unknown link 'b'"):
        m.add_clamp("b", 0)
    with pytest.raises(fc.ModelError, match="unknown slider 'slider'"):
        m.add_pin("p", "a", 0, slider="slider")
    with pytest.raises(fc.InvalidParameterError, match="target"):
        m.add_pin("p", "a", 0, target=42)
    with pytest.raises(fc.ModelError, match="unknown body 'hub'"):
        m.add_joint("j", "a", 0, body="hub", clearance=0.0, stiffness=1.0, damping=0.0)
    res = m.add_clamp("a", 0).simulate(0.02, 1e-2)
    # The same mistake, the same class, in building and in results alike.
    with pytest.raises(fc.ModelError, match="unknown link 'b'"):
        res.link("b")
    with pytest.raises(fc.ModelError, match="unknown joint"):
        res.joint("bearing")


def test_pin_that_does_not_close():
    # The slider pin of a slider-crank joined to the crank point: the two sides move apart.
    drv = fc.Rotation.constant(10.0)
    m = fc.Model()
    m.add_link(
        "rod",
        length=0.3,
        elements=2,
        youngs_modulus=2e11,
        density=7870,
        area=6.4e-5,
        inertia=3.4e-10,
        frame=fc.Frame.slider_crank(0.15, 0.3, drv, "rod"),
    )
    m.add_body("crank", frame=fc.Frame.slider_crank(0.15, 0.3, drv, "crank"))
    m.add_pin("p", "rod", 2, body="crank", point=(0.15, 0.0))
    with pytest.raises(fc.ModelError, match='pin "p" does not close'):
        m.validate(0.1)


# ---------------------------------------------------------------------------------------------
# Failures carry what was computed
# ---------------------------------------------------------------------------------------------


def test_convergence_error_carries_time_step_residual_and_partial_result():
    # At rest for 0.5 s (every step converges with a zero correction), then spun: with an
    # unattainable tolerance the first loaded step fails.
    rot = fc.Rotation.tabulated([0.0, 0.5, 10.0], [0.0, 0.0, 4.75], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    m = scenes.spin_up(rotation=rot)
    with pytest.raises(fc.ConvergenceError) as e:
        m.simulate(2.0, 1e-2, iter_tol=1e-300, max_iter=3)
    err = e.value
    assert err.time == pytest.approx(0.5)
    assert err.step == 51 and err.iterations == 3
    assert math.isfinite(err.residual) and math.isfinite(err.correction)
    res = err.result
    assert isinstance(res, fc.Result) and not res.complete and res.error is err
    assert len(res.time) == 51 and res.time[-1] == pytest.approx(0.5)
    assert np.all(res.link("beam").tip == 0.0)


def test_divergence_keeps_partial_result():
    # Without geometric stiffness the first in-plane mode goes unstable once the hub rate exceeds
    # it (2.91 rad/s); the Kane spin-up reaches it at about t = 8.9 s.
    with pytest.raises(fc.SimulationDivergedError) as e:
        scenes.spin_up(geometric=False).simulate(20.0, 1e-2)
    res = e.value.result
    assert not res.complete and 8.9 < e.value.time < 20.0
    # The result holds the steps before the one judged divergent.
    assert e.value.time - 2e-2 < res.time[-1] < e.value.time
    assert np.all(np.isfinite(res.link("beam").tip))


def test_interrupt_from_progress_callback():
    seen = []

    def progress(fraction):
        seen.append(fraction)
        if fraction > 0.2:
            raise KeyboardInterrupt

    with pytest.raises(fc.SimulationInterrupted) as e:
        scenes.four_bar().simulate(0.1, 1e-6, progress=progress)
    assert seen and all(0 <= f <= 1 for f in seen)
    res = e.value.result
    assert not res.complete and 0 < res.end_time < 0.1
    assert len(res.link("coupler").midspan) == 0  # not asked for
    assert res.link("coupler").v.shape[0] == len(res.time)


def test_progress_callback_error_propagates():
    def progress(fraction):
        raise RuntimeError("from the callback")

    with pytest.raises(RuntimeError, match="from the callback"):
        scenes.four_bar().simulate(0.05, 1e-6, progress=progress)


# ---------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------


def test_global_positions_follow_the_slider_crank():
    m = scenes.slider_crank()
    res = m.simulate(0.01, 1e-5, record=fc.Record(every=10))
    rod = res.link("rod")
    x, y = rod.global_positions()
    th = 150.0 * res.time
    # Node 0 is pinned to the rigid crank at A; the last node to the slider on the guide y = 0.
    np.testing.assert_allclose(x[:, 0], 0.15 * np.cos(th), atol=1e-12)
    np.testing.assert_allclose(y[:, 0], 0.15 * np.sin(th), atol=1e-12)
    np.testing.assert_allclose(y[:, -1], 0.0, atol=1e-12)
    # B is where the rigid slider-crank puts it, plus the rod's axial stretch (< 0.1 mm).
    xb = 0.15 * np.cos(th) + np.sqrt(0.3**2 - (0.15 * np.sin(th)) ** 2)
    assert np.max(np.abs(x[:, -1] - xb)) < 1e-4
    with pytest.raises(fc.InvalidParameterError):
        m.simulate(0.001, 1e-5, record=fc.Record(displacements=False)).link("rod").global_positions()


def _crank_pin_slider_crank(frames) -> fc.Model:
    """The crank-pin slider-crank scene built with the ``add_*`` calls on the link frames
    ``frames(link)`` (crank body, rod, slider path)."""
    p = scenes.slider_crank(clearance_at="crank_pin").parameters
    m = fc.Model()
    m.add_body("crank", frame=frames("crank"))
    m.add_link(
        "rod", length=p["rod_length"], elements=p["elements"], youngs_modulus=p["youngs_modulus"],
        density=p["density"], area=p["area"], inertia=p["inertia"], frame=frames("rod"),
    )  # fmt: skip
    m.add_slider("slider", mass=p["slider_mass"], path=frames("slider"))
    m.add_joint(
        "crank_pin", "rod", 0, body="crank", point=(p["crank_length"], 0.0), clearance=p["clearance"],
        stiffness=p["bearing_stiffness"], damping=p["bearing_damping"],
    )  # fmt: skip
    m.add_pin("slider_pin", "rod", p["elements"], slider="slider")
    return m


def _analytic_frames(link: str) -> Frame:
    return Frame.slider_crank(0.15, 0.3, Rotation.constant(150.0), link)


def _tabulated_frames(h: float, t_end: float):
    """The slider-crank's frames sampled every ``h`` (s) from the analytic ones (what a user's own
    kinematics solver would give for a linkage of their own) and tabulated."""
    t = np.arange(0.0, t_end + h, h)

    def frames(link: str) -> Frame:
        analytic = _analytic_frames(link)
        at = [analytic.at(x) for x in t]
        o, v, a, angle, rate, accel = (np.array([s[k] for s in at]) for k in range(6))
        return Frame.rotating(
            Rotation.tabulated(t, angle, rate, accel), origin=fc.motion.tabulated(t, o, v, a)
        )

    return frames


def test_a_linkage_of_ones_own_runs_on_its_tabulated_kinematics():
    # The crank-pin slider-crank on its links' rigid motions tabulated every 1e-3 s (42 samples a
    # crank turn at 150 rad/s) against the same model on the analytic frames: the quintic Hermite
    # tables are O(h^6), h^6 w^6 / 46080 = 2.5e-10 of a unit length, so the pins close (the check
    # asks for 1e-7 of the rod length) and the run follows the analytic one to about that
    # (measured: peak force 3e-8 relative, node positions 6e-10 m; with the linear tables this
    # replaced, 1e-4 s gave 4e-5 and 4e-6 m, and finer tables failed the closure check between
    # samples)
    exact = _crank_pin_slider_crank(_analytic_frames).simulate(0.02, 1e-5)
    assert np.array_equal(
        exact.joint("crank_pin").force,
        scenes.slider_crank(clearance_at="crank_pin").simulate(0.02, 1e-5).joint("crank_pin").force,
    )
    tab = _crank_pin_slider_crank(_tabulated_frames(1e-3, 0.021)).simulate(0.02, 1e-5)
    f0, f1 = exact.joint("crank_pin").force, tab.joint("crank_pin").force
    assert exact.joint("crank_pin").impacts >= 1 and f1.max() == pytest.approx(f0.max(), rel=1e-6)
    (x0, y0), (x1, y1) = exact.link("rod").global_positions(), tab.link("rod").global_positions()
    assert np.max(np.hypot(x1 - x0, y1 - y0)) < 1e-8
    # a table too coarse for its mechanism is refused before the run, naming the pin
    with pytest.raises(fc.ModelError, match='pin "slider_pin" does not close'):
        _crank_pin_slider_crank(_tabulated_frames(4e-3, 0.021)).simulate(0.02, 1e-5)


# ---------------------------------------------------------------------------------------------
# Cheap physics
# ---------------------------------------------------------------------------------------------


def test_spin_up_geometric_stiffening_bounds_the_tip():
    # Kane et al. (1987): with the geometric stiffness the tip lags (about half a metre for this
    # beam) and settles; without it the linear model diverges past the first in-plane frequency.
    res = scenes.spin_up(geometric=True).simulate(20.0, 1e-3)
    tip = res.link("beam").tip
    assert res.complete and np.max(np.abs(tip)) < 1.0
    try:
        lin = scenes.spin_up(geometric=False).simulate(20.0, 1e-3)
        assert np.max(np.abs(lin.link("beam").tip)) > 10.0
    except fc.SimulationDivergedError:
        pass


def test_stiff_rod_deflects_orders_of_magnitude_less():
    # Quasi-static inertial bending scales as 1/E, so E x 1e4 should shrink the midspan deflection
    # about 1e4 times (measured 1.64 mm -> 1.55e-4 mm, ratio 0.95e-4); the bounds allow the
    # dynamic part to differ by 10x either way.
    soft = scenes.slider_crank().simulate(0.02, 1e-5, record=fc.Record(midspan=True)).link("rod").midspan
    stiff = (
        scenes.slider_crank(youngs_modulus=2.0e15)
        .simulate(0.02, 1e-5, record=fc.Record(midspan=True))
        .link("rod")
        .midspan
    )
    assert np.max(np.abs(soft)) > 1e-4
    ratio = np.max(np.abs(stiff)) / np.max(np.abs(soft))
    assert 1e-5 < ratio < 1e-3


@pytest.mark.parametrize("elements, tol1, tol2", [(4, 1e-4, 3e-3), (10, 3e-6, 1e-4)])
def test_cantilever_frequencies_at_rest(elements, tol1, tol2):
    # Clamped-free Euler-Bernoulli beam: w_i = (beta_i L)^2 sqrt(EI / (rho A L^4)), (beta_1 L,
    # beta_2 L) = (1.8751041, 4.6940911). Cubic Hermite elements with consistent mass converge
    # from above as h^4: measured relative errors of mode 1 are 3.3e-5 (4 elements) and 8.6e-7
    # (10), of mode 2 1.2e-3 and 3.3e-5 (the 2.5x finer mesh gains 2.5^4 = 39x); the tolerances
    # allow about 3x that.
    m = scenes.spin_up(elements=elements, rotation=fc.Rotation.constant(0.0))
    p = m.parameters
    w_ref = math.sqrt(p["youngs_modulus"] * p["inertia"] / (p["density"] * p["area"] * p["length"] ** 4))
    exact = np.array([1.875104068711961**2, 4.694091132974175**2]) * w_ref
    w = 2 * np.pi * m.natural_frequencies(2)  # rad/s
    assert np.all(w >= exact * (1 - 1e-12))  # Rayleigh-Ritz: from above
    np.testing.assert_allclose(w[0], exact[0], rtol=tol1)
    np.testing.assert_allclose(w[1], exact[1], rtol=tol2)


def test_pinned_pinned_links_at_rest():
    # Crank at rest: the four-bar coupler and the slider-crank rod are pinned-pinned beams,
    # w_1 = pi^2 sqrt(EI / (rho A L^4)); 6 and 8 elements are within 1e-4 (measured 5.2e-5 and
    # 1.6e-5 above it).
    for mech, name in (
        (scenes.four_bar(crank_speed=0.0), "coupler_length"),
        (scenes.slider_crank(crank_speed=0.0), "rod_length"),
    ):
        p = mech.parameters
        exact = math.pi**2 * math.sqrt(
            p["youngs_modulus"] * p["inertia"] / (p["density"] * p["area"] * p[name] ** 4)
        )
        assert 2 * np.pi * mech.natural_frequencies(1)[0] == pytest.approx(exact, rel=1e-4)


def test_in_plane_frequency_without_stiffening_drops_as_omega_squared():
    # Without K2, K3 the spinning beam only softens: w^2 = w0^2 - Omega^2 (M_IC = -Omega^2 M on the
    # transverse DOFs, which it shifts uniformly; measured to 1e-11), tolerance 1e-6.
    w0 = 2 * np.pi * scenes.spin_up(rotation=fc.Rotation.constant(0.0)).natural_frequencies(1)[0]
    om = 2.0
    lin = scenes.spin_up(geometric=False, rotation=fc.Rotation.constant(om))
    w = 2 * np.pi * lin.natural_frequencies(1, coriolis=False)[0]
    assert w**2 == pytest.approx(w0**2 - om**2, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------


def test_cli_spin_up(tmp_path, capsys):
    ref = tmp_path / "table.csv"
    ref.write_text(
        "# made-up table, for the plotting path only\nlambda,w1,w2\n0,3.5160,22.0345\n1,3.6817,22.1810\n"
    )
    out = tmp_path / "su"
    argv = [
        "spin-up",
        "--out",
        str(out),
        "--t-end",
        "0.5",
        "--dt",
        "0.01",
        "--elements",
        "4",
        "--speeds",
        "3",
    ]
    assert main([*argv, "--reference", str(ref)]) == 0
    for f in ("spin_up_tip.png", "spin_up_frequencies.png", "summary.md"):
        assert (out / f).stat().st_size > 0
    assert "Euler-Bernoulli cantilever" in capsys.readouterr().out


def test_cli_slider_crank_with_clearance(tmp_path):
    out = tmp_path / "sc"
    assert main(["slider-crank", "--out", str(out), "--t-end", "0.002", "--clearance-at", "slider_pin"]) == 0
    for f in ("slider_crank_rod.png", "slider_crank_contact.png", "summary.md"):
        assert (out / f).stat().st_size > 0
    assert "Clearance joint `slider_pin`" in (out / "summary.md").read_text()


def test_cli_four_bar(tmp_path):
    out = tmp_path / "fb"
    assert main(["four-bar", "--out", str(out), "--t-end", "0.01", "--flexible-rocker"]) == 0
    assert (out / "four_bar_coupler.png").stat().st_size > 0


def test_cli_reports_bad_input(tmp_path, capsys):
    assert main(["four-bar", "--out", str(tmp_path), "--t-end", "0.01", "--elements", "0"]) == 2
    assert "elements" in capsys.readouterr().err


@pytest.mark.parametrize("at", ["crank_pin", "slider_pin"])
def test_slider_crank_clearance_with_little_damping_runs_with_implicit_contact(at):
    # Restitution about 0.9: the lagged kappa pumps energy into the impacts (MN forces, divergence
    # within 20 ms at dt = 1e-5 s); implicit contact keeps the peak force at its converged level
    # (measured over 0.05 s: 8.1-8.2 kN at the crank pin, 4.0-4.3 kN at the slider pin, dt = 1e-5
    # to 1.25e-6 s) and the rod's compression below its Euler load (7.5 kN). Checked over 0.02 s:
    # peak force below 10 kN, compression below the Euler load.
    mech = scenes.slider_crank(clearance_at=at, bearing_damping_ratio=0.03)
    p = mech.parameters
    euler = np.pi**2 * p["youngs_modulus"] * p["inertia"] / p["rod_length"] ** 2
    res = mech.simulate(0.02, 1e-5, iterate=True, record=fc.Record(axial_force=True, displacements=True))
    j = res.joint(at)
    assert j.impacts >= 1 and 0 < j.max_force < 1e4
    assert -res.link("rod").axial_force.min() < euler


def _flores() -> dict:
    rows = (Path(__file__).parent / "data" / "flores_slider_crank.csv").read_text().splitlines()
    pairs = [r.split(",") for r in rows if r and not r.startswith("#")][1:]
    return {k: float(v) for k, v in pairs}


def test_flores_slider_crank_kinematics_give_the_published_slider_acceleration():
    """The slider-crank frame driver at the Flores benchmark's geometry (crank 0.05 m, rod
    0.12 m, 5000 rpm, no offset) gives the slider acceleration extremes the benchmark reports for
    ideal joints, -19 419 and +9 696 m/s^2, to the unit they are given in; the minimum is the
    closed form at top dead centre, -r w^2 (1 + r / L)."""
    d = _flores()
    r, rod = d["crank_length"], d["rod_length"]
    w = d["crank_speed_rpm"] * 2 * np.pi / 60
    frame = Frame.slider_crank(r, rod, Rotation.constant(w), "slider")
    t = np.linspace(0.0, 2 * np.pi / w, 200_001)  # 1.8e-3 degrees apart
    acc = np.array([frame.at(x)[2][0] for x in t])
    assert acc.min() == pytest.approx(-r * w**2 * (1 + r / rod), rel=1e-12)
    assert round(acc.min()) == d["slider_acc_min"]
    assert round(acc.max()) == d["slider_acc_max"]


def test_fixed_steps_stop_their_iterations_on_the_carried_contraction_rate():
    # RATE_CARRY_DOWN: a step of the ideal slider-crank (no contact) stops once the correction
    # times the contraction rate carried from earlier steps (about 1e-4 on a kept factor) is
    # within iter_tol, instead of taking a third iteration to see its correction below it; the
    # midspan deflection is that of iterations to 1e-12 within the iteration tolerance's scale
    m = fc.scenes.slider_crank()
    r = m.simulate(0.02, 1e-5, record=fc.Record(midspan=True))
    tight = m.simulate(0.02, 1e-5, iter_tol=1e-12, record=fc.Record(midspan=True))
    # measured 1.99 iterations a step from rest (2.91 at iter_tol 1e-9; 1.81 over 0.1 s, 2.87
    # before the carried rate)
    assert r.stats["iterations"] < 2.4 * r.stats["steps"]
    a, b = r.link("rod").midspan, tight.link("rod").midspan
    scale = np.abs(b).max()
    # at most 1e-8 of the displacement scale left per step, over 2000 steps: 2e-5 of the
    # deflection's amplitude (1.6 mm; measured 2.7e-6, and 1.6e-9 at iter_tol 1e-9)
    assert np.abs(a - b).max() <= 2e-5 * scale


@pytest.mark.parametrize("clearance_at", [None, "crank_pin", "rocker_pin"])
def test_a_flexible_rocker_is_numbered_next_to_the_coupler(clearance_at):
    """The rocker of the four-bar is held at ground by its first node and attached to the coupler
    by its last: numbered from its last node, its unknowns follow the coupler's end and the half
    band stays that of one element's two nodes (6), not the coupler's whole length (19 and 20
    when numbered from its first node)."""
    m = scenes.four_bar(flexible_rocker=True, clearance_at=clearance_at)
    stats = m.simulate(2e-4, 1e-5).stats
    assert stats["unknowns"] in (36, 38)
    assert stats["bandwidth"] <= 6


@pytest.mark.parametrize(
    "build",
    [
        lambda: scenes.slider_crank(clearance_at="slider_pin"),
        lambda: scenes.four_bar(clearance_at="rocker_pin", flexible_rocker=True),
    ],
    ids=["slider pin", "four-bar rocker pin"],
)
def test_a_joint_whose_sides_turn_at_different_rates_runs_on_the_contact_free_factor(build):
    """The slider pin (a turning rod on a fixed guide) and the pin between a four-bar's flexible
    coupler and rocker: their contact goes on the contact-free factor by Woodbury (the damping's
    frame term through the velocity rows), which is kept for up to 20 steps, and the run agrees
    with the refactorizing solver to well within the step's discretization error (the rod's
    midspan over 0.01 s: 5e-5 and 1e-6 of its scale, against ~1e-1 from halving the step)."""
    rec = fc.Record(midspan=True)
    a = build().simulate(0.01, 1e-5, record=rec)
    b = build().simulate(0.01, 1e-5, record=rec, solver="refactor")
    assert a.stats["woodbury_steps"] > 500 and a.stats["woodbury_fallbacks"] == 0
    assert a.stats["factorizations"] < 0.1 * a.stats["steps"]
    assert b.stats["factorizations"] > a.stats["steps"]
    ma = a.link(a.link_names[-1]).midspan
    mb = b.link(b.link_names[-1]).midspan
    assert np.abs(ma - mb).max() <= 1e-3 * np.abs(mb).max()
    pa, pb = a.joint(a.joint_names[0]).max_force, b.joint(b.joint_names[0]).max_force
    assert pa == pytest.approx(pb, rel=1e-4)
