"""Friction in the clearance joint (issue 15, item 4): closed forms of a journal sliding in its
bearing, the regularizations below the regularization speed, the energy balance of a run, and
the errors.

The journal of these tests is node 0 of a short steel link carrying a point mass ``M`` there,
its rotation held in the link frame (so it spins with the frame), in a bearing of a ground body
or of a spinning body, under gravity: the journal sits on the bearing with the constant radial
load ``W`` (its weight). Sliding with slip speed ``v`` (the pin's spin enters:
``v = (v_J - v_B) . t + R_J w_J - R_B w_B``, docs/contact.md), it climbs the bearing to the
friction angle: at rest on the circle, the normal force ``F_N`` along ``-n`` and the friction
force ``F_t`` along ``t = S n`` balance the weight, ``-F_N n + F_t t = W y``, so
``F_N = -W n_y``, ``F_t = W n_x`` and ``F_t / F_N = -sign(v) mu c_d(|v|)`` (the friction circle:
``tan(alpha) = 1 / (sign(v) mu c_d)`` for the contact angle ``alpha`` of ``n``). The friction
moment on the spinning side is ``mu F_N R`` and the power it dissipates ``mu F_N |v|``: with
the journal spinning at ``w``, ``|v| = R_J w`` (the torque ``mu F_N R_J``); with the bearing
spinning, ``|v| = R_B w = (R_J + c) w``.
"""

from __future__ import annotations

import math
import pickle

import flexclear as fc
import numpy as np
import pytest
from flexclear import Frame, InvalidParameterError, Record, Rotation

G = 9.81  # m/s^2
M = 1.0  # kg, point mass at the journal
L, AREA, RHO, E, INERTIA = 0.02, 1e-4, 10.0, 2e11, 1e-9  # a light carrier for the journal
W = (M + RHO * AREA * L) * G  # N, the journal's load
CLEARANCE = 1e-4  # m
RJ = 0.01  # m, journal radius
K = 1e8  # N/m, bearing stiffness
C = 1e4  # N s/m, bearing damping (half the critical damping of M on K)
MU = 0.1


def journal_in_bearing(friction, *, spin="journal", rate=10.0, coefficient=None):
    """The scene of the module docstring with the side ``spin`` turning at ``rate`` (rad/s),
    started at the friction angle for the effective coefficient ``coefficient`` (``mu c_d``;
    ``MU`` by default) and the slip's sign."""
    mu_eff = MU if coefficient is None else coefficient
    s = 1.0 if spin == "journal" else -1.0  # sign of the slip speed
    alpha = math.atan2(-1.0, -s * mu_eff)
    f_n = W / math.sqrt(1 + mu_eff**2)
    q0 = (CLEARANCE + f_n / K) * np.array([math.cos(alpha), math.sin(alpha)])
    w = rate if spin == "journal" else 0.0
    u0, v0 = np.zeros(6), np.zeros(6)
    for node in (0, 1):
        u0[3 * node : 3 * node + 2] = q0
        # fixed in space while the link frame turns at w: local velocity -w S q
        v0[3 * node : 3 * node + 2] = (w * q0[1], -w * q0[0])
    m = fc.Model()
    m.add_link(
        "pin",
        length=L,
        elements=1,
        youngs_modulus=E,
        density=RHO,
        area=AREA,
        inertia=INERTIA,
        frame=Frame.rotating(Rotation.constant(w)),
        initial_displacement=u0,
        initial_velocity=v0,
    )
    m.add_mass("pin", 0, M)
    m.add_support("pin", 0, u=False, v=False, theta=True)
    m.add_gravity(0.0, -G)
    m.add_body("bearing", frame=Frame.rotating(Rotation.constant(rate if spin == "bearing" else 0.0)))
    m.add_joint(
        "joint",
        "pin",
        0,
        clearance=CLEARANCE,
        stiffness=K,
        damping=C,
        damping_law="radial",  # a normal dashpot: the recorded force is F_N
        body="bearing",
        friction=friction,
        journal_radius=RJ,
    )
    return m, f_n, alpha


def run(model, t_end=0.01, dt=1e-5, **kw):
    return model.simulate(
        t_end,
        dt,
        method="modified",
        iterate=True,
        record=Record(contact_modes=True, position=True),
        **kw,
    )


@pytest.mark.parametrize("spin", ["journal", "bearing"])
def test_sliding_journal_takes_the_friction_torque_mu_f_r(spin):
    rate = 10.0  # rad/s: slip 0.1 m/s, ten times the regularization's upper speed
    m, f_n, alpha = journal_in_bearing(fc.contact.Coulomb(MU), spin=spin, rate=rate)
    r = run(m)
    assert r.stats["stepper"] == "newton"
    j = r.joint("joint")
    radius = RJ if spin == "journal" else RJ + CLEARANCE
    # the slip speed: the spinning side's surface speed (the journal's centre stays put;
    # measured within 2e-8 of it)
    assert np.allclose(np.abs(j.slip), radius * rate, rtol=1e-6)
    assert np.all(np.sign(j.slip) == (1.0 if spin == "journal" else -1.0))
    # sliding: F_t = -sign(v) mu F_N at every recorded state (Coulomb at full friction)
    assert np.allclose(j.friction, -np.sign(j.slip) * MU * j.force, rtol=1e-12, atol=0)
    # the journal stays at the friction angle under the load W (measured: within 2e-7 rad)
    angle = np.arctan2(j.qy, j.qx)
    assert np.max(np.abs(angle - alpha)) < 1e-5
    assert np.allclose(j.force, f_n, rtol=1e-5)
    # the friction moment mu F_N R on the spinning side dissipates mu F_N R w: the friction
    # energy of the run is that torque times the angle turned (measured within 3e-7)
    torque = MU * f_n * radius
    assert j.friction_energy == pytest.approx(torque * rate * 0.01, rel=1e-5)
    # R_J and R_B differ by the clearance (1 %): the torque uses the spinning side's radius
    other = RJ + CLEARANCE if spin == "journal" else RJ
    assert abs(j.friction_energy / (MU * f_n * other * rate * 0.01) - 1) > 5e-3


@pytest.mark.parametrize(
    "law",
    [
        fc.contact.Coulomb(MU),  # Ambrosio: v0 = 1e-4, v1 = 1e-2 m/s
        fc.contact.Coulomb(MU, regularization="linear", v_reg=1e-2),
    ],
    ids=["ambrosio", "linear"],
)
def test_below_the_regularization_speed_the_force_follows_the_regularization(law):
    rate = 0.5  # rad/s: slip R_J w = 5e-3 m/s, inside both ramps
    v = RJ * rate
    if law.regularization == "ambrosio":
        cd = lambda s: np.clip((np.abs(s) - law.v0) / (law.v1 - law.v0), 0.0, 1.0)  # noqa: E731
    else:
        cd = lambda s: np.minimum(np.abs(s) / law.v_reg, 1.0)  # noqa: E731
    m, f_n, alpha = journal_in_bearing(law, rate=rate, coefficient=MU * float(cd(v)))
    j = run(m).joint("joint")
    # the ratio F_t / (mu F_N) is the regularization at the slip speed of each recorded state
    ratio = -j.friction / (MU * j.force)
    assert np.allclose(ratio, cd(j.slip), rtol=1e-9, atol=0)
    # and the journal stays where that reduced coefficient puts it, slipping at R_J w
    # (measured within 1.3e-9)
    assert np.allclose(j.slip, v, rtol=1e-6)
    assert np.allclose(ratio, float(cd(v)), rtol=1e-6)
    assert np.max(np.abs(np.arctan2(j.qy, j.qx) - alpha)) < 1e-6


def test_lugre_bristles_load_to_the_stribeck_curve():
    # from z = 0 at constant slip v the bristle state is z_ss (1 - exp(-t / tau)),
    # tau = g(v) / (sigma0 |v|) = 1e-5 s here (g = mu far above the Stribeck speed), and the
    # step's exact update gives it at every step: F_t / (-mu F_N) = 1 - exp(-t / tau)
    law = fc.contact.LuGre(mu=MU, mu_static=0.15, stribeck_speed=1e-3)
    rate, dt, t_end = 10.0, 1e-5, 0.01
    m, f_n, alpha = journal_in_bearing(law, rate=rate)
    r = run(m, t_end=t_end, dt=dt)
    j = r.joint("joint")
    tau = MU / (law.sigma0 * RJ * rate)
    ratio = -j.friction / (MU * j.force)
    # (the journal gives way by up to 6e-6 m/s while the friction loads: the slip moves by 6e-5)
    assert np.allclose(ratio, -np.expm1(-r.time / tau), rtol=2e-4, atol=1e-9)
    # exactly: the state of each step is the law's exact update over the step at the step's
    # end slip (LuGre.advance), from the last accepted state
    z = np.zeros_like(j.slip)
    for k in range(1, len(z)):
        z[k] = law.advance(z[k - 1], j.slip[k], dt)
    assert np.allclose(j.friction, law.force(z, j.slip, j.force), rtol=1e-9, atol=1e-12)
    # the energy: mu F_N v (t_end - tau) for the exponential loading, on the trapezoidal rule
    # (which adds dt (1/2 + sum exp(-k) - 1) = 0.082 dt to tau)
    lag = tau + dt * (0.5 + 1 / math.expm1(dt / tau) - tau / dt)
    assert j.friction_energy == pytest.approx(MU * f_n * RJ * rate * (t_end - lag), rel=1e-4)  # 2.2e-5


def bar(friction, *, vx=0.05, vy=0.1, x0=-8e-5, elements=2):
    """A steel bar thrown at two fixed bearings (tests/test_outputs.py) obliquely: from
    ``x0`` (m) off the bearings' centres, at ``vx`` along the bar and ``-vy`` across (m/s), so
    that the journals hit the bearing circles off their line of motion and slide."""
    m = fc.Model()
    n = 3 * (elements + 1)
    iv, iu = np.zeros(n), np.zeros(n)
    iv[0::3], iv[1::3], iu[0::3] = vx, -vy, x0
    m.add_link(
        "bar",
        length=0.1,
        elements=elements,
        youngs_modulus=2e11,
        density=7800.0,
        area=1e-4,
        inertia=1e-8,
        initial_velocity=iv,
        initial_displacement=iu,
    )
    m.add_body("ground")
    for name, node, x in (("left", 0, 0.0), ("right", elements, 0.1)):
        m.add_joint(
            name,
            "bar",
            node,
            clearance=1.0537e-4,
            stiffness=1e6,
            damping=2.0,
            damping_law="radial",  # a normal dashpot: the normal work counts all of it
            body="ground",
            point=(x, 0.0),
            friction=friction,
            journal_radius=0.005,
        )
    return m


@pytest.mark.parametrize("events", [False, True])
@pytest.mark.parametrize(
    "law",
    [fc.contact.Coulomb(0.3), fc.contact.LuGre(mu=0.3, mu_static=0.4, stribeck_speed=1e-3)],
    ids=["coulomb", "lugre"],
)
def test_friction_dissipation_is_the_work_balance_of_the_run(law, events):
    # no load, no drive: the kinetic and strain energy the run lost is what the joints took,
    # the normal law's dissipation plus friction's (with events, each cut restarts the step
    # from its start: LuGre's bristle state goes back with the rest of the state)
    r = bar(law).simulate(
        3e-3,
        1e-6,
        record=Record(contact_modes=True, energy=True),
        method="modified",
        iterate=True,
        events=events,
    )
    assert r.stats["stepper"] == "newton"
    lr = r.link("bar")
    lost = (lr.kinetic[0] + lr.strain[0]) - (lr.kinetic[-1] + lr.strain[-1])
    joints = [r.joint(n) for n in ("left", "right")]
    fric = sum(j.friction_energy for j in joints)
    normal = sum(j.dissipated_energy for j in joints)
    assert all(j.impacts >= 1 for j in joints)
    assert fric > 0.5 * lost  # friction takes most of it (measured 95 %)
    if events:
        assert r.stats["event_steps"] >= 2  # entries and exits cut
    assert fric + normal == pytest.approx(lost, rel=1e-3)  # measured 1.4e-4 (Coulomb)


def test_friction_routes_to_the_newton_stepper_and_the_constant_ones_refuse_it():
    # without friction this model runs on the constant stepper; with it, on Newton
    assert bar(None).simulate(1e-4, 1e-6).stats["stepper"] == "constant"
    m = bar(fc.contact.Coulomb(0.1))
    assert m.engine == "moving-frame" and bar(None).engine == "translating"
    assert m.simulate(1e-4, 1e-6).stats["stepper"] == "newton"
    # a result with friction pickles and goes to pandas with its friction channels
    r = m.simulate(2e-3, 1e-6)
    back = pickle.loads(pickle.dumps(r))
    assert np.array_equal(back.joint("left").friction, r.joint("left").friction)
    assert {"left.friction", "left.slip"} <= set(r.to_pandas().columns)
    # the memory estimate counts the two friction channels of each recorded joint
    rec = Record(energy=True)  # the Newton stepper for both
    extra = m.memory_estimate(1e-3, 1e-6, rec) - bar(None).memory_estimate(1e-3, 1e-6, rec)
    assert extra == 8 * (1000 + 2) * 2 * 2
    one = Record(energy=True, joints=["left"])
    assert m.memory_estimate(1e-3, 1e-6, one) - bar(None).memory_estimate(1e-3, 1e-6, one) == extra // 2
    for stepper in ("constant", "constant-rate"):
        with pytest.raises(InvalidParameterError, match="stepper") as e:
            m.simulate(1e-4, 1e-6, stepper=stepper)
        assert "friction" in str(e.value)


def test_bad_friction_input_names_the_parameter():
    with pytest.raises(InvalidParameterError, match="mu"):
        fc.contact.Coulomb(-0.1)
    m = fc.Model()
    m.add_link("bar", length=0.1, elements=1, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-8)
    m.add_body("ground")
    kw = dict(clearance=1e-4, stiffness=1e6, damping=0.0, body="ground")
    with pytest.raises(InvalidParameterError, match="journal_radius"):
        m.add_joint("a", "bar", 0, friction=fc.contact.Coulomb(0.1), **kw)
    for bad in (0.0, -1e-3, float("nan")):
        with pytest.raises(InvalidParameterError, match="journal_radius"):
            m.add_joint("a", "bar", 0, friction=fc.contact.Coulomb(0.1), journal_radius=bad, **kw)
    with pytest.raises(InvalidParameterError, match="friction"):
        m.add_joint("a", "bar", 0, friction=0.1, journal_radius=0.01, **kw)
    # nothing was added by the failed calls
    m.add_joint("a", "bar", 0, friction=fc.contact.Coulomb(0.1), journal_radius=0.01, **kw)
    assert m.joint_names == ["a"]


def test_friction_moments_act_on_both_sides_and_keep_the_angular_momentum():
    # Two free steel links joined at their node 0 (at the origin) by a clearance joint with
    # friction: link "a" (the journal) in a frame spinning at 5 rad/s, thrown towards -y; link
    # "b" (the bearing, along -x) at rest. Friction at the impact passes angular momentum from
    # "a" to "b": the force pair F_t t, -F_t t at the two centres and the moments F_t R_J on the
    # journal's rotation and -F_t R_B on the bearing's. About the origin, b gains
    # -integral F_t R_B dt, a gains integral F_t (R_J + |q|) dt (its centre sits at q from b's),
    # and the total changes by integral F_t (|q| + R_J - R_B) dt = integral F_t delta dt only
    # (the contact points differ by the penetration); the normal force pair (along q, radial
    # dashpot) has no moment. Without friction the total is kept to 5e-11 of the transfer.
    w, vy, rj, c = 5.0, 0.1, 5e-3, 1e-4
    steel = dict(length=0.1, elements=2, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-8)
    m = fc.Model()
    iv = np.zeros(9)
    iv[1::3] = -vy
    m.add_link("a", initial_velocity=iv, frame=Frame.rotating(Rotation.constant(w)), **steel)
    m.add_link("b", frame=Frame.rotating(Rotation.fixed(math.pi)), **steel)
    m.add_joint(
        "joint",
        "a",
        0,
        target=("b", 0),
        clearance=c,
        stiffness=1e6,
        damping=2.0,
        damping_law="radial",
        friction=fc.contact.Coulomb(0.3),
        journal_radius=rj,
    )
    r = m.simulate(
        3e-3,
        1e-6,
        record=Record(energy=True, contact_modes=True, position=True),
        method="modified",
        iterate=True,
    )
    j = r.joint("joint")
    ha, hb = r.link("a").momentum, r.link("b").momentum
    # one impact, slipping forwards: the journal's spin R_J w = 0.025 m/s dominates
    assert j.impacts == 1 and np.all(j.slip[j.force > 0] > 0)
    rq = np.hypot(j.qx, j.qy)
    to_b = np.trapezoid(-j.friction * (rj + c), r.time)
    to_a = np.trapezoid(j.friction * (rj + rq), r.time)
    leak = np.trapezoid(j.friction * (rq - c), r.time)
    assert to_b > 0
    assert hb[-1] - hb[0] == pytest.approx(to_b, rel=1e-3)  # measured 4e-5
    assert ha[-1] - ha[0] == pytest.approx(to_a, rel=2e-3)  # measured 5e-4
    change = (ha[-1] + hb[-1]) - (ha[0] + hb[0])
    assert abs(change - leak) <= 2e-3 * to_b  # measured 5e-4; the leak itself is 1.5e-3


@pytest.mark.parametrize(("method", "iterate"), [("force", False), ("modified", False), ("modified", True)])
@pytest.mark.parametrize(
    "law",
    [
        fc.contact.Coulomb(0.0),
        fc.contact.Coulomb(5.0, regularization="linear", v_reg=1e-6),
        fc.contact.Coulomb(0.3, mu_static=0.5, stribeck_speed=1e-2),
        fc.contact.LuGre(mu=2.0, mu_static=3.0, stribeck_speed=1e-4, sigma0=1e9, sigma1=1e3, sigma2=10.0),
    ],
    ids=["frictionless", "steep", "stribeck", "stiff-lugre"],
)
def test_every_coupling_gives_finite_results_or_a_named_error(law, method, iterate):
    # extreme friction on every coupling, with event cuts: a run completes with finite outputs or
    # stops with a ConvergenceError (no NaN, no panic)
    m = bar(law)
    try:
        r = m.simulate(
            2e-3, 1e-6, method=method, iterate=iterate, events=True, record=Record(contact_modes=True)
        )
    except fc.ConvergenceError as e:
        assert e.partial is not None
        return
    for n in ("left", "right"):
        j = r.joint(n)
        assert np.all(np.isfinite(j.friction)) and np.all(np.isfinite(j.slip))
        assert np.isfinite(j.friction_energy)
        if law.mu == 0.0:
            assert j.friction_energy == 0.0 and not np.any(j.friction)
