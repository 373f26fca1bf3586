"""Prescribed planar translations of rigid bodies and of flexible links' frames (SI units)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from . import _core
from ._numbers import is_real
from .errors import InvalidParameterError

Motion = _core.Motion


def _bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value!r}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, repr(value), allowed
    return e


def _real(x: Any) -> bool:
    return is_real(x)


def _pair(parameter: str, value: Any, unit: str) -> tuple[float, float]:
    ok = isinstance(value, (tuple, list, np.ndarray)) and len(value) == 2 and all(_real(x) for x in value)
    if not ok:
        raise _bad(parameter, value, f"a pair of numbers (x, y), {unit}")
    return float(value[0]), float(value[1])


def _scalar(parameter: str, value: Any, allowed: str) -> float:
    if not _real(value):
        raise _bad(parameter, value, allowed)
    return float(value)


def fixed(position: Sequence[float] = (0.0, 0.0)) -> Motion:
    """At rest at ``position`` (m)."""
    return _core.Motion.fixed(_pair("position", position, "m"))


def harmonic(
    amplitude: Sequence[float],
    frequency: float,
    offset: Sequence[float] = (0.0, 0.0),
    phase: float = 0.0,
) -> Motion:
    """``offset + amplitude * sin(2 pi frequency t + phase)``.

    Parameters
    ----------
    amplitude : (float, float)
        Amplitude along x and y, m.
    frequency : float
        Frequency, Hz (>= 0).
    offset : (float, float)
        Mean position, m.
    phase : float
        Phase, rad.
    """
    amp = _pair("amplitude", amplitude, "m")
    f = _scalar("frequency", frequency, "a finite number >= 0, Hz")
    w = 2.0 * np.pi * f
    if np.isfinite(f) and not all(np.isfinite(a * w * w) for a in amp if np.isfinite(a)):
        # the acceleration amplitude * (2 pi f)^2 overflows: every run would be inf
        raise _bad(
            "frequency", frequency, f"a frequency whose acceleration amplitude (2 pi f)^2 {amp} is finite, Hz"
        )
    return _core.Motion.harmonic(
        amp, f, _pair("offset", offset, "m"), _scalar("phase", phase, "a finite angle, rad")
    )


def tabulated(time, position, velocity=None, acceleration=None) -> Motion:
    """Tabulated motion: between two samples the quintic Hermite polynomial through their
    positions, velocities and accelerations, whose derivatives are the velocity and acceleration
    (consistent with one another, twice continuously differentiable, error O(h^6) in the
    sample spacing h); without ``acceleration``, the cubic Hermite polynomial through positions
    and velocities (velocities by central differences when not given either; it stays near the
    samples on uneven grids). The end samples' values are held outside the table.

    Sampled from a link's exact kinematics every 1e-3 s at 150 rad/s, a mechanism's pins stay
    closed between the samples to about 1e-10 of its length (the closure check of ``simulate``
    asks for 1e-7).

    Parameters
    ----------
    time : array_like, shape (n,)
        Strictly increasing times, s; must cover the run ``[0, t_end]``.
    position : array_like, shape (n, 2)
        Positions, m.
    velocity, acceleration : array_like, shape (n, 2), optional
        m/s and m/s^2; derived by central differences when omitted.
    """

    def floats(name: str, a: Any, shape: str) -> np.ndarray:
        try:
            out = np.asarray(a, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise _bad(name, a, f"an array of numbers of shape {shape}") from None
        return out

    def pairs(name: str, a):
        if a is None:
            return None
        arr = floats(name, a, "(n, 2)")
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise _bad(name, a, f"an array of shape (n, 2), m (here {arr.shape})")
        return list(map(tuple, arr.tolist()))

    t = floats("time", time, "(n,)")
    if t.ndim != 1:
        raise _bad("time", time, f"a 1-D array of times, s (here shape {t.shape})")
    return _core.Motion.tabulated(
        t.tolist(),
        pairs("position", position),
        pairs("velocity", velocity),
        pairs("acceleration", acceleration),
    )


__all__ = ["Motion", "fixed", "harmonic", "tabulated"]
