"""The test mechanisms flexclear ships (see ``docs/scenes.md``). Each returns a ready
:class:`flexclear.Model` (run it with ``.simulate(t_end, dt)``, or add to it). Every number is a
default that can be overridden by keyword; SI units (``clearance`` in metres, not a ratio).

* :func:`slider_yoke`, :func:`slider_yoke_stiff`: the paper's slider-yoke.
* :func:`spin_up`: a cantilever on a hub spun up in the plane.
* :func:`slider_crank`, :func:`four_bar`: flexible links in mechanism frames, each with an optional
  clearance joint at one of its pins (``clearance_at``).
"""

from __future__ import annotations

import inspect
import math
from typing import Any, Optional

from . import _core
from .errors import InvalidParameterError, ModelError
from .frames import Frame, Rotation
from .model import Model


def slider_yoke(
    *,
    clearance: float = 0.0,
    amplitude: float = 0.010,
    frequency: float = 6.0,
    bearing_stiffness: Optional[float] = None,
    bearing_damping: Optional[float] = None,
    elements: int = 12,
    length: float = 0.269,
    side: float = 0.0127,
    density: float = 7850.0,
    youngs_modulus: Optional[float] = None,
    first_frequency: float = 880.0,
    damping_ratio: float = 0.01,
    stiffness_ratio: float = 100.0,
    bearing_damping_ratio: float = 0.5,
    damping_law: str = "viscous",
    no_tension: bool = False,
    geometry: str = "end",
    rotary_inertia: bool = False,
) -> Model:
    """The paper's slider-yoke mechanism (Hong & Kim 1993, Fig. 4), as reconstructed in SCENES.md.

    A free-free steel slider (``length`` x ``side`` x ``side``) joined at its end x = 0 by a
    clearance bearing named ``"bearing"`` to a rigid yoke ``"yoke"`` moving
    ``Y(t) = amplitude sin(2 pi frequency t)`` transversely. The original parameters (Dubowsky,
    Deck & Costello 1987) are not available: this is a **reconstruction** that reproduces the
    paper's Table 1 analytic column within 1 dB with one parameter set.

    Parameters
    ----------
    clearance : float
        Radial clearance delta_c, m. Table 1 rows use ``r * amplitude``, r in {0, 0.001, 0.01, 0.1}.
    amplitude : float
        Yoke amplitude Y, m.
    frequency : float
        Yoke frequency f, Hz.
    bearing_stiffness : float, optional
        K_B, N/m. **Derived** when omitted: ``(m/4) (stiffness_ratio 2 pi f)^2`` with the slider
        mass m = rho A L (about 1.21e6 N/m); ``stiffness_ratio = 100`` gives the -80.0 dB row.
    bearing_damping : float, optional
        C_B, N s/m. **Derived** when omitted: ``2 bearing_damping_ratio sqrt(K_B m / 4)``
        (about 321 N s/m at 50 %).
    elements : int
        Beam elements (12 are converged for this scene).
    length, side : float
        Slider length and square-section side, m.
    density : float
        kg/m^3.
    youngs_modulus : float, optional
        Pa. **Derived** when omitted so that the first free-free bending frequency is
        ``first_frequency`` (Hz) with (beta1 L)^2 = 22.3733 (about 1.868e11 Pa).
    damping_ratio : float
        Kelvin-Voigt damping as a fraction of critical at ``first_frequency``
        (eta/E = 2 zeta / (2 pi f1)).
    damping_law : {"viscous", "radial", "literal"}
        Bearing damping form (see :meth:`flexclear.Model.add_joint`).
    no_tension : bool
        Forbid tensile contact force.
    geometry : {"end", "both_ends", "mid_span"}
        One bearing at x = 0 (default), one at each end (``"bearing"``, ``"bearing_2"``), or one
        at mid-span.
    rotary_inertia : bool
        Include rotary inertia.

    Returns
    -------
    Model
        With ``model.parameters`` holding the inputs and the derived values (``youngs_modulus``,
        ``eta``, ``bearing_stiffness``, ``bearing_damping``, ``mass``, ``area``, ``inertia``).

    Notes
    -----
    Initial state: the zero-clearance steady motion (absolute transverse velocity
    ``Y 2 pi f (1 - 1.5 x / L)``, rotation rate ``-1.5 Y 2 pi f / L``, no deformation). The slider
    frame translates with the yoke, whose motion enters as the inertia load ``-M_R a_R``.
    """
    inputs = dict(
        clearance=clearance,
        amplitude=amplitude,
        frequency=frequency,
        length=length,
        side=side,
        density=density,
        youngs_modulus=youngs_modulus,
        first_frequency=first_frequency,
        damping_ratio=damping_ratio,
        elements=elements,
        bearing_stiffness=bearing_stiffness,
        stiffness_ratio=stiffness_ratio,
        bearing_damping=bearing_damping,
        bearing_damping_ratio=bearing_damping_ratio,
        damping_law=damping_law,
        no_tension=no_tension,
        geometry=geometry,
        rotary_inertia=rotary_inertia,
    )
    core, derived = _core.slider_yoke(**inputs)
    params = {**inputs, **derived}
    return Model._wrap(core, params)


def slider_yoke_stiff(**overrides) -> Model:
    """The stiff-bearing (steel-on-steel) variant for the paper's Fig. 5(b): K_B = 1e10 N/m,
    C_B for 50 % damping of the end mass (about 9.2e3 N s/m), clearance 1e-5 m."""
    kw = dict(clearance=1e-5, bearing_stiffness=1e10)
    kw.update(overrides)
    return slider_yoke(**kw)


def _stiff_signature() -> inspect.Signature:
    sig = inspect.signature(slider_yoke)
    params = [
        p.replace(default=1e-5)
        if p.name == "clearance"
        else p.replace(default=1e10)
        if p.name == "bearing_stiffness"
        else p
        for p in sig.parameters.values()
    ]
    return sig.replace(parameters=params)


# The keywords (and their defaults) of the stiff variant, for introspection (flexclear.study).
slider_yoke_stiff.__signature__ = _stiff_signature()  # type: ignore[attr-defined]

# ---------------------------------------------------------------------------------------------
# Mechanisms in moving frames (kineto-elastodynamics)
# ---------------------------------------------------------------------------------------------


def _bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    """An :class:`InvalidParameterError` naming a scene keyword, formatted like the core's."""
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, str(value), allowed
    return e


def _positive(**kw: Any) -> None:
    for name, v in kw.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise _bad(name, v, "a finite number > 0")


def _finite(**kw: Any) -> None:
    for name, v in kw.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise _bad(name, v, "a finite number")


def _elements(name: str, n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1_000_000:
        raise _bad(name, n, "an integer in 1 ..= 1000000")
    return n


#: Beam data of the two classic spin-up problems, SI: length (m), E (Pa), rho (kg/m^3), A (m^2),
#: I (m^4), final hub rate W (rad/s), ramp time T (s).
SPIN_UP_DATA = {
    # Kane, Ryan & Banerjee (1987), J. Guidance 10(2) 139-151, the spin-up example.
    "kane": dict(
        length=8.0,
        youngs_modulus=6.8952e10,
        density=2766.67,
        area=7.2968e-5,
        inertia=8.2189e-9,
        final_rate=4.0,
        ramp_time=15.0,
    ),
    # Simo & Vu-Quoc (1986), J. Appl. Mech. 53 849-863: EI = 1.4e4 N m^2, rho A = 1.2 kg/m,
    # EA = 2.8e7 N, L = 10 m, W = 6 rad/s (T = 15 s). They give only these products; E = 7e10 Pa
    # is our choice, giving A = 4e-4 m^2, I = 2e-7 m^4, rho = 3000 kg/m^3 (same EI, EA, rho A).
    "simo": dict(
        length=10.0,
        youngs_modulus=7.0e10,
        density=3000.0,
        area=4.0e-4,
        inertia=2.0e-7,
        final_rate=6.0,
        ramp_time=15.0,
    ),
}


def spin_up(
    *,
    data: str = "kane",
    length: Optional[float] = None,
    youngs_modulus: Optional[float] = None,
    density: Optional[float] = None,
    area: Optional[float] = None,
    inertia: Optional[float] = None,
    final_rate: Optional[float] = None,
    ramp_time: Optional[float] = None,
    elements: int = 10,
    geometric: bool = True,
    damping: float = 0.0,
    rotation: Optional[Rotation] = None,
) -> Model:
    """A cantilever clamped to a hub that is spun up in the plane: the classic test of geometric
    (centrifugal) stiffening.

    The hub angle follows Kane's smooth spin-up: rate
    ``theta_dot(t) = (W/T) (t - (T/(2 pi)) sin(2 pi t/T))`` for ``t < T``, then ``W``. The beam
    (link ``"beam"``, node 0 clamped at the hub centre) deflects in the plane of rotation; its tip
    deflection ``res.link("beam").tip`` is measured in the hub frame. Without the geometric
    stiffness (``geometric=False``) the linear model softens with ``Omega^2`` (the inertia coupling
    ``M_IC``) and the deflection grows without bound once the rate exceeds the first bending
    frequency (2.91 rad/s for the Kane data); with it, the tip lags during the ramp and settles.

    Parameters
    ----------
    data : {"kane", "simo"}
        Which default data set (see :data:`SPIN_UP_DATA`; every value below overrides it):

        ========  ======  ===========  ========  ==========  ==========  ======  =====
        data      L (m)   E (Pa)       rho       A (m^2)     I (m^4)     W       T (s)
        ========  ======  ===========  ========  ==========  ==========  ======  =====
        kane      8       6.8952e10    2766.67   7.2968e-5   8.2189e-9   4       15
        simo      10      7.0e10       3000      4.0e-4      2.0e-7      6       15
        ========  ======  ===========  ========  ==========  ==========  ======  =====

        ``"kane"``: Kane, Ryan & Banerjee (1987), J. Guidance Control Dyn. 10(2) 139-151.
        ``"simo"``: Simo & Vu-Quoc (1986), J. Appl. Mech. 53 849-863, who give EI = 1.4e4 N m^2,
        rho A = 1.2 kg/m and EA = 2.8e7 N only; E = 7e10 Pa is chosen here and A, I, rho follow.
    length : float, optional
        L, m.
    youngs_modulus : float, optional
        E, Pa.
    density : float, optional
        rho, kg/m^3.
    area, inertia : float, optional
        Cross-section A (m^2) and second moment I (m^4), in-plane bending.
    final_rate : float, optional
        W, rad/s.
    ramp_time : float, optional
        T, s.
    elements : int
        Beam elements (10 put the first two in-plane frequencies within 0.01 % of their
        converged values for the Kane data at rest).
    geometric : bool
        Geometric stiffness (``K2``, ``K3``) on; False switches it off (the unstiffened linear
        model that diverges).
    damping : float
        Kelvin-Voigt coefficient eta, Pa s (none in the references).
    rotation : Rotation, optional
        A different hub angle driver, e.g. ``Rotation.constant(Omega)`` for frequencies at constant
        speed; ``final_rate`` and ``ramp_time`` are then unused.

    Returns
    -------
    Model
        One link ``"beam"``; ``parameters`` holds the data used.
    """
    if data not in SPIN_UP_DATA:
        raise _bad("data", repr(data), 'one of "kane", "simo"')
    given = dict(
        length=length,
        youngs_modulus=youngs_modulus,
        density=density,
        area=area,
        inertia=inertia,
        final_rate=final_rate,
        ramp_time=ramp_time,
    )
    p: dict[str, Any] = {**SPIN_UP_DATA[data], **{k: v for k, v in given.items() if v is not None}}
    _positive(**{k: p[k] for k in ("length", "youngs_modulus", "density", "area", "inertia", "ramp_time")})
    _finite(final_rate=p["final_rate"], damping=damping)
    _elements("elements", elements)
    if rotation is None:
        rotation = Rotation.spin_up(final_rate=float(p["final_rate"]), ramp_time=float(p["ramp_time"]))
    elif not isinstance(rotation, Rotation):
        raise _bad("rotation", repr(rotation), "a flexclear.Rotation")
    m = Model()
    m.add_link(
        "beam",
        length=p["length"],
        elements=elements,
        youngs_modulus=p["youngs_modulus"],
        density=p["density"],
        area=p["area"],
        inertia=p["inertia"],
        frame=Frame.rotating(rotation),
        damping=damping,
        geometric=bool(geometric),
    )
    m.add_clamp("beam", 0)
    m.parameters = {**p, "data": data, "elements": elements, "geometric": bool(geometric), "damping": damping}
    return m


def slider_crank(
    *,
    crank_length: float = 0.15,
    rod_length: float = 0.30,
    crank_speed: float = 150.0,
    side: float = 0.008,
    youngs_modulus: float = 2.0e11,
    density: float = 7870.0,
    slider_mass: float = 0.075552,
    elements: int = 8,
    damping: float = 0.0,
    offset: float = 0.0,
    clearance_at: Optional[str] = None,
    clearance: float = 5e-4,
    bearing_stiffness: Optional[float] = None,
    bearing_damping: Optional[float] = None,
    pin_radius: float = 5e-3,
    poisson_ratio: float = 0.3,
    reference_penetration: float = 1e-5,
    bearing_damping_ratio: float = 0.2,
    damping_law: str = "viscous",
    geometric: Optional[bool] = None,
) -> Model:
    """The flexible slider-crank of Simeon (1996): rigid crank at constant speed, flexible
    connecting rod, slider on a straight guide, no gravity.

    Crank pivot at the origin, guide along global x at height ``offset``. The rod is link
    ``"rod"`` (frame origin at the crank pin A, x axis towards the slider pin B, so node 0 is at A
    and the last node at B); the slider block is ``"slider"``. The crank pin joins rod node 0 to
    the crank body point ``(crank_length, 0)``; the slider pin joins the last rod node to the
    slider. Both pins are ideal unless ``clearance_at`` names one of them, which then becomes a
    revolute clearance joint of the same name. The mechanism is built by the Rust scene
    ``flexclear::scenes::FlexibleSliderCrank`` (the one the Rust tests and benches use), which
    also derives the bearing data and checks every keyword.

    Data: Simeon, B. (1996), "Modelling a flexible slider crank mechanism by a mixed system of DAEs
    and PDEs", Math. Modelling of Systems 2(1) 1-18; also the "slider crank" problem of the Test
    Set for IVP Solvers (Mazzia & Magherini): crank 0.15 m, rod 0.30 m of 8 x 8 mm steel
    (E = 2.0e11 Pa, rho = 7870 kg/m^3), slider 0.075552 kg, crank 150 rad/s, 0 to 0.1 s. Here the
    run starts from rest in the moving frames (no deformation), not from Simeon's initial values.

    Parameters
    ----------
    crank_length, rod_length : float
        m. The rod must be longer than ``crank_length + |offset|``.
    crank_speed : float
        Constant crank rate, rad/s (counter-clockwise positive).
    side : float
        Side of the square rod section, m (A = side^2, I = side^4/12).
    youngs_modulus, density : float
        Rod material, Pa and kg/m^3.
    slider_mass : float
        kg.
    elements : int
        Rod elements.
    damping : float
        Kelvin-Voigt coefficient of the rod, Pa s (Simeon's rod is undamped).
    offset : float
        Height of the guide line, m.
    clearance_at : {None, "crank_pin", "slider_pin"}
        Which pin, if any, has a radial clearance.
    clearance : float
        Radial clearance, m (0.5 mm, the value of Flores et al.'s slider-crank studies).
    bearing_stiffness : float, optional
        K_B, N/m. **Derived** when omitted: the secant stiffness at ``reference_penetration`` of a
        Hertz contact of a steel journal of ``pin_radius`` in a bearing of radius
        ``pin_radius + clearance`` (``F = K_h delta^1.5``, ``K_h = (4/3) E* sqrt(R (R + c)/c)``,
        ``E* = E / (2 (1 - nu^2))``): about 1.09e8 N/m for the defaults. A linear spring is a
        Hertz-like stand-in; say so when comparing with papers using the nonlinear law.
    bearing_damping : float, optional
        C_B, N s/m, active only in contact. **Derived** when omitted:
        ``2 bearing_damping_ratio sqrt(K_B m_eff)`` with ``m_eff`` half the rod mass (crank pin;
        the crank is driven) or the reduced mass of half the rod and the slider (slider pin):
        about 1.15e3 N s/m at the crank pin for the defaults.
    pin_radius, poisson_ratio, reference_penetration : float
        Inputs of the derived K_B: journal radius (m), Poisson's ratio, penetration (m) at which
        the Hertz law is linearized (10 um, the order of the computed penetrations).
    bearing_damping_ratio : float
        Fraction of critical of the derived C_B. 0.2 corresponds to a coefficient of restitution
        of about 0.53 for a linear spring-dashpot; 0.03 to about 0.9. Simulate with implicit
        contact (``simulate(..., iterate=True)``): with the lagged kappa of the default modified
        method (or with ``method="force"``) every impact adds energy of order ``dt`` over the
        contact time, which little damping does not remove: at ``bearing_damping_ratio=0.03`` and
        ``dt = 1e-5`` those runs reach contact forces of MN and diverge, with or without the
        geometric terms (``geometric=False``), i.e. not by buckling. With ``iterate=True`` the
        peak crank-pin force is 8.1-8.2 kN at dt = 1e-5 to 1.25e-6 s for both damping ratios and
        the rod's compression stays below half its Euler load (7.5 kN).
    damping_law : {"viscous", "radial", "literal"}
        Form of the bearing damping (see :meth:`flexclear.Model.add_joint`).
    geometric : bool, optional
        Geometric (axial-force) terms K2, K3, D2 of the rod; None = automatic (on: the rod
        rotates).

    Returns
    -------
    Model
        Link ``"rod"``, slider ``"slider"``, pins ``"crank_pin"`` and ``"slider_pin"`` (one of them a
        clearance joint when asked); ``parameters`` holds the inputs and the derived
        ``bearing_stiffness``, ``bearing_damping``, ``rod_mass``, ``area``, ``inertia``.

    Notes
    -----
    With a clearance joint use ``iterate=True`` and ``dt <= 1e-5`` s (a contact period is about
    2e-4 s for the default K_B). Measured at the defaults, 0 to 0.05 s, peak contact force at
    dt = 1e-5, 5e-6, 2.5e-6, 1.25e-6 s: crank pin 8.11, 8.43, 8.12, 8.03 kN; slider pin 3.74,
    3.76, 3.57, 3.38 kN (penetration 33.1, 31.3, 30.2, 29.7 um); the number of impacts does not
    converge (short rebounds near the wall). The lagged default instead gives 8.8 kN (crank
    pin) and 8.9 kN, 71 um (slider pin, with a rod compression of 10 kN, beyond the Euler load)
    at 1e-5 s, and fails at 5e-5 s. Without a clearance
    joint, 5e-5 s resolves the rod's first bending mode (about 1.3e3 rad/s) with 90 steps per
    period.
    """
    inputs: dict[str, Any] = dict(
        crank_length=crank_length,
        rod_length=rod_length,
        crank_speed=crank_speed,
        side=side,
        youngs_modulus=youngs_modulus,
        density=density,
        slider_mass=slider_mass,
        elements=elements,
        damping=damping,
        offset=offset,
        clearance_at=clearance_at,
    )
    bearing = dict(
        clearance=clearance,
        bearing_stiffness=bearing_stiffness,
        bearing_damping=bearing_damping,
        pin_radius=pin_radius,
        poisson_ratio=poisson_ratio,
        reference_penetration=reference_penetration,
        bearing_damping_ratio=bearing_damping_ratio,
        damping_law=damping_law,
    )
    core, derived = _core.slider_crank(**inputs, **bearing, geometric=geometric)
    params = {**inputs, **{k: derived[k] for k in ("area", "inertia", "rod_mass")}}
    if clearance_at is not None:
        params.update(
            clearance=clearance,
            bearing_stiffness=derived["bearing_stiffness"],
            bearing_damping=derived["bearing_damping"],
            pin_radius=pin_radius,
            poisson_ratio=poisson_ratio,
            reference_penetration=reference_penetration,
            bearing_damping_ratio=bearing_damping_ratio,
            effective_mass=derived["effective_mass"],
            damping_law=damping_law,
        )
    return Model._wrap(core, params)


def _hertz_stiffness(*, youngs_modulus, poisson_ratio, pin_radius, clearance, reference_penetration) -> float:
    """The derived bearing stiffness of :func:`slider_crank`, for scenes built in Python: the
    secant stiffness ``K_h sqrt(delta_ref)`` (N/m) of a Hertz contact of a journal of
    ``pin_radius`` in a bearing of radius ``pin_radius + clearance``
    (``K_h = (4/3) E* sqrt(R (R + c) / c)``, ``E* = E / (2 (1 - nu^2))``)."""
    e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    c = max(clearance, 1e-12)
    k_h = 4.0 / 3.0 * e_star * math.sqrt(pin_radius * (pin_radius + c) / c)
    return k_h * math.sqrt(reference_penetration)


def four_bar(
    *,
    ground_length: float = 0.254,
    crank_length: float = 0.0508,
    coupler_length: float = 0.2794,
    rocker_length: float = 0.2794,
    crank_speed: float = 100.0,
    branch: int = 1,
    youngs_modulus: float = 7.1e10,
    density: float = 2710.0,
    width: float = 0.0254,
    depth: float = 0.003175,
    elements: int = 6,
    flexible_rocker: bool = False,
    rocker_elements: Optional[int] = None,
    damping: float = 0.0,
    clearance_at: Optional[str] = None,
    clearance: float = 2.5e-4,
    bearing_stiffness: Optional[float] = None,
    bearing_damping: Optional[float] = None,
    pin_radius: float = 5e-3,
    poisson_ratio: float = 0.33,
    reference_penetration: float = 1e-5,
    bearing_damping_ratio: float = 0.2,
    damping_law: str = "viscous",
) -> Model:
    """A crank-rocker four-bar with a flexible coupler (and optionally a flexible rocker), driven
    by a rigid crank at constant speed; no gravity.

    Ground pivots O2 = (0, 0) (crank) and O4 = (``ground_length``, 0) (rocker). The coupler is
    link ``"coupler"`` (frame origin at the crank pin A, x axis towards the rocker pin B); the
    ``"crank_pin"`` joins its node 0 to the crank body point ``(crank_length, 0)``, the
    ``"rocker_pin"`` its last node to the rocker: to the rigid rocker's body point
    ``(rocker_length, 0)``, or, with ``flexible_rocker``, to the last node of link ``"rocker"``
    (frame origin at O4, x axis towards B), whose node 0 is pinned to the ground at O4. Either
    coupler pin may instead be a revolute clearance joint of the same name (``clearance_at``).

    The numbers are **illustrative**, not a published test case: the link lengths are round
    inch values (10, 2, 11, 11 in) in the proportions of laboratory flexible four-bars (e.g. Sung,
    Thompson et al., 1980s: a short steel crank, thin aluminium coupler and rocker flexing in the
    plane); the section is a 1 in x 1/8 in aluminium strip with its thin side in the plane. The
    geometry is Grashof (s + l = 0.330 m <= p + q = 0.533 m) with the crank shortest, so the crank
    turns fully (a crank-rocker). The coupler's first (pinned-pinned) bending frequency is about
    593 rad/s; the default crank speed, 100 rad/s (955 rpm), is a sixth of it.

    Parameters
    ----------
    ground_length, crank_length, coupler_length, rocker_length : float
        Link lengths, m. The loop must close at every crank angle (otherwise :class:`ModelError`).
    crank_speed : float
        Constant crank rate, rad/s.
    branch : {1, -1}
        Assembly: +1 open, -1 crossed.
    youngs_modulus, density : float
        Coupler (and rocker) material, Pa and kg/m^3 (aluminium).
    width, depth : float
        Section: out-of-plane width and in-plane depth, m (A = width depth,
        I = width depth^3 / 12).
    elements : int
        Coupler elements.
    flexible_rocker : bool
        Model the rocker as a flexible link of the same section too.
    rocker_elements : int, optional
        Rocker elements (default: ``elements``).
    damping : float
        Kelvin-Voigt coefficient, Pa s.
    clearance_at : {None, "crank_pin", "rocker_pin"}
        Which coupler pin, if any, has a radial clearance.
    clearance : float
        Radial clearance, m (0.25 mm).
    bearing_stiffness : float, optional
        K_B, N/m. **Derived** when omitted, as for :func:`slider_crank`: the secant stiffness at
        ``reference_penetration`` of a Hertz contact of a journal of ``pin_radius`` in a bearing
        of radius ``pin_radius + clearance``, with the links' ``youngs_modulus`` and
        ``poisson_ratio`` (about 4.7e7 N/m for the defaults).
    bearing_damping : float, optional
        C_B, N s/m, active only in contact. **Derived** when omitted:
        ``2 bearing_damping_ratio sqrt(K_B m_eff)`` with ``m_eff`` half the coupler mass (both
        pins sit on driven bodies), or, at a rocker pin on a flexible rocker, the reduced mass of
        half the coupler and half the rocker.
    pin_radius, poisson_ratio, reference_penetration : float
        Inputs of the derived K_B: journal radius (m), Poisson's ratio (aluminium), penetration
        (m) at which the Hertz law is linearized.
    bearing_damping_ratio : float
        Fraction of critical of the derived C_B.
    damping_law : {"viscous", "radial", "literal"}
        Form of the bearing damping (see :meth:`flexclear.Model.add_joint`).

    Returns
    -------
    Model
        Links ``"coupler"`` (and ``"rocker"``), pins or clearance joints ``"crank_pin"`` and
        ``"rocker_pin"``; ``parameters`` holds the inputs and ``area``, ``inertia`` (and the
        derived bearing data with a clearance joint).
    """
    _positive(
        ground_length=ground_length,
        crank_length=crank_length,
        coupler_length=coupler_length,
        rocker_length=rocker_length,
        youngs_modulus=youngs_modulus,
        density=density,
        width=width,
        depth=depth,
    )
    _finite(crank_speed=crank_speed, damping=damping)
    if damping < 0:
        raise _bad("damping", damping, ">= 0 Pa s")
    if branch not in (1, -1):
        raise _bad("branch", branch, "+1 (open) or -1 (crossed)")
    if clearance_at not in (None, "crank_pin", "rocker_pin"):
        raise _bad("clearance_at", clearance_at, 'None, "crank_pin" or "rocker_pin"')
    _elements("elements", elements)
    n_rocker = _elements("rocker_elements", elements if rocker_elements is None else rocker_elements)
    driver = Rotation.constant(float(crank_speed))
    lengths = (float(ground_length), float(crank_length), float(coupler_length), float(rocker_length))

    def frame(link: str) -> Frame:
        return Frame.four_bar(*lengths, driver, link, float(branch))

    period = 2.0 * math.pi / abs(crank_speed) if crank_speed != 0 else 1.0
    try:
        frame("coupler").check(period)
    except ModelError as e:
        raise ModelError(
            f"four_bar(ground_length={ground_length}, crank_length={crank_length}, "
            f"coupler_length={coupler_length}, rocker_length={rocker_length}): the loop does not close "
            f"over a crank turn: {e}"
        ) from None
    area, inertia = width * depth, width * depth**3 / 12.0
    section = dict(
        youngs_modulus=youngs_modulus, density=density, area=area, inertia=inertia, damping=damping
    )
    params: dict[str, Any] = dict(
        ground_length=ground_length,
        crank_length=crank_length,
        coupler_length=coupler_length,
        rocker_length=rocker_length,
        crank_speed=crank_speed,
        branch=branch,
        youngs_modulus=youngs_modulus,
        density=density,
        width=width,
        depth=depth,
        elements=elements,
        flexible_rocker=flexible_rocker,
        rocker_elements=n_rocker if flexible_rocker else None,
        damping=damping,
        area=area,
        inertia=inertia,
        clearance_at=clearance_at,
    )
    bearing: dict[str, Any] = {}
    if clearance_at is not None:
        _positive(pin_radius=pin_radius, reference_penetration=reference_penetration)
        _finite(clearance=clearance, bearing_damping_ratio=bearing_damping_ratio)
        if not 0.0 <= poisson_ratio < 0.5:
            raise _bad("poisson_ratio", poisson_ratio, "0 <= nu < 0.5")
        coupler_mass = density * area * coupler_length
        m_eff = 0.5 * coupler_mass
        if clearance_at == "rocker_pin" and flexible_rocker:
            m_rocker = 0.5 * density * area * rocker_length
            m_eff = m_eff * m_rocker / (m_eff + m_rocker)
        k_b = bearing_stiffness
        if k_b is None:
            k_b = _hertz_stiffness(
                youngs_modulus=youngs_modulus,
                poisson_ratio=poisson_ratio,
                pin_radius=pin_radius,
                clearance=clearance,
                reference_penetration=reference_penetration,
            )
        c_b = bearing_damping
        if c_b is None:
            c_b = 2.0 * bearing_damping_ratio * math.sqrt(max(k_b, 0.0) * m_eff)
        bearing = dict(clearance=clearance, stiffness=k_b, damping=c_b, damping_law=damping_law)
        params.update(
            clearance=clearance,
            bearing_stiffness=k_b,
            bearing_damping=c_b,
            pin_radius=pin_radius,
            poisson_ratio=poisson_ratio,
            reference_penetration=reference_penetration,
            bearing_damping_ratio=bearing_damping_ratio,
            effective_mass=m_eff,
            damping_law=damping_law,
        )

    def connect(name: str, link: str, node: int, **side) -> None:
        if clearance_at == name:
            m.add_joint(name, link, node, **side, **bearing)
        else:
            m.add_pin(name, link, node, **side)

    m = Model()
    m.add_body("crank", frame=frame("crank"))
    m.add_link("coupler", length=coupler_length, elements=elements, frame=frame("coupler"), **section)
    connect("crank_pin", "coupler", 0, body="crank", point=(float(crank_length), 0.0))
    if flexible_rocker:
        m.add_link("rocker", length=rocker_length, elements=n_rocker, frame=frame("rocker"), **section)
        m.add_support("rocker", 0, u=True, v=True, theta=False)
        connect("rocker_pin", "coupler", elements, target=("rocker", n_rocker))
    else:
        m.add_body("rocker", frame=frame("rocker"))
        connect("rocker_pin", "coupler", elements, body="rocker", point=(float(rocker_length), 0.0))
    m.parameters = params
    return m


__all__ = ["SPIN_UP_DATA", "four_bar", "slider_crank", "slider_yoke", "slider_yoke_stiff", "spin_up"]
