"""The one model class: :class:`Model`. Flexible links in any frame, rigid bodies, sliders, ideal
pins, supports, clamps, point masses, loads, gravity and clearance joints; one ``simulate``; one
:class:`~flexclear.Result`.

The user never names an engine. The model is one Rust model (``_core.Mechanism``: links in any
frame, rigid bodies, sliders, pins, clearance joints, ...) from the first call; the plan picks the
stepper. While every link translates (a fixed angle and a prescribed translation) and every joint
is a clearance joint to a node or a translating body, it runs on the constant stepper (the
contact-free effective matrix factorized once: the fast path of the slider-yoke and of its Monte
Carlo studies; :attr:`Model.engine` is ``"translating"``); a feature that needs the moving-frame
formulation (a rotating or mechanism frame, a pin, a slider, a support, a mass, a load, gravity, a
term switch) makes it run on the Newton stepper (``"moving-frame"``). ``Result.stats["engine"]``
and ``Result.stats["stepper"]`` say which ran.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time as _time
import warnings
from collections.abc import Sequence
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _core
from ._numbers import is_real
from .errors import (
    ConvergenceError,
    FlexclearError,
    InvalidParameterError,
    ModelError,
    NewmarkStabilityWarning,
    ResourceError,
    SimulationDivergedError,
    SingularMatrixError,
)
from .frames import Frame, Rotation
from .result import Record, Result

METHODS = ("modified", "force", "gap", "continuous")
TRANSLATING = "translating"
MOVING = "moving-frame"

#: Defaults of the within-step iterations, per engine (``iter_tol=None``, ``max_iter=None``):
#: the contact iteration of the translating engine converges kappa to 1e-10 relative in at most
#: 50 iterations; Newton on the moving-frame equations stops at a displacement correction of
#: 1e-8 of the displacement scale, or from its third iteration on where the contraction of its
#: last two corrections bounds the error left by that (``rho / (1 - rho)`` times the last,
#: ``rho`` below 0.5), at most 25 iterations; at fixed steps the default also stops once the
#: error left is within ``_core.TRUNCATION_FRACTION`` (1 %) of the step's own local truncation
#: error, where that is above 1e-8 (and up to 1e-6).
ITER_DEFAULTS = {TRANSLATING: (1e-10, 50), MOVING: (1e-8, 25)}

_STAT_KEYS = (
    "steps",
    "factorizations",
    "iterations",
    "max_iterations",
    "event_steps",
    "woodbury_steps",
    "woodbury_fallbacks",
    "unconverged_steps",
    "halved_substeps",
    "roundoff_steps",
    "event_fallbacks",
    "adaptive_steps",
    "rejected_steps",
    "floor_steps",
    "min_step",
    "max_step",
)


def _check_placement(frame, motion, angle: Optional[float] = None) -> None:
    """Checks how a link or body is placed: ``frame`` a :class:`Frame` or None, ``motion`` a
    :class:`~flexclear.motion.Motion` or None, and not ``frame`` together with ``motion`` (or with
    a non-zero ``angle``, where the caller takes one)."""
    if frame is not None:
        if not isinstance(frame, Frame):
            raise _bad("frame", frame, "a flexclear.Frame")
        if angle is None and motion is not None:
            raise _bad("frame", frame, "either `frame` or `motion`, not both")
        if angle is not None and (motion is not None or angle != 0.0):
            raise _bad("frame", frame, "either `frame` or `angle`/`motion`, not both")
    if motion is not None and not isinstance(motion, _core.Motion):
        allowed = "a flexclear.motion.Motion (motion.fixed, .harmonic, .tabulated) or None"
        raise _bad("motion", motion, allowed)


def _bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value!r}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, repr(value), allowed
    return e


def _is_number(x: Any) -> bool:
    return is_real(x)


#: Largest integer a count of the core (``every``, ``count``) may be: a signed 64-bit value.
_MAX_COUNT = 2**62


def _num(parameter: str, value: Any, allowed: str = "a finite number") -> float:
    """``value`` as a float, or :class:`InvalidParameterError` naming ``parameter`` when it is not
    a real number (a string, None, a list, a bool); ranges are checked where the value is used."""
    if not _is_number(value):
        raise _bad(parameter, value, allowed)
    return float(value)


#: The accuracy of :meth:`Model.simulate` given neither ``dt`` nor ``tol``: ``tol = 1e-2``, the
#: cheapest way to 1 % in the contact peaks on the measured scenes besides the slider-yoke's
#: hand-picked fixed steps (docs/accuracy/accuracy.md).
DEFAULT_TOL = 1e-2

#: Time integrators of :meth:`Model.simulate` (``integrator=``).
INTEGRATORS = ("newmark", "generalized-alpha", "hht")
#: Default ``rho_inf`` of ``integrator="generalized-alpha"`` and ``hht_alpha`` of ``"hht"``.
INTEGRATOR_DEFAULTS = {"rho_inf": 0.8, "hht_alpha": -0.1}

#: The integrator of a ``tol=`` run on the constant stepper (every link translates) given no
#: ``integrator``: generalized-alpha with this ``rho_inf``. Its numerical dissipation damps the
#: ringing of unresolved modes after an impact, which keeps Newmark's error estimate, and so
#: its steps, short through free flight: on the slider-yoke Table 1 scene at ``tol = 0.3`` 144
#: steps against 366 (0.58 against 1.21 ms, medians side by side; peak force within 5.6e-3), and
#: at ``tol = 0.01`` 396 against 1026. ``rho_inf = 0.5`` took fewer steps still but missed the
#: impact oscillator's exact ``x(2)`` by just over ``tol`` (1.07e-2 at ``tol = 1e-2``); 0.8 is
#: within it (4.95e-3). On the Newton stepper (rotating and rigid links) it took as many steps
#: or more (slider-crank crank pin at ``tol = 3e-2``: 4263 against 3939), so ``tol=`` runs there
#: keep Newmark. ``docs/method.md``, "Adaptive steps".
TOL_RHO_INF = 0.8


def _default_integrator(
    integrator: Any, rho_inf: Any, translating_tol: bool, *others: Any
) -> tuple[Any, Any]:
    """``(integrator, rho_inf)`` given ``integrator=None``: generalized-alpha with
    :data:`TOL_RHO_INF` for a ``tol=`` run on the constant stepper (``translating_tol``) when no
    integrator parameter (``rho_inf``, ``others``: ``hht_alpha``, ``beta``, ``gamma``) is
    given, else Newmark."""
    if integrator is not None:
        return integrator, rho_inf
    if translating_tol and rho_inf is None and all(x is None for x in others):
        return "generalized-alpha", TOL_RHO_INF
    return "newmark", rho_inf


def _scheme(
    integrator: Any, rho_inf: Any, hht_alpha: Any, beta: Any, gamma: Any, prefix: str = ""
) -> dict[str, Any]:
    """The integrator settings as the core takes them: ``beta``, ``gamma``, ``alpha_m``,
    ``alpha_f`` (Chung-Hulbert convention, both 0 for Newmark) and a description of the scheme for
    ``stats``. Checks every parameter, naming it (``prefix`` is prepended: ``run_options.``)."""
    if integrator not in INTEGRATORS:
        raise _bad(prefix + "integrator", integrator, f"one of {INTEGRATORS}")
    others = {"newmark": ("beta", "gamma"), "generalized-alpha": ("rho_inf",), "hht": ("hht_alpha",)}
    given = {"rho_inf": rho_inf, "hht_alpha": hht_alpha, "beta": beta, "gamma": gamma}
    for name, value in given.items():
        if value is not None and name not in others[integrator]:
            owner = next(k for k, v in others.items() if name in v)
            allowed = f'None unless integrator="{owner}" (integrator is "{integrator}")'
            raise _bad(prefix + name, value, allowed)
    if integrator == "newmark":
        b = _num(prefix + "beta", 0.25 if beta is None else beta, "0 < beta <= 0.5")
        g = _num(prefix + "gamma", 0.5 if gamma is None else gamma, "0.5 <= gamma <= 1")
        return dict(beta=b, gamma=g, alpha_m=0.0, alpha_f=0.0, integrator="newmark")
    if integrator == "generalized-alpha":
        rho = INTEGRATOR_DEFAULTS["rho_inf"] if rho_inf is None else rho_inf
        if not (_is_number(rho) and 0 <= rho <= 1):
            raise _bad(prefix + "rho_inf", rho_inf, "a number in [0, 1] (1: no numerical dissipation)")
        rho = float(rho)
        if rho == 1.0:  # alpha_m = alpha_f = 1/2 is average-acceleration Newmark, bitwise
            am = af = 0.0
        else:
            am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
        label = f"generalized-alpha, rho_inf = {rho:g}"
    else:
        alpha = INTEGRATOR_DEFAULTS["hht_alpha"] if hht_alpha is None else hht_alpha
        if not (_is_number(alpha) and -1 / 3 <= alpha <= 0):
            raise _bad(prefix + "hht_alpha", hht_alpha, "a number in [-1/3, 0] (0: no numerical dissipation)")
        am, af = 0.0, (0.0 - float(alpha))
        label = f"hht, alpha = {float(alpha):g}"
    g = 0.5 - am + af
    return dict(beta=0.25 * (g + 0.5) * (g + 0.5), gamma=g, alpha_m=am, alpha_f=af, integrator=label)


def _switch(parameter: str, value: Any) -> Optional[bool]:
    """A term switch: ``None`` (automatic) or a bool."""
    if value is None or isinstance(value, (bool, np.bool_)):
        return None if value is None else bool(value)
    raise _bad(parameter, value, "True, False or None (chosen from the frame's motion)")


def _pair(parameter: str, value: Any, unit: str) -> tuple[float, float]:
    """Two real numbers ``(x, y)``."""
    ok = isinstance(value, (tuple, list, np.ndarray)) and len(value) == 2
    if not (ok and all(_is_number(x) for x in value)):
        raise _bad(parameter, value, f"a pair of numbers (x, y), {unit}")
    return float(value[0]), float(value[1])


def _as_record(record: Any) -> Record:
    """``record`` of :meth:`Model.simulate` as a checked :class:`Record` (a Record, a dict of its
    fields, or None)."""
    if record is None or isinstance(record, Record):
        rec = record if record is not None else Record()
    elif isinstance(record, dict):
        fields = [f.name for f in dataclasses.fields(Record)]
        unknown = sorted(str(k) for k in record if k not in fields)
        if unknown:
            raise _bad(
                "record", record, f"a flexclear.Record or a dict of its fields {fields} (unknown: {unknown})"
            )
        rec = Record(**record)
    else:
        raise _bad("record", record, "a flexclear.Record, a dict of its fields, or None")
    if rec.joints is not None and not (
        isinstance(rec.joints, (list, tuple)) and all(isinstance(j, str) for j in rec.joints)
    ):
        raise _bad("record.joints", rec.joints, "None (every clearance joint) or a list of joint names")
    nodes_ok = isinstance(rec.nodes, (list, tuple)) and all(
        isinstance(x, (list, tuple)) and len(x) == 2 for x in rec.nodes
    )
    if not nodes_ok:
        raise _bad("record.nodes", rec.nodes, "a list of (link name, node index) pairs")
    if not isinstance(rec.sliders, (bool, np.bool_)):
        raise _bad("record.sliders", rec.sliders, "True or False")
    ref = rec.slider_reference
    if ref is not None and not (
        isinstance(ref, Result) and ref.record is not None and (ref.record.histories or ref.record.sliders)
    ):
        raise _bad(
            "record.slider_reference",
            type(ref).__name__,
            "None or a Result whose slider histories were kept (Record(sliders=True) or histories=True)",
        )
    return rec


def check_window(start: Any, t_end: Any, dt: Any, parameter: str = "record.start") -> None:
    """Refuses a reduction window ``[start, t_end]`` (s) that holds no step of ``dt``: the
    extremes would be -inf and the RMS values NaN."""
    for name, v in (("t_end", t_end), ("dt", dt)):
        if not (_is_number(v) and math.isfinite(v) and v > 0):
            raise _bad(name, v, "finite and > 0 s")
    if not (_is_number(start) and math.isfinite(start) and start >= 0):
        raise _bad(parameter, start, f"finite, 0 <= start < t_end = {float(t_end):g} s")
    if not math.isfinite(float(t_end) / float(dt)):
        raise _bad("dt", dt, f"a step that divides t_end = {float(t_end):g} s into a finite number of steps")
    last = max(round(float(t_end) / float(dt)), 1) * float(dt)  # the last step's time
    if start >= t_end or start > last:
        raise _bad(
            parameter,
            start,
            f"0 <= start < t_end = {float(t_end):g} s with a step of dt = {float(dt):g} s in between "
            f"(the last step is at {last:g} s): the extremes and RMS values are reduced over "
            "[start, t_end], which must not be empty",
        )


#: Environment variable that sets the memory limit of a run's histories, bytes (a number, with an
#: optional suffix k, M, G or T, powers of 1024; ``inf`` for none). ``simulate(memory_limit=)``
#: takes precedence; the default is half the available memory (``MemAvailable`` of
#: ``/proc/meminfo``), or 8 GiB where that cannot be read.
MEMORY_LIMIT_ENV = "FLEXCLEAR_MEMORY_LIMIT"
_DEFAULT_LIMIT = 8 * 2**30
_SUFFIX = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}


def _fmt_bytes(n: float) -> str:
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("kiB", 2**10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} bytes"


def _count(n: int) -> str:
    """A count for a message: ``1,234,567``, or ``1.23e+20`` when it is astronomical."""
    return f"{n:,}" if n < 10**15 else f"{float(n):.3g}"


def _mem_available() -> Optional[int]:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _memory_limit_env() -> str:
    """The text of :data:`MEMORY_LIMIT_ENV` ("" when unset or blank)."""
    return os.environ.get(MEMORY_LIMIT_ENV, "").strip()


def _memory_limit(value: Any = None) -> tuple[float, str]:
    """The memory limit of a run's histories, bytes, and where it comes from: ``value`` (the
    ``memory_limit=`` argument of :meth:`Model.simulate`), else :data:`MEMORY_LIMIT_ENV`, else
    half of ``MemAvailable`` (``/proc/meminfo``), else 8 GiB."""
    if value is not None:
        if not (_is_number(value) and value > 0) or math.isnan(value):
            raise _bad("memory_limit", value, "a number of bytes > 0 (inf: no limit), or None")
        return float(value), f"memory_limit={value:g}"
    text = _memory_limit_env()
    if text:
        t = text.lower().removesuffix("b").removesuffix("i")
        try:
            limit = float(t[:-1]) * _SUFFIX[t[-1]] if t and t[-1] in _SUFFIX else float(t)
        except ValueError:
            limit = float("nan")
        if not limit > 0:
            raise _bad(
                MEMORY_LIMIT_ENV, text, "a number of bytes > 0 with an optional suffix k, M, G, T (or inf)"
            )
        return limit, f"{MEMORY_LIMIT_ENV}={text}"
    avail = _mem_available()
    if avail:
        return 0.5 * avail, f"half the available memory, {_fmt_bytes(avail)}"
    return float(_DEFAULT_LIMIT), "the default 8 GiB (the available memory cannot be read here)"


def _singular(matrix: str, message: str) -> SingularMatrixError:
    e = SingularMatrixError(message)
    e.matrix = matrix
    return e


def _progress_callback(progress, label: str = "simulate"):
    if progress is None or progress is False:
        return None, None
    if callable(progress):
        return progress, None
    from tqdm import tqdm

    bar = tqdm(total=100, unit="%", desc=label, file=sys.stderr, leave=False)

    def cb(frac: float) -> None:
        bar.n = round(100 * frac)
        bar.refresh()

    return cb, bar


def _array(a) -> Optional[np.ndarray]:
    return None if a is None else np.ascontiguousarray(a, dtype=float)


class Model:
    """A planar mechanism of flexible beam links with clearance joints. SI units throughout.

    Build it with the ``add_*`` methods or take a ready one from :mod:`flexclear.scenes`::

        import flexclear as fc
        from flexclear import motion
        m = fc.Model()
        m.add_body("yoke", motion=motion.harmonic(amplitude=(0.0, 0.01), frequency=6.0))
        m.add_link("slider", length=0.269, elements=12, youngs_modulus=1.87e11, density=7850.0,
                   area=0.0127**2, inertia=0.0127**4 / 12, damping=676.0,
                   motion=motion.harmonic(amplitude=(0.0, 0.01), frequency=6.0))
        m.add_joint("bearing", "slider", 0, body="yoke", clearance=1e-4, stiffness=1.2e6, damping=321.0)
        res = m.simulate(0.1, 1e-5)

    Every parameter is checked when it is added (in time independent of the model's size): a bad
    value raises :class:`~flexclear.InvalidParameterError` naming it and its allowed range; an
    unknown name, a duplicate name or an inconsistent structure raises
    :class:`~flexclear.ModelError`. Node ``k`` of a link lies at ``k L / elements`` along its
    axis from the frame origin.
    """

    def __init__(self) -> None:
        self._core: Any = _core.Mechanism()
        self._link_ids: dict[str, int] = {}
        self._body_frames: dict[str, Frame] = {}
        self._slider_ids: dict[str, int] = {}
        self._connectors: set[str] = set()
        #: Inputs and derived values of the scene that built this model (empty otherwise).
        self.parameters: dict[str, Any] = {}

    @classmethod
    def _wrap(cls, core: Any, parameters: Optional[dict] = None) -> Model:
        """A model around a core one built in Rust (a scene), open to further building."""
        m = cls()
        m._core = core
        m._link_ids = {n: i for i, n in enumerate(core.link_names)}
        m._body_frames = dict(core.bodies)
        m._slider_ids = {n: i for i, n in enumerate(core.slider_names)}
        m._connectors = set(core.joint_names) | set(core.pin_names)
        m.parameters = dict(parameters or {})
        return m

    # -- what the model is ---------------------------------------------------------------------
    @property
    def engine(self) -> str:
        """What the plan runs the model on: ``"translating"`` (every link translates: the
        constant stepper, effective matrix factorized once) or ``"moving-frame"`` (the Newton
        stepper on the moving-frame equations). Follows the features added so far."""
        return self._kind

    @property
    def _kind(self) -> str:
        return TRANSLATING if self._core.translates else MOVING

    @property
    def link_names(self) -> list[str]:
        """Flexible link names, in order."""
        return list(self._core.link_names)

    @property
    def joint_names(self) -> list[str]:
        """Clearance joint names, in order."""
        return list(self._core.joint_names)

    @property
    def pin_names(self) -> list[str]:
        """Ideal pin names (:meth:`add_pin`), in order."""
        return list(self._core.pin_names)

    @property
    def body_names(self) -> list[str]:
        """Rigid body names added with :meth:`add_body`, in order."""
        return list(self._body_frames)

    @property
    def slider_names(self) -> list[str]:
        """Slider names, in order."""
        return list(self._slider_ids)

    def _link_index(self, name: str) -> int:
        try:
            return self._link_ids[name]
        except (KeyError, TypeError):
            raise ModelError(f"unknown link {name!r}; the model has {list(self._link_ids)}") from None

    def _node(self, link_i: int, node: Any, parameter: str = "node") -> int:
        """``node`` of link number ``link_i`` as an index, checked: an integer (an integral float
        is accepted) in ``0 ..= elements``; else :class:`InvalidParameterError` naming it."""
        n = int(self._core.link_elements[link_i])
        allowed = f'a node of link "{self.link_names[link_i]}": an integer 0 ..= {n}'
        if isinstance(node, (bool, np.bool_)) or not _is_number(node):
            raise _bad(parameter, node, allowed)
        if not float(node).is_integer() or not 0 <= node <= n:
            raise _bad(parameter, node, allowed)
        return int(node)

    def _joint_index(self, name: str) -> int:
        names = self.joint_names
        if name not in names:
            raise ModelError(f"unknown joint {name!r}; the model has {names}")
        return names.index(name)

    def _body_frame(self, name: str) -> Frame:
        if name not in self._body_frames:
            raise ModelError(f"unknown body {name!r}; the model has {self.body_names}")
        return self._body_frames[name]

    def _unique(self, kind: str, name: str, taken) -> None:
        if not isinstance(name, str) or not name:
            raise _bad(f"{kind} name", name, "a non-empty string")
        if name in taken:
            raise ModelError(f"two {kind}s are named {name!r}")

    # -- building ------------------------------------------------------------------------------
    def add_link(
        self,
        name: str,
        *,
        length: float,
        elements: int,
        youngs_modulus: float,
        density: float,
        area: float,
        inertia: float,
        damping: float = 0.0,
        angle: float = 0.0,
        motion=None,
        frame: Optional[Frame] = None,
        rotary_inertia: bool = False,
        coriolis: Optional[bool] = None,
        inertia_coupling: Optional[bool] = None,
        geometric: Optional[bool] = None,
        inertia_load: Optional[bool] = None,
        initial_displacement=None,
        initial_velocity=None,
    ) -> Model:
        """Adds a straight flexible link of ``elements`` equal Euler-Bernoulli beam elements.

        Parameters
        ----------
        name : str
            Unique link name.
        length : float
            Length L, m (> 0).
        elements : int
            Number of elements, 1 ..= 1000000; nodes 0..elements from the frame origin.
        youngs_modulus, density : float
            E (Pa, > 0) and rho (kg/m^3, > 0).
        area, inertia : float
            Section area A (m^2, > 0) and second moment of area I (m^4, > 0).
        damping : float
            Kelvin-Voigt coefficient eta, Pa s (>= 0); the damping matrix is (eta/E) K1.
        angle : float
            Fixed orientation of the link axis, rad (for a link that only translates).
        motion : flexclear.motion.Motion, optional
            Prescribed translation of the frame origin (default: fixed at the origin).
        frame : flexclear.Frame, optional
            A moving frame instead of ``angle``/``motion``: ``Frame.rotating(...)``,
            ``Frame.slider_crank(...)``, ``Frame.four_bar(...)``.
        rotary_inertia : bool
            Include rotary inertia in the mass matrix. Only the constant stepper has it (see
            ``stepper`` in :meth:`simulate`): a model that needs the Newton stepper (a rotating
            frame, a pin, gravity, ...) is refused at :meth:`simulate` with a :class:`ModelError`.
        coriolis, inertia_coupling, geometric, inertia_load : bool or None
            Force a term of the moving-frame equation on or off (None: chosen from the frame's
            motion: Coriolis and inertia coupling when it rotates, the geometric terms K2, K3,
            D2 when it rotates, the inertia load of the nominal motion when it moves).
        initial_displacement, initial_velocity : array_like, optional
            ``3 (elements + 1)`` values ``[u, v, theta]`` per node in the link frame (m, rad;
            m/s, rad/s).
        """
        self._unique("link", name, self._link_ids)
        _check_placement(frame, motion, angle)
        terms = tuple(
            _switch(k, v)
            for k, v in (
                ("coriolis", coriolis),
                ("inertia_coupling", inertia_coupling),
                ("geometric", geometric),
                ("inertia_load", inertia_load),
            )
        )
        integral = _is_number(elements) and float(elements).is_integer()
        if isinstance(elements, (bool, np.bool_)) or not integral or abs(elements) > _MAX_COUNT:
            raise _bad("elements", elements, "an integer in 1 ..= 1000000")
        args = (
            _num("length", length, "a finite number > 0, m"),
            int(elements),
            _num("youngs_modulus", youngs_modulus, "a finite number > 0, Pa"),
            _num("density", density, "a finite number > 0, kg/m^3"),
            _num("area", area, "a finite number > 0, m^2"),
            _num("inertia", inertia, "a finite number > 0, m^4"),
        )
        damping = _num("damping", damping, "a finite number >= 0, Pa s")
        angle = _num("angle", angle, "a finite angle, rad")
        initial = {}
        for key, value in (
            ("initial_displacement", initial_displacement),
            ("initial_velocity", initial_velocity),
        ):
            try:
                initial[key] = _array(value)
            except (TypeError, ValueError):
                raise _bad(
                    key, value, f"an array of 3 (elements + 1) = {3 * (int(elements) + 1)} numbers"
                ) from None
        if frame is None:
            frame = Frame.rotating(Rotation.fixed(float(angle)), origin=motion)
        self._core.add_link(
            name,
            *args,
            frame,
            float(damping),
            *terms,
            initial["initial_displacement"],
            initial["initial_velocity"],
            bool(rotary_inertia),
        )
        self._link_ids[name] = len(self._link_ids)
        return self

    def add_rigid_link(
        self,
        name: str,
        *,
        length: float,
        mass: float,
        inertia: float,
        centroid: Optional[float] = None,
        angle: float = 0.0,
        motion=None,
        frame: Optional[Frame] = None,
    ) -> Model:
        """Adds a rigid link: a rigid body along its frame's x axis that carries only its
        rigid-body deviation from the frame's nominal motion, not a beam.

        The link has two nodes, node 0 at the frame origin and node 1 at ``x = length``; use its
        name wherever a link name goes (pins, joints, supports, loads, masses, results). Its
        unknowns are node 0's deviation ``(u0, v0)`` (shared with pins as for any node) and one
        rotation ``theta``; node 1 follows as ``[u0, v0 + length theta, theta]`` (small
        deviations, as for the beam elements). It has the inertia of the rigid body (mass,
        Coriolis, inertia coupling, the nominal-motion load, gravity) and no stiffness or
        damping. Rigid links run on the Newton stepper. Node 1 may carry clearance joints,
        loads and point masses; pinning or supporting it is allowed only when node 0 is held
        (pinned to ground or a driven body): the link then follows its nominal motion exactly
        (a closed loop of rigid bodies, as the slider-crank with ideal joints), and a slider
        pinned to node 1 does too.

        Parameters
        ----------
        name : str
            Unique link name.
        length : float
            Distance between the two nodes, m (> 0).
        mass : float
            Mass m, kg (> 0).
        inertia : float
            Moment of inertia about the centroid, kg m^2 (>= 0).
        centroid : float, optional
            Centroid position along the link from node 0, m (default ``length / 2``).
        angle, motion, frame
            The link frame, as for :meth:`add_link`.

        Raises
        ------
        InvalidParameterError
            A parameter out of range (named ``length``, ``mass``, ``inertia``, ``centroid``,
            ``frame``, ...).
        ModelError
            A second link of the same name.
        """
        self._unique("link", name, self._link_ids)
        _check_placement(frame, motion, angle)
        length = _num("length", length, "a finite number > 0, m")
        mass = _num("mass", mass, "a finite number > 0, kg")
        inertia = _num("inertia", inertia, "a finite number >= 0, kg m^2")
        centroid = 0.5 * length if centroid is None else _num("centroid", centroid, "a finite number, m")
        angle = _num("angle", angle, "a finite angle, rad")
        if frame is None:
            frame = Frame.rotating(Rotation.fixed(float(angle)), origin=motion)
        self._core.add_rigid_link(name, length, mass, inertia, centroid, frame)
        self._link_ids[name] = len(self._link_ids)
        return self

    def add_body(self, name: str, motion=None, *, frame: Optional[Frame] = None) -> Model:
        """Adds a rigid body with prescribed motion: its reference point follows ``motion``
        (default: fixed at the origin), or its frame follows ``frame`` (a crank, a rocker).
        Points of the body (``point=`` of :meth:`add_joint` and :meth:`add_pin`) are given in
        its frame (for a translating body: global axes from the reference point), m."""
        self._unique("body", name, self.body_names)
        _check_placement(frame, motion)
        self._body_frames[name] = (
            frame if frame is not None else Frame.rotating(Rotation.fixed(0.0), origin=motion)
        )
        return self

    def add_slider(self, name: str, *, mass: float, path: Frame, angle: float = 0.0) -> Model:
        """Adds a slider block of ``mass`` (kg) on a straight guide at global ``angle`` (rad); its
        pin follows the origin of ``path`` (e.g. ``Frame.slider_crank(..., link="slider")``) and
        it has one elastic DOF along the guide."""
        self._unique("slider", name, self._slider_ids)
        if not isinstance(path, Frame):
            raise _bad("path", path, "a flexclear.Frame")
        mass = _num("mass", mass, "a finite number > 0, kg")
        angle = _num("angle", angle, "a finite angle, rad")
        self._core.add_slider(name, mass, angle, path)
        self._slider_ids[name] = len(self._slider_ids)
        return self

    def _other_side(self, body, point, target, slider) -> dict:
        given = [k for k, v in (("body", body), ("target", target), ("slider", slider)) if v is not None]
        if len(given) != 1:
            raise _bad(
                "body/target/slider",
                given,
                "exactly one of `body` (a rigid body name), `target` ((link name, node)) or "
                "`slider` (a slider name)",
            )
        if slider is not None:
            if slider not in self._slider_ids:
                raise ModelError(f"unknown slider {slider!r}; the model has {self.slider_names}")
            return {"target": "slider", "slider": self._slider_ids[slider]}
        if target is not None:
            if not (isinstance(target, (tuple, list)) and len(target) == 2):
                raise _bad("target", target, "a (link name, node index) pair")
            side = {
                "target_link": self._link_index(target[0]),
                "target_node": self._node(self._link_index(target[0]), target[1], "target[1]"),
            }
            return {"target": "node", **side}
        pt = _pair("point", point, "m")
        return {"target": "body", "frame": self._body_frame(body), "point": pt, "body": body}

    def add_joint(
        self,
        name: str,
        link: str,
        node: int,
        *,
        clearance: float,
        stiffness: Optional[float] = None,
        damping: Optional[float] = None,
        body: Optional[str] = None,
        point: Sequence[float] = (0.0, 0.0),
        target: Optional[tuple[str, int]] = None,
        slider: Optional[str] = None,
        damping_law: str = "viscous",
        no_tension: bool = False,
        law: Any = None,
        friction: Any = None,
        journal_radius: Optional[float] = None,
    ) -> Model:
        """Adds a revolute clearance joint: the journal is ``node`` of ``link``, the bearing a
        point of rigid body ``body`` (at ``point``, m, in the body frame), node
        ``target = (link name, node)`` of another link, or the pin of ``slider``. The two sides
        may have different nominal motions (a stop fixed in space beside a moving link).

        Parameters
        ----------
        clearance : float
            Radial clearance delta_c, m (>= 0).
        stiffness : float
            Bearing stiffness K_B, N/m (>= 0) of the paper's spring-dashpot (required without
            ``law``).
        damping : float
            Bearing damping C_B, N s/m (>= 0), active only in contact (required without ``law``).
        damping_law : {"viscous", "radial", "literal"}
            ``-C_B qdot`` (default, the paper's modified-matrix form), ``-C_B (n.qdot) n``, or the
            paper's literal force-method form ``-C_B |qdot| n`` (unstable on the slider-yoke).
        no_tension : bool
            Forbid a tensile (sticky) contact force.
        law : flexclear.contact.NormalLaw, optional
            The contact law instead of the spring-dashpot: ``Hertz``, ``HuntCrossley``,
            ``LankaraniNikravesh``, ``Flores``, ``Gonthier``, ``CarvalhoMartins`` (stiffness from
            :func:`flexclear.contact.pin_in_hole`) or ``KelvinVoigt`` (the spring-dashpot itself).
            The force ``F(d, dd, v0)`` acts along the line of centres; the approach speed ``v0`` of
            each contact episode is the penetration rate at its first state. With the modified
            coupling ``F(d, 0, v0) / |q|`` enters the stiffness and ``dF/d(dd)`` the damping (the
            split is exact for every law here). ``stiffness``, ``damping``, ``damping_law`` and
            ``no_tension`` are then not given.
        friction : flexclear.contact.Coulomb or flexclear.contact.LuGre, optional
            Friction in the joint (docs/contact.md, "Friction in the joint"): the tangential
            force ``F_t(v, F_N)`` at the contact point, with the slip speed
            ``v = (v_J - v_B) . t + R_J w_J - R_B w_B`` (the pin's and the bearing's total spin,
            frame rate plus elastic rotation rate, enter), acting on both sides' translations
            and as the moments ``F_t R_J`` on the journal node's rotation and ``-F_t R_B`` on the
            bearing node's (a rigid-body point or a slider has no rotation unknown). A model
            with friction runs on the Newton stepper, refactorizing its Jacobian (friction makes
            the contact tangent unsymmetric): ``stepper="constant"`` or ``"constant-rate"`` is
            refused. LuGre's bristle state is part of the run's state.
        journal_radius : float, optional
            Journal (pin) radius ``R_J``, m (> 0; required with ``friction``). The bearing
            radius is ``R_J + clearance``.
        """
        self._unique("joint", name, self._connectors)
        link_i = self._link_index(link)
        node = self._node(link_i, node)
        side = self._other_side(body, point, target, slider)
        if not isinstance(damping_law, str):
            raise _bad("damping_law", damping_law, 'one of "viscous", "radial", "literal"')
        if law is None:
            if stiffness is None or damping is None:
                missing = [k for k, v in (("stiffness", stiffness), ("damping", damping)) if v is None]
                raise _bad(missing[0], None, "a finite number >= 0 (or a contact law: law=...)")
            law = dict(
                clearance=_num("clearance", clearance, "a finite number >= 0, m"),
                stiffness=_num("stiffness", stiffness, "a finite number >= 0, N/m"),
                damping=_num("damping", damping, "a finite number >= 0, N s/m"),
                damping_law=damping_law,
                no_tension=bool(no_tension),
            )
        else:
            from .contact import NormalLaw

            if not isinstance(law, NormalLaw):
                raise _bad("law", law, "a law of flexclear.contact (Hertz, LankaraniNikravesh, ...)")
            given = [k for k, v in (("stiffness", stiffness), ("damping", damping)) if v is not None]
            if given or damping_law != "viscous" or no_tension:
                raise _bad(
                    given[0] if given else "damping_law" if damping_law != "viscous" else "no_tension",
                    stiffness if given and given[0] == "stiffness" else damping if given else damping_law,
                    "not given with law= (the law holds its stiffness, damping and tension choice)",
                )
            law = dict(
                clearance=_num("clearance", clearance, "a finite number >= 0, m"),
                stiffness=0.0,
                damping=0.0,
                law=law._core,
            )
        if friction is not None:
            from .contact import Coulomb, LuGre

            if not isinstance(friction, (Coulomb, LuGre)):
                raise _bad("friction", friction, "a friction law of flexclear.contact (Coulomb or LuGre)")
            if journal_radius is None:
                raise _bad("journal_radius", None, "a finite number > 0, m (required with friction)")
            law["friction"] = friction._core
            law["journal_radius"] = _num("journal_radius", journal_radius, "a finite number > 0, m")
        self._core.add_clearance(name, link_i, int(node), **law, **side)
        self._connectors.add(name)
        return self

    def add_pin(
        self,
        name: str,
        link: str,
        node: int,
        *,
        body: Optional[str] = None,
        point: Sequence[float] = (0.0, 0.0),
        target: Optional[tuple[str, int]] = None,
        slider: Optional[str] = None,
    ) -> Model:
        """Adds an ideal revolute joint (translations shared, rotations free) between ``node`` of
        ``link`` and a body point, another node or a slider (as for :meth:`add_joint`). The
        nominal motions must keep both sides together (checked when the model runs)."""
        self._unique("joint", name, self._connectors)
        self._core.add_pin(
            name,
            self._link_index(link),
            self._node(self._link_index(link), node),
            **self._other_side(body, point, target, slider),
        )
        self._connectors.add(name)
        return self

    def add_support(
        self, link: str, node: int, *, u: bool = True, v: bool = True, theta: bool = False
    ) -> Model:
        """Holds the chosen elastic DOFs of a node at zero in its link frame (a simple support by
        default: ``u`` and ``v``)."""
        li = self._link_index(link)
        self._core.add_support(li, self._node(li, node), bool(u), bool(v), bool(theta))
        return self

    def add_clamp(self, link: str, node: int) -> Model:
        """Clamps a node to its frame (u = v = theta = 0): a cantilever root at a hub."""
        return self.add_support(link, node, u=True, v=True, theta=True)

    def add_mass(self, link: str, node: int, mass: float) -> Model:
        """A point mass (kg, >= 0) at a node."""
        mass = _num("mass", mass, "a finite number >= 0, kg")
        li = self._link_index(link)
        self._core.add_mass(li, self._node(li, node), mass)
        return self

    def add_load(
        self, link: str, node: int, *, fu: float = 0.0, fv: float = 0.0, moment: float = 0.0
    ) -> Model:
        """A constant nodal load in the link frame: axial ``fu`` and transverse ``fv`` (N),
        ``moment`` (N m)."""
        fu, fv = _num("fu", fu, "a finite force, N"), _num("fv", fv, "a finite force, N")
        moment = _num("moment", moment, "a finite moment, N m")
        li = self._link_index(link)
        self._core.add_load(li, self._node(li, node), fu, fv, moment)
        return self

    def add_gravity(self, gx: float, gy: float) -> Model:
        """Sets gravity, global axes, m/s^2 (none by default; a second call replaces it)."""
        for k, v in (("gx", gx), ("gy", gy)):
            if not (_is_number(v) and math.isfinite(v)):
                raise _bad(k, v, "a finite acceleration, m/s^2")
        self._core.set_gravity(float(gx), float(gy))
        return self

    def validate(self, t_end: float) -> None:
        """Checks the whole model over ``[0, t_end]`` (s): references, connectivity, closure of
        the pins under the nominal motion. Raises :class:`ModelError` or
        :class:`InvalidParameterError`. (Parameters are checked when added; ``simulate`` runs
        this check itself.)"""
        self._core.validate(_num("t_end", t_end, "a finite time > 0, s"))

    # -- analysis ------------------------------------------------------------------------------
    def dof_map(self) -> list[tuple[int, int, str]]:
        """The unknowns of the moving-frame formulation: ``(link index, node, component)``;
        components ``u, v, theta`` (link frame), ``x, y`` (global, shared by pinned nodes) or
        ``s`` (along a guide)."""
        return self._core.dof_map()

    def static_state(
        self, t: float = 0.0, *, tol: float = 1e-12, max_iter: int = 50, contacts: bool = True
    ) -> np.ndarray:
        """Equilibrium of the moving-frame unknowns (see :meth:`dof_map`) at time ``t`` (s) with
        the frame rates and accelerations of that instant held (e.g. the centrifugally stretched
        beam at constant speed), by fixed-point iteration on the secant stiffness
        ``K(F) y = -r``. Where a link is free to move as a rigid body (a clearance joint leaves
        it held at one pin only), the iteration is repeated with the modes whose stiffness is
        below 1e-6 of the largest carrying no static load (they have no equilibrium).
        ``contacts=False`` leaves every clearance joint open. Raises :class:`ConvergenceError` if
        neither converges."""
        t = _num("t", t, "a finite time >= 0, s")
        tol = _num("tol", tol, "a finite relative tolerance > 0")
        if not (isinstance(max_iter, (int, np.integer)) and not isinstance(max_iter, bool) and max_iter >= 1):
            raise _bad("max_iter", max_iter, "an integer >= 1")
        contacts = bool(contacts)
        core = self._core
        n = len(core.dof_map())
        for rcond in (None, 1e-6):
            y = np.zeros(n)
            for _ in range(max_iter):
                _, _, k, r = core.linearize(float(t), y, contacts=contacts)
                if not (np.all(np.isfinite(k)) and np.all(np.isfinite(r))):
                    # LAPACK's least squares may never return on non-finite entries
                    msg = f"static_state: the secant stiffness or load at t = {t:g} s is not finite"
                    raise _singular("stiffness", msg)
                try:
                    dy = np.linalg.lstsq(k, -r, rcond=rcond)[0]
                except np.linalg.LinAlgError as e:  # SVD did not converge
                    msg = f"static_state: the secant stiffness at t = {t:g} s cannot be solved ({e})"
                    raise _singular("stiffness", msg) from None
                y = y + dy
                if np.max(np.abs(dy), initial=0.0) <= tol * max(np.max(np.abs(y), initial=0.0), 1e-30):
                    return y
                if not np.all(np.isfinite(y)):
                    break
        raise ConvergenceError(f"static_state did not converge in {max_iter} iterations (t = {t:g} s)")

    def natural_frequencies(self, count: int = 3, *, t: float = 0.0, coriolis: bool = True) -> np.ndarray:
        """The lowest ``count`` natural frequencies, **Hz**, ascending, with every clearance joint
        open and the rigid-body modes left out (eigenvalues below 1e-9 of the largest).

        For a model whose links all translate, the free vibration of the links. For a model in
        moving frames, the motion linearized at time ``t`` (s) about :meth:`static_state`, with
        the frame rates of that instant held: for a link spinning at constant speed, the in-plane
        frequencies with centrifugal stiffening (K2, K3) and softening (M_IC); ``coriolis=False``
        drops the gyroscopic coupling (the inextensible-beam idealization of the classic
        tables). Undamped."""
        if not (
            isinstance(count, (int, np.integer)) and not isinstance(count, bool) and 1 <= count <= _MAX_COUNT
        ):
            raise _bad("count", count, f"an integer in 1 ..= {_MAX_COUNT}")
        if self._kind == TRANSLATING:
            return self._core.natural_frequencies(int(count))
        t = _num("t", t, "a finite time >= 0, s")
        core = self._core
        y = self.static_state(t, contacts=False)
        m, c, k, _ = core.linearize(float(t), y, contacts=False)
        for name, x in (("mass", m), ("damping", c), ("stiffness", k)):
            if not np.all(np.isfinite(x)):
                # LAPACK's eigensolvers may never return on non-finite entries
                raise _singular(name, f"natural_frequencies: the {name} matrix at t = {t:g} s is not finite")
        try:
            return self._frequencies(m, c, k, int(count), coriolis)
        except np.linalg.LinAlgError as e:
            raise _singular(
                "mass",
                f"natural_frequencies: the mass matrix of the moving-frame unknowns is singular ({e}): a "
                "degree of freedom without mass (a massless slider, a link held by clearance joints "
                "only); give it mass",
            ) from None

    def matrices(self, t: float = 0.0, state: Optional[np.ndarray] = None) -> tuple:
        """The mass ``M`` (kg, kg m^2), damping ``C`` (N s/m, ...) and stiffness ``K`` (N/m, ...)
        of the moving-frame unknowns (in :meth:`dof_map` order) at time ``t`` (s), linearized
        about ``state`` (the unknowns' values; default zero deflection) with every clearance
        joint open and the frame rates of that instant held: the engine's own beam matrices
        (consistent mass, Euler-Bernoulli stiffness, Kelvin-Voigt damping) with the frame terms
        (Coriolis in ``C``; centrifugal softening and the axial-force stiffening in ``K``) where
        the frames move. Dense arrays; for a model of a few thousand unknowns at most."""
        t = _num("t", t, "a finite time >= 0, s")
        if t < 0:
            raise _bad("t", t, "a finite time >= 0, s")
        core = self._core
        n = len(core.dof_map())
        need = 4.0 * 8.0 * n * n  # M, C, K and the engine's working copy
        limit, source = _memory_limit()
        if need > limit:
            e = ResourceError(
                f"matrices of {n} unknowns would take about {_fmt_bytes(need)} as dense arrays, above the "
                f"memory limit of {_fmt_bytes(limit)} ({source}); use fewer elements"
            )
            e.estimate, e.limit = int(need), int(min(limit, 2**63 - 1))
            raise e
        if state is None:
            y = np.zeros(n)
        else:
            y = np.asarray(state, dtype=float).reshape(-1)
            if y.shape != (n,) or not np.all(np.isfinite(y)):
                raise _bad("state", state, f"{n} finite values, one per unknown of dof_map()")
        m, c, k, _ = core.linearize(float(t), y, contacts=False)
        return m, c, k

    @staticmethod
    def _frequencies(m, c, k, count: int, coriolis: bool) -> np.ndarray:
        n = m.shape[0]
        g = 0.5 * (c - c.T) if coriolis else np.zeros_like(c)
        if not np.any(g):
            w2 = np.linalg.eigvals(np.linalg.solve(m, k)).real
            w2 = np.sort(w2)
            top = np.max(np.abs(w2), initial=0.0)
            w = np.sqrt(w2[w2 > max(1e-12 * top, 1e-12)])
        else:
            a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, g)]])
            lam = np.linalg.eigvals(a)
            w = np.sort(np.abs(lam.imag[lam.imag > 0.0]))
            top = np.max(w, initial=0.0)
            w = w[w > max(1e-6 * top, 1e-6)]
        return w[: int(count)] / (2.0 * np.pi)

    # -- running -------------------------------------------------------------------------------
    def memory_estimate(self, t_end: float, dt: float, record: Union[Record, dict, None] = None) -> int:
        """Bytes the histories of ``simulate(t_end, dt, record=record)`` would take (8 bytes per
        recorded value: channels x recorded steps), without running anything. ``simulate``
        refuses a run above its memory limit with :class:`~flexclear.ResourceError`."""
        rec = _as_record(record)
        check_window(rec.start, t_end, dt, "record.start")
        if float(t_end) / float(dt) > 1e12:  # as simulate: at most 1e12 steps
            raise _bad("dt", dt, f"at least t_end/1e12 = {float(t_end) / 1e12:e} s (at most 1e12 steps)")
        return self._history_plan(float(t_end), float(dt), rec, MOVING if _on_newton(rec) else self._kind)[0]

    def _history_plan(self, t_end: float, dt: float, rec: Record, kind: str) -> tuple[int, int, int, dict]:
        """``(bytes, records, channels, channels by kind)`` of the histories of a run on the
        stepper of ``kind`` (``TRANSLATING``: the constant one)."""
        every = rec.every
        if not (
            isinstance(every, (int, np.integer)) and not isinstance(every, bool) and 1 <= every <= _MAX_COUNT
        ):
            raise _bad("record.every", every, f"an integer in 1 ..= {_MAX_COUNT}")
        steps = max(round(t_end / dt), 1)
        elements = list(self._core.link_elements)
        n_joints = len(self.joint_names) if rec.joints is None else len(rec.joints)
        per_joint = 2 + (2 if rec.position else 0)
        moving = kind == MOVING
        disp = (moving and bool(rec.histories)) if rec.displacements is None else bool(rec.displacements)
        if moving and rec.nodes:
            disp = True
        link_channels = 0
        if disp:
            for n in elements:
                link_channels += 3 * (n + 1) + (n if rec.axial_force else 0) + (1 if rec.midspan else 0)
        ch: dict[str, int] = {}
        if moving:
            # without histories the output grid is kept only for what is asked on it
            if not (rec.histories or rec.sliders or disp or rec.energy):
                return 0, 0, 0, {}
            records = steps // every + 2
            ch["time and link frames"] = 1 + 4 * len(elements)
            if self._slider_ids and (rec.histories or rec.sliders):
                ch["slider histories"] = 3 * len(self._slider_ids)
            if disp:
                ch["link displacements"] = link_channels
            if rec.energy:
                ch["energy"] = 3 * len(elements)
            if rec.histories:
                ch["joint histories"] = n_joints * per_joint
                # friction force and slip speed of the recorded joints with friction
                friction = [n for n, f in zip(self.joint_names, self._core.joint_friction) if f]
                n_friction = sum(1 for n in friction if rec.joints is None or n in rec.joints)
                if n_friction:
                    ch["friction histories"] = 2 * n_friction
        else:
            if not rec.histories:
                return 0, 0, 0, {}
            first = min(int(rec.start / dt), steps)
            records = (steps - first) // every + 2
            ch["time"] = 1
            ch["joint histories"] = n_joints * per_joint
            nodes = {(ln, self._node(self._link_index(ln), k, "record.nodes")) for ln, k in rec.nodes}
            if disp:  # every node, and the links' arrays made from them
                nodes |= {(ln, k) for ln, n in zip(self.link_names, elements) for k in range(n + 1)}
                ch["link displacements"] = link_channels + 4 * len(elements)
            if nodes:
                ch["node histories"] = 3 * len(nodes)
        channels = sum(ch.values())
        return 8 * records * channels, records, channels, ch

    def _check_memory(self, t_end: float, dt: float, rec: Record, limit_arg: Any, kind: str) -> None:
        estimate, records, channels, ch = self._history_plan(t_end, dt, rec, kind)
        if estimate == 0 and limit_arg is None and not _memory_limit_env():
            # nothing kept per step, no limit given to check: reading /proc/meminfo was a fifth of
            # a short run's Python-side time
            return
        limit, source = _memory_limit(limit_arg)
        if estimate <= limit:
            return
        steps = max(round(t_end / dt), 1)
        fits = limit / (8 * channels) - 2
        ways = []
        if fits >= 1:
            k = math.ceil(steps / fits)
            ways.append(f"Record(every={_count(k)}) or more (keeps every k-th step)")
        if kind == MOVING:
            if "link displacements" in ch:
                ways.append("Record(displacements=False) (or a few nodes in Record(nodes=...))")
            if rec.histories:
                ways.append("Record(histories=False) (the joints' extremes stay exact)")
        else:
            ways.append("Record(histories=False) (the joints' extremes stay exact)")
            ways.append("Record(start=...) (nothing is kept before it)")
        ways.append(f"a shorter t_end (now {t_end:g} s)")
        ways.append(f"a higher limit: simulate(memory_limit=bytes) or {MEMORY_LIMIT_ENV}")
        what = ", ".join(f"{v} {k}" for k, v in ch.items())
        e = ResourceError(
            f"the run would keep about {_fmt_bytes(estimate)} of histories ({_count(records)} records of "
            f"{channels} values: {what}; 8 bytes each), above the memory limit of {_fmt_bytes(limit)} "
            f"({source}); nothing was reserved. Ways out: " + "; ".join(ways)
        )
        e.estimate, e.limit = int(estimate), int(min(limit, 2**63 - 1))
        raise e

    def _omega_max(self) -> Optional[float]:
        """Highest natural circular frequency with every clearance joint open, rad/s, at t = 0
        (None for a model above 1000 unknowns, where the dense estimate would cost too much, or
        when it cannot be had)."""
        try:
            core = self._core
            n = len(core.dof_map())
            if not 0 < n <= 1000:
                return None
            m, _, k, _ = core.linearize(0.0, np.zeros(n), contacts=False)
            chol = np.linalg.cholesky(0.5 * (m + m.T))
            a = np.linalg.solve(chol, np.linalg.solve(chol, 0.5 * (k + k.T)).T)
            w2 = float(np.max(np.linalg.eigvalsh(0.5 * (a + a.T))))
        except (FlexclearError, np.linalg.LinAlgError, ValueError):
            return None
        return math.sqrt(w2) if w2 > 0 and math.isfinite(w2) else None

    def _check_newmark(self, beta: Any, gamma: Any, dt: float) -> None:
        """Warns (:class:`~flexclear.NewmarkStabilityWarning`) for valid but only conditionally
        stable Newmark parameters (``2 beta < gamma``), with the step limit."""
        if not (_is_number(beta) and _is_number(gamma) and 0 < beta <= 0.5 and 0.5 <= gamma <= 1):
            return  # out of range: the core refuses it, naming the parameter
        if 2 * beta >= gamma:
            return
        factor = 1.0 / math.sqrt(gamma / 2 - beta)
        w = self._omega_max()
        text = (
            f"Newmark beta = {beta:g}, gamma = {gamma:g} is only conditionally stable (2 beta < gamma): "
            f"steps above dt_crit = 1/(omega_max sqrt(gamma/2 - beta)) = {factor:.4g}/omega_max grow "
            "without bound"
        )
        if w is not None:
            crit = factor / w
            text += (
                f"; here omega_max = {w:.4g} rad/s (every clearance joint open; contact stiffness raises "
                f"it), so dt_crit = {crit:.3g} s and dt = {dt:g} s is "
                + (f"{dt / crit:.3g} x that: the run will diverge" if dt > crit else "below it")
            )
        text += "; beta >= gamma/2 (the default 1/4, 1/2) is unconditionally stable"
        warnings.warn(text, NewmarkStabilityWarning, stacklevel=3)

    def _iterate_default(self, method: str, kind: str) -> bool:
        """Implicit contact where a clearance joint sits on a rotating link or body (the lagged
        couplings pump energy into every impact there), lagged as in the paper otherwise."""
        if method != "modified" or kind == TRANSLATING:
            return False
        return any(self._core.joint_rotating)

    def simulate(
        self,
        t_end: float,
        dt: Optional[float] = None,
        method: str = "modified",
        *,
        tol: Optional[float] = None,
        max_step: Optional[float] = None,
        iterate: Optional[bool] = None,
        iter_tol: Optional[float] = None,
        max_iter: Optional[int] = None,
        events: bool = False,
        record: Union[Record, dict, None] = None,
        gap_stiffness: Optional[float] = None,
        gap_damping: float = 0.0,
        beta: Optional[float] = None,
        gamma: Optional[float] = None,
        integrator: Optional[str] = None,
        rho_inf: Optional[float] = None,
        hht_alpha: Optional[float] = None,
        solver: str = "woodbury",
        step_halving: int = 0,
        divergence_limit: Optional[float] = None,
        progress: Union[bool, Callable[[float], None], None] = None,
        raise_on_failure: bool = True,
        memory_limit: Optional[float] = None,
        stepper: Optional[str] = None,
    ) -> Result:
        """Runs the model from t = 0 to ``t_end`` at fixed step ``dt`` (Newmark by default, or a
        generalized-alpha scheme: ``integrator``), or with adaptive steps that meet the accuracy
        ``tol``.

        Parameters
        ----------
        t_end : float
            End time, s (> 0).
        dt : float, optional
            Time step, s (0 < dt <= t_end). With ``tol`` it is the output grid (default
            ``t_end / 1000``): adaptive steps may span several of its instants, whose states are
            interpolated (cubic Hermite displacements, linear accelerations). Given neither, the
            run is ``tol = 1e-2`` (:data:`DEFAULT_TOL`).
        tol : float, optional
            Relative accuracy asked of the run, in (0, 1) (e.g. 1e-3), instead of a step: the
            run takes adaptive steps with implicit contact (on the constant stepper where the
            model translates, its factorizations of recent step sizes kept; else on the Newton
            stepper; ``stepper="newton"`` forces Newton), each step's
            local error (the Zienkiewicz-Xie estimate ``|beta - 1/6| h^2 |a_(n+1) - a_n|``) kept
            within ``(tol / 10) ** 1.5`` relative to the displacement (absolute: that times the
            smallest clearance, m; a beam node's rotation counts as the largest displacement it
            makes within an element, ``(4/27) l_e theta``), every contact entry and exit located
            (a step that crosses one is cut there), steps doubling after an easy step and
            shrinking by what the estimate asks after a rejected one. On an impact oscillator
            with an exact solution
            the trajectory error at 2 s is about half of ``tol`` of the largest displacement
            (``tests/test_adaptive.py``). ``stats`` gains ``tol``, ``rtol``, ``atol``,
            ``h_min``, ``h_max`` (s), ``adaptive_steps``, ``rejected_steps``, ``floor_steps`` (accepted at the
            shortest step although over the tolerance), ``min_step`` and ``max_step`` (s),
            and the achieved-accuracy estimates (relative; ``None`` for fixed steps):
            ``error_estimate``, of the trajectory over the largest displacement (10 x the sum of
            the accepted steps' largest local errors over the largest ``|y|``; on the impact
            oscillator 2.8 to 3.1 times the largest error over the run at tol 1e-2 to 1e-5),
            and ``peak_force_error_estimate``, of the largest contact force (the joints' summed
            local errors of displacement and velocity up to the peak through the law's
            stiffness and damping there, x 40, over the peak; the largest over the joints; an
            upper estimate at tol 1e-3 and above: 3.8e-4 for an actual 2.3e-4 on the
            slider-yoke at tol 1e-2, pessimistic in a chatter; it speaks for the peak the run
            found). See
            ``docs/method.md``, "The achieved accuracy of a run". The iteration tolerance is
            ``iter_tol`` (by default tied to ``tol``, see there). The run stops with
            :class:`SimulationDivergedError` (its result so far on the exception) after 1000
            accepted steps in a row at the shortest step over the tolerance, or after a million
            accepted steps averaging below 1e-6 of the output step ``dt`` (a contact stiffness
            far too large for its masses: the message says how many steps the rest would take).
            ``progress`` and Ctrl-C are served every 1024 adaptive steps, also within one output
            step.
        max_step : float, optional
            With ``tol``: the longest adaptive step, s (> 0; default: the whole run, the error
            control alone bounding the step). Steps are ``max_step / 2**m``; a step whose
            interpolated joint path passes through a clearance circle between open ends is
            redone shorter, so no contact is stepped over. ``stats["max_step"]`` is the longest
            step taken.
        method : {"modified", "force", "gap", "continuous"}
            How the clearance force enters the step: the paper's modified stiffness/damping
            matrix method, the force reaction method (explicit), a gap element with status
            iteration (models the constant stepper runs, see ``stepper``), or the
            continuous-contact (massless-link) model of Earles & Wu (1977): no contact law, the
            journal held on the bearing circle ``|q| = c`` while the normal force (a Lagrange
            multiplier, N) is compressive; it leaves the wall at the instant that force would
            turn tensile (interpolated within the step: the exit of the joint's episode in
            ``impact_log``) and attaches again by a perfectly plastic impact when it reaches
            the wall. Runs on the Newton stepper (``stepper`` None or ``"newton"``), fixed steps
            without ``events``; the joint's ``force`` history is that normal force, its
            penetration 0 (5e-324, "closed") while attached. Needs every clearance > 0 (a
            zero clearance is an ideal pin). See ``docs/design.md``.
        iterate : bool or None
            Treat the contact implicitly (kappa and the spring tangent iterated within the step).
            None (default): on where a clearance joint sits on a rotating link or body (there the
            lagged couplings pump energy into every impact: +169 % after 22 undamped impacts of
            two free links), off otherwise (the paper's lagged kappa). ``stats["iterate"]`` says
            what ran.
        iter_tol, max_iter : float, int, optional
            Tolerance and cap (at most ``flexclear._core.MAX_ITER``, 10000) of the within-step
            iterations. Default (None): the contact
            iteration converges kappa to 1e-10 relative within 50 iterations while every link
            translates; Newton on the moving-frame equations stops at a correction of 1e-8 of the
            displacement scale, or (from the third iteration) where its corrections' contraction
            bounds the error left by that, within 25 iterations (see :data:`ITER_DEFAULTS`), and
            at fixed steps also once the error it leaves is within 1 % of the step's own local
            truncation error (the Zienkiewicz-Xie estimate ``|beta - 1/6| dt^2 |a_(n+1) - a_n|``
            over the displacement scale, never above 1e-6) where that is the larger: the
            equations are solved as far as the step is accurate
            (``stats["truncation_fraction"]``; an ``iter_tol`` given is met as given, with no
            such relaxation);
            with ``tol`` Newton stops at a tenth of the step's relative local tolerance
            (``0.1 (tol/10)**1.5``, 1.6e-5 at ``tol=3e-2``), never below 1e-8
            (``stats["iter_tol"]`` says what ran).
        events : bool
            Event-aware stepping: a step that opens or closes a clearance joint is redone as two
            substeps cut at the crossing; output stays on the ``dt`` grid. Counted in
            ``stats["event_steps"]``.
        record : Record or dict, optional
            What to keep (see :class:`~flexclear.Record`).
        gap_stiffness, gap_damping : float, optional
            Gap element (``method="gap"``): stiffness (N/m; default 1000 x 12 E I / l^3 of the
            element at the joint) and radial damping (N s/m).
        beta, gamma : float, optional
            Newmark parameters (``integrator="newmark"`` only); default (None) average
            acceleration (1/4, 1/2). Parameters with ``2 beta < gamma`` are only conditionally
            stable: a :class:`~flexclear.NewmarkStabilityWarning` states the step limit
            ``dt_crit = 1/(omega_max sqrt(gamma/2 - beta))``.
        integrator : {None, "newmark", "generalized-alpha", "hht"}
            Time integrator, on every stepper (default None: Newmark, except a ``tol=`` run on
            the constant stepper, which takes generalized-alpha with ``rho_inf = 0.8``,
            :data:`TOL_RHO_INF`, unless an integrator parameter is given): Newmark (``beta``,
            ``gamma``), Chung-Hulbert generalized-alpha (``rho_inf``) or HHT-alpha
            (``hht_alpha``), the alpha schemes in the form of Arnold & Bruls (2007): the
            equations of motion hold at the step's end and an acceleration-like variable carries
            the numerical dissipation (second order; see the method docs, "Integrators").
            ``stats["integrator"]`` says what ran.
        rho_inf : float, optional
            ``integrator="generalized-alpha"``: spectral radius at infinite frequency, in
            [0, 1] (default 0.8): modes with ``omega dt >> 1`` (the ringing after an impact)
            lose a factor ``rho_inf`` per step; 1 is average-acceleration Newmark (bitwise the
            default run), 0 annihilates them in one step.
        hht_alpha : float, optional
            ``integrator="hht"``: the HHT alpha, in [-1/3, 0] (default -0.1); spectral radius at
            infinite frequency ``(1 + alpha)/(1 - alpha)``; 0 is average-acceleration Newmark.
        solver : {"woodbury", "refactor"}
            Contact terms by a low-rank correction of the contact-free factorization (fast) or
            by numeric refactorization (reference). On the Newton stepper, ``"woodbury"``
            refactorizes the Jacobian only when its contact-free part changes (the frames, the
            axial forces) and ``"refactor"`` whenever it changes, contact included; the
            constant-rate stepper is the Woodbury one (``"refactor"`` runs such a model on
            Newton).
        step_halving : int
            In moving frames: how often a step whose Newton iterations do not converge may be
            halved (0: raise :class:`ConvergenceError`).
        divergence_limit : float, optional
            A displacement (or a clearance joint's penetration) beyond this, m, counts as
            divergence; default 10 x the longest link. Each clearance joint's penetration is
            checked at every step, the whole state every 16 steps (with ``tol``: every 16
            accepted adaptive steps) and at the last.
        progress : bool or callable, optional
            True shows a progress bar; a callable receives the fraction done.
        raise_on_failure : bool
            False returns the partial :class:`Result` of a run that diverged or did not converge
            (``complete=False``, ``error`` set) instead of raising.
        stepper : {None, "constant", "constant-rate", "newton"}
            Which stepper runs the model. None (default): chosen from the model: ``"constant"``
            (the contact-free matrix factorized once, contact by Woodbury) where every link and
            bearing body translates at a fixed angle with only clearance joints and no link
            energy or link peak recorded; else ``"constant-rate"`` (the moving-frame equations
            with the contact-free Jacobian factorized once, contact by Woodbury) where every
            frame is at rest or turns at a constant rate, no link carries geometric terms, no
            pinned or slider node sits on a rotating link and both sides of each clearance joint
            turn at one rate;
            ``"newton"`` (Newton on the moving-frame equations) otherwise. ``"newton"`` runs any
            model on the Newton stepper (e.g. to compare them); ``"constant"`` and
            ``"constant-rate"`` raise :class:`InvalidParameterError`, saying why, where the
            model does not allow them. ``stats["stepper"]`` says which ran.
        memory_limit : float, optional
            Largest memory the recorded histories may take, bytes (see :meth:`memory_estimate`;
            ``inf``: no limit). Default: the ``FLEXCLEAR_MEMORY_LIMIT`` environment variable
            (bytes, suffixes k, M, G, T allowed), else half the available memory
            (``MemAvailable`` of ``/proc/meminfo``), else 8 GiB. The estimate is made before
            anything is reserved; histories then grow in chunks as the run goes.

        Raises
        ------
        InvalidParameterError
            A parameter is out of range.
        ResourceError
            The histories asked for would exceed the memory limit (nothing ran); the message
            gives the estimate and the ways out (``Record(every=k)``,
            ``Record(histories=False)``, a shorter window, a start time, a higher limit).
        SimulationDivergedError, ConvergenceError
            The run blew up or a step did not converge; ``exc.result`` holds what was recorded.
        SimulationInterrupted
            Ctrl-C; ``exc.result`` holds what was recorded until then.
        """
        if method not in METHODS:
            raise _bad("method", method, f"one of {METHODS}")
        adaptive = None
        if tol is None and dt is None:
            tol = DEFAULT_TOL  # neither a step nor a tolerance: a run accurate to 1 %
        if tol is not None:
            dt, adaptive, iterate, stepper = self._tolerance_plan(
                t_end, dt, tol, method, iterate, stepper, max_step
            )
            adaptive, newton_tol = adaptive[:4], adaptive[4]
        elif max_step is not None:
            raise _bad("max_step", max_step, "None without tol= (it bounds adaptive steps)")
        if stepper not in (None, "constant", "constant-rate", "newton"):
            raise _bad("stepper", stepper, 'one of None, "constant", "constant-rate", "newton"')
        rec = _as_record(record)
        check_window(rec.start, t_end, dt, "record.start")
        if solver not in ("woodbury", "refactor"):
            raise _bad("solver", solver, 'one of "woodbury", "refactor"')
        gap_damping = _num("gap_damping", gap_damping, "a finite number >= 0, N s/m")
        if gap_stiffness is not None:
            gap_stiffness = _num("gap_stiffness", gap_stiffness, "None or a finite number > 0, N/m")
        if divergence_limit is not None:
            divergence_limit = _num("divergence_limit", divergence_limit, "None or a finite number > 0, m")
        if not (isinstance(step_halving, (int, np.integer)) and not isinstance(step_halving, bool)) or not (
            0 <= step_halving <= 20
        ):
            raise _bad("step_halving", step_halving, "an integer in 0 ..= 20")
        # the stepper the plan picks; energies and link peaks are recorded by the moving-frame
        # steppers (Newton, constant-rate)
        moving = (
            stepper in ("newton", "constant-rate")
            or (stepper is None and _on_newton(rec))
            or (method == "continuous" and stepper is None and len(self.joint_names) > 0)
        )
        kind = MOVING if moving else self._kind
        translating_tol = tol is not None and kind == TRANSLATING and stepper in (None, "constant")
        integrator, rho_inf = _default_integrator(
            integrator, rho_inf, translating_tol, hht_alpha, beta, gamma
        )
        scheme = _scheme(integrator, rho_inf, hht_alpha, beta, gamma)
        beta, gamma = scheme["beta"], scheme["gamma"]
        if iterate is None:
            iterate = self._iterate_default(method, kind)
        tol_default, iter_default = ITER_DEFAULTS[kind]
        # a fixed-step Newton run with the default iteration tolerance also stops at a fraction of
        # each step's own truncation error (NewtonSettings::truncation_fraction); an iter_tol
        # asked for is met as asked, and adaptive steps tie theirs to their tolerance
        truncation_fraction = (
            float(_core.TRUNCATION_FRACTION) if iter_tol is None and adaptive is None else 0.0
        )
        if iter_tol is None:
            # a tolerance-driven Newton run iterates to a tenth of its step's error test
            # (Adaptive::newton_tol); fixed steps to the validated default
            iter_tol = newton_tol if adaptive is not None and kind == MOVING else tol_default
        elif not (
            isinstance(iter_tol, (int, float, np.floating))
            and is_real(iter_tol)
            and math.isfinite(iter_tol)
            and iter_tol > 0
        ):
            raise _bad("iter_tol", iter_tol, "a finite relative tolerance > 0")
        max_iter = iter_default if max_iter is None else max_iter
        if not (isinstance(max_iter, (int, np.integer)) and not isinstance(max_iter, bool)) or not (
            1 <= max_iter <= _core.MAX_ITER
        ):
            raise _bad("max_iter", max_iter, f"an integer in 1 ..= {_core.MAX_ITER}")
        joints = None if rec.joints is None else [self._joint_index(j) for j in rec.joints]
        nodes = [
            (self._link_index(ln), self._node(self._link_index(ln), n, "record.nodes")) for ln, n in rec.nodes
        ]
        default = kind == MOVING and bool(rec.histories)  # histories=False: no output grid unless asked
        displacements = default if rec.displacements is None else bool(rec.displacements)
        if kind == MOVING and nodes:
            displacements = True  # node histories come from the link displacements
        if (rec.midspan or rec.axial_force) and not displacements:
            raise _bad("record.displacements", rec.displacements, "True (midspan and axial_force need them)")
        self._check_memory(float(t_end), float(dt), rec, memory_limit, kind)
        self._check_newmark(beta, gamma, float(dt))
        cb, bar = _progress_callback(progress)
        chosen = dict(
            engine=kind,
            integrator=scheme["integrator"],
            method=method,
            iterate=bool(iterate),
            iter_tol=float(iter_tol),
            max_iter=int(max_iter),
        )
        # the translating engine's contact iteration has no such relaxation
        chosen.update(truncation_fraction=truncation_fraction if kind == MOVING else 0.0)
        if adaptive is not None:
            chosen.update(
                tol=float(tol), rtol=adaptive[0], atol=adaptive[1], h_min=adaptive[2], h_max=adaptive[3]
            )
        t0 = _time.perf_counter()
        try:
            if kind == TRANSLATING:
                if step_halving:
                    raise _bad(
                        "step_halving", step_halving, "0 while every link translates (no Newton to halve)"
                    )
                for name in ("energy", "link_peaks"):
                    if getattr(rec, name):
                        raise _bad(
                            f"record.{name}",
                            True,
                            'False with stepper="constant" (the Newton stepper records it)',
                        )
            # one call for every stepper: the plan picks it, and the run's link channels (frame,
            # displacements, axial force, midspan) come from the Rust recorder either way
            raw = self._core.simulate(
                float(t_end),
                float(dt),
                method=method,
                iterate=bool(iterate),
                tol=float(iter_tol),
                max_iter=int(max_iter),
                step_halving=int(step_halving),
                beta=float(beta),
                gamma=float(gamma),
                alpha_m=scheme["alpha_m"],
                alpha_f=scheme["alpha_f"],
                divergence_limit=None if divergence_limit is None else float(divergence_limit),
                every=int(rec.every),
                displacements=displacements,
                axial_force=bool(rec.axial_force),
                midspan=bool(rec.midspan),
                energy=bool(rec.energy),
                link_peaks=bool(rec.link_peaks),
                progress=cb,
                events=bool(events),
                stepper=stepper,
                solver=solver,
                gap_stiffness=None if gap_stiffness is None else float(gap_stiffness),
                gap_damping=float(gap_damping),
                nodes=nodes,
                adaptive=adaptive,
                truncation_fraction=truncation_fraction,
                **_joint_record_kwargs(rec, joints),
            )
        except FlexclearError as exc:
            partial = getattr(exc, "partial", None)
            if partial is not None:
                exc.result = self._result(partial, chosen, rec, displacements, dt, t0, error=exc)
                if not raise_on_failure and isinstance(exc, (SimulationDivergedError, ConvergenceError)):
                    return exc.result
            raise
        finally:
            if bar is not None:
                bar.close()
        return self._result(raw, chosen, rec, displacements, dt, t0)

    #: Output points of a tolerance-driven run without ``dt``: ``dt = t_end / TOL_OUTPUT_POINTS``.
    TOL_OUTPUT_POINTS = 1000

    def _tolerance_plan(self, t_end, dt, tol, method, iterate, stepper, max_step=None):
        """The run settings a tolerance asks for: ``(dt, (rtol, atol, h_min, h_max, newton_tol),
        iterate, stepper)``; the local tolerances, the default longest step and the Newton
        tolerance come from the core (``Adaptive::for_tolerance``, ``Adaptive::default_max_step``,
        ``Adaptive::newton_tol``)."""
        if not (_is_number(tol) and math.isfinite(tol) and 0 < tol < 1):
            raise _bad("tol", tol, "a relative accuracy in (0, 1), e.g. 1e-3")
        if not (_is_number(t_end) and math.isfinite(t_end) and t_end > 0):
            raise _bad("t_end", t_end, "a finite time > 0, s")
        if method != "modified":
            raise _bad("method", method, '"modified" with tol= (the coupling is chosen for the tolerance)')
        if iterate is False:
            raise _bad("iterate", iterate, "None or True with tol= (the contact is implicit)")
        if stepper not in (None, "constant", "newton"):
            raise _bad(
                "stepper",
                stepper,
                'None, "constant" (translating models) or "newton" with tol= (adaptive steps run on '
                "the constant stepper where the model allows it, else on Newton)",
            )
        if dt is None:
            dt = float(t_end) / self.TOL_OUTPUT_POINTS
        elif not (_is_number(dt) and math.isfinite(dt) and 0 < dt <= t_end):
            raise _bad("dt", dt, f"the output grid, 0 < dt <= t_end = {t_end} s")
        if max_step is not None and not (_is_number(max_step) and math.isfinite(max_step) and max_step > 0):
            raise _bad("max_step", max_step, "None or the longest adaptive step, a finite time > 0, s")
        adaptive = tuple(
            self._core.tolerance_settings(
                float(tol), float(t_end), float(dt), None if max_step is None else float(max_step)
            )
        )
        return float(dt), adaptive, True, stepper

    def _result(
        self, raw: dict, chosen: dict, rec: Record, displacements: bool, dt, t0, error=None
    ) -> Result:
        wall = _time.perf_counter() - t0
        stats = {**chosen, **{k: 0 for k in _STAT_KEYS}, **raw.stats}
        lengths = list(self._core.link_lengths)
        elements = list(self._core.link_elements)
        if chosen["engine"] == TRANSLATING:
            ea = list(self._core.link_axial_stiffness)
        else:
            ea = [float("nan")] * len(lengths)
        links = list(zip(self.link_names, elements, lengths, ea))
        return Result(
            raw,
            joint_names=self.joint_names,
            links=links,
            method=chosen["method"],
            dt=float(dt),
            wall_time=wall,
            stats=stats,
            error=error,
            record=rec,
        )

    def __repr__(self) -> str:
        parts = [f"links={self.link_names}"]
        if self.body_names:
            parts.append(f"bodies={self.body_names}")
        if self._slider_ids:
            parts.append(f"sliders={self.slider_names}")
        parts.append(f"joints={self.joint_names}")
        return f"Model({', '.join(parts)}, engine={self._kind!r})"


def _on_newton(rec: Record) -> bool:
    """Whether ``rec`` asks for what only the moving-frame steppers record (link energies, the
    links' running peaks): a model the constant stepper would run then runs on Newton."""
    return bool(rec.energy or rec.link_peaks)


def _joint_record_kwargs(rec: Record, joints) -> dict:
    """The joint-recording options of the moving-frame run (the same meaning as in the
    translating run)."""
    return dict(
        joints=joints,
        joint_position=bool(rec.position),
        histories=bool(rec.histories),
        start=float(rec.start),
        impact_log=bool(rec.impact_log),
        contact_modes=bool(rec.contact_modes),
        sliders=bool(rec.sliders),
        slider_reference=None if rec.slider_reference is None else rec.slider_reference._slider_reference(),
    )
