"""Argument checks shared by the scene builders: each raises InvalidParameterError naming the
keyword and its allowed range."""

from __future__ import annotations

import math
from typing import Any

from ..errors import InvalidParameterError


def _bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    """An :class:`InvalidParameterError` naming a scene keyword, formatted like the core's."""
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, str(value), allowed
    return e


def _positive(**kw: Any) -> None:
    for name, v in kw.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise _bad(name, v, "a finite number > 0")


def _finite(**kw: Any) -> None:
    for name, v in kw.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise _bad(name, v, "a finite number")


def _elements(name: str, n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1_000_000:
        raise _bad(name, n, "an integer in 1 ..= 1000000")
    return n


#: Beam data of the two classic spin-up problems, SI: length (m), E (Pa), rho (kg/m^3), A (m^2),
#: I (m^4), final hub rate W (rad/s), ramp time T (s).
