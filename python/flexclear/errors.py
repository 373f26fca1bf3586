"""The flexclear exception tree. Every error raised by flexclear is a :class:`FlexclearError`.

The Rust core maps its errors to these classes in one place (``rust/python/errors.rs``) and sets
the structured attributes documented on each class.
"""

from __future__ import annotations

from typing import Any


class FlexclearError(Exception):
    """Base class of every flexclear error."""

    partial: Any = None


class InvalidParameterError(FlexclearError, ValueError):
    """A parameter is outside its allowed range.

    Attributes
    ----------
    parameter : str
        The parameter, as the caller spells it (e.g. ``"links[0].length"``, ``"dt"``).
    value : str
        The offending value, formatted.
    allowed : str
        The allowed range, with units.
    """

    parameter: str = ""
    value: str = ""
    allowed: str = ""


class ModelError(FlexclearError, ValueError):
    """The model is inconsistent (a joint on a missing node or link, duplicate names, ...)."""


class SingularMatrixError(FlexclearError, ArithmeticError):
    """A matrix that must be positive definite is not.

    Attributes
    ----------
    matrix : str
        Which matrix.
    pivot : int
        Pivot index where the factorization failed.
    dof : str
        The unknown of that pivot in the model's terms (``'theta of node 5 of link "rod"'``,
        ``'slider "slider"'``), or ``""`` where the matrix is not tied to a model's unknowns.
    """

    matrix: str = ""
    pivot: int = 0
    dof: str = ""


class SimulationDivergedError(FlexclearError, ArithmeticError):
    """The run blew up. What it had recorded until then is in :attr:`result`.

    Attributes
    ----------
    time : float
        Simulated time where divergence was detected, s.
    step : int
        Step count at detection.
    dof : str
        The degree of freedom that went first.
    reason : str
        Why the state was judged divergent.
    result : flexclear.Result
        Everything recorded until the failure (``result.complete`` is False).
    """

    time: float = float("nan")
    step: int = 0
    dof: str = ""
    reason: str = ""
    result: Any = None


class ConvergenceError(FlexclearError, ArithmeticError):
    """The nonlinear iterations of one step (geometric stiffness, iterated contact) did not
    converge within ``max_iter``, and step halving was not asked for (``step_halving=0``) or did
    not help. What was recorded until then is in :attr:`result`.

    Attributes
    ----------
    time : float
        Simulated time at the start of the failing step, s.
    step : int
        Index of that step.
    iterations : int
        Iterations done.
    residual : float
        Infinity norm of the last residual, N.
    correction : float
        Last displacement correction relative to the displacement scale.
    result : Any
        Everything recorded until the failure.
    """

    time: float = float("nan")
    step: int = 0
    iterations: int = 0
    residual: float = float("nan")
    correction: float = float("nan")
    result: Any = None


class SimulationInterrupted(FlexclearError, KeyboardInterrupt):
    """The run was interrupted (Ctrl-C). What it had recorded is in :attr:`result`."""

    time: float = float("nan")
    step: int = 0
    result: Any = None


class StoreError(FlexclearError, OSError):
    """A study store cannot be used: not writable, a failed write (full disk, removed folder),
    or two different results stored for one sample. What the run had computed is in
    :attr:`partial` (a :class:`flexclear.study.StudyResult`), written or not.

    Attributes
    ----------
    path : str
        The store folder.
    partial : StudyResult or None
        Every sample computed so far, including those whose write failed.
    """

    path: str = ""


class StoreLockedError(StoreError):
    """Another live process is writing to the study store (one writer per store).

    Attributes
    ----------
    owner : dict
        The lock's owner as recorded in the lock file: ``pid``, ``host``, ``started``.
    """

    owner: dict = {}


class ResourceError(FlexclearError, MemoryError):
    """A run would need more memory than allowed (checked before anything is reserved).

    Attributes
    ----------
    estimate : int
        Bytes the recorded histories would take.
    limit : int
        The limit, bytes (``memory_limit=`` of :meth:`flexclear.Model.simulate`, the
        ``FLEXCLEAR_MEMORY_LIMIT`` environment variable, or half the available memory).
    """

    estimate: int = 0
    limit: int = 0


class RecordingError(FlexclearError, AttributeError):
    """A channel of a result that the run's :class:`~flexclear.Record` did not keep."""


class NewmarkStabilityWarning(UserWarning):
    """Newmark parameters that are only conditionally stable (``2 beta < gamma``), with the
    step limit stated."""


__all__ = [
    "FlexclearError",
    "InvalidParameterError",
    "ModelError",
    "SingularMatrixError",
    "SimulationDivergedError",
    "ConvergenceError",
    "SimulationInterrupted",
    "StoreError",
    "StoreLockedError",
    "ResourceError",
    "RecordingError",
    "NewmarkStabilityWarning",
]
