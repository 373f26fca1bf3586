"""A crank-rocker four-bar with a flexible coupler, with an optional clearance joint at a coupler
pin."""

from __future__ import annotations

from typing import Any, Optional

from .. import _core
from ..model import Model
from ._checks import _bearing_parameters, _types


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

    Raises
    ------
    InvalidParameterError
        A keyword of the wrong type or out of its range (named, with the range).
    ModelError
        The loop does not close over a crank turn.

    Notes
    -----
    The mechanism is built by the Rust scene ``flexclear::scenes::FlexibleFourBar``, which also
    derives the bearing data and checks every range; this function checks the keywords' types.
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
    inputs: dict[str, Any] = dict(
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
        rocker_elements=rocker_elements,
        damping=damping,
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
    core, derived = _core.four_bar(**inputs, **bearing)
    params = {k: v for k, v in inputs.items() if k != "clearance_at"}
    params["rocker_elements"] = derived["rocker_elements"] if flexible_rocker else None
    params.update(area=derived["area"], inertia=derived["inertia"], clearance_at=clearance_at)
    if clearance_at is not None:
        params.update(_bearing_parameters(bearing, derived))
    model = Model._wrap(core, params)
    # the bodies in the scene's order (the core lists them by the joints that use them first)
    model._body_frames = {b: model._body_frames[b] for b in ("crank", "rocker") if b in model._body_frames}
    return model
