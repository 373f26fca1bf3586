"""Outputs of clearance studies (issue 14, item 3) against cases with known answers: the contact
modes (free flight, impact, continuous contact) and the energy dissipated in a joint, on both
steppers and as study outputs.

The bar of these tests is a stiff, nearly massless beam between two point masses ``m`` at its end
nodes, each the journal of a clearance joint to a fixed bearing: moving transversely, the two
joints close together and each sees one journal of mass ``m`` (the beam's own mass adds half of
it), the single-degree-of-freedom impact of the closed forms (docs/contact.md).
"""

from __future__ import annotations

import math

import flexclear as fc
import numpy as np
import pytest
from flexclear import Record, scenes
from flexclear.study import MODE_OUTPUTS, OUTPUTS, Study, Uniform

L, AREA, RHO, E, INERTIA = 0.1, 1e-4, 1.0, 2e11, 1e-8
MASS = 0.05  # kg, point mass at each end
M_EFF = MASS + RHO * AREA * L / 2  # kg, per joint
K = 1e6  # N/m
ZETA = 0.1
C = 2 * ZETA * math.sqrt(K * M_EFF)  # N s/m
V0 = 0.1  # m/s, approach speed
CLEARANCE = 1.0537e-4  # m (the crossing falls between steps)
MODES = ("free_flight_fraction", "impact_fraction", "continuous_fraction")


def bar(*, clearance=CLEARANCE, v0=V0, gravity=0.0, y0=0.0, masses=True, damping=C, elements=1):
    """The bar of the module docstring, moving at ``-v0`` (m/s) along y from ``y = y0`` (m)."""
    m = fc.Model()
    n = 3 * (elements + 1)
    iv, iu = np.zeros(n), np.zeros(n)
    iv[1::3], iu[1::3] = -v0, y0
    m.add_link(
        "bar",
        length=L,
        elements=elements,
        youngs_modulus=E,
        density=RHO if masses else 7800.0,
        area=AREA,
        inertia=INERTIA,
        initial_velocity=iv,
        initial_displacement=iu,
    )
    if masses:
        m.add_mass("bar", 0, MASS)
        m.add_mass("bar", elements, MASS)
    m.add_body("ground")
    for name, node, x in (("left", 0, 0.0), ("right", elements, L)):
        m.add_joint(
            name,
            "bar",
            node,
            clearance=clearance,
            stiffness=K,
            damping=damping,
            body="ground",
            point=(x, 0.0),
        )
    if gravity:
        m.add_gravity(0.0, -gravity)
    return m


def check_fractions(j) -> None:
    f = [getattr(j, k) for k in MODES]
    assert all(0.0 <= x <= 1.0 for x in f), f
    assert sum(f) == pytest.approx(1.0, abs=1e-12)


def analytic_dissipation() -> float:
    """One Kelvin-Voigt impact: 1/2 m (v_in^2 - v_out^2), v_out = e v_in,
    e = exp(-zeta pi / sqrt(1 - zeta^2))."""
    e = math.exp(-ZETA * math.pi / math.sqrt(1 - ZETA**2))
    return 0.5 * M_EFF * V0**2 * (1 - e**2)


def test_a_single_impact_dissipates_the_analytic_energy():
    an = analytic_dissipation()  # 1.1706e-4 J
    for dt, rel in ((1e-6, 0.02), (1e-7, 0.003)):
        r = bar().simulate(3e-3, dt, record=Record(contact_modes=True, impact_log=True))
        for name in ("left", "right"):
            j = r.joint(name)
            assert j.impacts == 1 and np.isfinite(j.impact_log.duration[0])
            # measured at dt 1e-6: -1.74 %, at 1e-7: -0.19 % (first order in the step)
            assert j.dissipated_energy == pytest.approx(an, rel=rel)
            assert j.continuous_fraction == 0.0 and j.impact_fraction > 0.0
            check_fractions(j)
            # the time in contact is the impact's: pi / omega_d (0.706 ms) of 3 ms
            assert j.impact_fraction == pytest.approx(j.contact_time / 3e-3, rel=1e-9)
        # the run's own balance: what the journals lost is what the joints dissipated
        v_out = r.state[1][1]
        lost = 0.5 * M_EFF * (V0**2 - v_out**2)
        assert 2 * j.dissipated_energy / (2 * lost) == pytest.approx(1.0, abs=3e-3)


def test_event_aware_iterated_steps_take_out_the_first_order_dissipation_error():
    # dt 1e-6 s: plain steps -1.74 %, events with the contact iterated -0.14 % (measured); events
    # with the contact lagged (iterate=False) leave the error as it is (measured -1.74 % too)
    an = analytic_dissipation()
    err = {}
    for key, kw in (("plain", {}), ("events", {"events": True}), ("both", {"events": True, "iterate": True})):
        j = bar().simulate(3e-3, 1e-6, record=Record(contact_modes=True), **kw).joint("left")
        assert j.impacts == 1
        err[key] = abs(j.dissipated_energy / an - 1)
    assert err["both"] < 0.003 and err["both"] < err["plain"] / 5
    assert err["events"] == pytest.approx(err["plain"], rel=0.05)


def test_a_single_impact_on_adaptive_steps_dissipates_the_analytic_energy():
    # measured -0.44 % at tol 1e-3 and -0.076 % at tol 1e-4: the error falls with the tolerance
    an = analytic_dissipation()
    err = {}
    for tol in (1e-3, 1e-4):
        j = bar().simulate(3e-3, tol=tol, record=Record(contact_modes=True)).joint("left")
        assert j.impacts == 1 and j.continuous_fraction == 0.0
        err[tol] = abs(j.dissipated_energy / an - 1)
    assert err[1e-3] < 0.01 and err[1e-4] < 0.002 and err[1e-4] < err[1e-3] / 3


def test_a_single_hunt_crossley_impact_dissipates_what_its_restitution_says():
    # Hunt-Crossley (n = 1.5, e = 0.9): the effective restitution of one impact of the journal's
    # mass, integrated to 1e-12 by flexclear.contact.effective_restitution (0.909, docs/contact.md)
    law = fc.contact.HuntCrossley(stiffness=5e8, restitution=0.9)
    e = fc.contact.effective_restitution(law, M_EFF, V0).restitution
    an = 0.5 * M_EFF * V0**2 * (1 - e**2)  # 4.343e-5 J
    m = fc.Model()
    iv = np.zeros(6)
    iv[1::3] = -V0
    m.add_link(
        "bar",
        length=L,
        elements=1,
        youngs_modulus=E,
        density=RHO,
        area=AREA,
        inertia=INERTIA,
        initial_velocity=iv,
    )
    m.add_mass("bar", 0, MASS)
    m.add_mass("bar", 1, MASS)
    m.add_body("ground")
    for name, node, x in (("left", 0, 0.0), ("right", 1, L)):
        m.add_joint(name, "bar", node, clearance=CLEARANCE, law=law, body="ground", point=(x, 0.0))
    j = m.simulate(3e-3, 1e-7, record=Record(contact_modes=True)).joint("left")
    # measured -0.93 % at dt 1e-7 (-9.4 % at 1e-6: first order, the approach speed of the law is
    # that of the episode's first step)
    assert j.impacts == 1 and j.dissipated_energy == pytest.approx(an, rel=0.015)
    assert j.continuous_fraction == 0.0
    check_fractions(j)


def test_dissipated_energy_is_the_work_balance_of_the_run_on_both_steppers():
    # a steel bar without point masses: the impact also sets the beam vibrating, and the
    # energy the run lost (kinetic + strain, Record(energy=True)) is what the joints dissipated
    model = bar(masses=False, elements=2)
    r = model.simulate(3e-3, 1e-6, record=Record(contact_modes=True, energy=True), stepper="newton")
    lr = r.link("bar")
    lost = (lr.kinetic[0] + lr.strain[0]) - (lr.kinetic[-1] + lr.strain[-1])
    w = sum(r.joint(n).dissipated_energy for n in ("left", "right"))
    assert w == pytest.approx(lost, rel=5e-3)  # measured 0.35 %
    # the constant stepper (every link translates, clearance joints only) agrees
    rc = bar(masses=False, elements=2).simulate(3e-3, 1e-6, record=Record(contact_modes=True))
    assert rc.stats["stepper"] == "constant"
    wc = sum(rc.joint(n).dissipated_energy for n in ("left", "right"))
    assert wc == pytest.approx(w, rel=5e-3)
    for res in (r, rc):
        for n in ("left", "right"):
            check_fractions(res.joint(n))
            assert res.joint(n).impacts == 1 and res.joint(n).continuous_fraction == 0.0


@pytest.mark.parametrize("stepper", ["constant", "newton"])
def test_an_ideal_joint_is_all_free_flight(stepper):
    # a clearance far wider than the motion: the joint never closes
    r = bar(clearance=1.0, masses=False).simulate(
        2e-3, 1e-5, stepper=stepper, record=Record(contact_modes=True)
    )
    assert r.stats["stepper"] == stepper
    for n in ("left", "right"):
        j = r.joint(n)
        assert j.impacts == 0 and j.max_force == 0.0 and j.dissipated_energy == 0.0
        assert (j.free_flight_fraction, j.impact_fraction, j.continuous_fraction) == (1.0, 0.0, 0.0)


def test_an_ideal_joint_of_a_mechanism_is_all_free_flight():
    sc = scenes.slider_crank(clearance_at="crank_pin", clearance=10.0)
    j = sc.simulate(0.01, 1e-5, record=Record(contact_modes=True, histories=False)).joint("crank_pin")
    assert j.impacts == 0 and j.dissipated_energy == 0.0
    assert (j.free_flight_fraction, j.impact_fraction, j.continuous_fraction) == (1.0, 0.0, 0.0)


def test_a_pressed_joint_is_all_continuous_contact():
    # gravity holds the bar on the bearings: started at rest in its static deflection
    g = 9.81
    sag = MASS * g / K  # + the beam's share, negligible
    model = bar(v0=0.0, gravity=g, y0=-(CLEARANCE + sag), damping=5 * C)
    r = model.simulate(0.02, 1e-5, record=Record(contact_modes=True, impact_log=True))
    for n in ("left", "right"):
        j = r.joint(n)
        # no episode begins in the run: contact from the initial state is no impact
        assert j.impacts == 0 and len(j.impact_log) == 0
        assert j.contact_time == pytest.approx(0.02, rel=1e-9)
        assert (j.free_flight_fraction, j.impact_fraction, j.continuous_fraction) == (0.0, 0.0, 1.0)
        # at rest on the wall: no dissipation beyond round-off, the stored spring energy left out
        assert abs(j.dissipated_energy) < 1e-6 * 0.5 * K * sag**2


def test_a_journal_dropped_on_the_wall_bounces_then_stays():
    # dropped from the centre: impacts first, then continuous contact
    model = bar(v0=0.0, gravity=9.81 * 50, damping=2 * C)
    r = model.simulate(0.05, 1e-6, record=Record(contact_modes=True, impact_log=True))
    j = r.joint("left")
    log = j.impact_log
    assert j.impacts >= 2 and np.isnan(log.duration[-1])  # the last episode lasts to the end
    assert j.impact_fraction > 0.0 and j.continuous_fraction > 0.5
    check_fractions(j)
    # the last, open-ended episode is the continuous contact, the earlier ones are impacts
    assert j.continuous_fraction * 0.05 == pytest.approx(0.05 - log.time[-1], rel=1e-3)


def test_clearance_outputs_converge_as_the_step_shrinks():
    """The crank-pin slider-crank (scene defaults, 0.1 s) at dt = 1e-5, 2.5e-6 and 6.25e-7 s.
    Measured (2026-11-29): peak force 7984.4, 7978.8, 7978.5 N; RMS force 675.60, 675.08,
    675.23 N; dissipated energy 0.1531, 0.1683, 0.1705 J (differences 0.0152 then 0.0022: about
    order 1.4, so the scene's default step leaves about 10 % out); free-flight, impact and
    continuous fractions within 0.0008 of each other; impact speed 2.132, 2.129, 2.134 m/s;
    3 impacts at every step (first closings at 0.47, 1.43 and 1.99 ms, after separations of
    330-338 and 41-46 um). Every closing counted (contact_episodes) gave 13, 37 and 103: after
    1.99 ms the journal stays on the wall but leaves it for a few steps, by at most 2.2, 0.29
    and 0.16 um, and closes again, and a finer step resolves more of these rebounds."""
    m = scenes.slider_crank(clearance_at="crank_pin")
    runs = []
    for dt in (1e-5, 2.5e-6, 6.25e-7):
        r = m.simulate(0.1, dt, record=Record(histories=False, contact_modes=True, impact_log=True))
        runs.append(r.joint("crank_pin"))
    # the approach speed of the first impact, from the last open state: 2.132, 2.129, 2.134 m/s
    # (from the first closed state it was 1.165, 1.715, 2.001: slowed by the contact force)
    speed = [j.max_impact_velocity for j in runs]
    assert max(speed) - min(speed) < 5e-3 * speed[2], speed
    # the natural contact period of the deepest impact: 104.5, 104.3, 104.2 us, ten steps of
    # the coarsest run
    period = [j.contact_period for j in runs]
    assert max(period) - min(period) < 5e-3 * period[2], period
    peak = [j.max_force for j in runs]
    rms = [j.rms_force for j in runs]
    work = [j.dissipated_energy for j in runs]
    # converging: the second refinement moves each output less than the first, and the peak and
    # RMS force sit within 0.2 % and 0.1 % of the finest run
    for v in (peak, rms, work):
        assert abs(v[2] - v[1]) < abs(v[1] - v[0]), v
    assert peak[0] == pytest.approx(peak[2], rel=2e-3)
    assert rms[0] == pytest.approx(rms[2], rel=1e-3)
    # the dissipated energy at better than first order (the differences fall by more than the
    # refinement's 4, here 6.9)
    assert abs(work[2] - work[1]) < abs(work[1] - work[0]) / 4, work
    for k in MODES:
        f = [getattr(j, k) for j in runs]
        assert max(f) - min(f) < 2e-3, (k, f)  # 200 us of the 0.1 s run
    # the impacts are the same three at every step, entered within 20 us of each other; the
    # closings counted one by one grow with the resolution
    assert [j.impacts for j in runs] == [3, 3, 3]
    for j in runs:
        assert len(j.impact_log) == 3
        np.testing.assert_allclose(j.impact_log.time, runs[2].impact_log.time, atol=2e-5)
    episodes = [j.contact_episodes for j in runs]
    assert 3 < episodes[0] < episodes[1] < episodes[2], episodes


@pytest.mark.parametrize("dt", [1e-4, 1e-5, 1e-6])
def test_the_impact_velocity_of_a_free_flight_is_its_speed(dt):
    # the bar flies at V0 until it reaches the walls: the approach speed is V0 at any step (the
    # first closed state of the implicit contact, slowed by the contact for part of its step,
    # gave 0.0917, 0.0995 and 0.09996 m/s at dt = 1e-4, 1e-5 and 1e-6 s)
    r = bar().simulate(4e-3, dt, iterate=True, record=Record(histories=False, impact_log=True))
    for name in ("left", "right"):
        j = r.joint(name)
        assert j.impact_log.speed[0] == pytest.approx(V0, rel=1e-9)
        # (at 1e-4 s, 7 steps a contact, the bar rebounds across the clearance faster than it
        # came, 0.134 m/s: the energy a fixed step adds at an entry between steps)
        assert j.max_impact_velocity == max(j.impact_log.speed)


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_the_impact_velocity_of_a_free_flight_is_its_speed_on_adaptive_steps(tol):
    # an adaptive step cuts just short of the circle: the approach speed is that of the cut's
    # state (V0, up to the cut's tolerance), not of the substep after it, which the contact has
    # slowed
    r = bar().simulate(4e-3, tol=tol, record=Record(histories=False, impact_log=True))
    for name in ("left", "right"):
        j = r.joint(name)
        assert j.impact_log.speed[0] == pytest.approx(V0, rel=1e-4)
        # the cut is the crossing: the bar flies CLEARANCE at V0 from the start
        assert j.impact_log.time[0] == pytest.approx(CLEARANCE / V0, rel=tol)


def test_a_mechanisms_impact_velocity_on_adaptive_steps_is_the_converged_one():
    # the four-bar's first rocker-pin impact (0.15 mm, 1.45 ms): 0.21808 m/s on fixed steps of
    # 1.5625e-7 s (0.2158, 0.2182, 0.2180 at 1e-5, 2.5e-6, 6.25e-7 s); the substep after the
    # adaptive cut read 0.197 at tol 1e-3; the cut's state gives 0.2187 and 0.2181 at tol 1e-3
    # and 1e-4 (within 0.5 %: the cut lies within its tolerance of the circle)
    def run(**kw):
        m = fc.scenes.four_bar(clearance_at="rocker_pin", clearance=1.5e-4, bearing_stiffness=5e7)
        return m.simulate(0.003, record=Record(histories=False, impact_log=True), **kw).joint("rocker_pin")

    fine = run(dt=1.5625e-7).impact_log
    for tol in (1e-3, 1e-4):
        log = run(tol=tol).impact_log
        assert log.speed[0] == pytest.approx(fine.speed[0], rel=5e-3)
        assert log.time[0] == pytest.approx(fine.time[0], abs=2e-7)


def test_an_adaptive_runs_output_instants_carry_the_laws_force_at_their_state():
    # output instants inside an accepted adaptive step are interpolated; their force is the law's
    # at the interpolated state: none where the joint is open (the step before the first impact's
    # cut read the cut's closed terms: 108 N at 1.4500 ms, 0.22 um short of the circle), and
    # the RMS of the history near the fine fixed-step one (8.2643 N at dt 1.5625e-7 s; 8.6530 N
    # before, 8.3928 N now: what is left is the 1 us output grid's sampling of the 4 us impact)
    m = fc.scenes.four_bar(clearance_at="rocker_pin", clearance=1.5e-4, bearing_stiffness=5e7)
    r = m.simulate(0.003, tol=1e-3, dt=1e-6, record=Record(joints=["rocker_pin"]))
    j = r.joint("rocker_pin")
    force, pen = np.asarray(j.force), np.asarray(j.penetration)
    assert (pen > 0).any() and (pen <= 0).any()
    assert not np.any(force[pen <= 0]), np.flatnonzero((pen <= 0) & (force != 0))
    assert math.sqrt(np.mean(force**2)) == pytest.approx(8.2643, rel=0.025)


def test_an_adaptive_runs_rms_is_weighted_by_time_whatever_its_output_grid():
    # the RMS of a tol run counts every accepted step for its length, not the output instants:
    # the four-bar's rocker pin over 3 ms (one 4 us impact, then contact) gives 8.2892, 8.2887
    # and 8.2851 N on output grids of 3 us (t_end / 1000), 10 us and 1 us, 8.2736 N at tol 1e-4,
    # against 8.2643 N over every fixed step of 1.5625e-7 s (on the output grid: 8.0410 N at
    # 10 us, 8.3928 N at 1 us)
    def rms(**kw):
        m = fc.scenes.four_bar(clearance_at="rocker_pin", clearance=1.5e-4, bearing_stiffness=5e7)
        return m.simulate(0.003, record=Record(histories=False), **kw).joint("rocker_pin")

    fine = rms(dt=1.5625e-7)
    for kw in (dict(tol=1e-3), dict(tol=1e-3, dt=1e-5), dict(tol=1e-3, dt=1e-6), dict(tol=1e-4)):
        j = rms(**kw)
        assert j.rms_force == pytest.approx(fine.rms_force, rel=5e-3), kw
        assert j.rms_penetration == pytest.approx(fine.rms_penetration, rel=2e-3), kw


def test_the_contact_period_is_that_of_an_undamped_linear_impact():
    # the bar hits the walls at V0 without damping: a half period of m_eff on K, pi sqrt(m/K)
    # (7.02e-4 s), from its approach speed and deepest penetration; at dt = 1e-6 s the sampled
    # peak is within (pi dt / T)^2 / 8 of the true one
    r = bar(damping=0.0).simulate(2.5e-3, 1e-6, iterate=True, record=Record(histories=False))
    period = math.pi * math.sqrt(M_EFF / K)
    for name in ("left", "right"):
        assert r.joint(name).contact_period == pytest.approx(period, rel=1e-4)
    # no impact yet: NaN
    r = bar(damping=0.0).simulate(5e-4, 1e-6, record=Record(histories=False))
    assert math.isnan(r.joint("left").contact_period)


def test_study_outputs_include_the_contact_modes_and_the_dissipation():
    for name in MODES + ("dissipated_energy",):
        assert name in OUTPUTS
    assert not set(MODE_OUTPUTS) & set(Study("slider_yoke", samples=1).outputs)  # opt-in
    res = Study(
        "slider_yoke",
        outputs=list(OUTPUTS),
        vary={"clearance": Uniform(1e-4, 5e-4)},
        samples=4,
        seed=3,
        t_end=0.01,
        dt=1e-5,
    ).run(threads=1, progress=False)
    f = res.frame
    assert (f["status"] == "ok").all()
    total = sum(f[f"bearing.{k}"] for k in MODES)
    np.testing.assert_allclose(total, 1.0, atol=1e-12)
    assert (f["bearing.dissipated_energy"] >= 0).all()
    # the same numbers as a single run of the first sample
    row = f.iloc[0]
    one = scenes.slider_yoke(clearance=row["clearance"]).simulate(
        0.01, 1e-5, record=Record(contact_modes=True, histories=False)
    )
    j = one.joint("bearing")
    for k in MODES + ("dissipated_energy",):
        assert row[f"bearing.{k}"] == getattr(j, k)


def test_moving_frame_study_outputs():
    res = Study(
        "slider_crank",
        outputs=list(MODE_OUTPUTS),
        vary={"clearance": Uniform(1e-4, 3e-4)},
        fixed={"clearance_at": "crank_pin"},
        samples=2,
        seed=1,
        t_end=0.005,
        dt=1e-5,
    ).run(threads=1, progress=False)
    f = res.frame
    assert (f["status"] == "ok").all()
    np.testing.assert_allclose(sum(f[f"crank_pin.{k}"] for k in MODES), 1.0, atol=1e-12)
    assert (f["crank_pin.dissipated_energy"] > 0).all()


def test_orbit_is_the_journal_position_history():
    r = bar().simulate(2e-3, 1e-6, record=Record(contact_modes=True, position=True, every=10))
    qx, qy = r.joint("left").orbit()
    assert qx.shape == qy.shape == r.time.shape == (201,)
    assert np.max(np.hypot(qx, qy)) < CLEARANCE + 2e-5  # inside the circle, but for the contact
    with pytest.raises(fc.RecordingError):
        bar().simulate(1e-4, 1e-6).joint("left").orbit()


# -- sliders ------------------------------------------------------------------------------------


def test_slider_histories_follow_the_slider_crank_kinematics():
    r_c, l_r, w = 0.15, 0.30, 150.0
    res = scenes.slider_crank().simulate(
        0.02, 1e-5, record=Record(contact_modes=True, histories=False, sliders=True)
    )
    assert res.slider_names == ["slider"]
    s = res.slider("slider")
    t = res.time
    assert s.position.shape == s.velocity.shape == s.acceleration.shape == t.shape
    # the rigid slider-crank: x = r cos(wt) + sqrt(l^2 - r^2 sin^2(wt)); the flexible rod moves
    # the slider by micrometres
    th = w * t
    x = r_c * np.cos(th) + np.sqrt(l_r**2 - (r_c * np.sin(th)) ** 2)
    assert np.max(np.abs(s.position - x)) < 1e-4
    # velocity and acceleration are the derivatives of the position (central differences)
    dt = t[1] - t[0]
    v_fd = np.gradient(s.position, dt)
    np.testing.assert_allclose(s.velocity[1:-1], v_fd[1:-1], atol=1e-3 * np.max(np.abs(s.velocity)))
    a_fd = np.gradient(s.velocity, dt)
    assert np.median(np.abs(s.acceleration[1:-1] - a_fd[1:-1])) < 1e-2 * np.max(np.abs(s.acceleration))
    # the peak over every step: here every step is recorded
    assert s.max_acceleration == np.max(np.abs(s.acceleration))
    # at least the rigid-body peak r w^2 (1 + r / l) at the top dead centre (5062 m/s^2); the
    # rod's vibration (it starts undeformed at full crank speed) adds to it (11596 m/s^2)
    assert s.max_acceleration > r_c * w**2 * (1 + r_c / l_r)
    with pytest.raises(fc.ModelError, match="unknown slider"):
        res.slider("piston")
    # without histories the slider keeps its exact peak only: the histories are an explicit opt-in
    lean = scenes.slider_crank().simulate(0.02, 1e-5, record=Record(contact_modes=True, histories=False))
    assert lean.slider("slider").max_acceleration == s.max_acceleration
    assert "position=<not recorded>" in repr(lean.slider("slider"))  # the repr shows, never raises
    with pytest.raises(fc.RecordingError, match=r"Record\(sliders=True\)"):
        _ = lean.slider("slider").position
    with pytest.raises(fc.RecordingError, match="slider_reference"):
        _ = s.position_deviation_mean


def test_slider_peak_counts_every_step_whatever_the_record_stride():
    every = scenes.slider_crank().simulate(0.01, 1e-5).slider("slider")
    thin = (
        scenes.slider_crank()
        .simulate(0.01, 1e-5, record=Record(contact_modes=True, every=50))
        .slider("slider")
    )
    assert thin.max_acceleration == every.max_acceleration
    assert thin.position.size == 21 and every.position.size == 1001
    np.testing.assert_array_equal(thin.acceleration, every.acceleration[::50])


# -- the orbit in studies -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "build,fixed,joint",
    [("slider_yoke", {}, "bearing"), ("slider_crank", {"clearance_at": "crank_pin"}, "crank_pin")],
)
def test_study_orbit_is_opt_in_and_matches_a_single_run(build, fixed, joint):
    kw = dict(vary={"clearance": Uniform(1e-4, 3e-4)}, fixed=fixed, samples=2, seed=5, t_end=0.004, dt=1e-5)
    plain = Study(build, history_every=10, **kw)
    assert f"{joint}.qx_history" not in plain.run(threads=1, progress=False).frame.columns
    s = Study(build, history_every=10, orbit=True, **kw)
    assert s.memory_estimate() == 2 * plain.memory_estimate()
    f = s.run(threads=1, progress=False).frame
    row = f.iloc[0]
    one = s._scene_fn(**s._scene_kwargs({"clearance": row["clearance"]})).simulate(
        0.004, 1e-5, record=Record(contact_modes=True, position=True, every=10)
    )
    qx, qy = one.joint(joint).orbit()
    np.testing.assert_array_equal(row[f"{joint}.qx_history"], qx)
    np.testing.assert_array_equal(row[f"{joint}.qy_history"], qy)
    assert Study.from_dict(s.to_dict()).orbit and "orbit" not in plain.to_dict()
    with pytest.raises(fc.InvalidParameterError, match="orbit"):
        Study(build, orbit=True, **kw)


def test_contact_modes_are_opt_in():
    for stepper in ("constant", "newton"):
        j = bar(masses=False).simulate(2e-3, 1e-5, stepper=stepper).joint("left")
        assert not j.recorded("dissipated_energy") and j.recorded("penetration")
        for k in MODE_OUTPUTS:
            with pytest.raises(fc.RecordingError, match="contact_modes=True"):
                getattr(j, k)
        assert j.impacts == 1  # the other outputs as ever


def test_link_peaks_are_those_of_the_recorded_histories():
    res = scenes.slider_crank().simulate(0.005, 1e-5, record=Record(midspan=True, axial_force=True))
    rod = res.link("rod")
    assert rod.max_midspan == np.max(np.abs(rod.midspan)) > 0
    assert rod.max_axial_force == np.max(np.abs(rod.axial_force)) > 0
    plain = scenes.slider_crank().simulate(0.001, 1e-5).link("rod")
    assert np.isnan(plain.max_midspan) and np.isnan(plain.max_axial_force)


def test_tracked_link_peaks_count_every_step_from_start_in_o1_memory():
    # Record(link_peaks=True): running maxima over every step, the same values as the channels'
    # largest magnitudes at every step (the same operations on the same states), kept without
    # any history, and from `start` on only
    model = scenes.slider_crank(clearance_at="crank_pin")
    full = model.simulate(0.005, 1e-5, record=Record(midspan=True, axial_force=True, link_peaks=True))
    rod = full.link("rod")
    assert rod.peaks == (np.max(np.abs(rod.midspan)), np.max(np.abs(rod.axial_force)))
    assert rod.max_midspan > 0 and rod.max_axial_force > 0
    bare = model.simulate(0.005, 1e-5, record=Record(histories=False, link_peaks=True))
    assert (
        _stored(bare) == 0 and model.memory_estimate(0.5, 1e-5, Record(histories=False, link_peaks=True)) == 0
    )
    assert bare.link("rod").peaks == rod.peaks
    # from 1 ms on: after the axial force's peak (0.61 ms, the first impact), before the
    # midspan's (3.53 ms)
    late = model.simulate(0.005, 1e-5, record=Record(histories=False, link_peaks=True, start=0.001)).link(
        "rod"
    )
    after = full.time >= 0.001
    assert late.max_midspan == np.max(np.abs(rod.midspan[after])) == rod.max_midspan
    assert late.max_axial_force == np.max(np.abs(rod.axial_force[after])) < rod.max_axial_force
    # tracking changes nothing else
    plain = model.simulate(0.005, 1e-5, record=Record(histories=False))
    assert plain.joint("crank_pin").max_force == bare.joint("crank_pin").max_force
    assert plain.link("rod").peaks is None


def test_link_peaks_run_on_the_newton_stepper():
    # as link energies: a model the constant stepper would run moves to a moving-frame stepper,
    # and stepper="constant" is refused naming the record field
    yoke = scenes.slider_yoke()
    assert yoke.simulate(0.002, 1e-5).stats["stepper"] == "constant"
    r = yoke.simulate(0.002, 1e-5, record=Record(histories=False, link_peaks=True))
    assert r.stats["stepper"] in ("constant-rate", "newton")
    with pytest.raises(fc.InvalidParameterError, match="record.link_peaks"):
        yoke.simulate(0.002, 1e-5, stepper="constant", record=Record(link_peaks=True))


def test_study_link_outputs_are_the_single_runs_peaks():
    from flexclear.study import LINK_OUTPUTS

    kw = dict(fixed={"clearance_at": "crank_pin"}, samples=3, seed=4, t_end=0.004, dt=1e-5)
    s = Study("slider_crank", vary={"clearance": Uniform(1e-4, 3e-4)}, links=True, **kw)
    assert s.output_columns[-2:] == [f"rod.{o}" for o in LINK_OUTPUTS]
    f = s.run(threads=2, progress=False).frame
    assert (f["status"] == "ok").all()
    for _, row in f.iterrows():
        one = s._scene_fn(**s._scene_kwargs({"clearance": row["clearance"]})).simulate(
            0.004, 1e-5, record=Record(histories=False, link_peaks=True)
        )
        assert (row["rod.max_midspan"], row["rod.max_axial_force"]) == one.link("rod").peaks
    # the same through the per-sample path of slider outputs
    both = Study("slider_crank", vary={"clearance": Uniform(1e-4, 3e-4)}, links=True, sliders=True, **kw)
    g = both.run(threads=1, progress=False).frame
    np.testing.assert_array_equal(g["rod.max_midspan"], f["rod.max_midspan"])
    assert Study.from_dict(s.to_dict()).links and "links" not in Study("slider_crank", **kw).to_dict()
    # with one link, a bare output name is its column (thresholds of a study file, exceedance)
    assert (
        s.column("max_midspan") == "rod.max_midspan"
        and both.column("max_acceleration") == "slider.max_acceleration"
    )
    with pytest.raises(fc.InvalidParameterError, match="links"):
        Study("slider_crank", links="yes", **kw)


def test_study_slider_outputs_against_the_ideal_mechanism():
    from flexclear.study import SLIDER_OUTPUTS

    kw = dict(fixed={"clearance_at": "crank_pin"}, samples=3, seed=2, t_end=0.004, dt=1e-5, sliders=True)
    s = Study("slider_crank", vary={"clearance": Uniform(1e-4, 3e-4)}, **kw)
    result = s.run(threads=2, progress=False)
    f = result.frame
    assert (f["status"] == "ok").all()
    cols = [f"slider.{o}" for o in SLIDER_OUTPUTS]
    assert all(c in f.columns for c in cols) and s.output_columns[-len(cols) :] == cols
    assert list(result.summary().index) == s.output_columns
    assert result.exceedance("slider.max_acceleration", 0.0)["n"] == 3
    assert s._ideal_made == 1  # one ideal run for the three samples (only the clearance varies)
    # the same numbers by hand for the first sample
    row = f.iloc[0]
    res = scenes.slider_crank(clearance_at="crank_pin", clearance=row["clearance"]).simulate(
        0.004, 1e-5, record=Record(histories=False, sliders=True)
    )
    ideal = (
        scenes.slider_crank()
        .simulate(0.004, 1e-5, record=Record(histories=False, sliders=True))
        .slider("slider")
    )
    x = res.slider("slider")
    assert row["slider.max_acceleration"] == x.max_acceleration
    dev = np.abs(x.position - ideal.position)
    assert row["slider.position_deviation_max"] == pytest.approx(np.max(dev), rel=1e-12)
    assert row["slider.acceleration_deviation_mean"] == pytest.approx(
        np.mean(np.abs(x.acceleration - ideal.acceleration)), rel=1e-12
    )
    assert row["slider.position_deviation_max"] > 0
    # an ideal joint has zero deviation: a clearance joint that never closes follows the ideal
    # mechanism's path only as far as the journal floats, so compare the ideal with itself
    same = scenes.slider_crank().simulate(0.004, 1e-5, record=Record(histories=False, sliders=True))
    from flexclear.study.runner import _slider_outputs

    zero = _slider_outputs(same, same, "slider", 0.0)
    assert all(
        zero[f"{c}_deviation_{m}"] == 0.0
        for c in ("position", "velocity", "acceleration")
        for m in ("mean", "max")
    )
    with pytest.raises(fc.InvalidParameterError, match="sliders"):
        Study("slider_yoke", sliders=True)


def _stored(res) -> int:
    """Values the run's output holds in arrays (time, joint, node, link and slider histories)."""
    raw = res._raw
    parts = [raw.time]
    for group, fields in (
        (raw.joints, ("penetration", "force", "qx", "qy", "friction", "slip")),
        (raw.nodes, ("u", "v", "theta")),
        (raw.links, ("frame", "displacements", "axial_force", "midspan", "kinetic", "strain", "momentum")),
        (raw.sliders, ("position", "velocity", "acceleration")),
    ):
        parts += [np.asarray(getattr(h, f)) for h in group for f in fields]
    return sum(p.size for p in parts)


def test_study_holds_an_ideal_run_only_while_samples_of_its_structure_wait(monkeypatch):
    # the crank speed varies: every sample is its own structure, with its own ideal run (slider
    # histories: O(steps)); the batch drops each once its samples have it, so that the runs held
    # stay about one per thread instead of growing with the samples (256 samples of the
    # reference study: 409 -> 174 MiB peak RSS)
    from flexclear.study import runner as st

    held = []
    get = st._IdealRuns.get

    def spy(self, *a, **k):
        run = get(self, *a, **k)
        held.append(len(self.runs))
        return run

    monkeypatch.setattr(st._IdealRuns, "get", spy)
    s = Study(
        "slider_crank",
        vary={"crank_speed": Uniform(100.0, 200.0)},
        fixed={"clearance_at": "crank_pin"},
        samples=5,
        seed=3,
        t_end=0.002,
        dt=1e-5,
        sliders=True,
    )
    f = s.run(threads=1, progress=False).frame
    assert (f["status"] == "ok").all() and f["slider.position_deviation_max"].gt(0).all()
    assert s._ideal_made == 5 and held == [1] * 5
    # on two threads the ideal runs are made side by side: the same frame, bit for bit
    g = Study.from_dict(s.to_dict()).run(threads=2, progress=False).frame
    assert g.drop(columns="wall_time").equals(f.drop(columns="wall_time"))


def test_slider_deviations_online_equal_the_history_based_ones():
    every, start = 2, 1e-3
    rec = dict(histories=False, every=every, start=start)
    ideal = scenes.slider_crank().simulate(0.004, 1e-5, record=Record(sliders=True, **rec))
    i = ideal.slider("slider")
    model = scenes.slider_crank(clearance_at="crank_pin", clearance=2e-4)
    full = model.simulate(0.004, 1e-5, record=Record(sliders=True, slider_reference=ideal, **rec))
    lean = model.simulate(0.004, 1e-5, record=Record(slider_reference=ideal, **rec))
    x, y = full.slider("slider"), lean.slider("slider")
    keep = full.time >= start
    assert np.array_equal(full.time, ideal.time) and 0 < keep.sum() < keep.size
    for ch in ("position", "velocity", "acceleration"):
        dev = np.abs(getattr(x, ch) - getattr(i, ch))[keep]
        # a running sum against numpy's pairwise sum: equal to round-off
        assert getattr(x, f"{ch}_deviation_mean") == pytest.approx(np.mean(dev), rel=1e-12)
        assert getattr(x, f"{ch}_deviation_max") == np.max(dev) > 0
        # the same online without the histories (nothing else differs between the two runs)
        for m in ("mean", "max"):
            assert getattr(y, f"{ch}_deviation_{m}") == getattr(x, f"{ch}_deviation_{m}")
    assert y.max_acceleration == x.max_acceleration
    # an ideal joint deviates by exactly 0 from the ideal run
    same = scenes.slider_crank().simulate(0.004, 1e-5, record=Record(slider_reference=ideal, **rec))
    s = same.slider("slider")
    assert all(
        getattr(s, f"{c}_deviation_{m}") == 0.0
        for c in ("position", "velocity", "acceleration")
        for m in ("mean", "max")
    )
    # a reference on another grid is refused, never misaligned
    for t_end, dt, k in ((0.005, 1e-5, every), (0.004, 2e-5, every), (0.004, 1e-5, 3)):
        with pytest.raises(fc.InvalidParameterError, match="record.slider_reference"):
            model.simulate(t_end, dt, record=Record(slider_reference=ideal, histories=False, every=k))
    with pytest.raises(fc.InvalidParameterError, match="record.slider_reference"):
        model.simulate(0.004, 1e-5, record=Record(slider_reference=lean))  # no histories to compare with


def test_a_run_without_histories_keeps_o_outputs_whatever_its_length():
    # the constant stepper (slider-yoke) and the Newton one (slider-crank, four-bar)
    for other in (scenes.slider_yoke(), scenes.four_bar()):
        assert [_stored(other.simulate(t, 1e-5, record=Record(histories=False))) for t in (0.002, 0.008)] == [
            0,
            0,
        ]
    model = scenes.slider_crank(clearance_at="crank_pin")
    sizes = [_stored(model.simulate(t, 1e-5, record=Record(histories=False))) for t in (0.002, 0.008)]
    assert sizes == [0, 0]
    r = model.simulate(0.002, 1e-5, record=Record(histories=False))
    assert r.time.size == 0 and model.memory_estimate(0.008, 1e-5, Record(histories=False)) == 0
    # what is asked for explicitly is kept on the grid (and only that grows with the run)
    kept = model.simulate(0.002, 1e-5, record=Record(histories=False, sliders=True))
    assert kept.time.size == kept.slider("slider").position.size == 201
    # a study sample with slider outputs: the same stored values over T and 4T (its deviations
    # online against the ideal run)
    from flexclear.study import runner as st

    runs = []
    for t_end in (0.002, 0.008):
        s = Study(
            "slider_crank",
            vary={"clearance": Uniform(1e-4, 3e-4)},
            fixed={"clearance_at": "crank_pin"},
            samples=1,
            t_end=t_end,
            dt=1e-5,
            sliders=True,
        )
        kw = s._scene_kwargs({"clearance": 2e-4})
        sample = s._scene_fn(**kw)
        sample._build_kwargs = kw
        simulate = sample.simulate

        def spy(*a, _simulate=simulate, **k):
            runs.append(_simulate(*a, **k))
            return runs[-1]

        sample.simulate = spy
        out = st._run_one_moving(s, sample, t_end, 1e-5, {})
        assert out["status"] == "ok" and out["sliders"]["slider"]["position_deviation_max"] > 0
    assert [_stored(r) for r in runs] == [0, 0]


def test_slider_histories_in_pandas():
    res = scenes.slider_crank().simulate(0.002, 1e-5, record=Record(every=10))
    df = res.to_pandas()
    s = res.slider("slider")
    np.testing.assert_array_equal(df["slider.position"].to_numpy(), s.position)
    np.testing.assert_array_equal(df["slider.acceleration"].to_numpy(), s.acceleration)
