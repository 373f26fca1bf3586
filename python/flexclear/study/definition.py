"""The study: its builder, the parameters it varies, the sampling design, the run settings and
outputs, and :class:`Study` itself, which runs locally or on Dask."""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import json
import math
import os
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Optional, Union

import numpy as np

from .. import _core, scenes
from .. import model as _model
from .._numbers import is_real
from ..errors import (
    InvalidParameterError,
    ResourceError,
    SimulationInterrupted,
    StoreError,
)
from .distributions import Distribution, Values, _as_distribution, _dist_to_dict, distribution_from_dict

if TYPE_CHECKING:
    from .results import StudyResult

#: Parameters that belong to the run rather than to the scene.
RUN_PARAMETERS = ("dt", "t_end")

#: Keywords of :meth:`flexclear.Model.simulate` a study's ``run_options`` may set.
RUN_OPTIONS = (
    "iterate",
    "iter_tol",
    "max_iter",
    "events",
    "gap_stiffness",
    "gap_damping",
    "beta",
    "gamma",
    "integrator",
    "rho_inf",
    "hht_alpha",
    "solver",
    "step_halving",
    "divergence_limit",
    "memory_limit",
)
#: Older spellings accepted in ``run_options`` (the batch engine's names).
_RUN_OPTION_ALIASES = {"tol": "iter_tol"}

#: Per-sample outputs, all from running reductions (no history needed), with units.
OUTPUTS = {
    "max_penetration": "largest penetration delta_r - delta_c, m (negative: never touched)",
    "time_of_max_penetration": "when it happened, s",
    "max_force": "largest contact force magnitude, N",
    "impacts": "closings after a separation deeper than 1 % of the clearance (rebounds not counted)",
    "contact_episodes": "every open-to-closed transition, rebounds included",
    "contact_time": "time in contact, s",
    "max_velocity": "peak speed of the journal relative to the bearing, m/s",
    "max_impact_velocity": "peak normal approach speed at an impact, m/s",
    "contact_period": "natural contact period pi d / v of the deepest impact, s (dt should be below a tenth)",
    "rms_penetration": "RMS of the penetration, m",
    "rms_force": "RMS of the contact force magnitude, N",
    "free_flight_fraction": "fraction of the time open (free flight)",
    "impact_fraction": "fraction of the time in impacts (episodes up to 5 natural contact periods)",
    "continuous_fraction": "fraction of the time in continuous contact (longer episodes)",
    "dissipated_energy": "energy dissipated in the joint (work balance of the contact force), J",
}
#: Per-slider outputs of ``Study(sliders=True)`` (columns ``"<slider>.<output>"``), with units: the
#: peak acceleration along the guide and the deviation of the slider's motion from the same
#: mechanism with ideal joints (mean absolute and peak over the output points from ``start`` on),
#: computed online during each sample's run in O(1) memory per slider (``Record.slider_reference``).
SLIDER_OUTPUTS = {
    "max_acceleration": "peak acceleration along the guide, m/s^2",
    "position_deviation_mean": "mean |x - x_ideal| along the guide, m",
    "position_deviation_max": "peak |x - x_ideal|, m",
    "velocity_deviation_mean": "mean |v - v_ideal|, m/s",
    "velocity_deviation_max": "peak |v - v_ideal|, m/s",
    "acceleration_deviation_mean": "mean |a - a_ideal|, m/s^2",
    "acceleration_deviation_max": "peak |a - a_ideal|, m/s^2",
}
#: Per-link outputs of ``Study(links=True)`` (columns ``"<link>.<output>"``, every flexible link),
#: with units: running peaks over every step from ``start`` on, O(1) memory per link and sample
#: (``Record(link_peaks=True)``; such samples run on the Newton stepper).
LINK_OUTPUTS = {
    "max_midspan": "peak midspan deflection relative to the chord through the end nodes, m",
    "max_axial_force": "peak axial force of any element, N",
}
#: Parameters of a build's clearance joint, left out of the ideal mechanism of ``sliders``.
_JOINT_PARAMETERS = frozenset(
    (
        "clearance_at",
        "clearance",
        "bearing_stiffness",
        "bearing_damping",
        "bearing_damping_ratio",
        "pin_radius",
        "poisson_ratio",
        "reference_penetration",
        "damping_law",
    )
)
#: Outputs that need the runs to track the contact modes (``Record(contact_modes=True)``).
MODE_OUTPUTS = ("free_flight_fraction", "impact_fraction", "continuous_fraction", "dissipated_energy")
#: Steps per natural contact period (``contact_period / dt``) that a fixed-step sample needs for
#: its impacts to count as resolved (:meth:`StudyResult.resolution`): at fewer, the peak force of
#: a stiff contact is sampled between its steps (the first 16 samples of the four-bar study file
#: had median rocker-pin peaks of 140, 242, 309 and 358 N at dt = 1e-5, 2.5e-6, 6.25e-7 and
#: 1.5625e-7 s, a median 1.4, 2.9, 7.3 and 25 steps a period, 2026-11-29).
RESOLVED_STEPS_PER_CONTACT = 10

#: The outputs a study keeps unless told (every output but :data:`MODE_OUTPUTS`, the raw count
#: of contact episodes and the contact period).
DEFAULT_OUTPUTS = tuple(
    o for o in OUTPUTS if o not in MODE_OUTPUTS and o not in ("contact_episodes", "contact_period")
)

_UNITS = {
    "max_penetration": "m",
    "time_of_max_penetration": "s",
    "max_force": "N",
    "impacts": "count",
    "contact_episodes": "count",
    "contact_time": "s",
    "max_velocity": "m/s",
    "max_impact_velocity": "m/s",
    "contact_period": "s",
    "rms_penetration": "m",
    "rms_force": "N",
    "max_acceleration": "m/s^2",
    "position_deviation_mean": "m",
    "position_deviation_max": "m",
    "velocity_deviation_mean": "m/s",
    "velocity_deviation_max": "m/s",
    "acceleration_deviation_mean": "m/s^2",
    "acceleration_deviation_max": "m/s^2",
    "free_flight_fraction": "1",
    "impact_fraction": "1",
    "continuous_fraction": "1",
    "dissipated_energy": "J",
    "max_midspan": "m",
    "max_axial_force": "N",
    "clearance": "m",
    "amplitude": "m",
    "frequency": "Hz",
    "bearing_stiffness": "N/m",
    "bearing_damping": "N s/m",
    "youngs_modulus": "Pa",
    "density": "kg/m^3",
    "length": "m",
    "side": "m",
    "dt": "s",
    "t_end": "s",
}


def _sci_ticks(ax, axis: str) -> None:
    """Tick labels of ``axis`` in powers of ten outside 1e-3 .. 1e5 (a penetration of 2e-5 m reads
    ``2`` over ``1e-5``, not ``0.00002``, whose neighbours overlap)."""
    ax.ticklabel_format(axis=axis, style="sci", scilimits=(-3, 5), useOffset=False)


def _scale_into_labels(fig) -> None:
    """Moves each axis's power-of-ten factor (:func:`_sci_ticks`' ``1e5`` at the axis's end,
    which a long label runs into) into its label's unit: ``name [m/s^2]`` over ``1e5`` becomes
    ``name [1e5 m/s^2]``, a label without a unit gets ``[1e5]``. Draws the figure once to know
    the factors; call it after the data and labels are set, before the layout."""
    fig.canvas.draw()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            text = axis.get_offset_text()
            factor = text.get_text()
            if not factor or not text.get_visible():
                continue
            label = axis.get_label_text()
            if label.endswith("]") and " [" in label:
                name, _, unit = label[:-1].rpartition(" [")
                axis.set_label_text(f"{name} [{factor} {unit}]")
            else:
                axis.set_label_text(f"{label} [{factor}]")
            text.set_visible(False)


def _panel_grid(count: int, ncol: int, size: tuple[float, float]):
    """A figure of ``count`` panels in rows of up to ``ncol``, each ``size`` (width, height)
    inches: the figure, its panels in reading order and its number of rows; the grid's places
    past ``count`` are hidden. (The caller has chosen matplotlib's backend.)"""
    import matplotlib.pyplot as plt

    ncol = min(ncol, count)
    nrow = math.ceil(count / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(size[0] * ncol, size[1] * nrow), squeeze=False)
    panels = list(axes.flat)
    for ax in panels[count:]:
        ax.set_visible(False)
    return fig, panels[:count], nrow


def _label(name: str) -> str:
    """``name [unit]`` for a parameter or an output column (``"<joint>.<output>"``: the output's
    unit)."""
    unit = _UNITS.get(name, _UNITS.get(name.rpartition(".")[2]))
    return f"{name} [{unit}]" if unit else name


DESIGNS = ("random", "lhs", "sobol", "grid", "given")
#: Most samples a study may have (its inputs alone are samples x parameters x 8 bytes).
MAX_SAMPLES = 10**8
_STATUS = ("ok", "diverged", "unconverged", "invalid", "singular", "interrupted", "not_run")


def _scene_names() -> list[str]:
    return [n for n in scenes.__all__ if inspect.isfunction(getattr(scenes, n))]


def _resolve_build(build: Union[str, Callable]) -> tuple[str, Callable]:
    """``(stored name, function)`` of a study's builder: a scene name (stored as is), a function
    of :mod:`flexclear.scenes` (stored as its name), a ``"module:qualname"`` string, or a
    module-level function (stored as ``"module:qualname"``, which a Dask worker can import)."""
    names = _scene_names()
    if callable(build):
        name = getattr(build, "__name__", "")
        if name in names and getattr(scenes, name) is build:
            return name, build
        qual = getattr(build, "__qualname__", "")
        module = getattr(build, "__module__", None)
        if not module or "<lambda>" in qual or "<locals>" in qual:
            raise InvalidParameterError(
                f"build = {build!r} is not allowed: a lambda or a function defined inside another cannot "
                "be imported by the workers that run the samples; allowed: a scene name, a function of "
                "flexclear.scenes, or a module-level function (or its 'module:qualname')"
            )
        return f"{module}:{qual}", build
    text = str(build)
    if ":" not in text:
        if text not in names:
            raise InvalidParameterError(
                f"build = {build!r} is not allowed; allowed: one of {names} or 'module:function'"
            )
        return text, getattr(scenes, text)
    module, _, qual = text.partition(":")
    try:
        obj: Any = importlib.import_module(module)
        for part in qual.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as e:
        raise InvalidParameterError(
            f"build = {text!r} cannot be imported: {e} (a module of your own must be on sys.path, e.g. "
            "through PYTHONPATH; a study file also finds it in its own folder or the current directory)"
        ) from None
    if not callable(obj):
        raise InvalidParameterError(f"build = {text!r} is not callable")
    return text, obj


def _check_run_options(options: Mapping[str, Any]) -> None:
    """The values of a study's ``run_options``, checked at ``Study(...)`` (types and simple
    ranges; what depends on the model is checked per sample): a bad value fails now, naming
    ``run_options.<key>``, not as a foreign exception in the middle of the run."""

    def real(v: Any) -> bool:
        return is_real(v)

    def integer(v: Any) -> bool:
        return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))

    rules: dict[str, tuple[Callable[[Any], bool], str]] = {
        "iterate": (lambda v: v is None or isinstance(v, (bool, np.bool_)), "None, True or False"),
        "events": (lambda v: isinstance(v, (bool, np.bool_)), "True or False"),
        "iter_tol": (
            lambda v: v is None or (real(v) and math.isfinite(v) and v > 0),
            "None or a finite tolerance > 0",
        ),
        "tol": (
            lambda v: v is None or (real(v) and math.isfinite(v) and v > 0),
            "None or a finite tolerance > 0",
        ),
        "max_iter": (
            lambda v: v is None or (integer(v) and 1 <= v <= _core.MAX_ITER),
            f"None or an integer in 1 ..= {_core.MAX_ITER}",
        ),
        "gap_stiffness": (
            lambda v: v is None or (real(v) and math.isfinite(v) and v > 0),
            "None or a finite N/m > 0",
        ),
        "gap_damping": (lambda v: real(v) and math.isfinite(v) and v >= 0, "a finite N s/m >= 0"),
        "beta": (lambda v: real(v) and 0 < v <= 0.5, "0 < beta <= 0.5"),
        "gamma": (lambda v: real(v) and 0.5 <= v <= 1, "0.5 <= gamma <= 1"),
        "solver": (
            lambda v: v in ("woodbury", "refactor") if isinstance(v, str) else False,
            '"woodbury" or "refactor"',
        ),
        "step_halving": (lambda v: integer(v) and 0 <= v <= 20, "an integer in 0 ..= 20"),
        "divergence_limit": (
            lambda v: v is None or (real(v) and v > 0 and not math.isnan(v)),
            "None or a length > 0, m",
        ),
        "memory_limit": (
            lambda v: v is None or (real(v) and v > 0 and not math.isnan(v)),
            "None or bytes > 0",
        ),
    }
    for key, value in options.items():
        check, allowed = rules.get(key, (lambda v: True, ""))
        if not check(value):
            e = InvalidParameterError(f"invalid parameter `run_options.{key}` = {value!r}: allowed {allowed}")
            e.parameter, e.value, e.allowed = f"run_options.{key}", repr(value), allowed
            raise e
    _batch_scheme(options, "run_options.")


def _tol_integrator(options: Mapping[str, Any], translating: bool) -> tuple[Any, Any]:
    """The ``(integrator, rho_inf)`` of a study's ``tol=`` runs given the integrator keys of
    ``options``: :meth:`flexclear.model.Model.simulate`'s default
    (:func:`flexclear.model._default_integrator`) on models that only translate, the options'
    own otherwise."""
    from ..model import _default_integrator

    return _default_integrator(
        options.get("integrator"),
        options.get("rho_inf"),
        translating,
        *(options.get(k) for k in ("hht_alpha", "beta", "gamma")),
    )


def _batch_scheme(options: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """The integrator keys of ``options`` (``integrator``, ``rho_inf``, ``hht_alpha``, ``beta``,
    ``gamma``) as the core's ``beta``, ``gamma``, ``alpha_m``, ``alpha_f``
    (:func:`flexclear.model._scheme`, which checks them)."""
    from ..model import _scheme

    scheme = _scheme(
        options.get("integrator", "newmark"),
        options.get("rho_inf"),
        options.get("hht_alpha"),
        options.get("beta"),
        options.get("gamma"),
        prefix,
    )
    return {k: scheme[k] for k in ("beta", "gamma", "alpha_m", "alpha_f")}


class Study:
    """A Monte Carlo (or grid) study of any model.

    Parameters
    ----------
    build : str or callable
        What builds one sample's :class:`flexclear.Model` from its parameters: a scene of
        :mod:`flexclear.scenes` (``"slider_yoke"``, ``"slider_crank"``, ``"four_bar"``, ... or the
        function), a module-level function of your own (stored as ``"module:qualname"``), or
        that string. Its keyword arguments are the parameters a study may vary or fix. A lambda
        or a closure is refused: Dask workers import the builder by name.
    vary : dict
        Parameter name -> :class:`Uniform`, :class:`Normal`, :class:`TruncatedNormal`,
        :class:`LogNormal`, :class:`Values` or a plain list of values. Names are the scene's
        keywords (SI units: ``clearance`` in m, ``bearing_stiffness`` in N/m,
        ``bearing_damping`` in N s/m, ``amplitude`` in m, ``frequency`` in Hz,
        ``youngs_modulus`` in Pa, ``damping_ratio``, ``elements``, ...) or the run parameters
        ``dt`` and ``t_end`` (s). Integer parameters (``elements``) are rounded.
    fixed : dict, optional
        Scene keywords held fixed for every sample.
    samples : int
        Number of samples (ignored by the ``"grid"`` design, whose size is the product of the
        levels).
    design : {"random", "lhs", "sobol", "grid", "given"}
        Plain random draws, Latin hypercube, scrambled Sobol (best balanced at a power of two),
        the full grid (lists as given; a distribution contributes ``levels`` quantiles), or the
        samples given row by row: every parameter a list of one common length ``n``, sample
        ``i`` takes the ``i``-th value of each (``samples`` is then ``n``; see also
        :meth:`Study.from_inputs`).
    seed : int
        Seed of the design: the same seed gives the same samples and, the runs being
        deterministic, the same results.
    levels : int
        Quantile levels per distribution in a grid design.
    t_end, dt : float
        Simulated time and step, s (unless varied); ``dt`` defaults to 1e-5 s, or with ``tol``
        is the output grid (default ``t_end / 1000``), whose instants the adaptive steps span
        (their states interpolated; the longest step is the whole run, as
        ``Model.simulate``'s default ``max_step``).
    tol : float, optional
        The relative accuracy of every sample, in (0, 1), instead of a step: each sample runs
        as ``Model.simulate(t_end, tol=tol)`` (adaptive steps on the constant stepper where the
        model translates, else on the Newton stepper; implicit
        contact, every contact entry and exit located). Before the samples, a pilot
        (:meth:`pilot`) runs the first :attr:`PILOT_SAMPLES` at ``tol`` and ``tol / 10`` and
        reports the achieved accuracy per output in :attr:`StudyResult.accuracy` (kept in the
        store as ``pilot.json``; a resumed study reads it back).
    method : {"modified", "force", "gap"}
        Clearance coupling; ``run_options`` passes any other :meth:`flexclear.Model.simulate`
        setting (``iterate``, ``integrator``, ``rho_inf``, ``hht_alpha``, ``beta``, ``gamma``,
        ``solver``, ``events``, ...). With
        ``{"iterate": True, "events": True}`` the largest contact force is the dashpot jump at
        entry located within the step (docs/stability.md section 6): accurate at steps ~10x
        larger than fixed steps need; event-aware samples are never stepped in lockstep.
    joints : str or list of str, optional
        The clearance joints whose outputs are reported (default: every clearance joint of the
        model). Output columns are named ``"<joint>.<output>"``, e.g. ``"crank_pin.max_force"``.
    outputs : sequence of str
        Which of :data:`OUTPUTS` to keep per joint (default :data:`DEFAULT_OUTPUTS`: all but the
        contact-mode fractions and the dissipated energy, which the runs then track, a few
        operations per joint and step more: name them to have them).
    start : float
        Outputs are reduced from this time on, s (to skip a start-up transient).
    history_every : int, optional
        Also keep the joint's penetration and force histories, decimated to every k-th step
        (memory grows with the run length: off by default).
    sliders : bool
        Also report every slider's :data:`SLIDER_OUTPUTS` (columns ``"<slider>.<output>"``):
        its peak acceleration along the guide, and the deviation of its position, velocity and
        acceleration from the same mechanism with ideal joints (the build called with
        ``clearance_at=None``; one ideal run per study structure, i.e. per distinct set of the
        other parameters, ``t_end`` and ``dt``, not per sample), mean absolute and peak over the
        output points from ``start`` on (every step, or every ``history_every``-th). The
        deviation is computed online during each sample's run against the ideal run's slider
        histories (shared by the samples of the structure): O(1) memory per slider and sample,
        whatever the run length (a sample retried at a smaller step, whose grid no longer lines
        up with the ideal run's, keeps its slider histories and compares them interpolated).
        Needs a build with a ``clearance_at`` parameter (``slider_crank``).
    links : bool
        Also report every flexible link's :data:`LINK_OUTPUTS` (columns ``"<link>.<output>"``):
        its peak midspan deflection relative to the chord (m) and its peak element axial force
        (N) over every step from ``start`` on, tracked during the run in O(1) memory per link
        (``Record(link_peaks=True)``; the samples run on the Newton stepper, as for link
        energies).
    orbit : bool
        Also keep the journal-centre orbit of each reported joint: columns
        ``"<joint>.qx_history"`` and ``"<joint>.qy_history"``, the journal centre relative to the
        bearing centre (m), decimated like the histories (needs ``history_every``; opt-in, memory
        O(steps / history_every) per sample).
    retries : int
        Retry a diverged sample this many times with the step times ``retry_factor``; the
        retried samples are flagged (column ``retries``) and the step used is in ``dt_used``.
        Retries stop before the step would fall below 1/1000 of the study's ``dt``
        (``flexclear._core.RETRY_MIN_STEP_RATIO``): each retry reruns the sample from its start,
        and one that diverges at any step would otherwise retry at ever smaller, ever longer
        steps.
    """

    def __init__(
        self,
        build: Union[str, Callable] = "slider_yoke",
        vary: Optional[Mapping[str, Any]] = None,
        *,
        fixed: Optional[Mapping[str, Any]] = None,
        samples: int = 100,
        design: str = "random",
        seed: int = 0,
        levels: int = 5,
        t_end: float = 0.5,
        dt: Optional[float] = None,
        method: str = "modified",
        joints: Union[str, Sequence[str], None] = None,
        outputs: Optional[Sequence[str]] = None,
        start: float = 0.0,
        history_every: Optional[int] = None,
        orbit: bool = False,
        sliders: bool = False,
        links: bool = False,
        retries: int = 0,
        retry_factor: float = 0.5,
        run_options: Optional[Mapping[str, Any]] = None,
        tol: Optional[float] = None,
    ) -> None:
        self.build, self._scene_fn = _resolve_build(build)
        sig = inspect.signature(self._scene_fn)
        self._scene_defaults = {
            k: p.default
            for k, p in sig.parameters.items()
            if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)
        }
        allowed = sorted(self._scene_defaults) + list(RUN_PARAMETERS)
        vary = dict(vary or {})
        fixed = dict(fixed or {})
        for k in list(vary) + list(fixed):
            if k not in allowed:
                raise InvalidParameterError(
                    f"unknown parameter {k!r} for build {self.build!r}; allowed: {allowed}"
                )
        both = sorted(set(vary) & set(fixed))
        if both:
            raise InvalidParameterError(f"parameters {both} are both varied and fixed")
        for k in fixed:
            if k in RUN_PARAMETERS:
                raise InvalidParameterError(f"fixed: {k!r} is a run parameter; pass {k}= to Study instead")
        self.vary: dict[str, Distribution] = {k: _as_distribution(k, v) for k, v in vary.items()}
        for k, v in fixed.items():
            if self._is_integer(k) and isinstance(v, (float, np.floating)):
                if not float(v).is_integer():
                    raise InvalidParameterError(f"fixed.{k} = {v!r} is not allowed; allowed: an integer")
                fixed[k] = int(v)  # 8.0 from a TOML file or a computation: the integer 8
        self.fixed = fixed
        if design not in DESIGNS:
            raise InvalidParameterError(
                f"design = {design!r} is not allowed; allowed: one of {list(DESIGNS)}"
            )
        self.design = design
        if not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_SAMPLES:
            raise InvalidParameterError(
                f"samples = {samples!r} is not allowed; allowed: an integer in 1 ..= {MAX_SAMPLES:,}"
            )
        if not isinstance(levels, (int, np.integer)) or levels < 1:
            raise InvalidParameterError(f"levels = {levels!r} is not allowed; allowed: an integer >= 1")
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InvalidParameterError(f"seed = {seed!r} is not allowed; allowed: an integer >= 0")
        if design == "given":
            lengths = {k: len(d.values) if isinstance(d, Values) else None for k, d in self.vary.items()}
            not_lists = sorted(k for k, n in lengths.items() if n is None)
            if not lengths or not_lists:
                raise InvalidParameterError(
                    f"vary = {not_lists or '{}'} is not allowed with design = 'given'; allowed: "
                    "at least one parameter, each a list (Values) of the samples' values"
                )
            if len(set(lengths.values())) > 1:
                raise InvalidParameterError(
                    f"vary lengths {lengths} are not allowed with design = 'given'; allowed: lists of one "
                    "length (one value per sample)"
                )
            samples = next(iter(lengths.values()))
            if samples > MAX_SAMPLES:
                raise InvalidParameterError(
                    f"{samples:,} given samples are not allowed; allowed: at most {MAX_SAMPLES:,}"
                )
        self.samples, self.levels, self.seed = int(samples), int(levels), int(seed)
        if design == "grid":
            size = 1
            for d in self.vary.values():
                size *= len(d.values) if isinstance(d, Values) else self.levels
            if size > MAX_SAMPLES:
                raise InvalidParameterError(
                    f"the grid of levels = {self.levels} over {list(self.vary)} has {size:.3g} samples; "
                    f"allowed: at most {MAX_SAMPLES:,} (fewer levels or values)"
                )
        if tol is not None and not (
            isinstance(tol, (int, float, np.floating)) and not isinstance(tol, bool) and 0 < tol < 1
        ):
            raise InvalidParameterError(
                f"tol = {tol!r} is not allowed; allowed: None or a relative accuracy in (0, 1), e.g. 0.01"
            )
        #: The relative accuracy of every sample's run (adaptive steps), or None (fixed ``dt``).
        self.tol = None if tol is None else float(tol)
        if dt is None:
            t = (
                t_end
                if isinstance(t_end, (int, float)) and is_real(t_end) and math.isfinite(t_end) and t_end > 0
                else 1.0
            )
            dt = 1e-5 if tol is None else t / _model.Model.TOL_OUTPUT_POINTS
        for name, v in (("t_end", t_end), ("dt", dt)):
            if not (isinstance(v, (int, float)) and is_real(v) and math.isfinite(v) and v > 0):
                raise InvalidParameterError(f"{name} = {v!r} is not allowed; allowed: finite and > 0 s")
        self.t_end, self.dt = float(t_end), float(dt)
        if not isinstance(method, str) or method not in ("modified", "force", "gap"):
            raise InvalidParameterError(
                f"method = {method!r} is not allowed; allowed: one of ['modified', 'force', 'gap']"
            )
        if self.tol is not None and method != "modified":
            raise InvalidParameterError(
                f"method = {method!r} is not allowed with tol; allowed: 'modified' (the tolerance "
                "chooses implicit contact with adaptive steps)"
            )
        self.method = method
        outputs = list(DEFAULT_OUTPUTS) if outputs is None else list(outputs)
        bad = [o for o in outputs if o not in OUTPUTS]
        if bad or not outputs:
            raise InvalidParameterError(
                f"outputs = {bad or outputs} is not allowed; allowed: a non-empty subset of {list(OUTPUTS)}"
            )
        self.outputs = outputs
        #: Whether the runs track the contact modes (an output of :data:`MODE_OUTPUTS` is asked for).
        self._modes = any(o in MODE_OUTPUTS for o in outputs)
        if not (is_real(start) and math.isfinite(start) and start >= 0):
            raise InvalidParameterError(f"start = {start!r} is not allowed; allowed: finite and >= 0 s")
        if "t_end" not in (vary or {}) and "dt" not in (vary or {}):
            from ..model import check_window

            check_window(start, self.t_end, self.dt, "start")
        self.start = float(start)
        if history_every is not None and (
            not isinstance(history_every, (int, np.integer))
            or isinstance(history_every, (bool, np.bool_))
            or not 1 <= history_every < 2**63
        ):
            raise InvalidParameterError(
                f"history_every = {history_every!r} is not allowed; allowed: None or an integer in 1 ..< 2^63"
            )
        self.history_every = None if history_every is None else int(history_every)
        if not isinstance(orbit, (bool, np.bool_)) or (orbit and history_every is None):
            raise InvalidParameterError(
                f"orbit = {orbit!r} is not allowed; allowed: False, or True with history_every (the "
                "orbit is a decimated history)"
            )
        self.orbit = bool(orbit)
        if not isinstance(retries, (int, np.integer)) or not 0 <= retries < 2**31:
            raise InvalidParameterError(
                f"retries = {retries!r} is not allowed; allowed: an integer in 0 ..= {2**31 - 1}"
            )
        numeric_factor = isinstance(retry_factor, (int, float, np.integer, np.floating))
        if not (numeric_factor and 0 < retry_factor < 1):
            raise InvalidParameterError(f"retry_factor = {retry_factor!r} is not allowed; allowed: 0 < f < 1")
        self.retries, self.retry_factor = int(retries), float(retry_factor)
        self.run_options = dict(run_options or {})
        reserved = {"t_end", "dt", "method", "record", "progress", "raise_on_failure"}
        clash = sorted(set(self.run_options) & reserved)
        if clash:
            raise InvalidParameterError(f"run_options may not set {clash}; they are Study arguments")
        unknown = sorted(set(self.run_options) - set(RUN_OPTIONS) - set(_RUN_OPTION_ALIASES))
        if unknown:
            raise InvalidParameterError(
                f"run_options: unknown {unknown}; allowed: {sorted(RUN_OPTIONS)} "
                "(keywords of flexclear.Model.simulate)"
            )
        _check_run_options(self.run_options)
        # Check the base model builds and the joints exist, so a typo fails now, not per sample.
        try:
            probe = self._scene_fn(**self._scene_kwargs({}))
        except TypeError as e:
            msg = f"build {self.build!r} cannot be called with the study's keywords: {e}"
            raise InvalidParameterError(msg) from None
        from ..model import Model

        if not isinstance(probe, Model):
            raise InvalidParameterError(
                f"build {self.build!r} returned {type(probe).__name__}; "
                "allowed: a function returning a flexclear.Model"
            )
        names = probe.joint_names
        if not names:
            raise InvalidParameterError(
                f"the model of {self.build!r} has no clearance joint to report on; give it one "
                "(e.g. fixed={'clearance_at': 'crank_pin'} for slider_crank or four_bar)"
            )
        chosen = list(names) if joints is None else [joints] if isinstance(joints, str) else list(joints)
        bad = [j for j in chosen if j not in names]
        if bad or not chosen:
            raise InvalidParameterError(f"joints = {joints!r} is not allowed; allowed: a subset of {names}")
        self.joints = chosen
        self._joint_indices = [names.index(j) for j in chosen]
        takes = "clearance_at" in self._scene_defaults
        if not isinstance(sliders, (bool, np.bool_)) or (sliders and not takes):
            raise InvalidParameterError(
                f"sliders = {sliders!r} is not allowed; allowed: False, or True with a build that takes "
                "clearance_at (the ideal mechanism is the build with clearance_at=None)"
            )
        self.sliders = bool(sliders)
        self._slider_names = list(probe.slider_names) if self.sliders else []
        flexible = [i for i, rigid in enumerate(probe._core.link_rigid) if not rigid]
        if not isinstance(links, (bool, np.bool_)) or (links and not flexible):
            raise InvalidParameterError(
                f"links = {links!r} is not allowed; allowed: False, or True with a model that has a "
                "flexible link"
            )
        self.links = bool(links)
        #: The reported links (every flexible link with ``links``) and their indices in the model.
        self._link_indices = flexible if self.links else []
        self._link_names = [probe.link_names[i] for i in self._link_indices]
        #: How many ideal-joint runs ``sliders`` has made (one per structure and batch,
        #: :class:`_IdealRuns`).
        self._ideal_made = 0
        self._inputs: Optional[Any] = None
        #: Thresholds for the report's exceedance table (output -> value), from a study file.
        self.report_thresholds: dict[str, float] = {}

    # -- definition ---------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The study's definition as plain data (what is stored beside the results)."""
        return {
            "build": self.build,
            "vary": {k: _dist_to_dict(v) for k, v in self.vary.items()},
            "fixed": self.fixed,
            "samples": self.samples,
            "design": self.design,
            "seed": self.seed,
            "levels": self.levels,
            "t_end": self.t_end,
            "dt": self.dt,
            "method": self.method,
            "joints": self.joints,
            "outputs": self.outputs,
            "start": self.start,
            "history_every": self.history_every,
            **({"orbit": True} if self.orbit else {}),
            **({"sliders": True} if self.sliders else {}),
            **({"links": True} if self.links else {}),
            "retries": self.retries,
            "retry_factor": self.retry_factor,
            "run_options": self.run_options,
            **({"tol": self.tol} if self.tol is not None else {}),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Study:
        """The inverse of :meth:`to_dict` (also what a study file holds, see :func:`load`)."""
        d = dict(d)
        if "scene" in d and "build" not in d:  # study files before `build`
            d["build"] = d.pop("scene")
        if "joint" in d and "joints" not in d:
            d["joints"] = d.pop("joint")
        known = set(inspect.signature(cls.__init__).parameters) - {"self"}
        unknown = sorted(set(d) - known)
        if unknown:
            raise InvalidParameterError(f"unknown study keys {unknown}; allowed: {sorted(known)}")
        vary = {k: distribution_from_dict(k, v) for k, v in (d.pop("vary", None) or {}).items()}
        return cls(vary=vary, **d)

    @classmethod
    def from_inputs(cls, build: Union[str, Callable], inputs: Any, **kwargs: Any) -> Study:
        """A study of exactly the samples in ``inputs`` (design ``"given"``).

        Parameters
        ----------
        build : str or callable
            As for :class:`Study`.
        inputs : pandas.DataFrame or mapping
            One column (or key) per varied parameter, one row (or list entry) per sample, in the
            builder's units.
        **kwargs
            Other :class:`Study` arguments (``fixed``, ``t_end``, ``dt``, ``outputs``, ...);
            ``vary``, ``design`` and ``samples`` come from ``inputs``.
        """
        clash = sorted({"vary", "design", "samples"} & set(kwargs))
        if clash:
            raise InvalidParameterError(f"{clash} may not be given to from_inputs; they come from inputs")
        try:
            columns = {str(k): np.asarray(inputs[k], dtype=float).reshape(-1).tolist() for k in inputs}
        except (TypeError, ValueError, KeyError) as e:
            raise InvalidParameterError(
                f"inputs = {type(inputs).__name__} is not allowed ({e}); allowed: a DataFrame or a "
                "mapping name -> sequence of numbers"
            ) from None
        vary = {k: Values(v) if v else v for k, v in columns.items()}
        return cls(build, vary=vary, design="given", **kwargs)

    @property
    def output_columns(self) -> list[str]:
        """The output columns of the result frame: ``"<joint>.<output>"`` per joint and output,
        then ``"<slider>.<output>"`` per slider and :data:`SLIDER_OUTPUTS` (``sliders=True``),
        then ``"<link>.<output>"`` per flexible link and :data:`LINK_OUTPUTS` (``links=True``)."""
        joints = [f"{j}.{o}" for j in self.joints for o in self.outputs]
        sliders = [f"{n}.{o}" for n in self._slider_names for o in SLIDER_OUTPUTS]
        return joints + sliders + [f"{n}.{o}" for n in self._link_names for o in LINK_OUTPUTS]

    def column(self, output: str) -> str:
        """The result column of ``output``: a full ``"<joint>.<output>"`` name, or a bare output
        name when the study reports on one joint (one slider for :data:`SLIDER_OUTPUTS`, one
        link for :data:`LINK_OUTPUTS`)."""
        cols = self.output_columns
        if output in cols:
            return output
        for names, outputs in (
            (self.joints, self.outputs),
            (self._slider_names, SLIDER_OUTPUTS),
            (self._link_names, LINK_OUTPUTS),
        ):
            if output in outputs and len(names) == 1:
                return f"{names[0]}.{output}"
        raise InvalidParameterError(f"output = {output!r} is not allowed; allowed: one of {cols}")

    def fingerprint(self) -> str:
        """A hash of the definition; a store only resumes a study with the same fingerprint."""
        blob = json.dumps(self.to_dict(), sort_keys=True, default=float).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    def _scene_kwargs(self, params: Mapping[str, Any]) -> dict:
        kw = dict(self.fixed)
        for k, v in params.items():
            if k in RUN_PARAMETERS:
                continue
            if self._is_integer(k):
                v = int(round(float(v)))
            kw[k] = v
        return kw

    def _is_integer(self, name: str) -> bool:
        """True for a scene keyword whose default is an int (``elements``): draws are rounded."""
        return type(self._scene_defaults.get(name)) is int

    # -- design ------------------------------------------------------------------------------

    def inputs(self):
        """The samples' inputs as a DataFrame (index ``sample``, one column per varied parameter)."""
        import pandas as pd

        if self._inputs is not None:
            return self._inputs
        names = list(self.vary)
        if self.design == "given":
            table = np.column_stack([np.asarray(self.vary[k].values, dtype=float) for k in names])
        elif self.design == "grid":
            axes = []
            for k in names:
                dist = self.vary[k]
                if isinstance(dist, Values):
                    axes.append(np.asarray(dist.values, dtype=float))
                else:
                    q = (np.arange(self.levels) + 0.5) / self.levels
                    axes.append(np.asarray(dist.ppf(q), dtype=float))
            if names:
                mesh = np.meshgrid(*axes, indexing="ij")
                table = np.column_stack([m.ravel() for m in mesh])
            else:
                table = np.empty((1, 0))
        else:
            n, d = self.samples, len(names)
            u = self._unit_samples(n, d)
            table = (
                np.column_stack(
                    [np.asarray(self.vary[k].ppf(u[:, i]), dtype=float) for i, k in enumerate(names)]
                )
                if d
                else np.empty((n, 0))
            )
        frame = pd.DataFrame(table, columns=names)
        for k in names:
            if self._is_integer(k):
                col = np.round(frame[k].to_numpy())
                bad = ~(np.abs(col) < 2**62)  # also NaN
                if bad.any():
                    i = int(np.argmax(bad))
                    raise InvalidParameterError(
                        f"vary[{k!r}] = {self.vary[k]!r} drew {float(frame[k].iloc[i])!r} for sample {i}; "
                        "allowed: an integer parameter's draws finite and below 2**62"
                    )
                frame[k] = col.astype(np.int64)
        frame.index.name = "sample"
        self._inputs = frame
        return frame

    def _unit_samples(self, n: int, d: int) -> np.ndarray:
        if d == 0:
            return np.empty((n, 0))
        if self.design == "random":
            return np.random.default_rng(self.seed).random((n, d))
        from scipy.stats import qmc

        cls = qmc.LatinHypercube if self.design == "lhs" else qmc.Sobol
        try:
            engine = cls(d, rng=np.random.default_rng(self.seed))
        except TypeError:  # scipy < 1.15 names it seed
            engine = cls(d, seed=np.random.default_rng(self.seed))
        with warnings.catch_warnings():
            # Sobol warns when n is not a power of two (its balance is best there); documented.
            warnings.simplefilter("ignore", UserWarning)
            return engine.random(n)

    # -- running ------------------------------------------------------------------------------

    def run(
        self,
        store: Union[str, os.PathLike, None] = None,
        *,
        threads: int = 0,
        chunk_size: Optional[int] = None,
        client: Any = None,
        progress: Union[bool, Callable[[int, int], None]] = True,
        lanes: int = 0,
        pilot: bool = True,
    ) -> StudyResult:
        """Runs the study (or what is left of it in ``store``).

        Parameters
        ----------
        store : path, optional
            A folder for the results: the definition (``study.json``), the inputs, and the
            results written in Parquet parts (named by their samples) as samples finish, at
            least every :data:`FLUSH_SECONDS` (5 s) of a long chunk. Running again with the same
            store resumes: finished samples are read back, not recomputed. A store holding a
            different study is refused, naming the fields that differ. One process writes to a
            store at a time: it holds ``writer.lock`` (pid, host) while it runs; a second writer
            is refused, and the lock of a writer that died on this host is taken over. The
            folder's writability is checked before any sample runs.
        threads : int
            Worker threads of the local Rust pool (0 = one per core). On Dask, threads per task.
        chunk_size : int, optional
            Samples per chunk (locally a part never spans two chunks; on Dask a task never
            does, and tasks are cut to last about FLUSH_SECONDS). Default: about 16 s of
            single-thread work (estimated at 1 us per step) per chunk locally, chunks of even
            size, and enough chunks to keep a cluster busy.
        client : dask.distributed.Client, optional
            Run the chunks on this cluster.
        progress : bool or callable
            A tqdm bar (samples/s and ETA) when True; or ``progress(done, total)``.
        lanes : int
            Largest lockstep group: consecutive samples with the same contact-free effective
            matrix and step (e.g. differing only in clearance or bearing law) that record no
            history are stepped together on one thread, sharing one factorization (0 = default,
            8; 1 = every sample alone; at most 8). Results are bitwise the same for any value.
            Lanes group samples on the constant stepper (links in translating frames, e.g. the
            slider-yoke); samples on the Newton stepper (rotating links: slider-cranks,
            four-bars, linkages) run one lane each whatever the value.
        pilot : bool
            Run the accuracy pilot of a study with ``tol`` first (:meth:`pilot`; default True).
            False leaves :attr:`StudyResult.accuracy` None, e.g. where the study's accuracy is
            checked otherwise (:func:`flexclear.analysis.distributions.convergence`).

        Returns
        -------
        StudyResult

        Raises
        ------
        SimulationInterrupted
            On Ctrl-C. The samples finished so far are in the store (when given) and in
            ``exc.partial`` (a :class:`StudyResult`).
        StoreLockedError
            Another live process writes to ``store`` (nothing ran).
        StoreError
            The store is not writable (nothing ran), a write failed (every sample computed,
            written or not, is in ``exc.partial``; rerun to resume), or two parts hold different
            results for one sample.
        """
        from .results import StudyResult
        from .runner import _concat
        from .store import _Progress, _Store

        for name, value, top in (("threads", threads, 2**16), ("lanes", lanes, 2**16)):
            if not (
                isinstance(value, (int, np.integer)) and not isinstance(value, bool) and 0 <= value <= top
            ):
                raise InvalidParameterError(f"{name} = {value!r} is not allowed; allowed: an integer >= 0")
        inputs = self.inputs()
        total = len(inputs)
        if chunk_size is not None and not (isinstance(chunk_size, (int, np.integer)) and chunk_size >= 1):
            raise InvalidParameterError(
                f"chunk_size = {chunk_size!r} is not allowed; allowed: an integer >= 1"
            )
        if client is not None and self.build.startswith("__main__:"):
            raise InvalidParameterError(
                f"build = {self.build!r} is defined in the main script, which Dask workers cannot "
                "import; allowed with a client: a function in an importable module"
            )
        self._check_memory(inputs)
        # The lock is taken and the folder's writability checked before any sample runs.
        store_ = _Store(Path(store), self) if store is not None else None
        bar = None
        frames: list = []
        t0 = time.perf_counter()
        accuracy = None
        try:
            if self.tol is not None and pilot:
                accuracy = store_.read_pilot() if store_ else None
                if accuracy is None:
                    accuracy = self.pilot(inputs, threads=threads)
                    if store_:
                        store_.write_pilot(accuracy)
            parts = store_.read() if store_ else []
            done_ids = set()
            for p in parts:
                done_ids.update(int(i) for i in p.index)
            todo = [i for i in range(total) if i not in done_ids]
            if chunk_size is None:
                chunk_size = self._default_chunk(total, client)
            chunks = [todo[i : i + chunk_size] for i in range(0, len(todo), chunk_size)]
            bar = _Progress(progress, total, initial=total - len(todo))
            frames.extend(parts)
            if client is not None:
                self._run_dask(client, inputs, chunks, (threads, lanes), store_, frames, bar)
            else:
                self._run_local(inputs, chunks, (threads, lanes), store_, frames, bar)
        except (SimulationInterrupted, StoreError) as exc:
            exc.partial = StudyResult(self, _concat(frames, self), time.perf_counter() - t0, accuracy)
            raise
        finally:
            if bar is not None:
                bar.close()
            if store_ is not None:
                store_.close()
        return StudyResult(self, _concat(frames, self), time.perf_counter() - t0, accuracy)

    #: Samples of the pilot of a study with ``tol``.
    PILOT_SAMPLES = 4

    def pilot(self, inputs=None, *, threads: int = 0) -> dict:
        """The pilot of a study with ``tol``: its first :attr:`PILOT_SAMPLES` samples run at
        ``tol`` and at ``tol / 10``; the achieved accuracy of each output is the largest
        relative difference between the two over those samples (relative to the largest
        magnitude of the output there). Returns a dict: ``tol``, ``samples``, ``accuracy``
        (output column -> relative difference; NaN where a pilot sample failed), ``met`` (the
        peak force and penetration columns within ``tol``), ``settings`` (what ran: stepper,
        implicit contact, adaptive steps with their local tolerances) and ``cpu`` (s, both
        runs). :meth:`run` makes it before the samples and keeps it in the store
        (``pilot.json``) and in :attr:`StudyResult.accuracy`."""
        from .runner import _run_rows

        if self.tol is None:
            raise InvalidParameterError("pilot: the study has no tol (a pilot checks a tolerance)")
        inputs = self.inputs() if inputs is None else inputs
        k = min(self.PILOT_SAMPLES, len(inputs))
        ids = list(range(k))
        rows = [inputs.iloc[i].to_dict() for i in ids]
        fine = Study.from_dict({**self.to_dict(), "tol": self.tol / 10})
        t0 = time.process_time()
        a, _ = _run_rows(self, ids, rows, (threads, 1))
        b, _ = _run_rows(fine, ids, rows, (threads, 1))
        cpu = time.process_time() - t0
        accuracy = {}
        for c in self.output_columns:
            x, y = a[c].to_numpy(float), b[c].to_numpy(float)
            scale = np.nanmax(np.abs(y)) if np.isfinite(y).any() else float("nan")
            ok = (a["status"] == "ok").all() and (b["status"] == "ok").all()
            accuracy[c] = float(np.max(np.abs(x - y)) / scale) if ok and scale > 0 else float("nan")
        key = [c for c in accuracy if c.endswith((".max_force", ".max_penetration"))]
        met = bool(key) and all(accuracy[c] <= self.tol for c in key)
        probe = self._scene_fn(**self._scene_kwargs(rows[0] if rows else {}))
        rtol, atol, h_min, h_max, newton_tol = probe._core.tolerance_settings(
            self.tol,
            float(rows[0].get("t_end", self.t_end)) if rows else self.t_end,
            float(rows[0].get("dt", self.dt)) if rows else self.dt,
        )
        from ..model import _scheme

        opts = self.run_options
        integrator, rho_inf = _tol_integrator(opts, probe.engine == "translating")
        scheme = _scheme(integrator, rho_inf, opts.get("hht_alpha"), opts.get("beta"), opts.get("gamma"))
        return {
            "tol": self.tol,
            "samples": k,
            "accuracy": accuracy,
            "met": met,
            "settings": {
                "stepper": "constant" if probe.engine == "translating" else "newton",
                "integrator": scheme["integrator"],
                "iterate": True,
                "iter_tol": opts.get("iter_tol") or (newton_tol if probe.engine != "translating" else None),
                "adaptive": {
                    "rtol": rtol,
                    "atol": atol,
                    "h_min": h_min,
                    "h_max": h_max,
                    "output_dt": self.dt,
                },
            },
            "cpu": cpu,
        }

    def memory_estimate(self) -> int:
        """Bytes the histories of every sample would take in the result (``history_every``: two
        channels per reported joint, four with ``orbit``; 0 without histories), 8 bytes per value."""
        if self.history_every is None:
            return 0
        inputs = self.inputs()
        t_end = inputs["t_end"].to_numpy(float) if "t_end" in inputs else np.full(len(inputs), self.t_end)
        dt = inputs["dt"].to_numpy(float) if "dt" in inputs else np.full(len(inputs), self.dt)
        # a sample with a step or length out of range runs as "invalid" and keeps nothing
        valid = (dt > 0) & (t_end > 0) & np.isfinite(dt) & np.isfinite(t_end)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            steps = np.round(t_end[valid] / dt[valid])
        # so does one whose step divides t_end into no finite number of steps (dt = 5e-324)
        steps = np.maximum(steps[np.isfinite(steps)], 1)
        channels = 4 if self.orbit else 2
        total = float(np.sum(steps // self.history_every + 2)) * channels * len(self.joints) * 8
        return int(min(total, 2**63 - 1))

    def _check_memory(self, inputs) -> None:
        from ..model import MEMORY_LIMIT_ENV, _fmt_bytes, _memory_limit

        estimate = self.memory_estimate()
        limit, source = _memory_limit(self.run_options.get("memory_limit"))
        if estimate <= limit:
            return
        e = ResourceError(
            f"the study's histories would take about {_fmt_bytes(estimate)} ({len(inputs)} samples, "
            f"history_every = {self.history_every}, {len(self.joints)} joints), above the memory limit "
            f"of {_fmt_bytes(limit)} ({source}); nothing ran. Ways out: a larger history_every, "
            "history_every=None (the outputs need no history), fewer samples, a shorter t_end, or a "
            f"higher limit: run_options={{'memory_limit': bytes}} or {MEMORY_LIMIT_ENV}"
        )
        e.estimate, e.limit = estimate, int(min(limit, 2**63 - 1))
        raise e

    def _default_chunk(self, total: int, client: Any) -> int:
        steps = self.t_end / self.dt
        per_sample = max(steps * 1e-6, 1e-3)  # about 1 us per step
        # Locally a chunk is one batch, which ends with its slowest lockstep group while the other
        # threads idle (about half a group each): ~16 s of work per chunk keeps that to a few %.
        chunk = int(max(8, min(1024, 16.0 / per_sample)))
        if client is not None:
            chunk = max(1, min(chunk, math.ceil(total / 32)))
        # as even as possible: no short last chunk
        return math.ceil(total / math.ceil(total / chunk)) if total > 0 else chunk

    def _run_local(self, inputs, chunks, pool, store_, frames, bar) -> None:
        from .runner import _run_rows
        from .store import FLUSH_SECONDS, _PartWriter

        def interrupted() -> SimulationInterrupted:
            return SimulationInterrupted(
                f"study interrupted: {sum(len(f) for f in frames)} of {len(inputs)} samples finished"
                + (f" and saved in {store_.path}" if store_ else "")
            )

        writer = _PartWriter(store_, frames)
        workers = pool[0] if pool[0] > 0 else (os.cpu_count() or 1)
        # Samples per call of the engine: sized so a call lasts about FLUSH_SECONDS (first guess
        # 1 us per step, then measured), so finished samples reach the store that often whatever
        # the chunk size. Results do not depend on it.
        rate = workers / max(self.t_end / self.dt * 1e-6, 1e-6)  # samples/s
        try:
            for ids in chunks:
                k = 0
                while k < len(ids):
                    size = int(min(len(ids) - k, max(workers, FLUSH_SECONDS * rate)))
                    sub = ids[k : k + size]
                    k += size
                    rows = inputs.loc[sub].to_dict("records")
                    base = bar.n
                    t_sub = time.perf_counter()
                    frame, pending = _run_rows(self, sub, rows, pool, lambda d, b=base: bar.update_to(b + d))
                    elapsed = time.perf_counter() - t_sub
                    if pending is None and elapsed > 0:
                        rate = len(sub) / elapsed
                    writer.add(frame)
                    bar.update_to(base + len(frame))
                    if pending is not None:
                        writer.flush()
                        if isinstance(pending, KeyboardInterrupt):
                            raise interrupted()
                        raise pending
                    writer.flush_if_due()
                writer.flush()
        except KeyboardInterrupt:
            # Ctrl-C outside a batch (between chunks, in Python code): the same as within one.
            # A part being written is either complete or absent (written whole, then renamed).
            raise interrupted() from None

    def _run_dask(self, client, inputs, chunks, pool, store_, frames, bar) -> None:
        """The chunks on a Dask cluster, cut into tasks that last about :data:`FLUSH_SECONDS`
        (the first ones one sample per thread, the next sized from the measured wall time of
        the samples done, and at most a fair share of what is left), two per thread of the
        cluster in flight: finished samples reach the store within about that time (grouped
        into one part per FLUSH_SECONDS), however large a chunk, as on the local path. Results
        do not depend on the cutting."""
        from dask.distributed import as_completed

        from .runner import _run_rows_task
        from .store import FLUSH_SECONDS, _PartWriter

        definition = self.to_dict()
        writer = _PartWriter(store_, frames)
        threads = max(pool[0], 1)
        try:
            cluster_threads = sum(client.nthreads().values())
        except Exception:  # a client that cannot tell: assume a small cluster
            cluster_threads = 4
        in_flight = max(2, 2 * math.ceil(cluster_threads / threads))
        todo = [list(ids) for ids in chunks if len(ids)]
        per_sample = [0.0, 0]  # measured wall time (s) and samples measured

        def task_size(left: int) -> int:
            if per_sample[1] == 0:
                return min(left, threads)
            rate = threads * per_sample[1] / max(per_sample[0], 1e-9)  # samples/s of one task
            # and no more than a fair share of what is left, so every slot has work
            share = math.ceil(sum(len(c) for c in todo) / in_flight)
            return int(min(left, max(threads, min(FLUSH_SECONDS * rate, share))))

        def submit():
            ids = todo[0][: task_size(len(todo[0]))]
            del todo[0][: len(ids)]
            if not todo[0]:
                todo.pop(0)
            return client.submit(
                _run_rows_task,
                definition,
                ids,
                inputs.loc[ids].to_dict("records"),
                (threads, pool[1]),
                pure=False,
            )

        futures = [submit() for _ in range(in_flight) if todo]
        running = as_completed(futures)
        try:
            for fut in running:
                frame = fut.result()
                if len(frame):
                    per_sample[0] += float(frame["wall_time"].sum())
                    per_sample[1] += len(frame)
                if todo:
                    new = submit()
                    futures.append(new)
                    running.add(new)
                writer.add(frame)
                bar.update_to(bar.n + len(frame))
                writer.flush_if_due()
            writer.flush()
        except KeyboardInterrupt:
            client.cancel(futures)
            writer.flush()
            raise SimulationInterrupted(
                f"study interrupted: {sum(len(f) for f in frames)} of {len(inputs)} samples finished"
                + (f" and saved in {store_.path}" if store_ else "")
            ) from None
        except StoreError:
            client.cancel(futures)
            raise
