"""Distributions of a study's varied parameters, and their TOML/JSON form."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any, Union

import numpy as np

from .._numbers import is_real
from ..errors import (
    InvalidParameterError,
)


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
