"""Impact-aware optimization: differential evolution whose population runs as one study batch per
generation (lanes and threads of the study runner), with an optional local refinement."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, Callable, Optional, Union

import numpy as np

from ._common import bad, number


@dataclasses.dataclass
class Optimum:
    """The outcome of :func:`optimize`.

    Attributes
    ----------
    x : dict
        Parameter -> best value found (the builder's units).
    fun : float
        Objective there (the output's unit, e.g. N).
    batches : list of int
        Size of every batch evaluated, in order: the initial population, one per generation,
        then the single-sample batches of the local refinement.
    generations : int
        Generations of differential evolution.
    evolution, refinement : scipy.optimize.OptimizeResult or None
        The raw results of the global and local stages.
    """

    x: dict
    fun: float
    batches: list
    generations: int
    evolution: Any
    refinement: Any = None


class _Batch:
    def __init__(self, build, names, objective, evaluate, fixed, options, threads):
        self.build, self.names, self.objective = build, names, objective
        self.evaluate, self.fixed, self.options, self.threads = evaluate, fixed, options, threads
        self.sizes: list[int] = []

    def __call__(self, xs: np.ndarray) -> np.ndarray:
        """Objective of every column of ``xs`` (shape (parameters, S)) as one batch."""
        import pandas as pd

        xs = np.atleast_2d(np.asarray(xs, dtype=float))
        inputs = pd.DataFrame(xs.T, columns=self.names)
        inputs.index.name = "sample"
        self.sizes.append(len(inputs))
        if self.evaluate is not None:
            y = np.asarray(self.evaluate(inputs), dtype=float).reshape(-1)
        else:
            from ..study import Study

            study = Study.from_inputs(self.build, inputs, fixed=self.fixed, **self.options)
            res = study.run(progress=False, threads=self.threads)
            if callable(self.objective):
                y = np.asarray(self.objective(res), dtype=float).reshape(-1)
            else:
                y = res.frame[study.column(self.objective)].to_numpy(dtype=float)
                y = np.where(res.frame["status"].to_numpy() == "ok", y, np.nan)
        if y.size != len(inputs):
            raise bad("objective", self.objective, f"one value per sample ({len(inputs)})")
        return np.where(np.isfinite(y), y, np.inf)  # a failed sample is the worst


def optimize(
    build: Union[str, Callable, None],
    objective: Union[str, Callable, None],
    bounds: Mapping[str, tuple],
    *,
    evaluate: Optional[Callable[[Any], np.ndarray]] = None,
    fixed: Optional[Mapping[str, Any]] = None,
    popsize: int = 8,
    maxiter: int = 30,
    tol: float = 1e-3,
    seed: int = 0,
    local: Optional[str] = "Nelder-Mead",
    local_maxfev: int = 40,
    threads: int = 0,
    **study_options: Any,
) -> Optimum:
    """Minimizes a study output over builder parameters by differential evolution
    (``scipy.optimize.differential_evolution``, ``vectorized=True``, ``updating="deferred"``):
    each generation's whole population is one :class:`flexclear.study.Study` run, so the study
    runner steps the samples in parallel (threads, and lockstep lanes where the models share a
    factorization). Then, optionally, a local method polishes the best point within the bounds
    (one single-sample study per evaluation).

    Parameters
    ----------
    build : str or callable or None
        Study builder (scene name or module-level function); None with ``evaluate``.
    objective : str or callable
        A study output column to minimize, e.g. ``"crank_pin.max_force"`` (N), or
        ``objective(study_result) -> array`` (one value per sample, in sample order) to combine
        outputs (a penalty for a constraint, a contact-loss margin, ...). Failed samples count
        as +inf.
    bounds : mapping
        Parameter -> ``(low, high)`` in the builder's units.
    evaluate : callable, optional
        ``evaluate(inputs) -> array`` instead of a study (a DataFrame with one column per
        parameter, one row per sample): for cheap objectives and tests.
    fixed : mapping, optional
        Fixed builder keywords.
    popsize, maxiter, tol, seed
        Differential evolution's settings (population ``popsize x parameters``).
    local : str or None
        ``scipy.optimize.minimize`` method for the refinement (bounded: "Nelder-Mead", "Powell",
        "L-BFGS-B"); None for none.
    local_maxfev : int
        Largest number of refinement evaluations.
    threads : int
        Study threads (0: one per core).
    **study_options
        Other :class:`~flexclear.study.Study` arguments (``t_end``, ``dt``, ``run_options``,
        ``joints``, ``outputs``, ``start``, ...).

    Returns
    -------
    Optimum
    """
    from scipy.optimize import differential_evolution, minimize

    if not isinstance(bounds, Mapping) or not bounds:
        raise bad("bounds", bounds, "a non-empty mapping name -> (low, high)")
    names = list(bounds)
    box = []
    for k, v in bounds.items():
        if not (isinstance(v, (tuple, list)) and len(v) == 2):
            raise bad(f"bounds[{k!r}]", v, "a (low, high) pair")
        lo = number(f"bounds[{k!r}][0]", v[0], low=-np.inf)
        hi = number(f"bounds[{k!r}][1]", v[1], low=-np.inf)
        if not lo < hi:
            raise bad(f"bounds[{k!r}]", v, "low < high")
        box.append((lo, hi))
    if evaluate is None:
        if build is None:
            raise bad("build", build, "a study builder (or pass `evaluate`)")
        if not (isinstance(objective, str) or callable(objective)):
            raise bad(
                "objective", objective, 'a study output column such as "crank_pin.max_force", or a callable'
            )
    if not (isinstance(popsize, (int, np.integer)) and popsize >= 4):
        raise bad("popsize", popsize, "an integer >= 4")
    if not (isinstance(maxiter, (int, np.integer)) and maxiter >= 1):
        raise bad("maxiter", maxiter, "an integer >= 1")
    batch = _Batch(build, names, objective, evaluate, dict(fixed or {}), study_options, threads)
    evo = differential_evolution(
        batch,
        box,
        popsize=int(popsize),
        maxiter=int(maxiter),
        tol=float(tol),
        seed=int(seed),
        vectorized=True,
        updating="deferred",
        polish=False,
    )
    x, fun = np.asarray(evo.x, dtype=float), float(evo.fun)
    refined = None
    if local is not None:
        refined = minimize(
            lambda v: float(batch(np.asarray(v, dtype=float)[:, None])[0]),
            x,
            method=local,
            bounds=box,
            options={"maxfev": int(local_maxfev)}
            if local in ("Nelder-Mead", "Powell")
            else {"maxfun": int(local_maxfev)},
        )
        if float(refined.fun) < fun:
            x, fun = np.asarray(refined.x, dtype=float), float(refined.fun)
    return Optimum({k: float(v) for k, v in zip(names, x)}, fun, batch.sizes, int(evo.nit), evo, refined)
