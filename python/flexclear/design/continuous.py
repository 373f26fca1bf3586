"""The continuous-contact (massless-link) model run on the whole mechanism: the engine's
``method="continuous"`` coupling (Earles & Wu 1977; Haines 1980), packaged as a loss prediction
comparable with :func:`~flexclear.design.contact_loss`. See docs/design.md."""

from __future__ import annotations

from typing import Any, Callable, Optional, Union

import numpy as np

from ..errors import ModelError
from ..model import Model
from ..result import Record
from ._common import bad, builder, number
from .contact_loss import ContactLoss


def loss_intervals(time: np.ndarray, closed: np.ndarray, log) -> list:
    """The intervals ``(loss, re-attachment)`` in s of a continuous-contact run's joint, from its
    impact log (entries = attachments, exits = the interpolated loss instants); a joint that starts
    free gives a first interval from the run's start, one free at the end an interval to its end."""
    t0, t1 = float(time[0]), float(time[-1])
    entries = np.asarray(log.time, dtype=float)
    exits = entries + np.asarray(log.duration, dtype=float)
    out: list = []
    free_from: Optional[float] = None if closed[0] else t0
    for k in range(entries.size):
        if free_from is not None:
            out.append((free_from, float(entries[k])))
            free_from = None
        if np.isfinite(exits[k]):
            free_from = float(exits[k])
    if free_from is not None:
        out.append((free_from, t1))
    return out


def continuous_loss(
    model: Union[Model, str, Callable[..., Model]],
    joint: str,
    t_end: float,
    dt: float,
    *,
    parameters: Optional[dict] = None,
    every: int = 1,
    **simulate_options: Any,
) -> ContactLoss:
    """Runs the mechanism with clearance joint ``joint`` as the continuous-contact model (the
    engine's ``simulate(method="continuous")``: the journal held on the bearing circle while the
    normal force, a Lagrange multiplier, is compressive) and returns where it loses contact, as a
    :class:`ContactLoss` comparable with :func:`contact_loss`'s prediction.

    Unlike :func:`contact_loss` (a zero-clearance run and a one-mass model of the journal), the
    whole flexible mechanism runs with the actual clearance: the journal flies free after a loss
    and re-attaches by a perfectly plastic impact where it reaches the wall. Every clearance joint
    of the model runs as the continuous-contact model.

    Parameters
    ----------
    model : Model, str or callable
        The model (used as is), a scene name, or a function returning a :class:`~flexclear.Model`
        (its keywords in ``parameters``).
    joint : str
        The clearance joint.
    t_end, dt : float
        Run length and step, s.
    every : int
        Record every ``every``-th step.
    **simulate_options
        Passed to :meth:`flexclear.Model.simulate` (``integrator``, ``iter_tol``, ...).

    Returns
    -------
    ContactLoss
        ``time`` the record times (s); ``force`` the normal force on the journal as a vector
        (``-N n``, N; zero in free flight); ``normal_force`` ``N`` (N, NaN in free flight);
        ``margin`` the same ``N`` (the model's criterion: loss where it turns tensile);
        ``in_contact``; ``intervals`` ``(loss, re-attachment)`` from the run's impact log (the
        loss instants interpolated within the step); ``clearance`` the joint's (m);
        ``effective_mass``, ``stiffness``, ``damping`` NaN (the model has none); ``result`` the run.
    """
    if isinstance(model, Model):
        if parameters:
            raise bad("parameters", parameters, "None when `model` is a Model (it holds its own)")
        m = model
    else:
        build, kwargs = builder(model, parameters)
        m = build(**kwargs)
        if not isinstance(m, Model):
            raise bad("model", model, "a builder returning a flexclear.Model")
    if joint not in m.joint_names:
        raise ModelError(f"unknown joint {joint!r}; the model has clearance joints {m.joint_names}")
    number("t_end", t_end, unit="s")
    number("dt", dt, unit="s")
    for key in ("method", "record"):
        if key in simulate_options:
            raise bad(key, simulate_options[key], "not given (continuous_loss sets it)")
    rec = Record(joints=[joint], position=True, impact_log=True, displacements=False, every=every)
    res = m.simulate(t_end, dt, method="continuous", record=rec, **simulate_options)
    j = res.joint(joint)
    closed = j.penetration > 0.0
    q = np.column_stack([j.qx, j.qy])
    r = np.hypot(q[:, 0], q[:, 1])
    n = q / np.where(r > 0, r, 1.0)[:, None]
    normal = np.where(closed, j.force, np.nan)
    force = -np.where(closed, j.force, 0.0)[:, None] * n
    clearance = float(m.parameters.get("clearance", np.nan)) if m.parameters else float("nan")
    return ContactLoss(
        joint=joint,
        time=res.time,
        force=force,
        margin=normal.copy(),
        normal_force=normal,
        in_contact=closed,
        intervals=loss_intervals(res.time, closed, j.impact_log),
        effective_mass=float("nan"),
        clearance=clearance,
        stiffness=float("nan"),
        damping=float("nan"),
        result=res,
    )
