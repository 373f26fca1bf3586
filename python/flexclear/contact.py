"""Contact physics of clearance joints: normal-force laws, friction laws, the restitution a law
actually achieves, and the stiffness of a pin in a hole from its geometry and materials.

Normal laws give the force ``F(d, dd)`` (N, compressive positive) along the contact normal from
the penetration ``d`` (m, contact when > 0) and its rate ``dd`` (m/s, positive while closing):

- :class:`KelvinVoigt`: the linear spring-dashpot ``k d + c dd`` (today's clearance-joint law);
- :class:`Hertz`: ``K d^n``, elastic;
- :class:`HuntCrossley`, :class:`LankaraniNikravesh`, :class:`Gonthier`, :class:`Flores`,
  :class:`CarvalhoMartins`: ``K d^n (1 + chi(e) dd / v0)`` with ``v0`` the approach speed of the
  contact episode and ``chi`` a function of the nominal restitution ``e``.

Every law has ``force`` and ``tangent`` (closed form), vectorized over numpy arrays.
:func:`effective_restitution` integrates one impact; :func:`pin_in_hole` derives ``K`` and ``n``
from radii, materials and length. :class:`Coulomb` and :class:`LuGre` are friction laws of the
slip speed and the normal force.

The laws are not yet selectable in :class:`flexclear.Model` (the engine keeps the spring-dashpot);
they are computed by the Rust core (``rust/contact/``). Formulas, sources and the choices made are
in ``docs/contact.md``.

>>> from flexclear import contact
>>> K, n = contact.pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3)  # N/m^1.5, 1.5
>>> law = contact.LankaraniNikravesh(stiffness=K, restitution=0.9)
>>> contact.effective_restitution(law, mass=0.14, approach_speed=1.0).restitution  # 0.913
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterator, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _core
from ._numbers import is_real
from .errors import InvalidParameterError

__all__ = [
    "CarvalhoMartins",
    "Coulomb",
    "Flores",
    "Gonthier",
    "Hertz",
    "HuntCrossley",
    "Impact",
    "KelvinVoigt",
    "LankaraniNikravesh",
    "LuGre",
    "NormalLaw",
    "PinStiffness",
    "effective_restitution",
    "pin_in_hole",
]

ArrayLike = Union[float, npt.ArrayLike]
FloatOrArray = Union[float, npt.NDArray[np.float64]]

#: Default floor of the approach speed, m/s (see :class:`LankaraniNikravesh`).
MIN_APPROACH_SPEED = 1e-3


def _invalid(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    exc = InvalidParameterError(f"invalid parameter `{parameter}` = {value}: allowed {allowed}")
    exc.parameter, exc.value, exc.allowed = parameter, str(value), allowed
    return exc


def _float(parameter: str, value: Any) -> float:
    """A law's number as a float; any other type is an :class:`InvalidParameterError` naming
    ``parameter`` (ranges are the core's to check)."""
    if not is_real(value):
        raise _invalid(parameter, value, "a real number")
    return float(value)


def _flat(*xs: ArrayLike) -> Tuple[Tuple[int, ...], list]:
    """Broadcasts the inputs and returns their common shape and contiguous 1-D float64 copies."""
    arrs = np.broadcast_arrays(*[np.asarray(x, dtype=np.float64) for x in xs])
    return arrs[0].shape, [np.ascontiguousarray(a, dtype=np.float64).ravel() for a in arrs]


def _shape(out: npt.NDArray[np.float64], shape: Tuple[int, ...]) -> FloatOrArray:
    res = out.reshape(shape)
    return float(res) if shape == () else res


class NormalLaw:
    """Base class of the normal-force laws (not instantiated itself).

    Subclasses are frozen dataclasses of their parameters; the Rust core checks them at
    construction and raises :class:`flexclear.InvalidParameterError` naming the parameter and its
    allowed range.
    """

    _core: Any

    def _build(self, kind: str, **kw: Any) -> None:
        object.__setattr__(self, "_core", _core.NormalLaw(kind, **kw))

    @property
    def velocity_dependent(self) -> bool:
        """Whether the force depends on the penetration rate (a damped law)."""
        return bool(self._core.velocity_dependent)

    @property
    def needs_approach_speed(self) -> bool:
        """Whether the force depends on the approach speed of the contact episode."""
        return bool(self._core.needs_approach_speed)

    def _args(self, penetration: ArrayLike, rate: ArrayLike, approach_speed: Optional[ArrayLike]) -> Any:
        if approach_speed is None:
            if self.needs_approach_speed:
                raise _invalid(
                    "approach_speed",
                    None,
                    "the normal approach speed of the contact episode, m/s "
                    f"(required by {type(self).__name__})",
                )
            approach_speed = 0.0
        return _flat(penetration, rate, approach_speed)

    def force(
        self, penetration: ArrayLike, rate: ArrayLike, approach_speed: Optional[ArrayLike] = None
    ) -> FloatOrArray:
        """Normal force, N (compressive positive; 0 where ``penetration <= 0``).

        Parameters
        ----------
        penetration : float or array_like
            Penetration ``d``, m (contact when > 0).
        rate : float or array_like
            Penetration rate ``dd``, m/s (positive while the bodies approach).
        approach_speed : float or array_like, optional
            Normal approach speed at the start of the contact episode, m/s; required by the laws
            with ``needs_approach_speed``, ignored by the others. Floored by the law's
            ``min_approach_speed``.

        Returns
        -------
        float or numpy.ndarray
            The force, broadcast over the inputs (a float for scalar inputs).
        """
        shape, (d, dd, v0) = self._args(penetration, rate, approach_speed)
        return _shape(self._core.force(d, dd, v0), shape)

    def tangent(
        self, penetration: ArrayLike, rate: ArrayLike, approach_speed: Optional[ArrayLike] = None
    ) -> Tuple[FloatOrArray, FloatOrArray]:
        """Closed-form tangents ``(dF/dd, dF/d(dd))`` in N/m and N s/m.

        Same arguments as :meth:`force`. Where the law clips a tensile force both are 0; at
        ``d = 0`` the contact-side limit is returned.
        """
        shape, (d, dd, v0) = self._args(penetration, rate, approach_speed)
        a, b = self._core.tangent(d, dd, v0)
        return _shape(a, shape), _shape(b, shape)


@dataclass(frozen=True)
class KelvinVoigt(NormalLaw):
    """The linear spring-dashpot of the clearance joints today (Dubowsky & Freudenstein 1971):
    ``F = k d + c dd`` in contact.

    The description of :meth:`flexclear.Model.add_clearance_joint`'s law; its force along the
    normal is computed here (``"viscous"`` and ``"radial"`` damping have the same normal
    component; ``"literal"`` gives ``k d + c |dd|``). The force jumps by ``c dd`` at entry.

    Parameters
    ----------
    stiffness : float
        Stiffness ``k``, N/m (> 0).
    damping : float
        Damping ``c``, N s/m (>= 0). A single impact of mass ``m`` has restitution
        ``exp(-zeta pi / sqrt(1 - zeta^2))``, ``zeta = c / (2 sqrt(k m))``.
    damping_law : {"viscous", "radial", "literal"}
        Form of the damping force in the joint.
    no_tension : bool
        Clip a tensile force to zero.
    """

    stiffness: float
    damping: float = 0.0
    damping_law: str = "viscous"
    no_tension: bool = False

    def __post_init__(self) -> None:
        self._build(
            "KelvinVoigt",
            stiffness=_float("stiffness", self.stiffness),
            damping=_float("damping", self.damping),
            damping_law=str(self.damping_law),
            clip_tension=bool(self.no_tension),
        )


@dataclass(frozen=True)
class Hertz(NormalLaw):
    """Elastic Hertz contact ``F = K d^n`` (Hertz 1882): no dissipation, restitution 1.

    Parameters
    ----------
    stiffness : float
        ``K``, N/m^n (> 0); for a pin in a hole see :func:`pin_in_hole`.
    exponent : float
        ``n``, 1 to 3; default 1.5 (Hertz point contact, the Flores pin-in-hole benchmark).
    """

    stiffness: float
    exponent: float = 1.5

    def __post_init__(self) -> None:
        self._build(
            "Hertz", stiffness=_float("stiffness", self.stiffness), exponent=_float("exponent", self.exponent)
        )


_HYSTERESIS_DOC = """

    ``F = K d^n (1 + chi dd / v0)`` for ``d > 0``, {chi}.

    Parameters
    ----------
    stiffness : float
        ``K``, N/m^n (> 0); for a pin in a hole see :func:`pin_in_hole`.
    restitution : float
        Nominal coefficient of restitution ``e``, {erange}.
    exponent : float
        ``n``, 1 to 3; default 1.5.
    min_approach_speed : float
        Floor of the approach speed, m/s (> 0; default 1e-3). ``v0`` is the penetration rate at
        the first instant of the contact episode, passed by the caller; the law uses
        ``max(v0, min_approach_speed)``, which bounds the damping of contacts that start at a
        near-zero speed (persistent contact) and makes ``v0 = 0`` or NaN harmless.
    clip_tension : bool
        Clip a tensile force to zero (default True). During restitution ``dd < 0`` and the
        formula pulls when ``chi |dd| > v0``; clipped, the contact cannot pull and both tangents
        are 0 there.

    Notes
    -----
    The effective restitution of a single impact depends on ``chi`` and ``n`` only (not on the
    mass, speed or stiffness); :func:`effective_restitution` computes it. {effective}
    """


def _hysteresis_doc(cls: Any, chi: str, erange: str, effective: str) -> Any:
    cls.__doc__ = (cls.__doc__ or "").rstrip() + _HYSTERESIS_DOC.format(
        chi=chi, erange=erange, effective=effective
    )
    return cls


class _Hysteresis(NormalLaw):
    stiffness: float
    restitution: float
    exponent: float
    min_approach_speed: float
    clip_tension: bool

    def __post_init__(self) -> None:
        self._build(
            type(self).__name__,
            stiffness=_float("stiffness", self.stiffness),
            exponent=_float("exponent", self.exponent),
            restitution=_float("restitution", self.restitution),
            min_approach_speed=_float("min_approach_speed", self.min_approach_speed),
            clip_tension=bool(self.clip_tension),
        )


@dataclass(frozen=True)
class HuntCrossley(_Hysteresis):
    """Hunt & Crossley (1975), J. Appl. Mech. 42:440-445: hysteresis damping proportional to the
    elastic force, derived for ``e`` near 1."""

    stiffness: float
    restitution: float
    exponent: float = 1.5
    min_approach_speed: float = MIN_APPROACH_SPEED
    clip_tension: bool = True


@dataclass(frozen=True)
class LankaraniNikravesh(_Hysteresis):
    """Lankarani & Nikravesh (1990), J. Mech. Des. 112:369-376: the default of most
    clearance-joint papers, from an energy balance valid for ``e`` of 0.9 and above."""

    stiffness: float
    restitution: float
    exponent: float = 1.5
    min_approach_speed: float = MIN_APPROACH_SPEED
    clip_tension: bool = True


@dataclass(frozen=True)
class Gonthier(_Hysteresis):
    """Gonthier, McPhee, Lange & Piedboeuf (2004), Multibody Syst. Dyn. 11:209-233: usable at low
    restitution."""

    stiffness: float
    restitution: float
    exponent: float = 1.5
    min_approach_speed: float = MIN_APPROACH_SPEED
    clip_tension: bool = True


@dataclass(frozen=True)
class Flores(_Hysteresis):
    """Flores, Machado, Silva & Martins (2011), Multibody Syst. Dyn. 25:357-375 (Chrono's SMC
    "Flores" model): for any restitution."""

    stiffness: float
    restitution: float
    exponent: float = 1.5
    min_approach_speed: float = MIN_APPROACH_SPEED
    clip_tension: bool = True


@dataclass(frozen=True)
class CarvalhoMartins(_Hysteresis):
    """Carvalho & Martins (2019), Mech. Mach. Theory 139:174-194: a Hunt-Crossley form whose
    ``chi(e)`` approximates the exact restitution of that form."""

    stiffness: float
    restitution: float
    exponent: float = 1.5
    min_approach_speed: float = MIN_APPROACH_SPEED
    clip_tension: bool = True


_hysteresis_doc(
    HuntCrossley, "``chi = 3 (1 - e) / 2``", "0 to 1", "With n = 1.5: 0.909 at e = 0.9, 0.663 at e = 0.5."
)
_hysteresis_doc(
    LankaraniNikravesh,
    "``chi = 3 (1 - e^2) / 4``",
    "0 to 1",
    "With n = 1.5: 0.913 at e = 0.9, 0.725 at e = 0.5.",
)
_hysteresis_doc(
    Gonthier,
    "``chi = (1 - e^2) / e``",
    "0 (excluded) to 1",
    "With n = 1.5: 0.876 at e = 0.9, 0.488 at e = 0.5.",
)
_hysteresis_doc(
    Flores,
    "``chi = 8 (1 - e) / (5 e)``",
    "0 (excluded) to 1",
    "With n = 1.5: 0.894 at e = 0.9, 0.470 at e = 0.5.",
)
_hysteresis_doc(
    CarvalhoMartins,
    "``chi = (3/2) (1 - e) (11 - e) / (1 + 9 e)``",
    "0 (excluded) to 1",
    "With n = 1.5 it achieves its nominal e within 2e-4 for e >= 0.5 (4e-3 at 0.3), but not "
    "below about 1/3 (0.067 at e = 0.01): use Gonthier there.",
)


@dataclass(frozen=True)
class Impact:
    """One impact of a point mass against a normal law (:func:`effective_restitution`).

    Attributes
    ----------
    restitution : float
        Exit speed over approach speed.
    contact_time : float
        Duration of contact, s.
    max_penetration : float
        Largest penetration, m.
    """

    restitution: float
    contact_time: float
    max_penetration: float


def effective_restitution(law: NormalLaw, mass: float, approach_speed: float) -> Impact:
    """The restitution a normal law achieves in one impact of a point mass.

    Integrates ``m d'' = -F(d, d', v0)`` from ``d = 0``, ``d' = v0`` until the mass leaves
    (``d = 0`` again) with an adaptive Dormand-Prince 5(4) scheme at a local tolerance of 1e-12 in
    scaled variables; the peak and the exit are located exactly within their step. The approach
    speed of the episode is ``v0``.

    Parameters
    ----------
    law : NormalLaw
        Any law of this module.
    mass : float
        The mass, kg (> 0).
    approach_speed : float
        Normal speed at contact, m/s (> 0).

    Returns
    -------
    Impact
        Restitution, contact time (s) and peak penetration (m).

    Raises
    ------
    flexclear.InvalidParameterError
        A parameter out of range (named).
    flexclear.ConvergenceError
        The mass did not leave the surface within 1e4 scaled time units (e.g. an overdamped
        spring-dashpot without ``no_tension``).
    """
    if not isinstance(law, NormalLaw):
        raise _invalid("law", type(law).__name__, "a normal law of flexclear.contact")
    e, t, d = law._core.effective_restitution(float(mass), float(approach_speed))
    return Impact(restitution=e, contact_time=t, max_penetration=d)


@dataclass(frozen=True)
class Coulomb:
    """Coulomb friction regularized near zero slip, with an optional Stribeck curve.

    ``F_t = -mu(v) c_d(v) F_N sign(v)``: the force on the body slipping at ``v``, opposing it;
    a tensile normal force carries no friction.

    Parameters
    ----------
    mu : float
        Kinetic friction coefficient (>= 0).
    regularization : {"ambrosio", "linear"}
        ``"ambrosio"``: Ambrosio's modified Coulomb law (as in Flores et al. 2008), ``c_d = 0``
        below ``v0``, a linear ramp to 1 at ``v1``, 1 above (no stiction). ``"linear"``:
        ``c_d = |v| / v_reg`` below ``v_reg``, 1 above (as Exudyn).
    v0, v1 : float
        Ramp of the Ambrosio regularization, m/s (0 <= v0 < v1; defaults 1e-4 and 1e-2, the low
        ends of the ranges used in clearance-joint studies).
    v_reg : float
        Speed of the linear regularization, m/s (> 0; default 1e-3).
    mu_static : float, optional
        Static coefficient (>= mu): adds the Stribeck curve
        ``mu(v) = mu + (mu_static - mu) exp(-(|v| / stribeck_speed)^stribeck_exponent)``.
    stribeck_speed : float
        Stribeck speed, m/s (> 0; default 1e-3).
    stribeck_exponent : float
        Shape exponent of the Stribeck curve (> 0; default 2).
    """

    mu: float
    regularization: str = "ambrosio"
    v0: float = 1e-4
    v1: float = 1e-2
    v_reg: float = 1e-3
    mu_static: Optional[float] = None
    stribeck_speed: float = 1e-3
    stribeck_exponent: float = 2.0
    _core: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        core = _core.CoulombFriction(
            _float("mu", self.mu),
            regularization=str(self.regularization),
            v0=_float("v0", self.v0),
            v1=_float("v1", self.v1),
            v_reg=_float("v_reg", self.v_reg),
            mu_static=None if self.mu_static is None else _float("mu_static", self.mu_static),
            stribeck_speed=_float("stribeck_speed", self.stribeck_speed),
            stribeck_exponent=_float("stribeck_exponent", self.stribeck_exponent),
        )
        object.__setattr__(self, "_core", core)

    def force(self, slip_speed: ArrayLike, normal_force: ArrayLike) -> FloatOrArray:
        """Friction force, N, at slip speed ``v`` (m/s) and normal force ``F_N`` (N), broadcast."""
        shape, (v, fn) = _flat(slip_speed, normal_force)
        return _shape(self._core.force(v, fn), shape)

    def tangent(self, slip_speed: ArrayLike, normal_force: ArrayLike) -> Tuple[FloatOrArray, FloatOrArray]:
        """Closed-form tangents ``(dF/dv, dF/dF_N)`` in N s/m and N/N (one-sided at the kinks)."""
        shape, (v, fn) = _flat(slip_speed, normal_force)
        a, b = self._core.tangent(v, fn)
        return _shape(a, shape), _shape(b, shape)


@dataclass(frozen=True)
class LuGre:
    """LuGre friction (Canudas de Wit, Olsson, Astrom & Lischinsky 1995), normalized by the
    normal force so that a joint with a varying load keeps a friction coefficient.

    Bristle state ``z`` (m): ``z' = v - sigma0 |v| z / g(v)``,
    ``g(v) = mu + (mu_static - mu) exp(-(v / stribeck_speed)^2)``; force on the body slipping at
    ``v``: ``F = -(F_N (sigma0 z + sigma1 z') + sigma2 v)``. At constant ``v`` the force tends to
    the Stribeck curve ``-(g(v) F_N sign(v) + sigma2 v)``. The state belongs to the caller:
    :meth:`derivative` for any integrator, :meth:`advance` for the exact update at constant ``v``.

    Parameters
    ----------
    mu : float
        Kinetic (Coulomb) coefficient (> 0).
    mu_static : float
        Static coefficient (>= mu).
    stribeck_speed : float
        m/s (> 0).
    sigma0 : float
        Bristle stiffness per unit normal force, 1/m (at least ``mu_static / 1 m`` and at most
        ``mu / 1e-15 m``: a microslip ``mu_static / sigma0`` of at most 1 m and ``mu / sigma0``
        of at least a femtometre; default 1e5, a microslip ``mu / sigma0`` of 1 micrometre at
        mu = 0.1).
    sigma1 : float
        Bristle damping per unit normal force, s/m (>= 0; default 0).
    sigma2 : float
        Viscous friction, N s/m (>= 0; default 0).
    """

    mu: float
    mu_static: float
    stribeck_speed: float = 1e-3
    sigma0: float = 1e5
    sigma1: float = 0.0
    sigma2: float = 0.0
    _core: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        core = _core.LuGreFriction(
            _float("mu", self.mu),
            _float("mu_static", self.mu_static),
            _float("stribeck_speed", self.stribeck_speed),
            sigma0=_float("sigma0", self.sigma0),
            sigma1=_float("sigma1", self.sigma1),
            sigma2=_float("sigma2", self.sigma2),
        )
        object.__setattr__(self, "_core", core)

    def derivative(self, state: ArrayLike, slip_speed: ArrayLike) -> FloatOrArray:
        """``dz/dt``, m/s, at state ``z`` (m) and slip speed ``v`` (m/s)."""
        shape, (z, v) = _flat(state, slip_speed)
        return _shape(self._core.derivative(z, v), shape)

    def advance(self, state: ArrayLike, slip_speed: ArrayLike, dt: ArrayLike) -> FloatOrArray:
        """The state (m) after ``dt`` (s) at constant slip speed, exactly (stable for any step)."""
        shape, (z, v, h) = _flat(state, slip_speed, dt)
        return _shape(self._core.advance(z, v, h), shape)

    def steady_state(self, slip_speed: ArrayLike) -> FloatOrArray:
        """The state ``g(v) sign(v) / sigma0`` (m) reached at constant slip speed."""
        shape, (v,) = _flat(slip_speed)
        return _shape(self._core.steady_state(v), shape)

    def force(self, state: ArrayLike, slip_speed: ArrayLike, normal_force: ArrayLike) -> FloatOrArray:
        """Friction force, N, at state (m), slip speed (m/s) and normal force (N), broadcast."""
        shape, (z, v, fn) = _flat(state, slip_speed, normal_force)
        return _shape(self._core.force(z, v, fn), shape)

    def tangent(
        self, state: ArrayLike, slip_speed: ArrayLike, normal_force: ArrayLike
    ) -> Tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
        """Closed-form tangents ``(dF/dz, dF/dv, dF/dF_N)`` in N/m, N s/m and N/N."""
        shape, (z, v, fn) = _flat(state, slip_speed, normal_force)
        a, b, c = self._core.tangent(z, v, fn)
        return _shape(a, shape), _shape(b, shape), _shape(c, shape)


# ---------------------------------------------------------------------------------------------
# Stiffness of a pin in a hole

_MODELS = ("hertz", "liu", "johnson")
#: Largest penetration of the Johnson model over the radial clearance, 4 / e^2: its
#: force-penetration curve turns back beyond.
JOHNSON_MAX_PENETRATION = 4.0 / math.e**2


@dataclass(frozen=True)
class PinStiffness:
    """Stiffness of a pin in a hole (:func:`pin_in_hole`). Unpacks as ``(stiffness, exponent)``.

    Attributes
    ----------
    stiffness : float
        ``K``, N/m^n: exact for ``"hertz"``; for the line-contact models the local power law
        ``F = K d^n`` that touches the model's curve at ``reference_penetration``.
    exponent : float
        ``n``: 1.5 for ``"hertz"``; the local slope ``d ln F / d ln d`` of the curve for the
        others.
    model : str
        ``"hertz"``, ``"liu"`` or ``"johnson"``.
    effective_modulus : float
        ``E*``, Pa: ``1/E* = (1 - nu_B^2)/E_B + (1 - nu_J^2)/E_J``.
    bearing_radius, journal_radius : float
        m.
    length : float or None
        Contact length, m (line-contact models).
    reference_penetration : float or None
        m, where the local power law of a line-contact model was taken (None for ``"hertz"``).
    """

    stiffness: float
    exponent: float
    model: str
    effective_modulus: float
    bearing_radius: float
    journal_radius: float
    length: Optional[float]
    reference_penetration: Optional[float]

    def __iter__(self) -> Iterator[float]:
        yield self.stiffness
        yield self.exponent

    @property
    def radial_clearance(self) -> float:
        """``R_B - R_J``, m."""
        return self.bearing_radius - self.journal_radius

    def force(self, penetration: ArrayLike) -> FloatOrArray:
        """The model's own force-penetration curve, N (0 where ``penetration <= 0``).

        For ``"hertz"`` this is ``K d^1.5``; for ``"liu"`` and ``"johnson"`` the full nonlinear
        curve (of which ``stiffness`` and ``exponent`` are the local power law).

        Raises
        ------
        flexclear.InvalidParameterError
            ``"johnson"`` beyond ``JOHNSON_MAX_PENETRATION`` times the radial clearance.
        """
        d = np.asarray(penetration, dtype=np.float64)
        if self.model == "hertz":
            out = self.stiffness * np.where(d > 0.0, d, 0.0) ** 1.5
        else:
            out = _model_force(self.model, d, self.effective_modulus, self.radial_clearance, self.length)
        return float(out) if out.ndim == 0 else out


def _positive(name: str, value: Any, unit: str) -> float:
    allowed = f"finite and > 0 {unit}"
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise _invalid(name, value, allowed) from None
    if not (math.isfinite(v) and v > 0.0):
        raise _invalid(name, value, allowed)
    return v


def _poisson(name: str, value: Any) -> float:
    allowed = f"-1 < {name} < 0.5"
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise _invalid(name, value, allowed) from None
    if not -1.0 < v < 0.5:
        raise _invalid(name, value, allowed)
    return v


def _johnson_x(d: npt.NDArray[np.float64], dr: float) -> npt.NDArray[np.float64]:
    """Solves ``d = x (ln(4 dR / x) - 1)`` for ``x = f / (pi E*)`` on ``0 < x <= 4 dR / e^2``
    (where the right side increases) by bisection on ``ln x``: bracketed, so it cannot fail.

    ``[ln d - 60, ln min(d, x*)]`` brackets the root: ``x <= d`` because ``ln(4 dR/x) - 1 >= 1``
    on the branch, and at ``x = d e^-60`` the right side is ``d e^-60 (ln(4 dR/d) + 59) < d``.
    64 halvings of a width-60 interval leave 60 / 2^64 ~ 3e-18 in ``ln x``: full precision.
    """
    xs = 4.0 * dr / math.e**2
    lo = np.log(d) - 60.0
    hi = np.log(np.minimum(d, xs))
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        x = np.exp(mid)
        g = x * (np.log(4.0 * dr / x) - 1.0) - d
        below = g < 0.0
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return np.exp(0.5 * (lo + hi))


def _model_force(
    model: str, d: npt.NDArray[np.float64], es: float, dr: float, length: Optional[float]
) -> npt.NDArray[np.float64]:
    """The force of a line-contact model (``"liu"`` or ``"johnson"``), N."""
    pos = np.where(d > 0.0, d, 0.0)
    assert length is not None
    if model == "liu":
        return np.asarray(length * 0.5 * math.pi * es * pos * np.sqrt(pos / (2.0 * (dr + pos))))
    # johnson
    if np.any(pos > JOHNSON_MAX_PENETRATION * dr):
        worst = float(np.max(pos))
        raise _invalid(
            "penetration",
            worst,
            f"<= 4/e^2 x radial clearance = {JOHNSON_MAX_PENETRATION * dr:.6g} m for the Johnson model "
            "(its force-penetration curve turns back beyond)",
        )
    out = np.zeros_like(pos)
    m = pos > 0.0
    if np.any(m):
        out[m] = math.pi * es * length * _johnson_x(pos[m], dr)
    return out


def pin_in_hole(
    bearing_radius: float,
    journal_radius: float,
    youngs_modulus: float,
    poisson_ratio: float,
    youngs_modulus_journal: Optional[float] = None,
    poisson_ratio_journal: Optional[float] = None,
    length: Optional[float] = None,
    model: str = "hertz",
    penetration: Optional[float] = None,
) -> PinStiffness:
    """Contact stiffness of a journal (pin) of radius ``R_J`` in a bearing (hole) of radius
    ``R_B``, from geometry and materials.

    With ``1/E* = (1 - nu_B^2)/E_B + (1 - nu_J^2)/E_J`` and ``dR = R_B - R_J``:

    - ``"hertz"``: ``K = (4/3) E* sqrt(R_B R_J / dR)``, ``n = 1.5``: the stiffness of the
      Flores et al. clearance-joint studies (Hertz's point-contact law with the radii of the
      conforming pair; independent of the length).
    - ``"liu"``: Liu, Zhang, Zhao & Hu (2006), explicit conformal line contact,
      ``F = L (pi/2) E* d sqrt(d / (2 (dR + d)))``; needs ``length``.
    - ``"johnson"``: Johnson (1985), implicit logarithmic conformal line contact,
      ``d = (F / (pi L E*)) (ln(4 pi L E* dR / F) - 1)``, solved for ``F`` by bracketed bisection
      (cannot fail); valid up to ``d = (4/e^2) dR`` (0.54 dR) where the curve turns back; needs
      ``length``.

    The line-contact models are not power laws: ``stiffness`` and ``exponent`` are the power law
    that touches their curve at ``penetration`` (value and slope in log-log); the exact curve is
    :meth:`PinStiffness.force`. All three are invariant under a change of scale: with every length
    (radii, length, penetration) times ``s`` the force is times ``s^2`` (``F / (E* R L)`` against
    ``d / R``), so a model at 1/10 scale behaves as the full-size one.

    Parameters
    ----------
    bearing_radius : float
        ``R_B``, m (> journal_radius).
    journal_radius : float
        ``R_J``, m (> 0).
    youngs_modulus : float
        ``E_B``, Pa (> 0); also the journal's unless ``youngs_modulus_journal`` is given.
    poisson_ratio : float
        ``nu_B`` (-1 < nu < 0.5); also the journal's unless ``poisson_ratio_journal`` is given.
    youngs_modulus_journal, poisson_ratio_journal : float, optional
        The journal's material.
    length : float, optional
        Axial contact length ``L``, m (> 0): required by ``"liu"`` and ``"johnson"``, not used by
        ``"hertz"``.
    model : {"hertz", "liu", "johnson"}
        The stiffness model.
    penetration : float, optional
        Reference penetration of the line-contact models' local power law, m (> 0; default 1 %
        of the radial clearance, the order of the penetrations of the Flores benchmark).

    Returns
    -------
    PinStiffness
        Unpacks as ``(stiffness, exponent)``.

    Raises
    ------
    flexclear.InvalidParameterError
        A parameter out of range, named.

    Examples
    --------
    >>> K, n = pin_in_hole(10e-3, 9.5e-3, 207e9, 0.3)  # 6.61e10 N/m^1.5, 1.5
    """
    if model not in _MODELS:
        raise _invalid("model", repr(model), 'one of "hertz", "liu", "johnson"')
    r_j = _positive("journal_radius", journal_radius, "m")
    r_b = _positive("bearing_radius", bearing_radius, "m")
    if not r_b > r_j:
        raise _invalid("bearing_radius", bearing_radius, f"> journal_radius = {r_j} m")
    e_b = _positive("youngs_modulus", youngs_modulus, "Pa")
    nu_b = _poisson("poisson_ratio", poisson_ratio)
    e_j = (
        e_b
        if youngs_modulus_journal is None
        else _positive("youngs_modulus_journal", youngs_modulus_journal, "Pa")
    )
    nu_j = nu_b if poisson_ratio_journal is None else _poisson("poisson_ratio_journal", poisson_ratio_journal)
    es = 1.0 / ((1.0 - nu_b**2) / e_b + (1.0 - nu_j**2) / e_j)
    dr = r_b - r_j
    if model == "hertz":
        k = (4.0 / 3.0) * es * math.sqrt(r_b * r_j / dr)
        return PinStiffness(k, 1.5, model, es, r_b, r_j, None if length is None else float(length), None)
    if length is None:
        raise _invalid("length", None, f'> 0 m (the axial contact length; required by model "{model}")')
    ln = _positive("length", length, "m")
    d_ref = 0.01 * dr if penetration is None else _positive("penetration", penetration, "m")
    if model == "liu":
        n = 1.5 - 0.5 * d_ref / (dr + d_ref)
    else:
        if d_ref >= JOHNSON_MAX_PENETRATION * dr:
            raise _invalid(
                "penetration", d_ref, f"< 4/e^2 x radial clearance = {JOHNSON_MAX_PENETRATION * dr:.6g} m"
            )
        x = float(_johnson_x(np.array([d_ref]), dr)[0])
        lg = math.log(4.0 * dr / x)
        # F = pi E* L x, d = x (lg - 1), dd/dx = lg - 2: n = (d / F) dF/dd = (lg - 1) / (lg - 2)
        n = (lg - 1.0) / (lg - 2.0)
    f_ref = float(_model_force(model, np.array([d_ref]), es, dr, ln)[0])
    k = f_ref / d_ref**n
    return PinStiffness(k, n, model, es, r_b, r_j, ln, d_ref)
