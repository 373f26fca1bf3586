"""A cantilever clamped to a hub spun up in the plane (Kane, Ryan & Banerjee 1987; Simo & Vu-Quoc
1986): the classic test of geometric stiffening."""

from __future__ import annotations

from typing import Any, Optional

from .. import _core
from ..frames import Rotation
from ..model import Model
from ._checks import _bad

#: Beam data of the two classic spin-up problems, SI: length (m), E (Pa), rho (kg/m^3), A (m^2),
#: I (m^4), final hub rate W (rad/s), ramp time T (s); defined by the Rust scene
#: (``flexclear::scenes::SpinUpData``). ``"kane"``: Kane, Ryan & Banerjee (1987), J. Guidance 10(2)
#: 139-151, the spin-up example. ``"simo"``: Simo & Vu-Quoc (1986), J. Appl. Mech. 53 849-863:
#: EI = 1.4e4 N m^2, rho A = 1.2 kg/m, EA = 2.8e7 N, L = 10 m, W = 6 rad/s (T = 15 s); they give
#: only these products, E = 7e10 Pa is our choice, giving A = 4e-4 m^2, I = 2e-7 m^4,
#: rho = 3000 kg/m^3.
SPIN_UP_DATA: dict[str, dict[str, float]] = _core.spin_up_data()


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

    Raises
    ------
    InvalidParameterError
        ``data`` unknown, a value out of its range (named, with the range), ``rotation`` not a
        :class:`~flexclear.Rotation`.

    Notes
    -----
    The mechanism is built by the Rust scene ``flexclear::scenes::SpinUp``, which checks the
    ranges; this function resolves ``parameters``.
    """
    if not isinstance(data, str) or data not in SPIN_UP_DATA:
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
    core = _core.spin_up(
        data=data, **given, elements=elements, geometric=bool(geometric), damping=damping, rotation=rotation
    )
    p: dict[str, Any] = {**SPIN_UP_DATA[data], **{k: v for k, v in given.items() if v is not None}}
    params = {**p, "data": data, "elements": elements, "geometric": bool(geometric), "damping": damping}
    return Model._wrap(core, params)
