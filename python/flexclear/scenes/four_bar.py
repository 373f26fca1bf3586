"""A crank-rocker four-bar with a flexible coupler, with an optional clearance joint at a coupler
pin."""

from __future__ import annotations

import math
from typing import Any, Optional

from ..errors import ModelError
from ..frames import Frame, Rotation
from ..model import Model
from ._checks import _bad, _elements, _finite, _positive, _types


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
        ``poisson_ratio`` (about 5.4e7 N/m for the defaults; C_B about 516 N s/m).
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
    _types(
        numbers=dict(
            clearance=clearance,
            pin_radius=pin_radius,
            poisson_ratio=poisson_ratio,
            reference_penetration=reference_penetration,
            bearing_damping_ratio=bearing_damping_ratio,
        ),
        optional_numbers=dict(bearing_stiffness=bearing_stiffness, bearing_damping=bearing_damping),
        strings=dict(damping_law=damping_law),
        flags=dict(flexible_rocker=flexible_rocker),
    )
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
    area, inertia = width * depth, width * depth * depth * depth / 12.0
    if not (math.isfinite(area) and math.isfinite(inertia) and area > 0 and inertia > 0):
        raise _bad(
            "depth",
            depth,
            f"a section whose area width depth and inertia width depth^3 / 12 are finite and > 0 (here "
            f"width = {width:g} m: {area:g} m^2, {inertia:g} m^4)",
        )
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
        if not (math.isfinite(coupler_mass) and coupler_mass > 0):
            raise _bad(
                "density",
                density,
                f"a density whose coupler mass rho A L is finite and > 0 (here {coupler_mass:g} kg with "
                f"A = {area:g} m^2, L = {coupler_length:g} m)",
            )
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
