"""Helpers shared by the design methods: parameter checks and rebuilding a model from its scene."""

from __future__ import annotations

import inspect
import math
from typing import Any, Callable, Optional, Union

from .. import scenes
from .._numbers import is_real
from ..errors import InvalidParameterError, ModelError
from ..model import Model


def bad(parameter: str, value: Any, allowed: str) -> InvalidParameterError:
    """An :class:`InvalidParameterError` naming the parameter, its value and the allowed range."""
    e = InvalidParameterError(f"invalid parameter `{parameter}` = {value!r}: allowed {allowed}")
    e.parameter, e.value, e.allowed = parameter, repr(value), allowed
    return e


def number(parameter: str, value: Any, *, low: float = 0.0, strict: bool = True, unit: str = "") -> float:
    """``value`` as a finite float ``> low`` (``>= low`` when not ``strict``), else raises."""
    ok = is_real(value)
    v = float(value) if ok else float("nan")
    if not (ok and math.isfinite(v) and (v > low if strict else v >= low)):
        rel = ">" if strict else ">="
        raise bad(parameter, value, f"a finite number {rel} {low:g}{' ' + unit if unit else ''}")
    return v


#: Scenes that may hold a clearance joint, tried in this order when a model is rebuilt.
_SCENES = ("slider_yoke", "slider_crank", "four_bar")


def _scene_of(model: Model) -> tuple[str, Callable[..., Model], dict]:
    """The scene that built ``model`` and its keywords, recognised from ``model.parameters``."""
    rebuild = getattr(model, "_rebuild", None)  # set by builders of this package that extend a scene
    if rebuild is not None:
        return rebuild
    params = model.parameters
    for name in _SCENES:
        fn = getattr(scenes, name)
        sig = inspect.signature(fn).parameters
        needed = [k for k, p in sig.items() if p.default is not None]
        if params and all(k in params for k in needed):
            kwargs = {k: params[k] for k in sig if k in params}
            return name, fn, kwargs
    raise ModelError(
        "this model was not built by a scene of flexclear.scenes (its `parameters` do not name one), "
        "so the design methods cannot rebuild it with another bearing: pass a builder instead, a "
        "function (or scene name) whose keywords include `clearance`, `bearing_stiffness` and "
        "`bearing_damping`, with its other keywords in `parameters=`"
    )


def builder(
    model: Union[Model, str, Callable[..., Model]], parameters: Optional[dict] = None
) -> tuple[Callable[..., Model], dict]:
    """``(build, keywords)`` that rebuild ``model``: a scene-built :class:`Model` (recognised
    from its ``parameters``), a scene name, or a function returning a :class:`Model`."""
    if isinstance(model, Model):
        if parameters:
            raise bad("parameters", parameters, "None when `model` is a Model (it holds its own)")
        _, fn, kwargs = _scene_of(model)
        return fn, kwargs
    if isinstance(model, str):
        fn = getattr(scenes, model, None)
        if fn is None or not callable(fn):
            raise bad("model", model, f"a Model, a function returning one, or a scene name {list(_SCENES)}")
        return fn, dict(parameters or {})
    if callable(model):
        return model, dict(parameters or {})
    raise bad("model", model, "a flexclear.Model, a function returning one, or a scene name")
