"""What the Python layer accepts as a number before it reaches the core (every parameter check of
the package goes through :func:`is_real`)."""

from __future__ import annotations

from typing import Any

import numpy as np


def is_real(x: Any) -> bool:
    """Whether ``x`` is a real number the core can take as a float: a Python or numpy integer or
    float, not a bool, and (a Python integer, which has no size limit) within the range of a
    float, so that ``float(x)`` cannot raise ``OverflowError`` (``2**1100`` is refused like a
    string, naming the parameter, where it used to escape as ``OverflowError``)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        return False
    if isinstance(x, int):
        try:
            float(x)
        except OverflowError:
            return False
    return True
