"""Contact-loss prediction from a zero-clearance run (after Earles & Wu 1975 and Earles &
Seneviratne 1990; the criterion used here is derived, see :func:`contact_loss` and docs/design.md).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Optional, Union

import numpy as np

from ..errors import InvalidParameterError, ModelError
from ..model import Model
from ..result import Record, Result
from ._common import bad, builder, number

#: Default stiffness of the zero-clearance bearing, as a multiple of the joint's own K_B.
STIFFNESS_FACTOR = 100.0


@dataclasses.dataclass(repr=False)
class ContactLoss:
    """What :func:`contact_loss` found. SI units.

    Attributes
    ----------
    joint : str
        The joint.
    time : ndarray, shape (n,)
        Record times of the zero-clearance run, s.
    force : ndarray, shape (n, 2)
        Reaction force of the zero-clearance bearing on the journal, global axes, N
        (``-K q - C qdot`` of the stiff bearing, ``q`` the journal position relative to the bearing).
    margin : ndarray, shape (n,)
        The loss criterion's margin, N: ``|F| - m c |psi''|`` (``psi`` the direction of ``-F``,
        ``m`` the effective mass, ``c`` the clearance). Negative where the journal cannot follow
        the load around the bearing wall (contact loss predicted); ``-inf`` at a reversal of the
        force through zero.
    normal_force : ndarray, shape (n,)
        Normal force of the continuous-contact model (small-clearance limit), N, compressive
        positive; NaN while the journal is predicted off the wall.
    in_contact : ndarray of bool, shape (n,)
        Whether the continuous-contact model holds the journal on the wall.
    intervals : list of (float, float)
        Predicted loss intervals ``(start, end)``, s: from where the continuous-contact normal force
        turns tensile to where the free-flying journal reaches the wall again (``end`` = the end of
        the run when it has not). A journal starting at the bearing centre gives a first interval
        from 0.
    effective_mass, clearance, stiffness, damping : float
        The journal's effective mass (kg), the clearance used by the criterion (m), and the
        stiffness (N/m) and damping (N s/m) of the zero-clearance bearing.
    result : flexclear.Result
        The zero-clearance run.
    """

    joint: str
    time: np.ndarray
    force: np.ndarray
    margin: np.ndarray
    normal_force: np.ndarray
    in_contact: np.ndarray
    intervals: list
    effective_mass: float
    clearance: float
    stiffness: float
    damping: float
    result: Result

    @property
    def magnitude(self) -> np.ndarray:
        """``|F|``, N."""
        return np.hypot(self.force[:, 0], self.force[:, 1])

    @property
    def loss_fraction(self) -> float:
        """Fraction of the run covered by the predicted loss intervals."""
        span = float(self.time[-1] - self.time[0]) if self.time.size > 1 else 0.0
        return sum(b - a for a, b in self.intervals) / span if span > 0 else 0.0

    def starts(self) -> np.ndarray:
        """Start times of the predicted loss intervals, s."""
        return np.array([a for a, _ in self.intervals], dtype=float)

    def plot(self, ax=None):
        """Polar plot of the zero-clearance force (loss intervals in red) beside the force
        magnitude, the margin and the continuous-contact normal force over time. Returns the
        matplotlib figure."""
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(11, 4.5))
        axp = fig.add_subplot(1, 2, 1)
        axt = fig.add_subplot(1, 2, 2)
        fx, fy = self.force[:, 0], self.force[:, 1]
        axp.plot(fx, fy, color="0.6", lw=0.8, label="zero-clearance force")
        lost = self._mask()
        axp.plot(np.where(lost, fx, np.nan), np.where(lost, fy, np.nan), "r", lw=1.6, label="loss predicted")
        axp.plot([0], [0], "k+")
        axp.set_xlabel("F_x [N]")
        axp.set_ylabel("F_y [N]")
        axp.set_title(f"joint {self.joint!r}: force polar")
        axp.axis("equal")
        axp.legend(loc="best", fontsize=8)
        axt.plot(self.time, self.magnitude, color="0.4", lw=0.8, label="|F| [N]")
        axt.plot(self.time, self.normal_force, "b", lw=0.8, label="continuous-contact N [N]")
        axt.plot(
            self.time, np.clip(self.margin, -self.magnitude.max(), None), "g", lw=0.6, label="margin [N]"
        )
        for a, b in self.intervals:
            axt.axvspan(a, b, color="r", alpha=0.2, lw=0)
        axt.axhline(0.0, color="k", lw=0.5)
        axt.set_xlabel("t [s]")
        axt.set_title("predicted loss (shaded)")
        axt.legend(loc="best", fontsize=8)
        fig.tight_layout()
        return fig

    def _mask(self) -> np.ndarray:
        m = np.zeros(self.time.size, dtype=bool)
        for a, b in self.intervals:
            m |= (self.time >= a) & (self.time <= b)
        return m

    def __repr__(self) -> str:
        return (
            f"ContactLoss(joint={self.joint!r}, intervals={len(self.intervals)}, "
            f"loss_fraction={self.loss_fraction:.3f}, m_eff={self.effective_mass:.4g} kg, "
            f"c={self.clearance:.3g} m)"
        )


def _effective_mass(params: dict) -> Optional[float]:
    if "effective_mass" in params:
        return float(params["effective_mass"])
    if "mass" in params and params.get("geometry", "end") == "end" and "amplitude" in params:
        # slider-yoke: a free-free bar pinned at its end; a force F at the end accelerates the end
        # by F/m + F (L/2)^2 / (m L^2/12) = 4 F/m.
        return 0.25 * float(params["mass"])
    return None


def zero_clearance_force(
    model: Union[Model, str, Callable[..., Model]],
    joint: str,
    t_end: float,
    dt: float,
    *,
    stiffness: Optional[float] = None,
    damping: Optional[float] = None,
    effective_mass: Optional[float] = None,
    parameters: Optional[dict] = None,
    **simulate_options: Any,
) -> tuple[np.ndarray, np.ndarray, Result, dict]:
    """The reaction force of ``joint`` made an ideal pin, by a zero-clearance, stiff, critically
    damped bearing. Returns ``(time [s], force [N, shape (n, 2)], result, info)`` with ``info``
    holding ``stiffness``, ``damping``, ``effective_mass``, ``clearance`` (the model's own) and
    the model's parameters. See :func:`contact_loss`."""
    build, kwargs = builder(model, parameters)
    original = build(**kwargs)
    if not isinstance(original, Model):
        raise bad("model", model, "a builder returning a flexclear.Model")
    if joint not in original.joint_names:
        raise ModelError(f"unknown joint {joint!r}; the model has clearance joints {original.joint_names}")
    params = dict(original.parameters)
    k0 = params.get("bearing_stiffness")
    if stiffness is None:
        if k0 is None:
            raise bad("stiffness", None, "a stiffness, N/m (the model does not say its bearing stiffness)")
        stiffness = STIFFNESS_FACTOR * float(k0)
    stiffness = number("stiffness", stiffness, unit="N/m")
    if effective_mass is None:
        effective_mass = _effective_mass(params)
        if effective_mass is None:
            raise bad(
                "effective_mass", None, "the journal's effective mass, kg > 0 (the model does not say it)"
            )
    effective_mass = number("effective_mass", effective_mass, unit="kg")
    if damping is None:
        damping = 2.0 * math.sqrt(stiffness * effective_mass)  # critical for the journal's mass
    damping = number("damping", damping, strict=False, unit="N s/m")
    stiff = build(**{**kwargs, "clearance": 0.0, "bearing_stiffness": stiffness, "bearing_damping": damping})
    record = Record(joints=[joint], position=True, displacements=False)
    res = stiff.simulate(t_end, dt, record=record, **simulate_options)
    j = res.joint(joint)
    q = np.column_stack([j.qx, j.qy])
    qd = np.gradient(q, res.time, axis=0) if res.time.size > 1 else np.zeros_like(q)
    force = -(stiffness * q + damping * qd)
    info = dict(
        stiffness=stiffness,
        damping=damping,
        effective_mass=effective_mass,
        clearance=float(params.get("clearance", 0.0)),
        parameters=params,
    )
    return res.time, force, res, info


def direction_margin(time: np.ndarray, force: np.ndarray, mass: float, clearance: float) -> np.ndarray:
    """The quasi-static margin ``|F| - m c |psi''|``, N, of a journal of mass ``m`` (kg) on a
    wall of radius ``c`` (m) under the load ``-F`` (N), ``psi`` its direction (rad, unwrapped;
    second differences on the record grid). A reversal of ``F`` through zero (a turn of about pi
    within one record step) gives ``-inf`` when ``c > 0``."""
    mag = np.hypot(force[:, 0], force[:, 1])
    psi = np.unwrap(np.arctan2(-force[:, 1], -force[:, 0]))
    acc = np.zeros_like(mag)
    if time.size > 2:
        acc = np.gradient(np.gradient(psi, time), time)
    margin = mag - mass * clearance * np.abs(acc)
    if clearance > 0 and time.size > 1:
        flips = np.nonzero(np.abs(np.diff(psi)) > 0.5 * math.pi)[0]
        margin[flips] = -np.inf
        margin[flips + 1] = -np.inf
    return margin


def continuous_contact(
    time: np.ndarray,
    force: np.ndarray,
    mass: float,
    clearance: float,
    *,
    restitution: float = 0.0,
    start: str = "centre",
) -> tuple[np.ndarray, np.ndarray, list]:
    """The continuous-contact model of a clearance joint in the small-clearance limit, with free
    flight after a loss: a journal of mass ``m`` (kg) in a bearing of radial clearance ``c`` (m),
    driven by the load ``-F(t)`` of the zero-clearance run (the rest of the mechanism keeps its
    zero-clearance motion). On the wall (``q = c n(theta)``)::

        m c theta'' = -F . t,     N = m c theta'^2 - F . n     (compressive positive)

    until ``N < 0``; then free flight ``m q'' = -F`` until ``|q| = c``, where the normal velocity
    is reversed times ``restitution`` (the journal stays on the wall when that leaves it less
    than 1e-3 c of further flight). ``F`` is interpolated linearly between records; substeps
    resolve the journal's pendulum frequency ``sqrt(|F|/(m c))``.

    Returns ``(normal force [N, NaN in flight], in contact [bool], intervals [(start, end) s])``.
    """
    n = time.size
    normal = np.full(n, np.nan)
    contact = np.zeros(n, dtype=bool)
    intervals: list = []
    if n == 0:
        return normal, contact, intervals
    fmax = float(np.max(np.hypot(force[:, 0], force[:, 1]))) if n else 0.0
    if clearance <= 0.0 or fmax == 0.0:
        # zero clearance: the journal is always on the wall; loss only where F reverses through 0
        mag = np.hypot(force[:, 0], force[:, 1])
        contact[:] = True
        normal[:] = mag
        psi = np.unwrap(np.arctan2(-force[:, 1], -force[:, 0]))
        for k in np.nonzero(np.abs(np.diff(psi)) > 0.5 * math.pi)[0]:
            intervals.append((float(time[k]), float(time[k + 1])))
        return normal, contact, intervals
    m, c = mass, clearance
    omega = math.sqrt(fmax / (m * c))
    # state
    if start == "wall":
        f0 = force[0]
        theta = math.atan2(-f0[1], -f0[0]) if np.any(f0) else 0.0
        on_wall, thd = True, 0.0
        q = np.array([c * math.cos(theta), c * math.sin(theta)])
        v = np.zeros(2)
    else:
        on_wall, theta, thd = False, 0.0, 0.0
        q, v = np.zeros(2), np.zeros(2)
        loss_start: Optional[float] = float(time[0])
    if on_wall:
        loss_start = None

    def n_force(th: float, w: float, f: np.ndarray) -> float:
        return m * c * w * w - (f[0] * math.cos(th) + f[1] * math.sin(th))

    if on_wall:
        normal[0] = n_force(theta, thd, force[0])
        contact[0] = True
    for k in range(n - 1):
        t0, t1 = float(time[k]), float(time[k + 1])
        span = t1 - t0
        sub = max(1, math.ceil(span * omega / 0.05))
        h = span / sub
        f_a, f_b = force[k], force[k + 1]
        for s in range(sub):
            tau = (s + 1) / sub
            f = f_a + (f_b - f_a) * tau
            ts = t0 + (s + 1) * h
            if on_wall:
                tang = -(-f[0] * math.sin(theta) + f[1] * math.cos(theta))  # -F . t
                thd += h * tang / (m * c)
                theta += h * thd
                if n_force(theta, thd, f) < 0.0:
                    on_wall = False
                    loss_start = ts
                    q = np.array([c * math.cos(theta), c * math.sin(theta)])
                    v = c * thd * np.array([-math.sin(theta), math.cos(theta)])
            else:
                v = v - h * f / m
                q = q + h * v
                r = math.hypot(q[0], q[1])
                if r >= c:
                    nv = q / r
                    vn = float(v @ nv)
                    if vn > 0:
                        q = c * nv
                        v = v - (1.0 + restitution) * vn * nv
                        load_n = float(-(f @ nv))  # outward load keeps it on the wall if > 0
                        rebound = restitution * vn
                        height = rebound**2 * m / (2 * abs(load_n)) if load_n > 0 else math.inf
                        if restitution == 0.0 or height < 1e-3 * c:
                            on_wall = True
                            theta = math.atan2(nv[1], nv[0])
                            thd = float(nv[0] * v[1] - nv[1] * v[0]) / c
                            intervals.append((loss_start, ts))
                            loss_start = None
        contact[k + 1] = on_wall
        if on_wall:
            normal[k + 1] = n_force(theta, thd, f_b)
    if loss_start is not None:
        intervals.append((loss_start, float(time[-1])))
    return normal, contact, intervals


def contact_loss(
    model: Union[Model, str, Callable[..., Model]],
    joint: str,
    t_end: float,
    dt: float,
    *,
    clearance: Optional[float] = None,
    effective_mass: Optional[float] = None,
    stiffness: Optional[float] = None,
    damping: Optional[float] = None,
    restitution: float = 0.0,
    start: str = "centre",
    parameters: Optional[dict] = None,
    **simulate_options: Any,
) -> ContactLoss:
    """Predicts where the journal of clearance joint ``joint`` leaves the bearing wall, from one run
    of the mechanism with that joint made an ideal pin.

    The ideal pin is a zero-clearance bearing, stiff (default ``100 x`` the joint's own K_B) and
    critically damped for the journal's effective mass (``2 sqrt(K m)``): its reaction force
    ``F = -K q - C q'`` converges to the ideal pin's as K grows (checked in the tests:
    1e-3 relative between 100 and 1000 x on the slider-yoke). The engine does not expose ideal-pin
    reactions, hence the stiff bearing; the model is rebuilt with ``clearance=0`` and that bearing.

    **Criterion** (derived here: the exact published forms of Earles & Wu 1975 and Earles &
    Seneviratne 1990 could not be read, so this is the continuous-contact dynamics of Earles &
    Wu 1977 / Haines 1980 in the small-clearance limit, in the spirit of both). Relative to the
    bearing, a journal of effective mass ``m`` obeys ``m q'' = F_c - F`` (``F_c`` the actual
    contact force, ``F`` the zero-clearance one, the rest of the mechanism keeping its
    zero-clearance motion). On the wall ``q = c n(theta)``, ``F_c = -N n``::

        m c theta'' = |F| sin(psi - theta),   N = m c theta'^2 + |F| cos(psi - theta)

    with ``psi`` the direction of ``-F``: the journal is a pendulum of frequency
    ``sqrt(|F|/(m c))`` pulled towards ``psi``. It can follow the load (a lag below 90 degrees)
    while ``|F| >= m c |psi''|``: contact is lost where the force falls through zero and reverses,
    or where its direction accelerates faster than ``|F| / (m c)``. A steady turning rate alone
    presses the journal harder on the wall (``m c theta'^2``), it does not lift it.

    ``margin`` is that quasi-static condition, ``|F| - m c |psi''|`` in N; ``intervals`` come from
    integrating the continuous-contact model itself (loss where ``N`` turns tensile) with free
    flight afterwards (see :func:`continuous_contact`), which also gives each interval a length.

    Parameters
    ----------
    model : Model, str or callable
        A model built by a scene (rebuilt from its ``parameters``; changes made to it afterwards
        are not seen), a scene name, or a function returning a :class:`~flexclear.Model` whose
        keywords include ``clearance`` (m), ``bearing_stiffness`` (N/m) and ``bearing_damping``
        (N s/m); its other keywords in ``parameters``.
    joint : str
        The clearance joint (e.g. ``"bearing"``, ``"crank_pin"``).
    t_end, dt : float
        Run length and step of the zero-clearance run, s.
    clearance : float, optional
        Radial clearance of the criterion, m (default: the model's own).
    effective_mass : float, optional
        The journal's effective mass, kg: the mass that a force at the joint accelerates
        (default: the scene's ``effective_mass``, or a quarter of the slider mass for the
        slider-yoke's end bearing).
    stiffness, damping : float, optional
        The zero-clearance bearing, N/m and N s/m (defaults above).
    restitution : float
        Coefficient of restitution of the predicted re-contacts, 0 <= e < 1 (0: the first
        re-contact ends the interval).
    start : {"centre", "wall"}
        The journal's initial place in the continuous-contact model: at the bearing centre (as
        the simulator starts a clearance joint), or on the wall under the initial load.
    **simulate_options
        Passed to :meth:`flexclear.Model.simulate` for the zero-clearance run (``method``,
        ``iterate``, ...).

    Returns
    -------
    ContactLoss
    """
    restitution = number("restitution", restitution, strict=False)
    if restitution >= 1.0:
        raise bad("restitution", restitution, "0 <= e < 1")
    if start not in ("centre", "wall"):
        raise bad("start", start, 'one of "centre", "wall"')
    time, force, res, info = zero_clearance_force(
        model,
        joint,
        t_end,
        dt,
        stiffness=stiffness,
        damping=damping,
        effective_mass=effective_mass,
        parameters=parameters,
        **simulate_options,
    )
    c = info["clearance"] if clearance is None else number("clearance", clearance, strict=False, unit="m")
    m = info["effective_mass"]
    margin = direction_margin(time, force, m, c)
    normal, contact, intervals = continuous_contact(time, force, m, c, restitution=restitution, start=start)
    return ContactLoss(
        joint=joint,
        time=time,
        force=force,
        margin=margin,
        normal_force=normal,
        in_contact=contact,
        intervals=intervals,
        effective_mass=m,
        clearance=c,
        stiffness=info["stiffness"],
        damping=info["damping"],
        result=res,
    )


def wall_departures(result: Result, joint: str, *, min_contact: float = 0.0) -> np.ndarray:
    """Times (s) where the journal of ``joint`` leaves the bearing wall in a clearance run, after
    a contact that lasted at least ``min_contact`` (s): from the run's impact log
    (``Record(impact_log=True)``) or, without one, from the penetration history."""
    j = result.joint(joint)
    log = j.impact_log
    if log is not None:
        ends = log.time + log.duration
        keep = np.isfinite(ends) & (log.duration >= min_contact)
        return np.asarray(ends[keep], dtype=float)
    pen = j.penetration
    t = result.time
    closed = pen > 0
    out = []
    entered: Optional[float] = float(t[0]) if closed[0] else None
    for k in range(1, t.size):
        if closed[k] and not closed[k - 1]:
            entered = float(t[k])
        elif closed[k - 1] and not closed[k] and entered is not None:
            if t[k] - entered >= min_contact:
                out.append(float(t[k]))
            entered = None
    return np.array(out, dtype=float)


def agreement(predicted: ContactLoss, departures: np.ndarray, window: float) -> dict:
    """How the predicted loss intervals meet the departures of a clearance run: ``matched`` (the
    departures with a predicted interval starting within ``window`` s), ``missed``, ``false``
    (predicted intervals, other than one from t = 0, with no departure within ``window``) and the
    largest start offset of a matched departure, s."""
    if not (window > 0):
        raise InvalidParameterError(f"invalid parameter `window` = {window!r}: allowed > 0 s")
    starts = predicted.starts()
    starts_lossy = starts[starts > predicted.time[0]] if starts.size else starts
    matched, offsets = 0, []
    for d in departures:
        off = np.abs(starts - d) if starts.size else np.array([np.inf])
        if off.min() <= window:
            matched += 1
            offsets.append(float(off.min()))
    false = sum(1 for s in starts_lossy if departures.size == 0 or np.min(np.abs(departures - s)) > window)
    return {
        "departures": int(departures.size),
        "matched": matched,
        "missed": int(departures.size) - matched,
        "false": int(false),
        "max_offset": max(offsets) if offsets else float("nan"),
    }
