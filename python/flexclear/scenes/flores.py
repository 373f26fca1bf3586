"""The slider-crank of Flores, Ambrosio, Claro & Lankarani (2006-2008) with a revolute clearance
joint at the piston pin: the field's standard clearance-joint benchmark."""

from __future__ import annotations

import math
from typing import Any, Optional

from .. import _core
from ..model import Model, _bad, _is_number

#: The benchmark's data as commonly cited (not checked against the papers' own tables), SI units.
FLORES_DATA: dict[str, float] = dict(
    crank_length=0.05,
    crank_mass=0.30,
    crank_inertia=1.0e-4,
    rod_length=0.12,
    rod_mass=0.21,
    rod_inertia=2.5e-4,
    slider_mass=0.14,
    bearing_radius=0.0100,
    journal_radius=0.0095,
    youngs_modulus=207e9,
    poisson_ratio=0.3,
    restitution=0.9,
    crank_speed_rpm=5000.0,
)


def flores_slider_crank(
    clearance: Optional[float] = 5e-4,
    law=None,
    *,
    friction=None,
    flexible_rod: bool = False,
    rod_elements: int = 4,
    crank_speed: float = 5000.0 * 2.0 * math.pi / 60.0,
) -> Model:
    """The Flores slider-crank: rigid crank at constant speed, rigid connecting rod, slider, an
    ideal crank pin and a revolute clearance joint at the piston pin.

    Data as **commonly cited** (``../shared/CONTACT.md`` section 4; not checked against the
    papers' own tables): crank 0.05 m, 0.30 kg, 1.0e-4 kg m^2 (a prescribed body here: its
    inertia enters only the driving moment, zero at constant speed); rod 0.12 m, 0.21 kg,
    2.5e-4 kg m^2 about its centroid at mid-length; slider 0.14 kg; bearing radius 10.0 mm,
    journal radius 9.5 mm (c = 0.5 mm); steel, E = 207 GPa, nu = 0.3; Lankarani-Nikravesh with
    restitution 0.9 and the Hertz stiffness of the pin,
    ``flexclear.contact.pin_in_hole(R_J + c, R_J, 207e9, 0.3)`` (6.61e10 N/m^1.5 at c = 0.5 mm);
    crank 5000 rpm; no gravity; no friction unless ``friction`` is given.

    Sources: P. Flores, J. Ambrosio, J.C.P. Claro, H.M. Lankarani, "Kinematics and Dynamics of
    Multibody Systems with Imperfect Joints", Springer (2008), and the authors' 2006-2007
    papers on the slider-crank with a revolute clearance joint.

    Crank pivot at the origin, guide along global x through it, crank angle 0 at t = 0. The rod
    is the rigid link ``"rod"`` (node 0 at the crank pin, node 1 at the piston pin; its unknown
    is its rotation), the slider ``"slider"`` (``Result.slider("slider").acceleration`` is its
    acceleration along the guide), the ideal crank pin ``"crank_pin"``, the piston-pin clearance
    joint ``"piston_pin"`` (journal: the rod end; bearing: the slider). With
    ``clearance=None`` the piston pin is ideal: the mechanism of rigid bodies then has no
    unknown and follows the rigid slider-crank's kinematics.

    Run it with implicit contact, ``simulate(t_end, dt, iterate=True)`` (the default coupling
    is the modified method), ``dt`` about 1e-6 s or less at 5000 rpm (one revolution is 12 ms).

    Parameters
    ----------
    clearance : float or None
        Radial clearance of the piston pin, m (> 0; 5e-4 by default, 2.5e-4 and 1e-4 in the
        parametric studies), or None for an ideal piston pin.
    law : flexclear.contact.NormalLaw, optional
        The piston pin's contact law; default ``LankaraniNikravesh(K, restitution=0.9)`` with
        ``K`` the Hertz stiffness above at this clearance.
    friction : flexclear.contact.Coulomb or flexclear.contact.LuGre, optional
        Friction in the piston pin, on the 9.5 mm journal (the bearing radius is the journal's
        plus the clearance); default frictionless. Such a run takes the Newton stepper's
        refactorizing path (docs/contact.md section 4.1).
    flexible_rod : bool
        A flexible rod instead of the rigid one: a steel beam of the rod's mass and length
        (density 7800 kg/m^3, square section of area 2.244e-4 m^2, side 14.98 mm,
        I = side^4 / 12 = 4.20e-9 m^4, E = 207 GPa; its own rotary inertia m L^2 / 12 =
        2.52e-4 kg m^2, the rigid rod's 2.5e-4), with the geometric terms of a rotating link.
        It starts undeformed and undamped: the slider's inertia load then rings the rod's axial
        mode (about 5e4 rad/s with the slider), which adds to the slider acceleration (with
        ideal joints -43 080 to +33 246 m/s^2 over the first revolution at dt = 1e-6 s, against
        the rigid rod's -19 419 to +9 696).
    rod_elements : int
        Elements of the flexible rod (1 ..= 1000000; not used for the rigid rod).
    crank_speed : float
        Constant crank speed, rad/s (default 5000 rpm = 523.6 rad/s).

    Returns
    -------
    Model
        ``parameters`` holds the data above and ``pin_stiffness`` (N/m^1.5, with a clearance).

    Raises
    ------
    InvalidParameterError
        A parameter out of range, named (``clearance``, ``crank_speed``, ``rod_elements``,
        ``law``...).
    """
    if clearance is not None and not _is_number(clearance):
        raise _bad("clearance", clearance, "a finite number > 0 m, or None for an ideal pin")
    if not _is_number(crank_speed):
        raise _bad("crank_speed", crank_speed, "a finite number, rad/s")
    if not isinstance(flexible_rod, bool):
        raise _bad("flexible_rod", flexible_rod, "True or False")
    if (
        isinstance(rod_elements, bool)
        or not isinstance(rod_elements, int)
        or not 1 <= rod_elements <= 1_000_000
    ):
        raise _bad("rod_elements", rod_elements, "an integer in 1 ..= 1000000")
    if friction is not None:
        from ..contact import Coulomb, LuGre

        if not isinstance(friction, (Coulomb, LuGre)):
            raise _bad("friction", friction, "None or a friction law of flexclear.contact (Coulomb, LuGre)")
    core_law: Any = None
    if law is not None:
        from ..contact import NormalLaw

        if not isinstance(law, NormalLaw):
            raise _bad("law", law, "a law of flexclear.contact (LankaraniNikravesh, Hertz, ...)")
        core_law = law._core
    core, derived = _core.flores_slider_crank(
        None if clearance is None else float(clearance),
        core_law,
        float(crank_speed),
        flexible_rod,
        rod_elements,
        None if friction is None else friction._core,
    )
    params: dict[str, Any] = dict(FLORES_DATA)
    params.update(
        clearance=clearance,
        crank_speed=float(crank_speed),
        flexible_rod=flexible_rod,
        rod_elements=rod_elements if flexible_rod else None,
        law=law,
        **derived,
    )
    return Model._wrap(core, params)
