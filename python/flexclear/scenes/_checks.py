"""Argument checks shared by the scene builders: each raises InvalidParameterError naming the
keyword and its allowed range."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from .._numbers import is_real
from ..errors import InvalidParameterError


def _bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    """An :class:`InvalidParameterError` naming a scene keyword, formatted like the core's."""
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, str(value), allowed
    return e


def _real(v: Any) -> bool:
    return is_real(v)


def _types(
    numbers: Optional[dict] = None,
    optional_numbers: Optional[dict] = None,
    strings: Optional[dict] = None,
    optional_strings: Optional[dict] = None,
    flags: Optional[dict] = None,
    optional_flags: Optional[dict] = None,
) -> None:
    """Refuses a keyword of the wrong type (a string for a number, a number for a switch, ...)
    before it reaches the core, whose own checks give the ranges."""
    for name, v in (numbers or {}).items():
        if not _real(v):
            raise _bad(name, repr(v), "a number")
    for name, v in (optional_numbers or {}).items():
        if v is not None and not _real(v):
            raise _bad(name, repr(v), "None (derived) or a number")
    for name, v in (strings or {}).items():
        if not isinstance(v, str):
            raise _bad(name, repr(v), "a string")
    for name, v in (optional_strings or {}).items():
        if v is not None and not isinstance(v, str):
            raise _bad(name, repr(v), "None or a string")
    for name, v in (flags or {}).items():
        if not isinstance(v, (bool, np.bool_)):
            raise _bad(name, repr(v), "True or False")
    for name, v in (optional_flags or {}).items():
        if v is not None and not isinstance(v, (bool, np.bool_)):
            raise _bad(name, repr(v), "None (automatic), True or False")


def _elements(name: str, n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1_000_000:
        raise _bad(name, n, "an integer in 1 ..= 1000000")
    return n


def _bearing_parameters(bearing: dict, derived: dict) -> dict:
    """The ``parameters`` entries of a scene's clearance joint: the bearing keywords as given
    (``bearing``) with the stiffness, damping and effective mass the Rust scene derived."""
    return dict(
        clearance=bearing["clearance"],
        bearing_stiffness=derived["bearing_stiffness"],
        bearing_damping=derived["bearing_damping"],
        pin_radius=bearing["pin_radius"],
        poisson_ratio=bearing["poisson_ratio"],
        reference_penetration=bearing["reference_penetration"],
        bearing_damping_ratio=bearing["bearing_damping_ratio"],
        effective_mass=derived["effective_mass"],
        damping_law=bearing["damping_law"],
    )
