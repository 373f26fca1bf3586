"""What a run keeps and what it gives back: :class:`Record`, :class:`Result` and its parts
(:class:`JointResult`, :class:`LinkResult`, :class:`NodeResult`, :class:`SliderResult`,
:class:`ImpactLog`).

One result type serves every model, whichever stepper ran it. Results hold plain numpy arrays
and names (no reference to the model or the engine), so they pickle and travel to Dask workers.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional

import numpy as np

from .errors import FlexclearError, InvalidParameterError, ModelError, RecordingError


@dataclasses.dataclass
class Record:
    """What a run keeps. The default keeps every clearance joint's penetration and force at every
    step (and, for a model in moving frames, every node's displacements).

    Parameters
    ----------
    joints : list of str or None
        Clearance joints whose histories (and impact logs) are kept; ``None`` = all.
    position : bool
        Also keep the journal position ``qx, qy`` (m, global axes) of those joints.
    nodes : list of (str, int)
        ``(link name, node index)`` pairs whose displacements ``u, v, theta`` (link frame; m, m,
        rad) are kept (see :meth:`Result.node`).
    displacements : bool or None
        Keep every node of every link (see :meth:`Result.link`). ``None`` (default): on for a
        model with a link in a rotating or mechanism frame (as the moving-frame reports read
        them) unless ``histories=False``, off for a model whose links all translate (its
        histories can be long; ask for ``nodes`` or switch this on).
    midspan, axial_force : bool
        Link channels: transverse deflection at mid-length relative to the chord (m) and the
        element axial forces (N, tension positive). Need the displacements of the link.
    energy : bool
        Kinetic and strain energy (J) and angular momentum (kg m^2/s) of each link. Recorded by
        the Newton stepper: a model that the constant stepper would run runs on the Newton one
        when energies are asked for (``stats["stepper"]``).
    link_peaks : bool
        Track every flexible link's peak midspan deflection (m, relative to the chord) and peak
        element axial force (N) over every step from ``start`` on (:attr:`LinkResult.max_midspan`,
        :attr:`LinkResult.max_axial_force`): running maxima, O(1) memory per link whatever
        ``every`` and ``histories`` (a ``tol=`` run tracks them at its output points). Tracked
        by the Newton stepper, as ``energy``.
    every : int
        Keep every k-th step (the initial state is always kept).
    histories : bool
        False keeps only the running extremes (memory independent of run length): no joint
        histories, and in moving frames no output grid (:attr:`Result.time`, the link frames)
        unless something on it is asked for explicitly (``displacements=True``, ``nodes``,
        ``midspan``, ``axial_force``, ``energy`` or ``sliders``). Peaks (the joints' extremes,
        the sliders' ``max_acceleration``, ``link_peaks``) stay exact over every step.
    start : float
        Joint extremes and impact logs start at this time, s (and every history, while every
        link translates; in moving frames the histories share the links' grid from t = 0).
    impact_log : bool
        Also keep an :class:`ImpactLog` per recorded joint: one entry per impact (its rebounds
        included).
    sliders : bool
        Keep the sliders' position, velocity and acceleration histories (:meth:`Result.slider`,
        with :attr:`Result.time`) even with ``histories=False`` (with ``histories=True`` they are
        kept anyway; without either, reading them raises :class:`~flexclear.RecordingError`).
    slider_reference : Result, optional
        A run of a mechanism with the same sliders over the same ``t_end``, ``dt`` and ``every``
        whose slider histories were kept (e.g. the same mechanism with ideal joints, run with
        ``Record(histories=False, sliders=True)``): each slider then accumulates online, at every
        output point from ``start`` on, the mean and peak of ``|x - x_ref|`` for its position,
        velocity and acceleration (:class:`SliderResult` ``position_deviation_mean``, ...), in
        O(1) memory per slider whatever the run length. A reference on another grid is refused
        (:class:`~flexclear.InvalidParameterError` naming ``record.slider_reference``).
    contact_modes : bool
        Also track every joint's contact modes (the time fractions of free flight, impact and
        continuous contact) and the energy dissipated in it (:class:`JointResult`): O(1) memory,
        a few operations per joint and step; off by default (reading them then raises
        :class:`~flexclear.RecordingError`).
    """

    joints: Optional[list[str]] = None
    position: bool = False
    nodes: list[tuple[str, int]] = dataclasses.field(default_factory=list)
    displacements: Optional[bool] = None
    midspan: bool = False
    axial_force: bool = False
    energy: bool = False
    link_peaks: bool = False
    every: int = 1
    histories: bool = True
    start: float = 0.0
    impact_log: bool = False
    contact_modes: bool = False
    sliders: bool = False
    slider_reference: Optional[Result] = None


@dataclasses.dataclass
class ImpactLog:
    """The impacts of one joint, one array entry each: from the closing that starts it to the
    opening that ends its last rebound (closings after a separation of at most
    ``flexclear._core.REBOUND_DEPTH`` of the clearance are rebounds, docs/contact.md).

    On fixed steps an entry is the first step that ends closed, and the peaks are those of the
    steps. With event-aware stepping (``simulate(..., events=True)``) entry and exit are the
    cuts at the crossings, the speed is the approach speed there and the peak force includes the
    force just after the cut (the dashpot jump at entry).

    Attributes
    ----------
    time : ndarray
        Entry times, s.
    speed : ndarray
        Normal approach speed at entry, ``q' . q / |q|``, m/s (on fixed steps that of the last
        state before the entry, as ``max_impact_velocity``).
    peak_force : ndarray
        Largest contact force magnitude of each impact, its rebounds included, N.
    peak_penetration : ndarray
        Largest penetration of each impact, its rebounds included, m.
    duration : ndarray
        From the entry to the last exit, s (NaN for an impact still closed at the end of the
        run).
    """

    time: np.ndarray
    speed: np.ndarray
    peak_force: np.ndarray
    peak_penetration: np.ndarray
    duration: np.ndarray

    def __len__(self) -> int:
        return len(self.time)


class _NotRecorded:
    """Stands for a channel the run's :class:`Record` did not keep; reading it raises
    :class:`~flexclear.RecordingError` saying so (an empty array would pass for data)."""

    __slots__ = ("message",)

    def __init__(self, message: str) -> None:
        self.message = message

    def __repr__(self) -> str:
        return "<not recorded>"


class _Channels:
    """Reading a field that holds :class:`_NotRecorded` raises its
    :class:`~flexclear.RecordingError`; the repr shows it as ``<not recorded>`` (for the
    dataclasses of one joint's or one slider's results)."""

    def __getattribute__(self, name: str) -> Any:
        value = object.__getattribute__(self, name)
        if type(value) is _NotRecorded:
            raise RecordingError(value.message)
        return value

    def __repr__(self) -> str:
        fields = (f"{f.name}={object.__getattribute__(self, f.name)!r}" for f in dataclasses.fields(self))
        return f"{type(self).__name__}({', '.join(fields)})"


@dataclasses.dataclass(repr=False)
class JointResult(_Channels):
    """Histories and extremes of one clearance joint (the same fields for every model).

    Attributes
    ----------
    name : str
        Joint name.
    penetration : ndarray
        ``|q| - delta_c`` at the recorded times, m (negative when open).
    force : ndarray
        Magnitude of the contact force, N.
    qx, qy : ndarray
        Journal centre relative to the bearing centre, m (``Record(position=True)``).

    A history the run did not keep (``Record(histories=False)``, a joint left out of
    ``Record.joints``, ``qx``/``qy`` without ``Record(position=True)``) raises
    :class:`~flexclear.RecordingError` (an ``AttributeError``) naming the recording choice;
    :meth:`recorded` tells beforehand.
    max_penetration : float
        Largest penetration since ``Record.start``, m.
    time_of_max_penetration : float
        When it happened, s.
    max_force : float
        Largest contact force magnitude, N.
    impacts : int
        Impacts: closings after a separation deeper than 1 % of the radial clearance
        (``flexclear._core.REBOUND_DEPTH``); a closing after a shallower one is a rebound of the impact
        going on. During continuous contact the journal leaves the wall for a few steps and
        closes again, and a finer step resolves more of these: counting every closing made the
        count grow with the resolution (docs/contact.md, "Impacts and rebounds").
    contact_episodes : int
        Every open-to-closed transition, rebounds included (the raw count; it depends on the
        step).
    contact_time : float
        Time spent in contact, s.
    max_velocity : float
        Largest speed of the journal relative to the bearing, m/s.
    max_impact_velocity : float
        Largest normal approach speed at an impact, m/s: on fixed steps the speed of the last
        state before the step that closes (the closing state has already been slowed by the
        contact force), with ``events=True`` the speed at the crossing.
    contact_period : float
        Natural contact period ``pi d / v`` of the impact that penetrated deepest (``v`` its
        approach speed, ``d`` its largest penetration), s; NaN before an impact has ended. The
        contact is resolved when ``dt`` is below about a tenth of it: the peak force otherwise
        depends on the step.
    rms_penetration, rms_force : float
        Root mean square of the penetration (m) and of the force magnitude (N) over every step
        from ``Record.start`` (whatever ``Record.every``); in a ``tol=`` run weighted by time
        over its accepted steps and output instants, whatever its output grid.
    free_flight_fraction, impact_fraction, continuous_fraction : float
        Fractions (dimensionless, summing to 1) of the time from ``Record.start`` that the joint
        spent open (free flight), in contact episodes classified as impacts, and in continuous
        contact. The rule (docs/contact.md, "Contact modes"): an episode of duration ``T``
        (s) entered at normal approach speed ``v`` (m/s) that reaches penetration ``d`` (m) is
        continuous contact when ``(T - dt) v > 5 pi d``, i.e. when it lasts longer than five
        natural contact periods ``T_n = pi sqrt(m_eff / k)``, estimated from the episode itself
        as ``pi d / v`` (the duration of an undamped linear impact with that speed and depth;
        ``dt`` the step, one step of slack). An episode without approach (``v <= 0``, e.g. in
        contact from the start) is continuous contact. An episode still closed at the end is
        classified by its duration so far. NaN before any step. Need
        ``Record(contact_modes=True)``.
    dissipated_energy : float
        Energy dissipated in the joint, J: the work balance of the normal contact force over
        the run, ``integral F_n d(delta)`` (trapezoidal rule over every step from
        ``Record.start``, whatever ``Record.every``; event cuts included), i.e. the energy the
        contact force took out of the journal's motion relative to the bearing. Over a finished
        contact episode the elastic part returns to zero and the balance is the dissipation; for
        an episode still closed at the end the elastic energy still stored, estimated as
        ``F_n delta / 2`` (exact for a linear spring), is left out. Needs
        ``Record(contact_modes=True)``.
    friction_energy : float
        Energy dissipated by friction in the joint, J: ``-integral F_t v dt`` (friction force
        times slip speed, on the step's trapezoidal rule, from ``Record.start``; event cuts
        included), the work the friction force and moments did on both sides; 0 for a joint
        without friction. Needs ``Record(contact_modes=True)``.
    friction, slip : ndarray
        Friction force ``F_t`` on the journal along the tangent ``t`` (N; ``t`` is the normal
        from the bearing centre to the journal centre turned by +90 degrees) and slip speed
        ``v = (v_J - v_B) . t + R_J w_J - R_B w_B`` (m/s) at the recorded times; empty for a
        joint without friction (histories as ``penetration``).
    impact_log : ImpactLog or None
        Every contact episode (when ``Record(impact_log=True)``).
    """

    name: str
    penetration: np.ndarray
    force: np.ndarray
    qx: np.ndarray
    qy: np.ndarray
    max_penetration: float
    time_of_max_penetration: float
    max_force: float
    impacts: int
    contact_episodes: int
    contact_time: float
    max_velocity: float
    max_impact_velocity: float
    contact_period: float
    rms_penetration: float
    rms_force: float
    free_flight_fraction: Any = float("nan")
    impact_fraction: Any = float("nan")
    continuous_fraction: Any = float("nan")
    dissipated_energy: Any = float("nan")
    friction_energy: Any = float("nan")
    impact_log: Optional[ImpactLog] = None
    friction: Any = None
    slip: Any = None

    def orbit(self) -> tuple[np.ndarray, np.ndarray]:
        """The journal-centre orbit: ``(qx, qy)``, the journal centre relative to the bearing
        centre at the recorded times, m (inside the clearance circle of radius ``delta_c`` while
        the joint is open). Opt-in: needs ``Record(position=True)``; ``Record(every=k)``
        decimates it. Raises :class:`~flexclear.RecordingError` when it was not recorded."""
        return self.qx, self.qy

    def recorded(self, channel: str) -> bool:
        """Whether history ``channel`` (``"penetration"``, ``"force"``, ``"qx"``, ``"qy"``,
        ``"friction"``, ``"slip"``) or contact-mode output (``"free_flight_fraction"``, ...,
        ``"dissipated_energy"``, ``"friction_energy"``:
        ``Record(contact_modes=True)``) was kept by the run's :class:`Record` (reading one that
        was not raises :class:`~flexclear.RecordingError`)."""
        return type(object.__getattribute__(self, channel)) is not _NotRecorded


@dataclasses.dataclass
class NodeResult:
    """Displacement history of one node, link frame: ``u`` (m), ``v`` (m), ``theta`` (rad)."""

    link: str
    node: int
    u: np.ndarray
    v: np.ndarray
    theta: np.ndarray


@dataclasses.dataclass
class LinkResult:
    """Histories of one flexible link.

    Attributes
    ----------
    name : str
        Link name.
    x : ndarray
        Undeformed node positions along the link, m.
    frame : ndarray, shape (n, 4)
        Frame origin x, y (m), angle (rad) and rate (rad/s) at each record.
    u, v, theta : ndarray, shape (n, nodes)
        Nodal displacements in the link frame: axial (m), transverse (m), rotation (rad). Empty
        unless recorded (``Record.displacements``).
    axial_force : ndarray, shape (n, elements)
        Element axial force ``E A (u_{k+1} - u_k) / l``, N (tension positive). Empty unless
        ``Record(axial_force=True)``.
    midspan : ndarray
        Transverse deflection at mid-length relative to the chord through the end nodes, m.
        Empty unless ``Record(midspan=True)``.
    kinetic, strain, momentum : ndarray
        Kinetic energy of the absolute motion (J), linear strain energy ``Q^T K1 Q / 2`` (J) and
        angular momentum about the frame origin (kg m^2/s). Empty unless ``Record(energy=True)``.
    peaks : tuple of float or None
        ``(peak midspan deflection m, peak axial force N)`` tracked over every step from
        ``Record.start`` on with ``Record(link_peaks=True)``; None otherwise.
    """

    name: str
    x: np.ndarray
    frame: np.ndarray
    u: np.ndarray
    v: np.ndarray
    theta: np.ndarray
    axial_force: np.ndarray
    midspan: np.ndarray
    kinetic: np.ndarray
    strain: np.ndarray
    momentum: np.ndarray
    peaks: Optional[tuple[float, float]] = None

    @property
    def max_midspan(self) -> float:
        """Peak midspan deflection, m: with ``Record(link_peaks=True)`` the largest magnitude over
        every step from ``Record.start`` on, else the largest magnitude of :attr:`midspan` over
        the recorded samples (``Record(every=k)`` thins them; NaN unless ``Record(midspan=True)``)."""
        if self.peaks is not None:
            return self.peaks[0]
        return float(np.max(np.abs(self.midspan))) if self.midspan.size else float("nan")

    @property
    def max_axial_force(self) -> float:
        """Peak axial force over the elements, N: with ``Record(link_peaks=True)`` the largest
        magnitude over every step from ``Record.start`` on, else over the recorded samples of
        :attr:`axial_force` (NaN unless ``Record(axial_force=True)``)."""
        if self.peaks is not None:
            return self.peaks[1]
        return float(np.max(np.abs(self.axial_force))) if self.axial_force.size else float("nan")

    @property
    def tip(self) -> np.ndarray:
        """Transverse displacement of the last node, m."""
        return self.v[:, -1] if self.v.size else np.empty(0)

    def global_positions(self) -> tuple[np.ndarray, np.ndarray]:
        """Deformed node positions in global axes, ``(X, Y)`` each of shape (n, nodes), m."""
        if not self.u.size:
            raise InvalidParameterError(
                f"the displacements of link {self.name!r} were not recorded (Record(displacements=True))"
            )
        ox, oy, ang = self.frame[:, 0:1], self.frame[:, 1:2], self.frame[:, 2:3]
        lx = self.x[None, :] + self.u
        ly = self.v
        c, s = np.cos(ang), np.sin(ang)
        return ox + c * lx - s * ly, oy + s * lx + c * ly


@dataclasses.dataclass(repr=False)
class SliderResult(_Channels):
    """Motion of one slider along its guide (a model in moving frames): the nominal path of its
    pin plus its elastic travel, projected on the guide direction.

    Attributes
    ----------
    name : str
        Slider name.
    position : ndarray
        Position along the guide at the recorded times (:attr:`Result.time`), m (the guide
        direction from the global origin).
    velocity : ndarray
        Velocity along the guide, m/s.
    acceleration : ndarray
        Acceleration along the guide, m/s^2.
    max_acceleration : float
        Largest magnitude of the acceleration along the guide over every step from
        ``Record.start`` (whatever ``Record.every``), m/s^2.
    position_deviation_mean, position_deviation_max : float
        Mean and peak ``|x - x_ref|`` against ``Record.slider_reference`` over the output points
        from ``Record.start`` on, m; likewise ``velocity_deviation_*`` (m/s) and
        ``acceleration_deviation_*`` (m/s^2). Accumulated online during the run (O(1) memory);
        reading them without a reference raises :class:`~flexclear.RecordingError`.

    The histories raise :class:`~flexclear.RecordingError` when the run did not keep them
    (``Record(histories=False)`` without ``sliders=True``).
    """

    name: str
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    max_acceleration: float
    position_deviation_mean: Any = float("nan")
    position_deviation_max: Any = float("nan")
    velocity_deviation_mean: Any = float("nan")
    velocity_deviation_max: Any = float("nan")
    acceleration_deviation_mean: Any = float("nan")
    acceleration_deviation_max: Any = float("nan")


_EMPTY = np.empty(0)
#: The history channels of a slider.
_SLIDER_CHANNELS = ("position", "velocity", "acceleration")
#: The joint outputs of ``Record(contact_modes=True)``.
_IMPACT_FIELDS = ("time", "speed", "peak_force", "peak_penetration", "duration")
_MODE_OUTPUTS = (
    "free_flight_fraction",
    "impact_fraction",
    "continuous_fraction",
    "dissipated_energy",
    "friction_energy",
)


def _unknown(kind: str, name: Any, names: list) -> ModelError:
    return ModelError(f"unknown {kind} {name!r}; the model has {names}")


class Result:
    """The output of :meth:`flexclear.Model.simulate`, the same type for every model.

    Attributes
    ----------
    time : ndarray
        Recorded times, s.
    stats : dict
        What ran and what it cost: ``engine`` (``"translating"``: every link translates, the
        contact-free matrix is factorized once; ``"moving-frame"``: Newton on the moving-frame
        equations), ``method``, ``iterate``, ``iter_tol``, ``max_iter`` (the settings chosen),
        ``steps``, ``factorizations``, ``iterations``, ``max_iterations``, ``event_steps``,
        ``woodbury_steps``, ``woodbury_fallbacks``, ``unconverged_steps``, ``halved_substeps``,
        ``roundoff_steps`` (Newton steps accepted at the round-off floor: the correction stopped
        decreasing below 1e-6 of the displacement scale, above a tolerance finer than the
        arithmetic delivers), ``event_fallbacks`` (counters that do not apply to the engine are
        0), ``stepper``
        (``"constant"``: one factorization of a constant effective matrix, contact by Woodbury;
        ``"constant-rate"``: moving frames at rest or turning at a constant rate without
        geometric terms, the contact-free Jacobian factorized once, contact by Woodbury;
        ``"newton"``: the Jacobian refactorized when it changes), ``unknowns`` (number of
        unknowns), ``bandwidth`` (half-bandwidth of the Newton Jacobian, 0 for the constant
        stepper) and ``terms`` (the terms active in the equations).
    complete : bool
        False when the run stopped early (divergence, non-convergence, interruption).
    error : FlexclearError or None
        Why it stopped early.
    method : str
        The clearance coupling used.
    dt : float
        Step, s.
    wall_time : float
        Wall-clock time of the run, s.
    end_time : float
        Time reached, s.
    """

    def __init__(
        self,
        raw: dict,
        *,
        joint_names: list[str],
        links: list[tuple[str, int, float, float]],
        method: str,
        dt: float,
        wall_time: float,
        stats: dict,
        error: Optional[FlexclearError] = None,
        record: Optional[Record] = None,
    ) -> None:
        self.time: np.ndarray = raw.time
        self.stats: dict = stats
        self.method = method
        self.dt = dt
        self.wall_time = wall_time
        self.error = error
        self.complete = error is None
        self.end_time: float = raw.t
        #: ``(u, v, a)`` at the end (m or rad, per s, per s^2): the global DOF vectors where every
        #: link translates, else the moving-frame unknowns in the order of
        #: :meth:`flexclear.Model.dof_map`.
        self.state: Optional[tuple[np.ndarray, np.ndarray, np.ndarray]] = raw.state
        self.joint_names = list(joint_names)
        self.link_names = [name for name, *_ in links]
        self._links_info = links
        self._raw = raw
        #: What the run was asked to keep.
        self.record = record

    # -- pickling: the error may hold this result; keep its message and class only ---------------
    def __getstate__(self) -> dict:
        d = dict(self.__dict__)
        d["_raw"] = _plain(d["_raw"])  # the engine's output objects, as plain attribute objects
        d.pop("_slider_ref", None)  # the core's copy of the slider histories: rebuilt on demand
        if d["error"] is not None:
            d["error"] = (type(d["error"]), str(d["error"]))
        return d

    def __setstate__(self, d: dict) -> None:
        err = d.get("error")
        if isinstance(err, tuple):
            d["error"] = err[0](err[1])
        self.__dict__.update(d)

    def joint(self, name: str) -> JointResult:
        """Histories and extremes of clearance joint ``name`` (e.g. ``"bearing"``)."""
        if name not in self.joint_names:
            raise _unknown("joint", name, self.joint_names)
        idx = self.joint_names.index(name)
        raw = self._raw
        ext = raw.extremes[idx]
        hist = next((h for h in raw.joints if h.joint == idx), None)
        log = next((lg for lg in raw.impact_log if lg.joint == idx), None)
        rec = self.record
        if hist is None:
            if rec is not None and not rec.histories:
                why = "Record(histories=False) keeps only the joints' extremes"
            else:
                why = f"the joint is not in Record(joints={rec.joints if rec else None!r})"
            gone = _NotRecorded(
                f"the histories of joint {name!r} were not recorded: {why}; run with "
                "Record(histories=True) (every=k to thin them) to read penetration, force, qx, qy"
            )
            channels = dict(penetration=gone, force=gone, qx=gone, qy=gone, friction=gone, slip=gone)
        else:
            channels = {k: getattr(hist, k) for k in ("penetration", "force", "qx", "qy", "friction", "slip")}
            if rec is not None and not rec.position:
                for k in ("qx", "qy"):
                    channels[k] = _NotRecorded(
                        f"the journal position {k} of joint {name!r} was not recorded: run with "
                        "Record(position=True)"
                    )
        modes: dict[str, Any] = {k: getattr(ext, k) for k in _MODE_OUTPUTS}
        if rec is not None and not rec.contact_modes:
            gone_modes = _NotRecorded(
                f"the contact modes and dissipated energy of joint {name!r} were not tracked: run "
                "with Record(contact_modes=True)"
            )
            modes = dict.fromkeys(_MODE_OUTPUTS, gone_modes)
        return JointResult(
            name=name,
            **channels,
            max_penetration=ext.max_penetration,
            time_of_max_penetration=ext.time_of_max_penetration,
            max_force=ext.max_force,
            impacts=ext.impacts,
            contact_episodes=ext.contact_episodes,
            contact_time=ext.contact_time,
            max_velocity=ext.max_velocity,
            max_impact_velocity=ext.max_impact_velocity,
            contact_period=ext.contact_period,
            rms_penetration=ext.rms_penetration,
            rms_force=ext.rms_force,
            **modes,
            impact_log=None if log is None else ImpactLog(**{k: getattr(log, k) for k in _IMPACT_FIELDS}),
        )

    @property
    def slider_names(self) -> list[str]:
        """Names of the model's sliders (see :meth:`slider`)."""
        return [h.name for h in self._raw.sliders]

    def slider(self, name: str) -> SliderResult:
        """Position, velocity and acceleration of slider ``name`` along its guide (histories on
        the output grid, :attr:`time`) and its peak acceleration."""
        for h in self._raw.sliders:
            if h.name == name:
                rec = self.record
                hist: dict[str, Any] = {c: getattr(h, c) for c in _SLIDER_CHANNELS}
                if rec is not None and not (rec.histories or rec.sliders):
                    gone = _NotRecorded(
                        f"the histories of slider {name!r} were not recorded: Record(histories=False) "
                        "keeps its max_acceleration only; run with Record(sliders=True) (or "
                        "histories=True) to read position, velocity, acceleration"
                    )
                    hist = dict.fromkeys(_SLIDER_CHANNELS, gone)
                devs: dict[str, Any] = {}
                tracked = getattr(h, "deviation", False)
                for c, mean, peak in zip(
                    _SLIDER_CHANNELS,
                    getattr(h, "deviation_mean", (np.nan,) * 3),
                    getattr(h, "deviation_max", (np.nan,) * 3),
                ):
                    if tracked:
                        devs[f"{c}_deviation_mean"], devs[f"{c}_deviation_max"] = float(mean), float(peak)
                    else:
                        gone = _NotRecorded(
                            f"the deviation of slider {name!r} was not tracked: run with "
                            "Record(slider_reference=<a run with the slider histories on the same grid>)"
                        )
                        devs[f"{c}_deviation_mean"] = devs[f"{c}_deviation_max"] = gone
                return SliderResult(name=name, **hist, max_acceleration=h.max_acceleration, **devs)
        raise _unknown("slider", name, self.slider_names)

    def _slider_reference(self) -> Any:
        """The core's :class:`~flexclear._core.SliderReference` of this run's slider histories
        (built once, then shared by every run that compares with it; needs the histories)."""
        ref = self.__dict__.get("_slider_ref")
        if ref is None:
            from . import _core

            sliders = [self.slider(n) for n in self.slider_names]
            columns = [
                (s.name, *(np.asarray(getattr(s, c), dtype=float) for c in _SLIDER_CHANNELS)) for s in sliders
            ]
            ref = _core.SliderReference(np.asarray(self.time, dtype=float), columns)
            self._slider_ref = ref
        return ref

    def link(self, name: str) -> LinkResult:
        """Histories of flexible link ``name`` (see :class:`Record` for what is kept)."""
        if name not in self.link_names:
            raise _unknown("link", name, self.link_names)
        idx = self.link_names.index(name)
        _, elements, length, ea = self._links_info[idx]
        h = self._raw.links[idx]
        nodes = elements + 1
        d = h.displacements
        empty = np.empty((0, nodes))
        return LinkResult(
            name=name,
            x=np.linspace(0.0, length, nodes),
            frame=h.frame,
            u=d[:, 0::3] if d.size else empty,
            v=d[:, 1::3] if d.size else empty,
            theta=d[:, 2::3] if d.size else empty,
            axial_force=h.axial_force,
            midspan=h.midspan,
            kinetic=h.kinetic,
            strain=h.strain,
            momentum=h.momentum,
            peaks=None if math.isnan(h.max_midspan) else (float(h.max_midspan), float(h.max_axial_force)),
        )

    def node(self, link: str, node: int) -> NodeResult:
        """Displacement history of ``node`` of ``link``: from ``Record.nodes``, or from the link's
        recorded displacements."""
        if link not in self.link_names:
            raise _unknown("link", link, self.link_names)
        li = self.link_names.index(link)
        integral = isinstance(node, (int, float, np.integer, np.floating)) and not isinstance(
            node, (bool, np.bool_)
        )
        if not (integral and float(node).is_integer()):
            e = InvalidParameterError(
                f"invalid parameter `node` = {node!r}: allowed a node index, an integer >= 0"
            )
            e.parameter, e.value, e.allowed = "node", repr(node), "a node index, an integer >= 0"
            raise e
        node = int(node)  # an integral float, as Record.nodes accepts it
        for h in self._raw.nodes:
            if h.link == li and h.node == node:
                return NodeResult(link, node, h.u, h.v, h.theta)
        lr = self.link(link)
        if lr.u.size and 0 <= node < lr.u.shape[1]:
            return NodeResult(link, node, lr.u[:, node], lr.v[:, node], lr.theta[:, node])
        raise InvalidParameterError(
            f"node {node} of link {link!r} was not recorded; add it to Record.nodes or set "
            "Record(displacements=True)"
        )

    def to_pandas(self):
        """The recorded histories as a pandas DataFrame indexed by time (s): one column per joint
        channel (``"<joint>.penetration"`` m, ``"<joint>.force"`` N, ``"<joint>.qx"``/``qy`` m;
        ``"<joint>.friction"`` N and ``"<joint>.slip"`` m/s for a joint with friction) and
        per recorded node (``"<link>[<node>].u"``, ``.v`` m, ``.theta`` rad), and the link channels
        ``"<link>.midspan"`` (m) where recorded, and per slider ``"<slider>.position"`` (m),
        ``.velocity`` (m/s), ``.acceleration`` (m/s^2) along its guide."""
        import pandas as pd

        cols: dict[str, np.ndarray] = {}
        n = self.time.size
        for name in self.joint_names:
            j = self.joint(name)
            for ch in ("penetration", "force", "qx", "qy", "friction", "slip"):
                if not j.recorded(ch):
                    continue
                a = getattr(j, ch)
                if a.size == n and n:
                    cols[f"{name}.{ch}"] = a
        for h in self._raw.nodes:
            ln = self.link_names[h.link]
            for ch in ("u", "v", "theta"):
                cols[f"{ln}[{h.node}].{ch}"] = getattr(h, ch)
        for ln in self.link_names:
            lr = self.link(ln)
            if lr.midspan.size == n and n:
                cols[f"{ln}.midspan"] = lr.midspan
        for h in self._raw.sliders:
            for ch in ("position", "velocity", "acceleration"):
                a = getattr(h, ch)
                if a.size == n and n:
                    cols[f"{h.name}.{ch}"] = a
        frame = pd.DataFrame(cols, index=pd.Index(self.time, name="time"))
        return frame

    def __repr__(self) -> str:
        status = "complete" if self.complete else f"stopped early: {self.error}"
        return (
            f"Result(engine={self.stats.get('engine')!r}, method={self.method!r}, dt={self.dt:g} s, "
            f"t_end={self.end_time:g} s, steps={self.stats.get('steps')}, samples={self.time.size}, {status})"
        )


def _plain(x: Any) -> Any:
    """The engine's output objects (``flexclear._core.RunOutput`` and its parts) as
    :class:`types.SimpleNamespace` trees with the same attributes (for pickling)."""
    if isinstance(x, (list, tuple)):
        return type(x)(_plain(v) for v in x)
    if type(x).__module__ == "flexclear._core":
        from types import SimpleNamespace

        names = [k for k in dir(x) if not k.startswith("_") and not callable(getattr(x, k))]
        return SimpleNamespace(**{k: _plain(getattr(x, k)) for k in names})
    return x
