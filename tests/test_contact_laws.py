"""Contact laws of flexclear.contact (issue 15, the part before the engine merge): closed forms of
single impacts, the effective-restitution table of ../shared/CONTACT.md, closed-form tangents,
the pin-in-hole stiffness and its scale invariance, friction, and extreme parameters.

Every reference is physics or a published/closed-form value, never a value this code printed.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from flexclear import ConvergenceError, InvalidParameterError, contact
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

DATA = Path(__file__).parent / "data"
K_FLORES = 6.61e10  # N/m^1.5, the pin of the Flores benchmark (CONTACT.md section 2)

HYSTERESIS = [
    contact.HuntCrossley,
    contact.LankaraniNikravesh,
    contact.Flores,
    contact.Gonthier,
    contact.CarvalhoMartins,
]


def all_laws(k: float, e: float) -> list:
    """Every normal law at stiffness k and nominal restitution e (where it applies)."""
    return [
        contact.KelvinVoigt(k, damping=1e-3 * k),
        contact.Hertz(k),
        *[cls(k, e) for cls in HYSTERESIS],
    ]


# ---------------------------------------------------------------------------------------------
# single impacts against closed forms


@pytest.mark.parametrize(
    "m, k, v0", [(1.0, 1e10, 1.0), (0.14, K_FLORES, 0.3), (1e-3, 1e3, 20.0), (50.0, 1e13, 1e-3)]
)
def test_undamped_hertz_impact(m, k, v0):
    # Hertz impact (Johnson 1985, ch. 11): peak (5 m v0^2 / (4 K))^(2/5) exactly; duration
    # 3.2181 (m/K)^(2/5) v0^(-1/5) with the constant given to 5 digits (rounding 1.6e-5
    # relative: tolerance 2e-5); no dissipation, so e = 1 to the integration accuracy (1e-9)
    imp = contact.effective_restitution(contact.Hertz(k), m, v0)
    peak = (5 * m * v0**2 / (4 * k)) ** 0.4
    assert imp.restitution == pytest.approx(1.0, abs=1e-9)
    assert imp.max_penetration == pytest.approx(peak, rel=1e-9)
    assert imp.contact_time == pytest.approx(3.2181 * (m / k) ** 0.4 * v0**-0.2, rel=2e-5)
    assert imp.contact_time == pytest.approx(2.9433 * peak / v0, rel=5e-5)  # 4 digits given


@pytest.mark.parametrize("zeta", [0.0, 0.02, 0.2, 0.6, 0.95])
def test_linear_spring_dashpot_restitution(zeta):
    # a spring-dashpot that separates at d = 0: e = exp(-zeta pi / sqrt(1 - zeta^2)) and contact
    # time pi / omega_d, both exact; 1e-9 covers the integration error
    m, k = 0.5, 2e8
    c = 2 * zeta * math.sqrt(k * m)
    imp = contact.effective_restitution(contact.KelvinVoigt(k, c), m, 0.8)
    wd = math.sqrt(k / m) * math.sqrt(1 - zeta**2)
    assert imp.restitution == pytest.approx(math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), abs=1e-9)
    assert imp.contact_time == pytest.approx(math.pi / wd, rel=1e-9)


def test_overdamped_spring_dashpot_without_clip_never_separates():
    # zeta > 1 and tension allowed: the mass creeps back to d = 0 without reaching it; named error
    law = contact.KelvinVoigt(1e6, damping=2 * 3.0 * math.sqrt(1e6 * 1.0))
    with pytest.raises(ConvergenceError):
        contact.effective_restitution(law, 1.0, 1.0)
    # with no_tension the dashpot cannot pull: the mass leaves with a small but finite speed
    imp = contact.effective_restitution(contact.KelvinVoigt(1e6, law.damping, no_tension=True), 1.0, 1.0)
    assert 0.0 < imp.restitution < 0.2


def _table():
    with open(DATA / "contact_restitution.csv") as f:
        rows = [r for r in f if not r.startswith("#")]
    return [(r["law"], float(r["nominal"]), float(r["effective"])) for r in csv.DictReader(rows)]


@pytest.mark.parametrize("law, nominal, effective", _table())
def test_effective_restitution_table(law, nominal, effective):
    # the table gives 3 decimals: +-5e-4 rounding, 1e-4 margin
    cls = getattr(contact, law)
    got = contact.effective_restitution(cls(K_FLORES, nominal), mass=0.14, approach_speed=0.5)
    assert got.restitution == pytest.approx(effective, abs=6e-4)


@pytest.mark.parametrize("law, nominal, effective", _table())
def test_effective_restitution_against_an_independent_integrator(law, nominal, effective):
    # scipy's DOP853 on the scaled impact y'' = -y^1.5 (1 + chi y') (m = K = v0 = 1) with the
    # chi of the published formulas, written here again: the core must agree to 1e-7 (both
    # integrate to ~1e-10; the event location of solve_ivp limits the agreement)
    from scipy.integrate import solve_ivp

    e = nominal
    chi = {
        "LankaraniNikravesh": 0.75 * (1 - e**2),
        "HuntCrossley": 1.5 * (1 - e),
        "Flores": 1.6 * (1 - e) / e,
    }[law]

    def rhs(t, x):
        y = max(x[0], 0.0)
        return [x[1], -(y**1.5) * (1 + chi * x[1])]

    def leave(t, x):
        return x[0]

    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(rhs, (0, 100), [0.0, 1.0], method="DOP853", rtol=1e-12, atol=1e-14, events=leave)
    ref = -sol.y_events[0][0][1]
    got = contact.effective_restitution(getattr(contact, law)(1.0, e), 1.0, 1.0).restitution
    assert got == pytest.approx(ref, abs=1e-7)


@pytest.mark.parametrize("e", [0.5, 0.7, 0.9, 0.95, 0.99, 1.0])
def test_carvalho_martins_achieves_its_nominal_restitution(e):
    # their chi(e) approximates the exact restitution of the Hunt-Crossley form: 5e-4 covers the
    # approximation (the paper's claim is agreement over the usual range, e >= ~1/3)
    got = contact.effective_restitution(contact.CarvalhoMartins(K_FLORES, e), 0.14, 0.5).restitution
    assert got == pytest.approx(e, abs=5e-4)


@pytest.mark.parametrize("cls", HYSTERESIS)
def test_effective_restitution_independent_of_mass_speed_and_stiffness(cls):
    # the scaled impact equation holds only chi and n: identical up to integration error (1e-9)
    ref = contact.effective_restitution(cls(1e9, 0.6), 1.0, 1.0)
    ref_scale = (1.0 / 1e9) ** 0.4
    for k, m, v0 in [(1e3, 1e-3, 1e-2), (1e13, 100.0, 30.0), (K_FLORES, 0.14, 0.5)]:
        imp = contact.effective_restitution(cls(k, 0.6), m, v0)
        assert imp.restitution == pytest.approx(ref.restitution, abs=1e-9)
        # and the peak scales as (m v0^2 / K)^(1/(n+1)), the time as that over v0
        scale = (m * v0**2 / k) ** 0.4
        assert imp.max_penetration / scale == pytest.approx(ref.max_penetration / ref_scale, rel=1e-8)
        assert imp.contact_time * v0 / scale == pytest.approx(ref.contact_time / ref_scale, rel=1e-8)


# ---------------------------------------------------------------------------------------------
# forces and tangents


def test_force_formulas():
    # the published forms, written out here: F = K d^1.5 (1 + chi dd / v0)
    d, dd, v0, k, e = 2e-5, -0.1, 0.4, K_FLORES, 0.8
    chis = {
        contact.HuntCrossley: 1.5 * (1 - e),
        contact.LankaraniNikravesh: 0.75 * (1 - e**2),
        contact.Flores: 8 * (1 - e) / (5 * e),
        contact.Gonthier: (1 - e**2) / e,
        contact.CarvalhoMartins: 1.5 * (1 - e) * (11 - e) / (1 + 9 * e),
    }
    for cls, chi in chis.items():
        assert cls(k, e).force(d, dd, v0) == pytest.approx(k * d**1.5 * (1 + chi * dd / v0), rel=1e-14)
    assert contact.Hertz(k, exponent=1.2).force(d, dd) == pytest.approx(k * d**1.2, rel=1e-14)
    assert contact.KelvinVoigt(1e8, 50.0).force(d, dd) == pytest.approx(1e8 * d + 50.0 * dd, rel=1e-14)
    lit = contact.KelvinVoigt(1e8, 50.0, damping_law="literal")
    assert lit.force(d, dd) == pytest.approx(1e8 * d + 50.0 * abs(dd), rel=1e-14)


def test_approach_speed_floor_and_tension_clip():
    law = contact.LankaraniNikravesh(1e9, 0.5, min_approach_speed=1e-2)
    d = 1e-5
    # below the floor (and for 0 or NaN) the floor is used
    for v0 in [1e-4, 0.0, float("nan")]:
        assert law.force(d, 1e-3, v0) == law.force(d, 1e-3, 1e-2)
    # a fast restitution pulls: clipped to zero with zero tangents, or kept when asked
    assert law.force(d, -1.0, 0.5) == 0.0
    assert law.tangent(d, -1.0, 0.5) == (0.0, 0.0)
    sticky = contact.LankaraniNikravesh(1e9, 0.5, clip_tension=False)
    assert sticky.force(d, -1.0, 0.5) < 0.0
    # open contact: nothing
    assert law.force(-1e-6, 1.0, 1.0) == 0.0


@pytest.mark.parametrize("e", [0.05, 0.5, 0.95])
def test_closed_form_tangents_match_central_differences(e):
    d = np.array([1e-7, 3e-6, 2e-5, 4e-5])
    dd = np.array([0.3, -0.05, 0.0, -0.2])
    v0 = np.array([0.5, 0.2, 1e-4, 0.7])
    for law in all_laws(K_FLORES, e):
        kd, kv = law.tangent(d, dd, v0)
        # central differences with relative steps 1e-6: truncation ~1e-12 relative, round-off
        # ~1e-16 / 1e-6 = 1e-10 relative: 1e-6 is a wide margin
        hd, hv = 1e-6 * d, 1e-6 * np.maximum(abs(dd), 1e-3)
        fd = (law.force(d + hd, dd, v0) - law.force(d - hd, dd, v0)) / (2 * hd)
        fv = (law.force(d, dd + hv, v0) - law.force(d, dd - hv, v0)) / (2 * hv)
        clip = (law.force(d, dd + hv, v0) == 0) | (law.force(d, dd - hv, v0) == 0)  # one-sided there
        f = law.force(d, dd, v0)
        ok_d = (abs(kd - fd) <= 1e-6 * np.maximum(abs(kd), abs(f / d))) | clip
        ok_v = (abs(kv - fv) <= 1e-6 * abs(kv) + 1e-9 * abs(f)) | clip
        assert ok_d.all() and ok_v.all(), (law, kd, fd, kv, fv)


def test_vectorized_shapes():
    law = contact.Flores(K_FLORES, 0.7)
    f = law.force(np.linspace(0, 1e-5, 4), np.array([[0.1], [0.2], [-0.1]]), 0.5)
    assert f.shape == (3, 4)
    assert isinstance(law.force(1e-6, 0.1, 0.3), float)
    a, b = law.tangent(np.ones((2, 2)) * 1e-6, 0.1, 0.3)
    assert a.shape == b.shape == (2, 2)


def test_named_errors():
    with pytest.raises(InvalidParameterError) as ex:
        contact.Flores(1e9, 0.0)
    assert ex.value.parameter == "restitution" and "< restitution <= 1" in ex.value.allowed
    with pytest.raises(InvalidParameterError) as ex:
        contact.HuntCrossley(-1.0, 0.5)
    assert ex.value.parameter == "stiffness"
    with pytest.raises(InvalidParameterError) as ex:
        contact.Hertz(1e9, exponent=0.5)
    assert ex.value.parameter == "exponent"
    with pytest.raises(InvalidParameterError) as ex:
        contact.Gonthier(1e9, 0.5, min_approach_speed=0.0)
    assert ex.value.parameter == "min_approach_speed"
    with pytest.raises(InvalidParameterError) as ex:
        contact.KelvinVoigt(1e9, damping_law="sticky")
    assert ex.value.parameter == "damping_law"
    with pytest.raises(InvalidParameterError) as ex:
        contact.LankaraniNikravesh(1e9, 0.9).force(1e-6, 0.1)
    assert ex.value.parameter == "approach_speed"
    with pytest.raises(InvalidParameterError) as ex:
        contact.effective_restitution(contact.Hertz(1e9), mass=0.0, approach_speed=1.0)
    assert ex.value.parameter == "mass"
    with pytest.raises(InvalidParameterError) as ex:
        contact.effective_restitution("Hertz", 1.0, 1.0)  # type: ignore[arg-type]
    assert ex.value.parameter == "law"


@pytest.mark.parametrize("k", [1e3, 1e8, 1e13])
@pytest.mark.parametrize("e", [0.01, 0.3, 1.0])
def test_extremes_finite_or_named_error(k, e):
    d = np.array([1e-12, 1e-3, 1.0, 10.0])
    dd = np.array([1e3, -1e3, 1e-9, 1e6])
    v0 = np.array([0.0, np.nan, -5.0, 1e-9])
    for law in all_laws(k, e):
        assert np.isfinite(law.force(d, dd, v0)).all()
        assert all(np.isfinite(t).all() for t in law.tangent(d, dd, v0))
        if isinstance(law, contact.KelvinVoigt):
            continue  # restitution 1 - O(1e-3) by construction; covered above
        imp = contact.effective_restitution(law, 0.1, 0.5)
        assert 0.0 <= imp.restitution <= 1.0 + 1e-9
        assert math.isfinite(imp.contact_time) and imp.contact_time > 0
        assert math.isfinite(imp.max_penetration) and imp.max_penetration > 0


# ---------------------------------------------------------------------------------------------
# pin in hole


def test_pin_in_hole_flores_value():
    # CONTACT.md section 2: R_B 10 mm, R_J 9.5 mm, steel 207 GPa, 0.3 -> 6.61e10 N/m^1.5 (3
    # digits: +-5e-3 / 6.61 = 7.6e-4 relative)
    k, n = contact.pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3)
    assert k == pytest.approx(6.61e10, rel=8e-4)
    assert n == 1.5
    # and the formula itself, written out: (4/3) E* sqrt(R_B R_J / dR), 1/E* = 2 (1 - nu^2) / E
    es = 207e9 / (2 * (1 - 0.3**2))
    assert k == pytest.approx(4 / 3 * es * math.sqrt(10e-3 * 9.5e-3 / 0.5e-3), rel=1e-14)
    # two materials: a steel pin in a bronze bearing is softer than steel on steel
    k2, _ = contact.pin_in_hole(
        10e-3, 9.5e-3, 110e9, 0.34, youngs_modulus_journal=207e9, poisson_ratio_journal=0.3
    )
    es2 = 1 / ((1 - 0.34**2) / 110e9 + (1 - 0.3**2) / 207e9)
    assert k2 == pytest.approx(4 / 3 * es2 * math.sqrt(10e-3 * 9.5e-3 / 0.5e-3), rel=1e-14)


def test_liu_is_explicit_and_tends_to_a_power_law():
    p = contact.pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3, length=0.02, model="liu")
    es, dr, length = p.effective_modulus, 0.5e-3, 0.02
    d = np.array([1e-7, 1e-6, 1e-5])
    expect = length * 0.5 * math.pi * es * d * np.sqrt(d / (2 * (dr + d)))  # Liu et al. (2006)
    np.testing.assert_allclose(p.force(d), expect, rtol=1e-14)
    # the local power law touches the curve at the reference penetration (1 % of dR)
    assert p.reference_penetration == pytest.approx(0.01 * dr, rel=1e-14)
    assert p.stiffness * p.reference_penetration**p.exponent == pytest.approx(
        float(p.force(p.reference_penetration)), rel=1e-12
    )
    assert p.exponent == pytest.approx(1.5 - 0.5 * 0.01 / 1.01, rel=1e-14)


def test_johnson_solves_its_implicit_law():
    p = contact.pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3, length=0.02, model="johnson")
    es, dr, length = p.effective_modulus, 0.5e-3, 0.02
    d = np.array([1e-9, 1e-6, 1e-5, 1e-4, 0.5 * dr])
    f = p.force(d)
    # Johnson (1985): d = (F / (pi L E*)) (ln(4 pi L E* dR / F) - 1); bisection to full precision
    back = f / (math.pi * length * es) * (np.log(4 * math.pi * length * es * dr / f) - 1)
    np.testing.assert_allclose(back, d, rtol=1e-12)
    assert (np.diff(f) > 0).all()
    # its local exponent is close to 1 (a log-corrected line contact), its slope matches
    h = 1e-6 * p.reference_penetration
    slope = (p.force(p.reference_penetration + h) - p.force(p.reference_penetration - h)) / (2 * h)
    assert p.exponent * p.stiffness * p.reference_penetration ** (p.exponent - 1) == pytest.approx(
        slope, rel=1e-6
    )
    with pytest.raises(InvalidParameterError) as ex:
        p.force(0.6 * dr)  # beyond 4/e^2 dR the curve turns back
    assert ex.value.parameter == "penetration"


@pytest.mark.parametrize("model", ["hertz", "liu", "johnson"])
@pytest.mark.parametrize("s", [0.1, 10.0])
def test_pin_in_hole_scale_invariance(model, s):
    # every length (radii, length, penetration) times s: the force is times s^2 in all three
    # models (F / (E* R L) is a function of d / R). The Chrono issue 462 failure mode (right at
    # full scale, wrong at 1/10) cannot occur with a stiffness derived this way.
    base = contact.pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3, length=0.02, model=model)
    scaled = contact.pin_in_hole(s * 10e-3, s * 9.5e-3, 207e9, 0.3, length=s * 0.02, model=model)
    d = np.array([1e-7, 1e-6, 1e-5, 1e-4])
    np.testing.assert_allclose(scaled.force(s * d), s**2 * np.asarray(base.force(d)), rtol=1e-12)
    assert scaled.exponent == pytest.approx(base.exponent, rel=1e-12)
    assert scaled.stiffness == pytest.approx(base.stiffness * s ** (2 - base.exponent), rel=1e-12)


def test_pin_in_hole_errors():
    cases = [
        (dict(bearing_radius=9e-3), "bearing_radius"),
        (dict(journal_radius=-1.0), "journal_radius"),
        (dict(poisson_ratio=0.5), "poisson_ratio"),
        (dict(youngs_modulus=0.0), "youngs_modulus"),
        (dict(model="liu"), "length"),
        (dict(model="persson"), "model"),
        (dict(model="johnson", length=0.01, penetration=0.3e-3), "penetration"),
    ]
    for kw, name in cases:
        args = dict(bearing_radius=10e-3, journal_radius=9.5e-3, youngs_modulus=207e9, poisson_ratio=0.3)
        args.update(kw)
        with pytest.raises(InvalidParameterError) as ex:
            contact.pin_in_hole(**args)
        assert ex.value.parameter == name


# ---------------------------------------------------------------------------------------------
# friction


def test_coulomb_beyond_the_regularization_speed():
    c = contact.Coulomb(0.1, v0=1e-4, v1=1e-2)
    v = np.array([1e-2, 0.3, -2.0])
    np.testing.assert_array_equal(c.force(v, 2719.0), -0.1 * 2719.0 * np.sign(v))
    # below v0 nothing (no stiction); on the ramp the linear interpolation of Ambrosio's law
    assert c.force(5e-5, 100.0) == 0.0
    vm = 0.25 * 1e-4 + 0.75 * 1e-2
    assert c.force(vm, 100.0) == pytest.approx(-0.1 * 100.0 * 0.75, rel=1e-12)
    lin = contact.Coulomb(0.1, regularization="linear", v_reg=1e-3)
    assert lin.force(-2.5e-4, 100.0) == pytest.approx(0.1 * 100.0 * 0.25, rel=1e-12)
    assert lin.force(1.0, -50.0) == 0.0  # a tensile normal force carries no friction


def test_friction_torque_of_a_spinning_journal():
    # a journal of radius R_J spinning at w in a fixed bearing under a constant radial load F:
    # slip speed R_J w, torque mu F R_J once sliding (CONTACT.md section 3)
    mu, f, r_j = 0.15, 2000.0, 9.5e-3
    c = contact.Coulomb(mu)
    for w in [5.0, 523.6]:  # rad/s: slip 0.0475 and 5.0 m/s, beyond v1 = 0.01
        assert abs(c.force(r_j * w, f) * r_j) == pytest.approx(mu * f * r_j, rel=1e-15)


def test_coulomb_stribeck_and_tangents():
    c = contact.Coulomb(0.1, regularization="linear", v_reg=1e-4, mu_static=0.15, stribeck_speed=1e-2)
    v = np.array([2e-4, 5e-3, 1e-2, 0.1])
    mu = 0.1 + 0.05 * np.exp(-((v / 1e-2) ** 2))  # the Stribeck curve, written out
    np.testing.assert_allclose(c.force(v, 100.0), -mu * 100.0, rtol=1e-14)
    dv, dn = c.tangent(v, 100.0)
    h = 1e-7 * v
    fd = (c.force(v + h, 100.0) - c.force(v - h, 100.0)) / (2 * h)
    # relative step 1e-7 away from the kink: truncation ~1e-14, round-off ~1e-9 of mu F / v
    np.testing.assert_allclose(dv, fd, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(dn, -mu, rtol=1e-14)


def test_lugre_steady_state_is_its_stribeck_curve():
    lg = contact.LuGre(0.1, 0.15, stribeck_speed=1e-3, sigma0=1e5, sigma1=300.0, sigma2=0.4)
    stribeck = contact.Coulomb(0.1, regularization="linear", v_reg=1e-12, mu_static=0.15, stribeck_speed=1e-3)
    v = np.array([-0.2, -2e-3, 5e-4, 1e-3, 0.05])
    g = 0.1 + 0.05 * np.exp(-((v / 1e-3) ** 2))
    tau = g / (1e5 * abs(v))  # bristle time constant, s
    z = np.zeros_like(v)
    z = lg.advance(z, v, 50 * tau)  # exact update: e^-50 ~ 2e-22 of the transient remains
    np.testing.assert_allclose(z, lg.steady_state(v), rtol=1e-12)
    np.testing.assert_allclose(lg.force(z, v, 800.0), stribeck.force(v, 800.0) - 0.4 * v, rtol=1e-12)
    assert np.all(abs(lg.derivative(z, v)) <= 1e-12 * abs(v))


def test_lugre_from_rest_by_explicit_integration():
    # the explicit state + derivative API with a plain RK4 loop at a step of tau / 20 agrees
    # with the exact update (RK4 error ~ (h/tau)^4 ~ 6e-6 per unit time constant)
    lg = contact.LuGre(0.1, 0.1)
    v, z, dt = 0.01, 0.0, (0.1 / (1e5 * 0.01)) / 20
    for _ in range(200):
        k1 = lg.derivative(z, v)
        k2 = lg.derivative(z + dt / 2 * k1, v)
        k3 = lg.derivative(z + dt / 2 * k2, v)
        k4 = lg.derivative(z + dt * k3, v)
        z += dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert z == pytest.approx(lg.advance(0.0, v, 200 * dt), rel=1e-6)


def test_lugre_tangents():
    lg = contact.LuGre(0.1, 0.15, sigma1=250.0, sigma2=0.3)
    z = np.array([4e-7, -1e-6, 1.2e-6])
    v = np.array([2e-3, -5e-4, 0.3])
    dz, dv, dn = lg.tangent(z, v, 900.0)
    hz, hv = 1e-6 * abs(z), 1e-6 * abs(v)
    # relative steps 1e-6: truncation ~1e-12, round-off ~1e-10 of the force scale
    np.testing.assert_allclose(
        dz, (lg.force(z + hz, v, 900.0) - lg.force(z - hz, v, 900.0)) / (2 * hz), rtol=1e-6
    )
    np.testing.assert_allclose(
        dv, (lg.force(z, v + hv, 900.0) - lg.force(z, v - hv, 900.0)) / (2 * hv), rtol=1e-5
    )
    np.testing.assert_allclose(dn, (lg.force(z, v, 901.0) - lg.force(z, v, 899.0)) / 2, rtol=1e-9)


def test_friction_errors():
    for kw, name in [
        (dict(mu=-0.1), "mu"),
        (dict(mu=0.1, v0=1e-2, v1=1e-3), "v1"),
        (dict(mu=0.1, regularization="tanh"), "regularization"),
        (dict(mu=0.2, mu_static=0.1), "mu_static"),
    ]:
        with pytest.raises(InvalidParameterError) as ex:
            contact.Coulomb(**kw)
        assert ex.value.parameter == name
    with pytest.raises(InvalidParameterError) as ex:
        contact.LuGre(0.1, 0.15, sigma0=0.0)
    assert ex.value.parameter == "sigma0"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    k=st.floats(1e3, 1e13),
    e=st.floats(0.01, 1.0),
    n=st.floats(1.0, 3.0),
    d=st.floats(-1.0, 1.0),
    dd=st.floats(-1e3, 1e3),
    v0=st.floats(0.0, 1e2),
    mass=st.floats(1e-3, 1e3),
)
def test_any_law_any_input_is_finite(k, e, n, d, dd, v0, mass):
    # property: finite forces, tangents and impacts over the extremes (or a named error)
    for cls in HYSTERESIS:
        law = cls(k, e, exponent=n)
        assert math.isfinite(law.force(d, dd, v0))
        assert all(math.isfinite(t) for t in law.tangent(d, dd, v0))
    imp = contact.effective_restitution(cls(k, e, exponent=n), mass, max(v0, 1e-3))
    assert 0.0 <= imp.restitution <= 1.0 + 1e-9
    assert math.isfinite(imp.contact_time) and math.isfinite(imp.max_penetration)


@pytest.mark.parametrize(
    "build, parameter",
    [
        (lambda: contact.Hertz("abc"), "stiffness"),
        (lambda: contact.KelvinVoigt(1e6, damping={}), "damping"),
        (lambda: contact.LankaraniNikravesh(1e9, restitution=None), "restitution"),
        (lambda: contact.Coulomb(True), "mu"),
        (lambda: contact.Coulomb(0.1, v_reg="1e-3"), "v_reg"),
        (lambda: contact.LuGre(0.1, 0.13, sigma0={}), "sigma0"),
        (lambda: contact.LuGre("abc", 0.13), "mu"),
    ],
)
def test_laws_of_the_wrong_type_name_the_parameter(build, parameter):
    # found by the fuzzer (LuGre(sigma0="abc") raised a bare ValueError from float())
    with pytest.raises(InvalidParameterError) as ex:
        build()
    assert ex.value.parameter == parameter
