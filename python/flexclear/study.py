"""Monte Carlo studies: many variants of any model, run in parallel, with results that survive a kill.

A :class:`Study` is a builder (a scene of :mod:`flexclear.scenes`, or any importable function
that returns a :class:`flexclear.Model` and whose keyword arguments are the study's parameters),
the parameters to vary (each a fixed list of values or a distribution), a sampling design and the
run settings. Running it gives a :class:`StudyResult`: a pandas DataFrame with one row per sample
(its inputs, its outputs per clearance joint, ``"<joint>.<output>"``, and its status), summaries,
exceedance probabilities with confidence intervals, and plots.

>>> from flexclear.study import Study, Uniform
>>> study = Study("slider_yoke", vary={"clearance": Uniform(0.0, 1e-3)}, samples=1000, seed=1,
...               t_end=0.5, dt=1e-5)
>>> result = study.run(store="clearance-study")   # resumable; Ctrl-C keeps finished samples
>>> result.summary()
>>> result.exceedance("bearing.max_force", 50.0)    # P(max force > 50 N) with a 95 % interval

The samples run in one process on a thread pool (``threads=``), or on a Dask cluster when a
``dask.distributed.Client`` is passed (``client=``): chunks of samples per task. Every chunk runs
as one Rust batch with the GIL released: samples the constant stepper runs and that share the
contact-free factorization step in lockstep lanes; any other sample (a model in moving frames,
on the Newton stepper) runs as one lane, its outputs those of its own ``Model.simulate``. A
sample's result does not depend on where or with how many threads it ran, so the same study gives
identical results serially, threaded and on Dask.

Needs pandas, pyarrow (for ``store=``) and scipy (for the Latin hypercube and Sobol designs and the
normal-family distributions); ``pip install flexclear[study]``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib
import importlib.util
import inspect
import json
import math
import os
import sys
import threading
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _core, scenes
from . import model as _model
from ._numbers import is_real
from .errors import (
    FlexclearError,
    InvalidParameterError,
    ResourceError,
    SimulationInterrupted,
    StoreError,
    StoreLockedError,
)

# --------------------------------------------------------------------------------------------
# Distributions
# --------------------------------------------------------------------------------------------


def _check_finite(name: str, **values: float) -> None:
    for k, v in values.items():
        if not (isinstance(v, (int, float)) and is_real(v)) or not math.isfinite(v):
            raise InvalidParameterError(f"{name}: {k} = {v!r} is not allowed; allowed: a finite number")


@dataclasses.dataclass(frozen=True)
class Uniform:
    """Uniform on ``[low, high]`` (``low < high``)."""

    low: float
    high: float

    def __post_init__(self) -> None:
        _check_finite("Uniform", low=self.low, high=self.high)
        if not self.low < self.high:
            raise InvalidParameterError(f"Uniform: low = {self.low} must be < high = {self.high}")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return self.low + u * (self.high - self.low)


@dataclasses.dataclass(frozen=True)
class Normal:
    """Normal with ``mean`` and standard deviation ``std`` (> 0)."""

    mean: float
    std: float

    def __post_init__(self) -> None:
        _check_finite("Normal", mean=self.mean, std=self.std)
        if not self.std > 0:
            raise InvalidParameterError(f"Normal: std = {self.std} is not allowed; allowed: std > 0")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats

        return stats.norm.ppf(u, loc=self.mean, scale=self.std)


@dataclasses.dataclass(frozen=True)
class TruncatedNormal:
    """Normal(``mean``, ``std``) truncated to ``[low, high]`` (a tolerance band)."""

    mean: float
    std: float
    low: float
    high: float

    def __post_init__(self) -> None:
        _check_finite("TruncatedNormal", mean=self.mean, std=self.std, low=self.low, high=self.high)
        if not self.std > 0:
            raise InvalidParameterError(f"TruncatedNormal: std = {self.std} is not allowed; allowed: std > 0")
        if not self.low < self.high:
            raise InvalidParameterError(f"TruncatedNormal: low = {self.low} must be < high = {self.high}")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats

        a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
        return stats.truncnorm.ppf(u, a, b, loc=self.mean, scale=self.std)


@dataclasses.dataclass(frozen=True)
class LogNormal:
    """Lognormal: ``log(x)`` is normal with mean ``log(median)`` and std ``sigma`` (> 0).

    Natural for stiffnesses and damping known within a factor (``sigma = log(2)/2`` puts 95 % of
    the draws within a factor 2 of the median).
    """

    median: float
    sigma: float

    def __post_init__(self) -> None:
        _check_finite("LogNormal", median=self.median, sigma=self.sigma)
        if not self.median > 0:
            raise InvalidParameterError(f"LogNormal: median = {self.median} is not allowed; allowed: > 0")
        if not self.sigma > 0:
            raise InvalidParameterError(f"LogNormal: sigma = {self.sigma} is not allowed; allowed: > 0")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats

        with np.errstate(over="ignore"):  # a huge sigma draws inf, refused where it is used
            return self.median * np.exp(self.sigma * stats.norm.ppf(u))


@dataclasses.dataclass(frozen=True)
class Values:
    """A fixed list of values: every value once in a grid; drawn with equal probability otherwise."""

    values: tuple

    def __init__(self, values: Sequence[float]) -> None:
        vals = tuple(values)
        if not vals:
            raise InvalidParameterError("Values: the list is empty; allowed: at least one value")
        for v in vals:
            _check_finite("Values", value=v)
        object.__setattr__(self, "values", vals)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        idx = np.minimum((u * len(self.values)).astype(np.int64), len(self.values) - 1)
        return np.asarray(self.values, dtype=float)[idx]


Distribution = Union[Uniform, Normal, TruncatedNormal, LogNormal, Values]
_DISTRIBUTIONS = {
    "uniform": Uniform,
    "normal": Normal,
    "truncated_normal": TruncatedNormal,
    "lognormal": LogNormal,
    "values": Values,
}


def distribution_from_dict(name: str, spec: Any) -> Distribution:
    """A distribution from its description in a study file.

    ``spec`` is a list of values, or a table ``{distribution = "uniform", low = .., high = ..}``
    (``"normal"``: mean, std; ``"truncated_normal"``: mean, std, low, high; ``"lognormal"``:
    median, sigma; ``"values"``: values).
    """
    if isinstance(spec, (list, tuple)):
        return Values(spec)
    if isinstance(spec, (int, float)):
        return Values([spec])
    if not isinstance(spec, Mapping):
        raise InvalidParameterError(f"vary.{name}: {spec!r} is not allowed; allowed: a list or a table")
    spec = dict(spec)
    kind = spec.pop("distribution", None)
    if kind not in _DISTRIBUTIONS:
        raise InvalidParameterError(
            f"vary.{name}.distribution = {kind!r} is not allowed; allowed: one of {sorted(_DISTRIBUTIONS)}"
        )
    cls = _DISTRIBUTIONS[kind]
    fields = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(spec) - set(fields))
    missing = sorted(set(fields) - set(spec))
    if unknown or missing:
        raise InvalidParameterError(
            f"vary.{name}: a {kind} distribution takes exactly {fields}"
            + (f"; unknown {unknown}" if unknown else "")
            + (f"; missing {missing}" if missing else "")
        )
    try:
        return cls(**spec)
    except InvalidParameterError as e:
        raise InvalidParameterError(f"vary.{name}: {e}") from None


def _as_distribution(name: str, d: Any) -> Distribution:
    if isinstance(d, (Uniform, Normal, TruncatedNormal, LogNormal, Values)):
        return d
    return distribution_from_dict(name, d)


def _dist_to_dict(d: Distribution) -> dict:
    kind = next(k for k, c in _DISTRIBUTIONS.items() if isinstance(d, c))
    out = {"distribution": kind}
    out.update(
        {
            f.name: (list(v) if isinstance(v, tuple) else v)
            for f in dataclasses.fields(d)
            for v in [getattr(d, f.name)]
        }
    )
    return out


# --------------------------------------------------------------------------------------------
# The study
# --------------------------------------------------------------------------------------------

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
    from .model import _default_integrator

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
    from .model import _scheme

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
            from .model import check_window

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
        from .model import Model

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
        from .model import _scheme

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
        from .model import MEMORY_LIMIT_ENV, _fmt_bytes, _memory_limit

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


class _PartWriter:
    """Collects finished rows (into ``frames``, which the caller's result is made of) and writes
    them to the store as one part when asked, or when :data:`FLUSH_SECONDS` have passed since the
    last write. A failed write raises :class:`StoreError`; its rows stay in ``frames``."""

    def __init__(self, store_: Optional[_Store], frames: list) -> None:
        self.store = store_
        self.frames = frames
        self.pending: list = []
        self.last = time.monotonic()

    def add(self, frame) -> None:
        if len(frame):
            self.frames.append(frame)
            if self.store is not None:
                self.pending.append(frame)

    def flush_if_due(self) -> None:
        if time.monotonic() - self.last >= FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        self.last = time.monotonic()
        if not self.pending:
            return
        import pandas as pd

        frame = pd.concat(self.pending) if len(self.pending) > 1 else self.pending[0]
        try:
            self.store.write(frame)  # type: ignore[union-attr]
        except OSError as e:
            path = self.store.path  # type: ignore[union-attr]
            raise _store_error(
                path,
                f"writing {len(frame)} finished samples failed ({type(e).__name__}: {e}); every sample "
                "computed by this run is in exc.partial, and those written before are safe in the store: "
                "fix the cause (space, permissions) and run again to resume",
            ) from e
        self.pending = []


# --------------------------------------------------------------------------------------------
# One chunk: models built, one Rust batch, rows out. Shared by the local and Dask paths.
# --------------------------------------------------------------------------------------------


def _run_rows(study: Study, ids: list, rows: list, pool: tuple, progress=None):
    """Runs the samples ``ids`` with inputs ``rows`` on ``pool = (threads, lanes)``; returns
    (DataFrame, pending exception). Every sample goes to one Rust batch, which runs each on the
    stepper its plan picks: lockstep lanes for samples the constant stepper runs and that share
    a factorization, one lane each for the others (a sample that needs Newton gives the outcome
    of its single ``simulate``)."""
    threads, lanes = pool
    import pandas as pd

    from .model import check_window

    records: list[dict] = []
    batch: list[tuple[int, Any, float, float]] = []
    for i, row in zip(ids, rows):
        rec: dict[str, Any] = {"sample": int(i)}
        rec.update(row)
        try:
            build_kwargs = study._scene_kwargs(row)
            model = study._scene_fn(**build_kwargs)
            if study.sliders:
                model._build_kwargs = build_kwargs  # for the ideal run of the same structure
        except FlexclearError as e:
            rec.update(status="invalid", message=str(e), dt_used=float("nan"), retries=0, wall_time=0.0)
            records.append(rec)
            continue
        job = (len(records), model, float(row.get("t_end", study.t_end)), float(row.get("dt", study.dt)))
        try:  # a varied t_end or dt may leave no step after `start`
            check_window(study.start, job[2], job[3], "start")
        except FlexclearError as e:
            rec.update(status="invalid", message=str(e), dt_used=job[3], retries=0, wall_time=0.0)
            records.append(rec)
            continue
        batch.append(job)
        records.append(rec)
    hist = study.history_every is not None
    outcomes: dict[int, dict] = {}
    pending = None

    simulate_options = {_RUN_OPTION_ALIASES.get(k, k): v for k, v in study.run_options.items()}
    simulate_options.pop("memory_limit", None)  # checked once for the whole study
    batch_options = {k: v for k, v in simulate_options.items() if v is not None}
    if "iter_tol" in batch_options:
        batch_options["tol"] = batch_options.pop("iter_tol")
    if study.tol is not None and batch and all(job[1].engine == "translating" for job in batch):
        # tol= runs of translating models take Model.simulate's default integrator there
        integrator, rho_inf = _tol_integrator(batch_options, True)
        batch_options.update(integrator=integrator, rho_inf=rho_inf)
    scheme = _batch_scheme(batch_options)
    for key in ("integrator", "rho_inf", "hht_alpha"):
        batch_options.pop(key, None)
    batch_options.update(scheme)
    halving = batch_options.pop("step_halving", 0)
    if halving:
        # the constant stepper has no Newton iteration to halve: refused per sample, as
        # Model.simulate refuses it
        from .model import _bad

        message = str(_bad("step_halving", halving, "0 while every link translates (no Newton to halve)"))
        for k, m, *_ in batch:
            if m.engine == "translating":
                records[k].update(status="invalid", message=message, dt_used=float("nan"), retries=0)
                records[k]["wall_time"] = 0.0
        batch = [job for job in batch if job[1].engine != "translating"]
    if batch and study.sliders:
        # slider outputs compare each sample with its ideal-joint mechanism through Result
        # objects: these samples run one per thread through Model.simulate
        done = [0]

        def one_done() -> None:
            done[0] += 1
            if progress is not None:
                progress(done[0])

        outs_by_job, pending = _run_moving(study, batch, threads, one_done, simulate_options)
        outcomes.update(outs_by_job)
        batch = []
    if batch:
        outs, _stats, pending = _core.run_batch(
            [m._core for _, m, _, _ in batch],
            [t for _, _, t, _ in batch],
            [d for _, _, _, d in batch],
            threads=threads,
            lanes=lanes,
            retries=study.retries,
            retry_factor=study.retry_factor,
            method=study.method,
            joints=study._joint_indices,
            every=study.history_every or 1,
            histories=hist,
            joint_position=study.orbit,
            contact_modes=study._modes,
            link_peaks=study.links,
            start=study.start,
            progress=progress,
            step_halving=halving,
            accuracy=study.tol,
            **batch_options,
        )
        for (k, *_), out in zip(batch, outs):
            outcomes[k] = out
    for k, out in outcomes.items():
        rec = records[k]
        status = out["status"]
        rec.update(
            status=status,
            message=out["message"],
            dt_used=out["dt"],
            retries=out["retries"],
            wall_time=out["wall_time"],
        )
        for n, vals in (out.get("sliders") or {}).items():
            for o, v in vals.items():
                rec[f"{n}.{o}"] = v
        peaks = out.get("links") or []
        for n, li in zip(study._link_names, study._link_indices):
            if status == "ok" and li < len(peaks):
                rec[f"{n}.max_midspan"], rec[f"{n}.max_axial_force"] = map(float, peaks[li])
        for j, ji in zip(study.joints, study._joint_indices):
            ext = out["extremes"][ji] if out["extremes"] and status == "ok" else None
            for o in study.outputs:
                rec[f"{j}.{o}"] = float(getattr(ext, o)) if ext is not None else float("nan")
            if hist:
                h = next((h for h in out["joints"] if h["joint"] == ji), None) if status == "ok" else None
                rec[f"{j}.penetration_history"] = h["penetration"] if h is not None else np.empty(0)
                rec[f"{j}.force_history"] = h["force"] if h is not None else np.empty(0)
                if study.orbit:
                    rec[f"{j}.qx_history"] = h["qx"] if h is not None else np.empty(0)
                    rec[f"{j}.qy_history"] = h["qy"] if h is not None else np.empty(0)
    keep = [r for r in records if r.get("status") not in (None, "interrupted", "not_run")]
    for r in keep:
        for c in study.output_columns:
            r.setdefault(c, float("nan"))
        if hist:
            for j in study.joints:
                for ch in _history_channels(study):
                    r.setdefault(f"{j}.{ch}_history", np.empty(0))
    frame = pd.DataFrame.from_records(keep, columns=_columns(study))
    frame = frame.set_index("sample")
    return frame, pending


class _IdealRuns:
    """The ideal-joint runs of one batch of samples of ``Study(sliders=True)``: one per structure
    (the build's parameters other than the clearance joint's, ``t_end`` and ``dt``), made by the
    first sample of its structure that asks for it, outside any lock shared with other
    structures (the other samples of the structure wait for it; other structures' runs go on in
    parallel), and dropped from the cache once the last sample of its structure that the batch
    expects (:meth:`expect`) has taken it (:meth:`release`; that sample keeps it while it runs):
    a batch holds about one ideal run per worker thread, not one per structure (their slider
    histories are O(steps))."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.lock = threading.Lock()
        self.runs: dict = {}
        self.pending: dict = {}

    @staticmethod
    def key(kwargs: dict, t_end: float, dt: float) -> tuple:
        kw = {k: v for k, v in kwargs.items() if k not in _JOINT_PARAMETERS}
        kw["clearance_at"] = None
        return (json.dumps(kw, sort_keys=True, default=repr), float(t_end), float(dt)), kw

    def expect(self, kwargs: Optional[dict], t_end: float, dt: float) -> None:
        """Counts one more sample of ``kwargs``' structure in the batch."""
        if kwargs is not None:
            key = self.key(kwargs, t_end, dt)[0]
            with self.lock:
                self.pending[key] = self.pending.get(key, 0) + 1

    def get(self, kwargs: Optional[dict], t_end: float, dt: float, options: dict):
        """The ideal run of the sample built with ``kwargs`` (a :class:`Result` with its slider
        histories and their shared core reference); None when it failed or without ``kwargs``."""
        if kwargs is None:
            return None
        from concurrent.futures import Future

        from .result import Record

        key, kw = self.key(kwargs, t_end, dt)
        with self.lock:
            fut = self.runs.get(key)
            owner = fut is None
            if owner:
                fut = self.runs[key] = Future()
                self.study._ideal_made += 1
        if owner:
            # the slider histories only: the reference every sample of the structure compares
            # with online (Record.slider_reference)
            record = Record(
                histories=False, displacements=False, sliders=True, every=self.study.history_every or 1
            )
            try:
                run = self.study._scene_fn(**kw).simulate(t_end, dt, record=record, progress=False, **options)
                run._slider_reference()  # the core's shared copy, built once here
            except FlexclearError:
                run = None
            except BaseException as e:  # the waiting samples see it too
                fut.set_exception(e)
                raise
            fut.set_result(run)
        return fut.result()

    def release(self, kwargs: Optional[dict], t_end: float, dt: float) -> None:
        """One sample of ``kwargs``' structure is done with its ideal run: dropped after the last."""
        if kwargs is None:
            return
        key = self.key(kwargs, t_end, dt)[0]
        with self.lock:
            left = self.pending.get(key, 0) - 1
            if left > 0:
                self.pending[key] = left
            else:
                self.pending.pop(key, None)
                self.runs.pop(key, None)


def _run_one_moving(
    study: Study, model, t_end: float, dt: float, options: dict, ideals: Optional[_IdealRuns] = None
) -> dict:
    """One moving-frame sample, with retries at a smaller step after a divergence or a step that
    does not converge; the outcome in the layout of the Rust batch. ``ideals``: the batch's
    ideal-joint runs (``sliders``; a cache of its own when not given)."""
    from .result import Record

    hist = study.history_every is not None
    dt0 = dt
    if study.tol is not None:
        options = {**options, "tol": study.tol}
    ideal = None
    if study.sliders:
        ideals = ideals or _IdealRuns(study)
        build = getattr(model, "_build_kwargs", None)
        try:
            ideal = ideals.get(build, t_end, dt0, options)
        finally:
            ideals.release(build, t_end, dt0)
    retries = 0
    t0 = time.perf_counter()
    while True:
        # the slider deviations: online against the ideal run (O(1) memory per slider) while the
        # grids line up; after a retry at a smaller step they do not, and the sample keeps its
        # slider histories for the history-based comparison (the ideal run interpolated onto
        # its times, _slider_outputs)
        online = ideal is not None and dt == dt0
        record = Record(
            joints=study.joints,
            displacements=False,
            histories=hist,
            every=study.history_every or 1,
            start=study.start,
            position=study.orbit,
            contact_modes=study._modes,
            link_peaks=study.links,
            sliders=study.sliders and ideal is not None and not online,
            slider_reference=ideal if online else None,
        )
        try:
            res = model.simulate(t_end, dt, study.method, record=record, progress=False, **options)
        except FlexclearError as e:
            from .errors import ConvergenceError, SimulationDivergedError, SingularMatrixError

            failed = isinstance(e, (SimulationDivergedError, ConvergenceError))
            above_floor = dt * study.retry_factor >= _core.RETRY_MIN_STEP_RATIO * dt0
            if failed and retries < study.retries and above_floor:
                retries += 1
                dt *= study.retry_factor
                continue
            status = (
                "diverged"
                if isinstance(e, SimulationDivergedError)
                else "unconverged"
                if isinstance(e, ConvergenceError)
                else "singular"
                if isinstance(e, SingularMatrixError)
                else "invalid"
            )
            return _outcome(status, str(e), dt, retries, time.perf_counter() - t0)
        extremes = list(res._raw.extremes)  # the JointExtremes of the batch's rows, joint order
        joints = []
        if hist:
            for ji, name in zip(study._joint_indices, study.joints):
                j = res.joint(name)
                h = {"joint": ji, "penetration": j.penetration, "force": j.force}
                if study.orbit:
                    h["qx"], h["qy"] = j.orbit()
                joints.append(h)
        out = _outcome("ok", "", dt, retries, time.perf_counter() - t0)
        # the links' running peaks in the layout of the Rust batch (NaN where not tracked)
        links = [(h.max_midspan, h.max_axial_force) for h in res._raw.links]
        out.update(extremes=extremes, joints=joints, links=links)
        if study.sliders:
            out["sliders"] = {
                n: _online_slider_outputs(res, n) if online else _slider_outputs(res, ideal, n, study.start)
                for n in study._slider_names
            }
        return out


def _online_slider_outputs(res, name: str) -> dict:
    """:data:`SLIDER_OUTPUTS` of slider ``name`` of run ``res``, which accumulated its deviations
    from the ideal run online (``Record.slider_reference``)."""
    s = res.slider(name)
    return {o: float(getattr(s, o)) for o in SLIDER_OUTPUTS}


_SLIDER_CH = ("position", "velocity", "acceleration")


def _slider_outputs(res, ideal, name: str, start: float) -> dict:
    """:data:`SLIDER_OUTPUTS` of slider ``name`` of run ``res`` against the ideal run ``ideal``
    over the recorded samples from ``start`` (s); the ideal run interpolated onto the run's
    times where the grids differ (after a retry at a smaller step)."""
    s = res.slider(name)
    out = {"max_acceleration": s.max_acceleration}
    i = ideal.slider(name) if ideal is not None else None
    if i is None:  # no ideal run: no deviation (nor slider histories: they were not kept)
        out.update({f"{ch}_deviation_{m}": float("nan") for ch in _SLIDER_CH for m in ("mean", "max")})
        return out
    keep = res.time >= start
    for ch in _SLIDER_CH:
        x = getattr(s, ch)
        if not x.size:
            dev = np.full(1, np.nan)
        elif np.array_equal(ideal.time, res.time):
            dev = np.abs(x - getattr(i, ch))[keep]
        else:
            dev = np.abs(x - np.interp(res.time, ideal.time, getattr(i, ch)))[keep]
        out[f"{ch}_deviation_mean"] = float(np.mean(dev))
        out[f"{ch}_deviation_max"] = float(np.max(dev))
    return out


def _outcome(status: str, message: str, dt: float, retries: int, wall: float) -> dict:
    return {
        "status": status,
        "message": message,
        "dt": dt,
        "retries": retries,
        "wall_time": wall,
        "extremes": [],
        "joints": [],
    }


def _run_moving(study: Study, jobs: list, threads: int, one_done, options: dict):
    """Moving-frame samples on ``threads`` worker threads (0 = one per core); each run releases
    the GIL. Returns ``({record index: outcome}, pending exception)``; on Ctrl-C the samples not
    started are dropped and the finished ones kept."""
    from concurrent.futures import ThreadPoolExecutor, as_completed

    workers = threads if threads > 0 else (os.cpu_count() or 1)
    out: dict[int, dict] = {}
    ideals = _IdealRuns(study)
    for _, m, t, d in jobs:
        ideals.expect(getattr(m, "_build_kwargs", None), t, d)
    with ThreadPoolExecutor(max_workers=min(workers, len(jobs))) as ex:
        futures = {ex.submit(_run_one_moving, study, m, t, d, options, ideals): k for k, m, t, d in jobs}
        try:
            for fut in as_completed(futures):
                out[futures[fut]] = fut.result()
                one_done()
        except KeyboardInterrupt as e:
            for f in futures:
                f.cancel()
            for f, k in futures.items():
                if f.done() and not f.cancelled() and f.exception() is None:
                    out[k] = f.result()
            return out, e
    return out, None


def _run_rows_task(definition: dict, ids: list, rows: list, pool: tuple):
    """A Dask task: one chunk of samples as one Rust batch (the study travels as plain data)."""
    frame, pending = _run_rows(Study.from_dict(definition), ids, rows, pool)
    if pending is not None:
        raise pending
    return frame


def _columns(study: Study) -> list[str]:
    cols = ["sample", *study.vary, "status", "message", "dt_used", "retries", "wall_time"]
    cols += study.output_columns
    if study.history_every is not None:
        for j in study.joints:
            cols += [f"{j}.{ch}_history" for ch in _history_channels(study)]
    return cols


def _history_channels(study: Study) -> tuple[str, ...]:
    """The history columns per joint (``"<joint>.<channel>_history"``)."""
    return ("penetration", "force", "qx", "qy") if study.orbit else ("penetration", "force")


def _concat(frames: list, study: Study):
    import pandas as pd

    if not frames:
        return pd.DataFrame(columns=_columns(study)).set_index("sample")
    return pd.concat(frames).sort_index()


# --------------------------------------------------------------------------------------------
# Store: Parquet parts written atomically, the definition beside them
# --------------------------------------------------------------------------------------------


class _Store:
    """A study's folder: the definition (``study.json``), the inputs, and Parquet parts of results.

    A writer holds ``writer.lock`` (its pid, host and start time) for as long as it runs; a second
    writer is refused with :class:`StoreLockedError`, and a lock whose owner is dead (on this
    host) is taken over. Parts are named by the samples they hold, written to a temporary file
    named after the writer and renamed whole; a reader de-duplicates samples and refuses two
    different results for one sample. ``write=False`` opens a store for reading only (no lock).
    """

    def __init__(self, path: Path, study: Study, *, write: bool = True) -> None:
        self.path = path
        self.study = study
        self._lock: Optional[_Lock] = None
        meta = path / "study.json"
        if not write:
            if not meta.exists():
                raise InvalidParameterError(f"{str(path)!r} is not a study store (no study.json)")
            self._check_definition(meta)
            return
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise _store_error(path, f"the store folder cannot be created: {e}") from None
        self._lock = _Lock(path)
        self._lock.acquire()  # also checks that the folder is writable
        try:
            if meta.exists():
                self._check_definition(meta)
            else:
                _write_parquet(study.inputs(), path / "inputs.parquet")
                _write_text(
                    meta,
                    json.dumps(
                        {
                            "fingerprint": study.fingerprint(),
                            "study": study.to_dict(),
                            "report_thresholds": study.report_thresholds,
                        },
                        indent=2,
                        default=float,
                    ),
                )
            self._remove_dead_temporaries()
            _probe_write(path)
        except OSError as e:
            self.close()
            if isinstance(e, StoreError):
                raise
            raise _store_error(path, f"the store is not writable: {e}") from None
        except BaseException:
            self.close()
            raise

    def read_pilot(self) -> Optional[dict]:
        """The pilot kept in the store (``pilot.json``), or None."""
        f = self.path / "pilot.json"
        return json.loads(f.read_text()) if f.exists() else None

    def write_pilot(self, pilot: dict) -> None:
        """Keeps the pilot of a study with ``tol`` in the store (``pilot.json``)."""
        _write_text(self.path / "pilot.json", json.dumps(pilot, indent=2, default=float))

    def _check_definition(self, meta: Path) -> None:
        study = self.study
        fp = study.fingerprint()
        stored = json.loads(meta.read_text())
        if stored.get("fingerprint") == fp:
            return
        old = json.loads(json.dumps(stored.get("study", {}), sort_keys=True, default=float))
        new = json.loads(json.dumps(study.to_dict(), sort_keys=True, default=float))
        changed = [
            f"{k} (stored {old.get(k, '<absent>')!r}, now {new.get(k, '<absent>')!r})"
            for k in sorted(set(old) | set(new))
            if old.get(k, "<absent>") != new.get(k, "<absent>")
        ]
        raise InvalidParameterError(
            f"store {str(self.path)!r} holds a different study (fingerprint {stored.get('fingerprint')}, "
            f"this one {fp}); changed: {'; '.join(changed) or 'the definition format'}; "
            "use another folder or delete it"
        )

    def _remove_dead_temporaries(self) -> None:
        """Temporary files of writers that died mid-write (never those of a live process)."""
        host = _host()
        for tmp in self.path.glob("*.tmp"):
            owner = _tmp_owner(tmp.name)
            if owner is None:
                # no owner in the name (an older flexclear): only when clearly abandoned
                try:
                    stale = time.time() - tmp.stat().st_mtime > 600.0
                except OSError:
                    continue
            else:
                pid, h = owner
                stale = h == host and (pid == os.getpid() or not _pid_alive(pid))
            if stale:
                tmp.unlink(missing_ok=True)

    def close(self) -> None:
        """Releases the writer's lock (a store opened for reading holds none)."""
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def read(self) -> list:
        """The stored rows as a list of at most one DataFrame, each sample once. Raises
        :class:`StoreError` when two parts hold different results for one sample, or a part
        cannot be read."""
        import pandas as pd

        parts, names = [], []
        for p in sorted(self.path.glob("part-*.parquet")):
            try:
                parts.append(pd.read_parquet(p))
            except FileNotFoundError:
                continue
            except Exception as e:  # a damaged file: say which
                raise _store_error(
                    self.path,
                    f"part {p.name!r} cannot be read ({type(e).__name__}: {e}); move it out of the store "
                    "and run again to recompute its samples",
                ) from None
            names.append(p.name)
        if not parts:
            return []
        source = np.concatenate([np.full(len(f), k) for k, f in enumerate(parts)])
        frame = pd.concat(parts)
        dup = frame.index.duplicated(keep=False)
        if dup.any():
            first = ~frame.index.duplicated(keep="first")
            rows = np.flatnonzero(dup)
            firsts = {}
            for r in rows:
                i = frame.index[r]
                if i not in firsts:
                    firsts[i] = r
                    continue
                column = _first_difference(frame.iloc[firsts[i]], frame.iloc[r])
                if column is not None:
                    a, b = frame.iloc[firsts[i]][column], frame.iloc[r][column]
                    raise _store_error(
                        self.path,
                        f"sample {i} has two different results: {column} = {a!r} in "
                        f"{names[source[firsts[i]]]!r} and {b!r} in {names[source[r]]!r} (the store was "
                        "written by different flexclear versions or corrupted); move one part out of the "
                        "store",
                    )
            frame = frame[first]
        return [frame]

    def write(self, frame) -> None:
        """Writes ``frame`` (rows indexed by sample) as one part named by its samples."""
        if not len(frame):
            return
        _write_parquet(frame, self.path / _part_name([int(i) for i in frame.index]))


#: Name of the writer's lock file in a store.
LOCK_FILE = "writer.lock"
#: Finished samples are written to the store at least this often while a chunk runs, s.
FLUSH_SECONDS = 5.0


def _store_error(path: Path, message: str, cls: Optional[type] = None) -> Any:
    e = (cls or StoreError)(f"store {str(path)!r}: {message}")
    e.path = str(path)
    return e


def _host() -> str:
    import socket

    return socket.gethostname()


def _proc_stat(pid: int) -> Optional[tuple[str, str]]:
    """``(state, start time in clock ticks since boot)`` of process ``pid`` from
    ``/proc/<pid>/stat``; None where there is no such file."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rfind(")") + 2 :].split()
    return (fields[0], fields[19]) if len(fields) > 19 else None


def _pid_alive(pid: int, started: Optional[str] = None) -> bool:
    """Whether process ``pid`` of this host is alive (and, with ``started``, is the same process:
    a reused pid is not). Where that cannot be told (Windows), True."""
    if not isinstance(pid, int) or pid <= 0:
        return False
    if os.name == "nt":  # os.kill would terminate it
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # alive, another user's
    stat = _proc_stat(pid)
    if stat is not None:
        state, start = stat
        if state in ("Z", "X"):  # a zombie: dead, not yet reaped
            return False
        if started is not None and start != str(started):
            return False
    return True


def _me() -> dict:
    stat = _proc_stat(os.getpid())
    return {
        "pid": os.getpid(),
        "host": _host(),
        "started": stat[1] if stat else None,
        "since": time.strftime("%Y-%m-%d %H:%M:%S"),
    }


def _tmp_suffix() -> str:
    return f".{os.getpid()}@{_host()}.tmp"


def _tmp_owner(name: str) -> Optional[tuple[int, str]]:
    """``(pid, host)`` of a temporary file named by :func:`_tmp_suffix`, else None."""
    left, at, host = name[: -len(".tmp")].rpartition("@")
    pid = left.rsplit(".", 1)[-1]
    if not at or not pid.isdigit():
        return None
    return int(pid), host


def _part_name(ids: list[int]) -> str:
    """A part's file name from its samples: first and last, and a digest of all (so that the
    same samples always give the same name, and a rerun overwrites rather than duplicates)."""
    digest = hashlib.sha256(",".join(map(str, sorted(ids))).encode()).hexdigest()[:12]
    return f"part-{min(ids):09d}-{max(ids):09d}-{digest}.parquet"


def _first_difference(a, b) -> Optional[str]:
    """The first column (but the wall-clock time) where two stored rows of one sample differ."""
    for c in a.index:
        if c == "wall_time":
            continue
        x, y = a[c], b[c]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True):
                return c
        elif x != y and not (_isnan(x) and _isnan(y)):
            return c
    return None


def _isnan(x) -> bool:
    return isinstance(x, (float, np.floating)) and math.isnan(x)


class _Guard:
    """An exclusive ``flock`` on ``.writer.lock.guard`` while the lock file is examined, so that two
    processes of one host taking over a stale lock cannot both win (no-op without fcntl)."""

    def __init__(self, path: Path) -> None:
        self.file = path / ".writer.lock.guard"
        self.fd: Optional[int] = None

    def __enter__(self) -> _Guard:
        try:
            import fcntl
        except ImportError:  # Windows
            return self
        try:
            self.fd = os.open(self.file, os.O_CREAT | os.O_RDWR, 0o644)
        except OSError as e:
            raise _store_error(self.file.parent, f"the store is not writable: {e}") from None
        fcntl.flock(self.fd, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)  # releases the flock
            self.fd = None


class _Lock:
    """The writer's lock file: created whole (written to a private file, then hard-linked to its
    name, which fails when it exists), holding the owner's pid, host and start time."""

    def __init__(self, path: Path) -> None:
        self.dir = path
        self.file = path / LOCK_FILE
        self.me = _me()
        self.held = False

    def owner(self) -> Optional[dict]:
        try:
            data = json.loads(self.file.read_text())
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}
        return data if isinstance(data, dict) else {}

    def _stale(self, owner: dict) -> bool:
        if not owner:  # unreadable: a writer killed mid-creation (O_EXCL fallback), if old
            try:
                return time.time() - self.file.stat().st_mtime > 60.0
            except OSError:
                return True
        return owner.get("host") == self.me["host"] and not _pid_alive(owner.get("pid"), owner.get("started"))

    def acquire(self) -> None:
        body = json.dumps(self.me).encode()
        with _Guard(self.dir):
            for _ in range(3):
                tmp = self.dir / (LOCK_FILE + _tmp_suffix())
                try:
                    with open(tmp, "wb") as f:
                        f.write(body)
                        f.flush()
                        os.fsync(f.fileno())
                except OSError as e:
                    tmp.unlink(missing_ok=True)
                    raise _store_error(self.dir, f"the store is not writable: {e}") from None
                try:
                    try:
                        os.link(tmp, self.file)
                    except FileExistsError:
                        raise
                    except OSError:  # no hard links here: exclusive creation instead
                        fd = os.open(self.file, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
                        with os.fdopen(fd, "wb") as f:
                            f.write(body)
                    self.held = True
                    return
                except FileExistsError:
                    owner = self.owner()
                    if owner is None:
                        continue  # released meanwhile
                    if self._stale(owner):
                        self.file.unlink(missing_ok=True)
                        continue
                    raise self._locked(owner) from None
                finally:
                    tmp.unlink(missing_ok=True)
        raise self._locked(self.owner() or {})

    def _locked(self, owner: dict) -> StoreLockedError:
        who = f"process {owner.get('pid', '?')} on host {owner.get('host', '?')!r}"
        since = f" since {owner['since']}" if owner.get("since") else ""
        e = _store_error(
            self.dir,
            f"another writer holds it: {who}{since} (one writer per store; wait for it to finish, "
            f"or read it with flexclear.study.open_store). If that process is gone (on another host, or "
            f"the lock is left over), delete {str(self.file)!r}",
            StoreLockedError,
        )
        e.owner = dict(owner)
        return e

    def release(self) -> None:
        if not self.held:
            return
        self.held = False
        with contextlib.suppress(OSError):
            owner = self.owner()
            if owner and owner.get("pid") == self.me["pid"] and owner.get("started") == self.me["started"]:
                self.file.unlink()


def _fsync(path: Path) -> None:
    """Flushes a file, or a folder's entries, to the disk (where the platform allows: a folder
    cannot be opened on Windows, nor fsynced on some file systems). A file is opened for writing
    (Windows flushes only such handles)."""
    folder = path.is_dir()
    try:
        fd = os.open(path, os.O_RDONLY if folder else os.O_RDWR)
    except OSError:
        if folder:
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not folder:
            raise
    finally:
        os.close(fd)


def _write_whole(path: Path, write: Callable[[Path], None]) -> None:
    """Writes a store file whole: ``write`` fills a temporary file named after this writer,
    which is flushed to the disk and then renamed to ``path`` (and the rename flushed too).
    Readers take no lock: they see the file whole or not at all, while the writer runs (the
    rename is atomic) and after a crash of the machine (the data is on the disk before the name
    points at it; without the flush a crash could leave a named but empty part)."""
    tmp = path.with_name(path.name + _tmp_suffix())
    try:
        write(tmp)
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # e.g. Ctrl-C mid-write: leave no half-written file
        raise
    _fsync(path.parent)


def _write_text(path: Path, text: str) -> None:
    _write_whole(path, lambda tmp: tmp.write_text(text))


def _probe_write(path: Path) -> None:
    """Writes (and removes) a small file: a store on a full disk or a read-only mount fails here,
    before any sample runs."""
    probe = path / (".probe" + _tmp_suffix())
    try:
        with open(probe, "wb") as f:
            f.write(b"\0" * 65536)
            f.flush()
            os.fsync(f.fileno())
    finally:
        probe.unlink(missing_ok=True)


def _write_parquet(frame, path: Path) -> None:
    _write_whole(path, frame.to_parquet)


class _Progress:
    def __init__(self, progress, total: int, initial: int) -> None:
        self.n = initial
        self.total = total
        self._cb = progress if callable(progress) else None
        self._bar = None
        if progress is True:
            from tqdm.auto import tqdm

            self._bar = tqdm(total=total, initial=initial, unit="sample", smoothing=0.1)

    def update_to(self, n: int) -> None:
        if n == self.n:
            return
        if self._bar is not None:
            self._bar.update(n - self.n)
        self.n = n
        if self._cb is not None:
            self._cb(n, self.total)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


class StudyResult:
    """The outcome of a study.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per sample (index ``sample``): the varied inputs, ``status`` ("ok",
        "diverged", "invalid", "singular"), ``message``, ``dt_used`` (s), ``retries``,
        ``wall_time`` (s) and the outputs (NaN for a failed sample).
    wall_time : float
        Wall-clock time of this call, s.
    """

    def __init__(self, study: Study, frame, wall_time: float, accuracy: Optional[dict] = None) -> None:
        self.study = study
        self.frame = frame
        self.wall_time = wall_time
        #: The pilot of a study with ``tol`` (see :meth:`Study.pilot`): the achieved accuracy
        #: per output and the settings that ran; None without ``tol``.
        self.accuracy = accuracy

    @property
    def ok(self):
        """The rows of the samples that completed."""
        return self.frame[self.frame["status"] == "ok"]

    @property
    def failed(self):
        """The rows of the samples that did not complete, with their status and message."""
        return self.frame[self.frame["status"] != "ok"]

    def array(self, column: str) -> np.ndarray:
        """One column as a numpy array (all samples, in sample order); an output may be named
        bare when the study has one joint."""
        if column not in self.frame.columns:
            column = self.study.column(column)
        return self.frame[column].to_numpy()

    def summary(self, quantiles: Sequence[float] = (0.05, 0.5, 0.95)):
        """Mean, std, min, quantiles and max of every output over the completed samples."""
        import pandas as pd

        ok = self.ok
        rows = {}
        for o in self.study.output_columns:
            x = ok[o].to_numpy(dtype=float)
            row = {"count": x.size, "mean": np.mean(x) if x.size else np.nan}
            row["std"] = np.std(x, ddof=1) if x.size > 1 else np.nan
            row["min"] = np.min(x) if x.size else np.nan
            for q in quantiles:
                row[f"q{q:g}"] = np.quantile(x, q) if x.size else np.nan
            row["max"] = np.max(x) if x.size else np.nan
            rows[o] = row
        return pd.DataFrame.from_dict(rows, orient="index")

    def resolution(self):
        """Whether the fixed step of each completed sample resolves its joints' impacts: per
        clearance joint whose ``contact_period`` the study keeps, a row with ``impacted`` (samples
        with an impact), ``median_steps`` (the median over those of ``contact_period /
        dt_used``, the steps per natural contact period) and ``unresolved`` (those with fewer
        than :data:`RESOLVED_STEPS_PER_CONTACT`; their peak force and penetration are lower
        bounds, and their dissipated energy further off). Empty for a study with ``tol``
        (its steps follow the contact; :attr:`accuracy` is its check) or without the output.

        Returns
        -------
        pandas.DataFrame
            Index: joint names; columns ``impacted``, ``median_steps``, ``unresolved``.
        """
        import pandas as pd

        rows = {}
        if self.study.tol is None and "contact_period" in self.study.outputs:
            ok = self.ok
            dt = ok["dt_used"].to_numpy(dtype=float)
            for joint in self.study.joints:
                period = ok[f"{joint}.contact_period"].to_numpy(dtype=float)
                hit = np.isfinite(period)
                steps = period[hit] / dt[hit]
                rows[joint] = {
                    "impacted": int(hit.sum()),
                    "median_steps": float(np.median(steps)) if steps.size else np.nan,
                    "unresolved": int(np.sum(steps < RESOLVED_STEPS_PER_CONTACT)),
                }
        columns = ["impacted", "median_steps", "unresolved"]
        return pd.DataFrame.from_dict(rows, orient="index", columns=columns)

    def unresolved(self) -> list[str]:
        """One sentence per joint whose contacts the fixed step leaves unresolved in some samples
        (:meth:`resolution`): how many, the median steps per contact period, what that means for
        the outputs and what resolves them. Empty when every sample resolves its contacts (and
        for a study with ``tol``). The report's Resolution section and ``flexclear montecarlo``'s
        warnings print these."""
        return [
            f"Unresolved: {int(row['unresolved'])} of {int(row['impacted'])} samples take fewer than "
            f"{RESOLVED_STEPS_PER_CONTACT} steps per natural contact period (pi d / v of the deepest "
            f"impact) at {joint} (median {row['median_steps']:.3g}): their peak forces and "
            "penetrations are lower bounds and their dissipated energies further off; a smaller dt "
            "or a tol resolves them (flexclear converge compares the choices)."
            for joint, row in self.resolution().iterrows()
            if row["unresolved"] > 0
        ]

    def compare(self, reference: StudyResult, **options):
        """Whether this study's output distributions are those of ``reference`` (e.g. the same
        study file at a finer step, or ``tol / 10``): per output, the relative differences of the
        median, the 90 % quantile and the mean with bootstrap intervals (over the pairs when both
        ran the same inputs), the Kolmogorov-Smirnov p-value and a verdict against ``rtol``
        (differs, equivalent or undecided). Single samples of a rattling joint are chaotic;
        their distribution is what a step must resolve. ``options``: ``outputs``,
        ``quantiles``, ``confidence``, ``rtol``, ``resamples``, ``seed``; see
        :func:`flexclear.analysis.distributions.compare`, which returns the table (a pandas
        DataFrame, one row per output)."""
        from .analysis.distributions import compare

        return compare(self, reference, **options)

    def exceedance(self, output: str, threshold: float, confidence: float = 0.95) -> dict:
        """Probability that ``output`` (``"<joint>.<output>"``, or the bare output name when the
        study has one joint) exceeds ``threshold``, with a Clopper-Pearson interval.

        Returns a dict ``{"probability", "low", "high", "exceed", "n"}`` over the completed
        samples (exact binomial interval at ``confidence``, valid for any n and for 0 or n
        exceedances).
        """
        from scipy import stats

        output = self.study.column(output)
        real = is_real(threshold)
        if not (real and not math.isnan(threshold)):
            raise InvalidParameterError(f"threshold = {threshold!r} is not allowed; allowed: a number")
        if not (isinstance(confidence, (int, float)) and 0 < confidence < 1):
            raise InvalidParameterError(f"confidence = {confidence!r} is not allowed; allowed: 0 < c < 1")
        x = self.ok[output].to_numpy(dtype=float)
        if x.size == 0:
            raise InvalidParameterError(
                f"exceedance of {output!r}: no completed sample to estimate it from "
                f"({len(self.frame)} samples, none 'ok'); allowed: a result with a completed sample"
            )
        n, k = x.size, int(np.sum(x > threshold))
        a = 1 - confidence
        low = stats.beta.ppf(a / 2, k, n - k + 1) if k > 0 else 0.0
        high = stats.beta.ppf(1 - a / 2, k + 1, n - k) if k < n else 1.0
        return {
            "probability": k / n if n else float("nan"),
            "low": float(low),
            "high": float(high),
            "exceed": k,
            "n": n,
        }

    def plot(self, folder: Union[str, os.PathLike], exceedance: Optional[Sequence[str]] = None) -> list[Path]:
        """Saves histograms of the outputs, outputs against each varied input, and exceedance
        curves (``1 - ECDF`` with 95 % pointwise intervals) as PNG files; returns their paths."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        ok = self.ok
        outs = self.study.output_columns
        paths = []
        fig, panels, nrow = _panel_grid(len(outs), 3, (4.2, 3.2))
        for ax, o in zip(panels, outs):
            ax.hist(ok[o].to_numpy(dtype=float), bins=40, color="C0")
            ax.set_xlabel(_label(o))
            ax.set_ylabel("samples")
            _sci_ticks(ax, "x")
        fig.suptitle(f"{self.study.build}: {len(ok)} samples ({len(self.failed)} failed)")
        # room above the top row for the title
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / (3.2 * nrow)))
        paths.append(folder / "histograms.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
        for k in self.study.vary:
            fig, panels, _ = _panel_grid(len(outs), 3, (4.2, 3.2))
            for ax, o in zip(panels, outs):
                ax.plot(ok[k], ok[o], ".", ms=2, alpha=0.6)
                bad = self.failed
                if len(bad):
                    ax.plot(bad[k], np.zeros(len(bad)), "x", color="C3", ms=4, label="failed")
                ax.set_xlabel(_label(k))
                ax.set_ylabel(_label(o))
                _sci_ticks(ax, "both")
            fig.tight_layout()
            paths.append(folder / f"outputs_vs_{k}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
        default = [c for c in outs if c.rsplit(".", 1)[-1] in ("max_force", "max_penetration")]
        for o in [self.study.column(e) for e in exceedance] if exceedance else default:
            x = np.sort(ok[o].to_numpy(dtype=float))
            n = x.size
            if n == 0:
                continue
            p = 1.0 - np.arange(1, n + 1) / n
            half = 1.96 * np.sqrt(np.maximum(p * (1 - p), 1.0 / n) / n)
            fig, ax = plt.subplots(figsize=(5.5, 4))
            ax.step(x, p, where="post", label="P(output > x)")
            ax.fill_between(
                x, np.clip(p - half, 0, 1), np.clip(p + half, 0, 1), step="post", alpha=0.25, label="95 %"
            )
            ax.set_yscale("log")
            ax.set_ylim(max(0.5 / n, 1e-6), 1.05)
            ax.set_xlabel(_label(o))
            ax.set_ylabel("exceedance probability")
            ax.legend()
            ax.grid(True, which="both", alpha=0.3)
            fig.tight_layout()
            paths.append(folder / f"exceedance_{o}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
        return paths

    def __repr__(self) -> str:
        counts = self.frame["status"].value_counts().to_dict() if len(self.frame) else {}
        return (
            f"StudyResult({self.study.build!r}, samples={len(self.frame)}, status={counts}, "
            f"wall_time={self.wall_time:.2f} s)"
        )


def _find_builder(build: Any, folder: Path) -> None:
    """Makes a study file's ``"module:function"`` builder importable the way a script's own
    modules are: when ``module`` is not found on ``sys.path``, the study file's folder, then the
    current directory, is put in front of it where the module's file or package is there (the
    ``flexclear`` command, unlike ``python -m``, does not search the current directory). Dask
    workers started from this process inherit the path; remote ones need the module installed."""
    if not isinstance(build, str) or ":" not in build:
        return
    top = build.partition(":")[0].split(".")[0]
    if not top.isidentifier():
        return
    try:
        if importlib.util.find_spec(top) is not None:
            return
    except (ImportError, ValueError):
        return
    for place in (folder.resolve(), Path.cwd()):
        if (place / f"{top}.py").is_file() or (place / top / "__init__.py").is_file():
            if str(place) not in sys.path:
                sys.path.insert(0, str(place))
            importlib.invalidate_caches()
            return


def load(path: Union[str, os.PathLike]) -> Study:
    """A study from a TOML file or a store's ``study.json``.

    A study file holds :class:`Study`'s arguments at top level (``build``: a scene name or
    ``"module:function"``, the module found as installed, else next to the study file or in the
    current directory; ``samples``,
    ``design``, ``seed``, ``outputs``, ...), the run settings in ``[run]`` (``t_end``, ``dt``,
    ``method``, ``start``, ``retries``, ...), fixed scene keywords in ``[fixed]``, one entry per
    varied parameter in ``[vary]`` (a list, or a table with ``distribution`` and its
    parameters), and optionally ``[report] thresholds = {max_force = 40.0}`` for the exceedance
    table of the report (kept in ``study.report_thresholds``). Unknown keys, parameters or
    distributions raise :class:`~flexclear.InvalidParameterError`.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "study.json"
    if not path.exists():
        raise InvalidParameterError(f"study file {str(path)!r} does not exist")
    if path.suffix == ".json":
        stored = json.loads(path.read_text())
        # a store's builder of one's own: beside the store or in the current directory
        _find_builder(stored.get("study", {}).get("build"), path.parent.parent)
        study = Study.from_dict(stored["study"])
        study.report_thresholds = dict(stored.get("report_thresholds", {}))
        return study
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11
        import tomli as tomllib
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise InvalidParameterError(f"{path}: not valid TOML: {e}") from None
    run = data.pop("run", {}) or {}
    report = data.pop("report", {}) or {}
    if not isinstance(run, Mapping) or not isinstance(report, Mapping):
        raise InvalidParameterError(f"{path}: [run] and [report] must be tables")
    unknown = sorted(set(report) - {"thresholds"})
    if unknown:
        raise InvalidParameterError(f"{path}: unknown [report] keys {unknown}; allowed: ['thresholds']")
    both = sorted(set(data) & set(run))
    if both:
        raise InvalidParameterError(f"{path}: {both} given both at top level and in [run]")
    _find_builder(data.get("build"), path.parent)
    study = Study.from_dict({**data, **run})
    thresholds = dict(report.get("thresholds", {}))
    for k, v in thresholds.items():
        try:
            study.column(k)
        except InvalidParameterError:
            raise InvalidParameterError(
                f"{path}: [report.thresholds] {k!r} is not an output of the study; "
                f"allowed: {study.output_columns}"
            ) from None
        _check_finite(f"report.thresholds.{k}", value=v)
    study.report_thresholds = thresholds
    return study


def write_report(
    result: StudyResult, folder: Union[str, os.PathLike], thresholds: Optional[Mapping] = None
) -> Path:
    """Writes ``report.md`` (definition, status counts, throughput, summary, exceedance table,
    failures) and the plots of :meth:`StudyResult.plot` into ``folder``; returns the report path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    study = result.study
    thresholds = dict(thresholds or {})
    pngs = result.plot(folder, exceedance=list(thresholds) or None)
    frame = result.frame
    counts = frame["status"].value_counts().to_dict() if len(frame) else {}
    lines = [f"# Monte Carlo study: {study.build}", ""]
    lines += ["## Definition", "", "```json", json.dumps(study.to_dict(), indent=2, default=float), "```", ""]
    lines += ["## Samples", ""]
    lines += [f"- {len(frame)} samples: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))]
    retried = int((frame["retries"] > 0).sum()) if len(frame) else 0
    lines += [f"- {retried} retried with a smaller step"]
    if len(frame):
        cpu = float(frame["wall_time"].sum())
        lines += [
            f"- CPU time in the runs: {cpu:.2f} s ({len(frame) / max(cpu, 1e-12):.1f} samples/s per thread)"
        ]
    if result.wall_time > 0:
        lines += [f"- wall time of this call: {result.wall_time:.2f} s"]
    lines += _resolution_section(result)
    lines += ["", "## Outputs over the completed samples", ""]
    summ = result.summary()
    cols = list(summ.columns)
    lines += ["| output | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for name, row in summ.iterrows():
        lines += [f"| {name} | " + " | ".join(f"{row[c]:.4g}" for c in cols) + " |"]
    units = [f"{k}: {OUTPUTS[k]}" for k in study.outputs]
    if study._slider_names:
        units += [f"{k}: {v}" for k, v in SLIDER_OUTPUTS.items()]
    if study._link_names:
        units += [f"{k}: {v}" for k, v in LINK_OUTPUTS.items()]
    lines += ["", "Units: " + "; ".join(units), ""]
    if thresholds:
        lines += ["## Exceedance (Clopper-Pearson 95 % interval)", ""]
        lines += ["| output | threshold | P(exceed) | 95 % interval | exceed / n |", "|---|---|---|---|---|"]
        for k, v in thresholds.items():
            e = result.exceedance(k, v)
            interval = f"[{e['low']:.4g}, {e['high']:.4g}]"
            lines += [f"| {k} | {v:g} | {e['probability']:.4g} | {interval} | {e['exceed']} / {e['n']} |"]
        lines += [""]
    bad = result.failed
    if len(bad):
        lines += ["## Failed samples (first 20)", "", "| sample | status | message |", "|---|---|---|"]
        for i, row in bad.head(20).iterrows():
            lines += [f"| {i} | {row['status']} | {str(row['message']).replace('|', '/')} |"]
        lines += [""]
    lines += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in pngs] + [""]
    path = folder / "report.md"
    path.write_text("\n".join(lines))
    return path


def _resolution_section(result: StudyResult) -> list[str]:
    """The report's lines on whether the samples resolve their contacts: the pilot of a study
    with ``tol``, the steps per contact period of a fixed-step one (:meth:`StudyResult.resolution`)."""
    pilot = result.accuracy
    if pilot is not None:
        lines = ["", "## Resolution: the accuracy pilot", ""]
        lines += [
            f"The first {pilot['samples']} samples ran at tol = {pilot['tol']:g} and at tol / 10; the "
            "largest relative difference of each output between the two (relative to its largest magnitude):",
            "",
            "| output | relative difference |",
            "|---|---|",
        ]
        lines += [f"| {k} | {v:.3g} |" for k, v in pilot["accuracy"].items()]
        verdict = "within" if pilot["met"] else "not within"
        lines += [
            "",
            f"Peak forces and penetrations: {verdict} tol. A joint that rattles is chaotic: its single "
            "samples' peaks move with any change of the step sequence while their distribution stays; "
            "where they are not within tol, compare the distributions at tol and tol / 10 over more "
            f"samples (`flexclear converge STUDY.toml --tol {pilot['tol']:g} {pilot['tol'] / 10:g}`, "
            "paired bootstrap intervals).",
        ]
        return lines
    table = result.resolution()
    if table.empty:
        return []
    lines = ["", "## Resolution: steps per contact period", ""]
    lines += ["| joint | samples with an impact | median steps per contact period | unresolved |"]
    lines += ["|---|---|---|---|"]
    for joint, row in table.iterrows():
        impacted, unresolved = int(row["impacted"]), int(row["unresolved"])
        lines += [f"| {joint} | {impacted} | {row['median_steps']:.3g} | {unresolved} |"]
    for sentence in result.unresolved():
        lines += ["", sentence]
    return lines


def open_store(path: Union[str, os.PathLike]) -> StudyResult:
    """The results stored in ``path`` so far (finished or not), without running anything.

    Takes no lock, so it may be called while a writer runs (to watch a long study): every file
    of a store is written to a temporary name, flushed to the disk and renamed whole, so a read
    sees each part whole or not at all, and each sample once (a sample in two parts with
    different results raises :class:`StoreError`)."""
    study = load(path)
    store = _Store(Path(path), study, write=False)
    return StudyResult(study, _concat(store.read(), study), 0.0)


__all__ = [
    "DESIGNS",
    "OUTPUTS",
    "DEFAULT_OUTPUTS",
    "RESOLVED_STEPS_PER_CONTACT",
    "MODE_OUTPUTS",
    "SLIDER_OUTPUTS",
    "LINK_OUTPUTS",
    "LogNormal",
    "Normal",
    "Study",
    "StudyResult",
    "TruncatedNormal",
    "Uniform",
    "Values",
    "distribution_from_dict",
    "load",
    "open_store",
    "write_report",
]
