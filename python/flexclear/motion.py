"""Prescribed planar translations of rigid bodies and of flexible links' frames (SI units)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import _core

Motion = _core.Motion


def fixed(position: Sequence[float] = (0.0, 0.0)) -> Motion:
    """At rest at ``position`` (m)."""
    return _core.Motion.fixed(tuple(float(x) for x in position))


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
    return _core.Motion.harmonic(
        tuple(float(x) for x in amplitude), float(frequency), tuple(float(x) for x in offset), float(phase)
    )


def tabulated(time, position, velocity=None, acceleration=None) -> Motion:
    """Tabulated motion, linearly interpolated.

    Parameters
    ----------
    time : array_like, shape (n,)
        Strictly increasing times, s; must cover the run ``[0, t_end]``.
    position : array_like, shape (n, 2)
        Positions, m.
    velocity, acceleration : array_like, shape (n, 2), optional
        m/s and m/s^2; derived by central differences when omitted.
    """

    def pairs(a):
        if a is None:
            return None
        a = np.asarray(a, dtype=float)
        if a.ndim != 2 or a.shape[1] != 2:
            from .errors import InvalidParameterError

            raise InvalidParameterError(f"motion arrays must have shape (n, 2), got {a.shape}")
        return [tuple(r) for r in a]

    return _core.Motion.tabulated(
        [float(t) for t in np.asarray(time, dtype=float)],
        pairs(position),
        pairs(velocity),
        pairs(acceleration),
    )


__all__ = ["Motion", "fixed", "harmonic", "tabulated"]
