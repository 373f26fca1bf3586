"""The worked example of :func:`flexclear.design.optimize`: the preload of a slider-crank that
minimizes the peak crank-pin contact force at a given clearance."""

from __future__ import annotations

import inspect
from typing import Any

from .. import scenes
from ..model import Model
from ._common import number


def preloaded_slider_crank(preload: float = 0.0, **kwargs: Any) -> Model:
    """Simeon's flexible slider-crank (:func:`flexclear.scenes.slider_crank`, same keywords) with a
    constant compressive preload along the rod at the slider pin, N (>= 0): the force a return
    spring or a gas load on the slider would put through the linkage. It keeps the crank pin
    loaded in one direction, so the journal stays on the bearing wall instead of crossing the
    clearance at every reversal of the inertia force; too much of it is a force of its own.

    A module-level builder, so studies (and Dask workers) can import it:
    ``Study("flexclear.design.preload:preloaded_slider_crank", ...)`` or pass the function.
    """
    p = number("preload", preload, strict=False, unit="N")
    model = scenes.slider_crank(**kwargs)
    if p > 0.0:
        # the rod's frame x axis runs from the crank pin A to the slider pin B: a compressive
        # preload at B points back towards A, i.e. along -x of the rod frame
        model.add_load("rod", model.parameters["elements"], fu=-p)
    model.parameters["preload"] = p
    # the design methods rebuild a model with another bearing: from this builder, not the scene
    model._rebuild = ("preloaded_slider_crank", preloaded_slider_crank, {**kwargs, "preload": p})  # type: ignore[attr-defined]
    return model


# Studies read a builder's keywords from its signature: give it the scene's, after `preload`.
preloaded_slider_crank.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
    [inspect.Parameter("preload", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=0.0)]
    + list(inspect.signature(scenes.slider_crank).parameters.values()),
    return_annotation=Model,
)
