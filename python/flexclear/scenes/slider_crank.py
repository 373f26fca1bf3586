"""The flexible slider-crank of Simeon (1996), with an optional clearance joint at a pin."""

from __future__ import annotations

from typing import Any, Optional

from .. import _core
from ..model import Model
from ._checks import _bearing_parameters, _types


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
    _types(
        optional_numbers=dict(bearing_stiffness=bearing_stiffness, bearing_damping=bearing_damping),
        strings=dict(damping_law=damping_law),
        optional_strings=dict(clearance_at=clearance_at),
        optional_flags=dict(geometric=geometric),
    )
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
        params.update(_bearing_parameters(bearing, derived))
    return Model._wrap(core, params)
