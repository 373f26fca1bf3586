"""Statistical tolerance allocation on top of :class:`flexclear.study.Study` (in the spirit of
Oh 1985: link lengths, pin positions and clearances treated as random variables)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, Callable, Optional, Union

import numpy as np

from ..errors import InvalidParameterError
from ._common import bad, number

BOUNDS = ("estimate", "upper")


@dataclasses.dataclass
class Allocation:
    """The outcome of :func:`allocate_tolerances`.

    Attributes
    ----------
    tolerances : dict
        Parameter -> allocated tolerance half-width (the parameter's unit: m for lengths and
        clearances, Hz for a frequency, ...).
    scale : float
        The allocated tolerances over the given ones (a common factor; for a cost allocation,
        the factor along the cheapest shape found).
    exceedance : dict
        ``P(output > limit)`` at the allocation: ``probability``, its Clopper-Pearson interval
        ``low``, ``high`` at ``confidence``, ``exceed`` and ``n`` (completed samples).
    confidence : float
        Confidence level of the interval.
    cost : float or None
        ``cost(tolerances)`` at the allocation (None without a cost).
    batches : int
        Sample batches evaluated (one study each, or one call of ``evaluate``).
    limited : bool
        True when the search stopped at the top of ``scale_range`` (the limit is never exceeded
        there): the tolerances may be widened further.
    """

    tolerances: dict
    scale: float
    exceedance: dict
    confidence: float
    cost: Optional[float]
    batches: int
    limited: bool = False


def clopper_pearson(k: int, n: int, confidence: float) -> tuple[float, float]:
    """Exact binomial interval of a probability from ``k`` of ``n`` (the study's interval)."""
    from scipy import stats

    a = 1.0 - confidence
    low = float(stats.beta.ppf(a / 2, k, n - k + 1)) if k > 0 else 0.0
    high = float(stats.beta.ppf(1 - a / 2, k + 1, n - k)) if k < n else 1.0
    return low, high


class _Evaluator:
    """P(output > limit) at given tolerances, by a study (same seed: common random numbers, so
    the estimate changes only where a sample crosses the limit) or by a user ``evaluate``."""

    def __init__(
        self,
        build,
        names,
        nominal,
        limit,
        output,
        evaluate,
        samples,
        seed,
        sigmas,
        confidence,
        fixed,
        options,
    ):
        self.build, self.names, self.nominal = build, names, nominal
        self.limit, self.output, self.evaluate = limit, output, evaluate
        self.samples, self.seed, self.sigmas, self.confidence = samples, seed, sigmas, confidence
        self.fixed, self.options = fixed, options
        self.batches = 0
        self._z: Optional[np.ndarray] = None

    def __call__(self, tol: np.ndarray) -> dict:
        self.batches += 1
        if self.evaluate is not None:
            return self._by_function(tol)
        from ..study import Normal, Study

        vary = {k: Normal(float(m), float(t) / self.sigmas) for k, m, t in zip(self.names, self.nominal, tol)}
        study = Study(
            self.build, vary=vary, fixed=self.fixed, samples=self.samples, seed=self.seed, **self.options
        )
        res = study.run(progress=False)
        return res.exceedance(self.output, self.limit, self.confidence)

    def _by_function(self, tol: np.ndarray) -> dict:
        import pandas as pd
        from scipy import stats

        if self._z is None:  # the study's "random" design: the same unit draws for every batch
            u = np.random.default_rng(self.seed).random((self.samples, len(self.names)))
            self._z = stats.norm.ppf(u)
        x = self.nominal[None, :] + self._z * (tol[None, :] / self.sigmas)
        y = np.asarray(self.evaluate(pd.DataFrame(x, columns=self.names)), dtype=float).reshape(-1)
        if y.size != self.samples:
            raise bad("evaluate", self.evaluate, f"a function returning {self.samples} outputs, one per row")
        ok = np.isfinite(y)
        n, k = int(ok.sum()), int(np.sum(y[ok] > self.limit))
        if n == 0:
            raise InvalidParameterError("evaluate returned no finite output; allowed: finite outputs")
        low, high = clopper_pearson(k, n, self.confidence)
        return {"probability": k / n, "low": low, "high": high, "exceed": k, "n": n}


def allocate_tolerances(
    build: Union[str, Callable, None],
    tolerances: Mapping[str, tuple],
    limit: float,
    probability: float,
    *,
    output: Optional[str] = None,
    cost: Optional[Callable[[dict], float]] = None,
    evaluate: Optional[Callable[[Any], np.ndarray]] = None,
    samples: int = 200,
    seed: int = 0,
    sigmas: float = 3.0,
    confidence: float = 0.95,
    bound: str = "estimate",
    fixed: Optional[Mapping[str, Any]] = None,
    scale_range: tuple = (1e-3, 1e3),
    rtol: float = 1e-3,
    max_shapes: int = 200,
    **study_options: Any,
) -> Allocation:
    """The widest (or, with ``cost``, the cheapest) tolerances whose probability of exceeding
    ``limit`` stays below ``probability``.

    Each toleranced parameter is drawn from a normal distribution about its nominal value whose
    tolerance half-width ``t`` is ``sigmas`` standard deviations (``t = 3 sigma`` by default:
    99.73 % of the parts within tolerance). The probability is estimated from ``samples``
    samples by a :class:`flexclear.study.Study` of ``build`` (or by ``evaluate``), always with
    the same seed: the estimates at different tolerances share their random numbers, so the
    search is deterministic.

    * Without ``cost``: every tolerance is scaled by one factor ``s``, found by bisection (in
      log s, to ``rtol``) as the largest ``s`` in ``scale_range`` with ``P <= probability`` (the
      output's exceedance is assumed to grow with ``s``).
    * With ``cost`` (a function of the tolerance dict, e.g. ``sum(w_i / t_i)``): the shape of
      the tolerance vector (the log-ratios) is searched by Nelder-Mead, each shape scaled to the
      limit as above; the cheapest is returned. That is ``max_shapes`` scale searches at most:
      meant for cheap outputs (``evaluate``) or a few parameters.

    Parameters
    ----------
    build : str or callable or None
        The study builder (a scene name or a module-level function, see
        :class:`flexclear.study.Study`); None with ``evaluate``.
    tolerances : mapping
        Parameter -> ``(nominal, tolerance)``, in the parameter's unit (SI), tolerance > 0.
    limit : float
        Threshold of the output (its unit, e.g. N for ``"bearing.max_force"``).
    probability : float
        Largest allowed ``P(output > limit)``, 0 < p < 1.
    output : str
        Study output column (``"<joint>.<output>"``); not with ``evaluate``.
    evaluate : callable, optional
        ``evaluate(inputs) -> outputs``: a DataFrame with one column per parameter (one row per
        sample) to an array of outputs, instead of a study (a closed-form model or a surrogate).
    samples, seed : int
        Samples per batch and the seed of the draws.
    sigmas : float
        Standard deviations per tolerance half-width (> 0).
    confidence : float
        Confidence of the reported Clopper-Pearson interval.
    bound : {"estimate", "upper"}
        Compare the point estimate, or the interval's upper end (a conservative allocation),
        with ``probability``.
    fixed : mapping, optional
        Fixed builder keywords of the study.
    scale_range : (float, float)
        Range of the common factor searched.
    **study_options
        Other :class:`~flexclear.study.Study` arguments (``t_end``, ``dt``, ``run_options``,
        ``joints``, ``outputs``, ...).

    Returns
    -------
    Allocation
    """
    if not isinstance(tolerances, Mapping) or not tolerances:
        raise bad("tolerances", tolerances, "a non-empty mapping name -> (nominal, tolerance)")
    names = list(tolerances)
    nominal, tol0 = [], []
    for k, v in tolerances.items():
        if not (isinstance(v, (tuple, list)) and len(v) == 2):
            raise bad(f"tolerances[{k!r}]", v, "a (nominal, tolerance) pair")
        nominal.append(number(f"tolerances[{k!r}][0]", v[0], low=-math.inf))
        tol0.append(number(f"tolerances[{k!r}][1]", v[1]))
    limit = number("limit", limit, low=-math.inf)
    probability = number("probability", probability)
    if probability >= 1:
        raise bad("probability", probability, "0 < p < 1")
    confidence = number("confidence", confidence)
    if confidence >= 1:
        raise bad("confidence", confidence, "0 < c < 1")
    sigmas = number("sigmas", sigmas)
    if bound not in BOUNDS:
        raise bad("bound", bound, f"one of {BOUNDS}")
    if not (isinstance(samples, (int, np.integer)) and samples >= 1):
        raise bad("samples", samples, "an integer >= 1")
    lo_s, hi_s = (number("scale_range[0]", scale_range[0]), number("scale_range[1]", scale_range[1]))
    if not lo_s < hi_s:
        raise bad("scale_range", scale_range, "(low, high) with 0 < low < high")
    if evaluate is None:
        if build is None:
            raise bad("build", build, "a study builder (or pass `evaluate`)")
        if output is None:
            raise bad("output", output, 'a study output column such as "bearing.max_force"')
    elif output is not None or study_options:
        raise bad("evaluate", evaluate, "no `output` or study options with `evaluate`")
    ev = _Evaluator(
        build,
        names,
        np.asarray(nominal),
        limit,
        output,
        evaluate,
        int(samples),
        int(seed),
        sigmas,
        confidence,
        dict(fixed or {}),
        study_options,
    )
    key = "probability" if bound == "estimate" else "high"
    base = np.asarray(tol0)

    def boundary(shape: np.ndarray) -> tuple[float, dict, bool]:
        """Largest feasible scale along ``base * shape``, its exceedance, and whether it hit the top."""
        lo, hi = math.log(lo_s), math.log(hi_s)
        e_lo = ev(base * shape * math.exp(lo))
        if e_lo[key] > probability:
            raise InvalidParameterError(
                f"even the tolerances times scale_range[0] = {lo_s:g} give P(output > {limit:g}) = "
                f"{e_lo[key]:.3g} > probability = {probability:g}; allowed: a smaller scale_range[0], "
                "a higher limit or a larger probability"
            )
        e_hi = ev(base * shape * math.exp(hi))
        if e_hi[key] <= probability:
            return math.exp(hi), e_hi, True
        best = e_lo
        while hi - lo > math.log1p(rtol):
            mid = 0.5 * (lo + hi)
            e = ev(base * shape * math.exp(mid))
            if e[key] <= probability:
                lo, best = mid, e
            else:
                hi = mid
        return math.exp(lo), best, False

    def as_dict(t: np.ndarray) -> dict:
        return {k: float(x) for k, x in zip(names, t)}

    if cost is None:
        s, e, limited = boundary(np.ones(len(names)))
        tol = base * s
        return Allocation(as_dict(tol), s, e, confidence, None, ev.batches, limited)

    from scipy.optimize import minimize

    cache: dict = {}

    def shape_of(v: np.ndarray) -> np.ndarray:
        full = np.concatenate([v, [-np.sum(v)]])  # log-ratios summing to zero
        return np.exp(full)

    def objective(v: np.ndarray) -> float:
        shape = shape_of(v)
        s, e, limited = boundary(shape)
        t = base * shape * s
        c = float(cost(as_dict(t)))
        cache[tuple(np.round(v, 12))] = (c, t, s, e, limited)
        return c

    d = len(names)
    if d == 1:
        objective(np.zeros(0))
    else:
        minimize(
            objective,
            np.zeros(d - 1),
            method="Nelder-Mead",
            options={
                "maxfev": int(max_shapes),
                "xatol": 1e-3,
                "fatol": 1e-9,
                # log-ratio steps of 0.5 (a factor 1.6): the estimate is piecewise constant in the
                # shape, so the default tiny first steps would see no change
                "initial_simplex": np.vstack([np.zeros(d - 1), 0.5 * np.eye(d - 1)]),
            },
        )
    c, t, s, e, limited = min(cache.values(), key=lambda r: r[0])
    return Allocation(as_dict(t), s, e, confidence, c, ev.batches, limited)
