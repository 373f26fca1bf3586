"""Building mechanisms and running them: :class:`Model`, :class:`Record`, :class:`Result`."""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _core
from .errors import FlexclearError, InvalidParameterError, SimulationDivergedError, SimulationInterrupted

METHODS = ("force", "modified", "gap")


@dataclasses.dataclass
class Record:
    """What a run keeps. The default keeps every joint's penetration and force at every step.

    Parameters
    ----------
    joints : list of str or None
        Joints whose histories are kept; ``None`` = all.
    position : bool
        Also keep the journal position ``qx, qy`` (m) of those joints.
    nodes : list of (str, int)
        ``(link name, node index)`` pairs whose displacements ``u, v, theta`` (link frame; m,
        m, rad) are kept.
    every : int
        Keep every k-th step (the initial state is always kept).
    histories : bool
        False keeps only the running extremes per joint (memory independent of run length).
    start : float
        Histories and extremes start at this time, s.
    impact_log : bool
        Also keep an :class:`ImpactLog` of those joints: one entry per contact episode (memory
        grows with the number of impacts, not of steps; independent of ``histories``).
    """

    joints: Optional[list[str]] = None
    position: bool = False
    nodes: list[tuple[str, int]] = dataclasses.field(default_factory=list)
    every: int = 1
    histories: bool = True
    start: float = 0.0
    impact_log: bool = False


@dataclasses.dataclass
class ImpactLog:
    """The contact episodes (open -> closed -> open) of one joint, one array entry each.

    On fixed steps an entry is the first step that ends closed, and speed and peaks are those of
    the steps. With event-aware stepping (``simulate(..., events=True)``) entry and exit are the
    cuts at the crossings, the speed is the approach speed there and the peak force includes the
    force just after the cut (the dashpot jump at entry).

    Attributes
    ----------
    time : ndarray
        Entry times, s.
    speed : ndarray
        Normal approach speed at entry, ``q' . q / |q|``, m/s.
    peak_force : ndarray
        Largest contact force magnitude of each episode, N.
    peak_penetration : ndarray
        Largest penetration of each episode, m.
    duration : ndarray
        Time in contact, s (NaN for an episode still closed at the end of the run).
    """

    time: np.ndarray
    speed: np.ndarray
    peak_force: np.ndarray
    peak_penetration: np.ndarray
    duration: np.ndarray

    def __len__(self) -> int:
        return len(self.time)


@dataclasses.dataclass
class JointResult:
    """Histories and extremes of one clearance joint.

    Attributes
    ----------
    penetration : ndarray
        ``delta_r - delta_c`` at the recorded times, m (negative when open).
    force : ndarray
        Magnitude of the contact force that acted in each step, N.
    qx, qy : ndarray
        Journal centre relative to the bearing centre, m (empty unless recorded).
    max_penetration : float
        Largest penetration since ``Record.start``, m.
    time_of_max_penetration : float
        When it happened, s.
    max_force : float
        Largest contact force magnitude, N.
    impacts : int
        Open-to-closed transitions.
    contact_time : float
        Time spent in contact, s.
    max_velocity : float
        Largest speed of the journal relative to the bearing, m/s.
    max_impact_velocity : float
        Largest normal approach speed at an impact (the step that closes the gap), m/s.
    rms_penetration, rms_force : float
        Root mean square of the penetration (m) and of the force magnitude (N) over the
        recorded steps (every step from ``Record.start``, whatever ``Record.every``).
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
    contact_time: float
    max_velocity: float
    max_impact_velocity: float
    rms_penetration: float
    rms_force: float
    impact_log: Optional[ImpactLog] = None


@dataclasses.dataclass
class NodeResult:
    """Displacement history of one node, link frame: ``u`` (m), ``v`` (m), ``theta`` (rad)."""

    link: str
    node: int
    u: np.ndarray
    v: np.ndarray
    theta: np.ndarray


class Result:
    """The output of :meth:`Model.simulate`.

    Attributes
    ----------
    time : ndarray
        Recorded times, s.
    stats : dict
        Counters: ``steps``, ``factorizations``, ``woodbury_steps``, ``woodbury_fallbacks``, ``event_steps``,
        ``iterations``, ``max_iterations``, ``unconverged_steps``, and ``terms`` (the terms that
        were active in the equations, in words).
    complete : bool
        False when the run stopped early (divergence, interruption); see :attr:`error`.
    error : FlexclearError or None
        Why it stopped early.
    method : str
        The coupling used.
    dt : float
        Step, s.
    wall_time : float
        Wall-clock time of the run, s.
    """

    def __init__(self, raw: dict, model: Model, method: str, dt: float, wall_time: float, error=None):
        self._raw = raw
        self._model = model
        self.time: np.ndarray = raw["time"]
        self.stats: dict = raw["stats"]
        self.method = method
        self.dt = dt
        self.wall_time = wall_time
        self.error: Optional[FlexclearError] = error
        self.complete = error is None
        self.end_time: float = raw["t"]
        self.state: tuple[np.ndarray, np.ndarray, np.ndarray] = raw["state"]

    def joint(self, name: str) -> JointResult:
        """Histories and extremes of joint ``name`` (e.g. ``"bearing"``)."""
        names = self._model.joint_names
        if name not in names:
            raise InvalidParameterError(f"unknown joint {name!r}; the model has {names}")
        idx = names.index(name)
        ext = self._raw["extremes"][idx]
        hist = next((h for h in self._raw["joints"] if h["joint"] == idx), None)
        empty = np.empty(0)
        return JointResult(
            name=name,
            penetration=hist["penetration"] if hist else empty,
            force=hist["force"] if hist else empty,
            qx=hist["qx"] if hist else empty,
            qy=hist["qy"] if hist else empty,
            max_penetration=ext["max_penetration"],
            time_of_max_penetration=ext["time_of_max_penetration"],
            max_force=ext["max_force"],
            impacts=ext["impacts"],
            contact_time=ext["contact_time"],
            max_velocity=ext["max_velocity"],
            max_impact_velocity=ext["max_impact_velocity"],
            rms_penetration=ext["rms_penetration"],
            rms_force=ext["rms_force"],
            impact_log=next(
                (
                    ImpactLog(**{k: v for k, v in log.items() if k != "joint"})
                    for log in self._raw.get("impact_log", ())
                    if log["joint"] == idx
                ),
                None,
            ),
        )

    def node(self, link: str, node: int) -> NodeResult:
        """Displacement history of ``node`` of ``link`` (must have been recorded)."""
        li = self._model._link_index(link)
        for h in self._raw["nodes"]:
            if h["link"] == li and h["node"] == node:
                return NodeResult(link, node, h["u"], h["v"], h["theta"])
        raise InvalidParameterError(f"node {node} of link {link!r} was not recorded; add it to Record.nodes")

    def __repr__(self) -> str:
        status = "complete" if self.complete else f"stopped early: {self.error}"
        return (
            f"Result(method={self.method!r}, dt={self.dt:g} s, t_end={self.end_time:g} s, "
            f"steps={self.stats['steps']}, samples={self.time.size}, {status})"
        )


def _progress_callback(progress, t_end: float):
    if progress is None or progress is False:
        return None, None
    if callable(progress):
        return progress, None
    try:
        from tqdm import tqdm

        bar = tqdm(total=100, unit="%", desc="simulate", file=sys.stderr, leave=False)

        def cb(frac: float) -> None:
            bar.n = round(100 * frac)
            bar.refresh()

        return cb, bar
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None, None


class Model:
    """A planar mechanism: flexible links, rigid bodies with prescribed motion, clearance joints.

    Build one with :meth:`add_link`, :meth:`add_body` and :meth:`add_joint`, or take a ready
    scene from :mod:`flexclear.scenes`. SI units throughout. Every parameter is checked when it
    is added; a bad one raises :class:`~flexclear.InvalidParameterError` naming it and its
    allowed range.
    """

    def __init__(self) -> None:
        self._core = _core.Model()
        self.parameters: dict[str, Any] = {}

    @classmethod
    def _wrap(cls, core: Any, parameters: Optional[dict] = None) -> Model:
        m = cls.__new__(cls)
        m._core = core
        m.parameters = dict(parameters or {})
        return m

    # -- building ---------------------------------------------------------------------------
    def add_link(
        self,
        name: str,
        *,
        length: float,
        elements: int,
        youngs_modulus: float,
        density: float,
        area: float,
        inertia: float,
        damping: float = 0.0,
        angle: float = 0.0,
        motion=None,
        rotary_inertia: bool = False,
        initial_displacement=None,
        initial_velocity=None,
    ) -> Model:
        """Adds a straight flexible link of ``elements`` equal beam elements.

        Parameters
        ----------
        name : str
            Unique link name.
        length : float
            Length, m (> 0).
        elements : int
            Number of elements, 1 ..= 1000000; nodes are numbered 0..elements from the frame origin.
        youngs_modulus : float
            E, Pa (> 0).
        density : float
            rho, kg/m^3 (> 0).
        area : float
            Section area A, m^2 (> 0).
        inertia : float
            Second moment of area I, m^4 (> 0).
        damping : float
            Kelvin-Voigt coefficient eta, Pa s (>= 0); the damping matrix is (eta/E) K1.
        angle : float
            Fixed orientation of the link axis, rad.
        motion : flexclear.motion.Motion, optional
            Prescribed translation of the link frame origin (default: fixed at the origin).
        rotary_inertia : bool
            Include rotary inertia in the mass matrix.
        initial_displacement, initial_velocity : array_like, optional
            ``3 (elements + 1)`` values ``[u, v, theta]`` per node in the link frame (m, rad;
            m/s, rad/s).
        """
        as_arr = lambda a: None if a is None else np.ascontiguousarray(a, dtype=float)  # noqa: E731
        self._core.add_link(
            name,
            float(length),
            int(elements),
            float(youngs_modulus),
            float(density),
            float(area),
            float(inertia),
            float(damping),
            float(angle),
            motion,
            bool(rotary_inertia),
            as_arr(initial_displacement),
            as_arr(initial_velocity),
        )
        return self

    def add_body(self, name: str, motion=None) -> Model:
        """Adds a rigid body whose reference point follows ``motion`` (default: fixed at 0)."""
        self._core.add_body(name, motion)
        return self

    def add_joint(
        self,
        name: str,
        link: str,
        node: int,
        *,
        clearance: float,
        stiffness: float,
        damping: float,
        body: Optional[str] = None,
        point: Sequence[float] = (0.0, 0.0),
        target: Optional[tuple[str, int]] = None,
        damping_law: str = "viscous",
        no_tension: bool = False,
    ) -> Model:
        """Adds a revolute clearance joint at ``node`` of ``link``.

        The bearing is either a point of rigid body ``body`` (offset ``point`` from its reference
        point, m) or node ``target = (link name, node)`` of another flexible link.

        Parameters
        ----------
        clearance : float
            Radial clearance delta_c, m (>= 0).
        stiffness : float
            Bearing stiffness K_B, N/m (>= 0).
        damping : float
            Bearing damping C_B, N s/m (>= 0), active only in contact.
        damping_law : {"viscous", "radial", "literal"}
            ``-C_B qdot`` (default, the paper's modified-matrix form), ``-C_B (n.qdot) n``, or the
            paper's literal force-method form ``-C_B |qdot| n`` (unstable on the slider-yoke).
        no_tension : bool
            Forbid a tensile (sticky) contact force.
        """
        link_i = self._link_index(link)
        kw: dict[str, Any] = {}
        if body is not None:
            kw["body"] = self._body_index(body)
            kw["point"] = (float(point[0]), float(point[1]))
        if target is not None:
            kw["target_link"] = self._link_index(target[0])
            kw["target_node"] = int(target[1])
        self._core.add_joint(
            name,
            link_i,
            int(node),
            float(clearance),
            float(stiffness),
            float(damping),
            damping_law=damping_law,
            no_tension=bool(no_tension),
            **kw,
        )
        return self

    def _link_index(self, name: str) -> int:
        names = self._core.link_names
        if name not in names:
            raise InvalidParameterError(f"unknown link {name!r}; the model has {names}")
        return names.index(name)

    def _body_index(self, name: str) -> int:
        names = self._core.body_names
        if name not in names:
            raise InvalidParameterError(f"unknown body {name!r}; the model has {names}")
        return names.index(name)

    @property
    def link_names(self) -> list[str]:
        """Link names, in order."""
        return list(self._core.link_names)

    @property
    def joint_names(self) -> list[str]:
        """Joint names, in order."""
        return list(self._core.joint_names)

    @property
    def body_names(self) -> list[str]:
        """Rigid body names, in order."""
        return list(self._core.body_names)

    # -- analysis ---------------------------------------------------------------------------
    def natural_frequencies(self, count: int = 3) -> np.ndarray:
        """Lowest ``count`` natural frequencies, Hz, with every clearance joint open and the
        rigid-body modes left out (eigenvalues below 1e-9 of the largest)."""
        return self._core.natural_frequencies(int(count))

    def simulate(
        self,
        t_end: float,
        dt: float,
        method: str = "modified",
        *,
        iterate: bool = False,
        tol: float = 1e-10,
        max_iter: int = 50,
        gap_stiffness: Optional[float] = None,
        gap_damping: float = 0.0,
        beta: float = 0.25,
        gamma: float = 0.5,
        solver: str = "woodbury",
        divergence_limit: Optional[float] = None,
        record: Union[Record, dict, None] = None,
        progress: Union[bool, Callable[[float], None], None] = None,
        raise_on_failure: bool = True,
        events: bool = False,
    ) -> Result:
        """Runs the model from t = 0 to ``t_end`` with Newmark at fixed step ``dt``.

        Parameters
        ----------
        t_end : float
            End time, s (> 0).
        dt : float
            Time step, s (0 < dt <= t_end).
        method : {"modified", "force", "gap"}
            How the clearance force enters the step: the paper's modified stiffness/damping matrix
            method (kappa from the last state, or iterated with ``iterate=True``), the force
            reaction method (explicit), or a gap element with status iteration.
        iterate : bool
            Modified method: iterate kappa to convergence within each step.
        tol, max_iter : float, int
            Relative tolerance and cap of the within-step iterations.
        gap_stiffness : float, optional
            Gap-element stiffness, N/m; default 1000 x 12 E I / l^3 of the element at the joint.
        gap_damping : float
            Gap-element radial damping, N s/m.
        beta, gamma : float
            Newmark parameters; default average acceleration (1/4, 1/2).
        solver : {"woodbury", "refactor"}
            Contact terms by a low-rank correction of the contact-free factorization (fast) or by
            numeric refactorization whenever they change (reference).
        divergence_limit : float, optional
            A translational displacement beyond this (m) counts as divergence; default 10 x the
            longest link.
        record : Record or dict, optional
            What to keep (default: every joint's penetration and force at every step).
        progress : bool or callable, optional
            True shows a progress bar; a callable receives the fraction done.
        raise_on_failure : bool
            If False, a diverged run returns its partial :class:`Result` (``complete=False``)
            instead of raising.
        events : bool
            Event-aware stepping: a step that changes a joint's contact status is redone as two
            substeps cut at the crossing (linear interpolation of the penetration), each with a
            factorization of its own size; output stays on the ``dt`` grid. A step without a
            status change is bitwise the fixed-step one. Counted in ``stats["event_steps"]``.

        Raises
        ------
        InvalidParameterError
            A parameter is out of range.
        SimulationDivergedError
            The run blew up; ``exc.result`` holds what was recorded until then.
        SimulationInterrupted
            Ctrl-C; ``exc.result`` holds what was recorded until then.
        """
        import time as _time

        if method not in METHODS:
            raise InvalidParameterError(f"invalid parameter `method` = {method!r}: allowed one of {METHODS}")
        rec = record if isinstance(record, Record) else Record(**(record or {}))
        joints = None if rec.joints is None else [self._joint_index(j) for j in rec.joints]
        nodes = [(self._link_index(ln), int(n)) for ln, n in rec.nodes]
        cb, bar = _progress_callback(progress, t_end)
        t0 = _time.perf_counter()
        try:
            raw = self._core.simulate(
                float(t_end),
                float(dt),
                method,
                iterate=bool(iterate),
                tol=float(tol),
                max_iter=int(max_iter),
                gap_stiffness=None if gap_stiffness is None else float(gap_stiffness),
                gap_damping=float(gap_damping),
                beta=float(beta),
                gamma=float(gamma),
                solver=solver,
                divergence_limit=None if divergence_limit is None else float(divergence_limit),
                joints=joints,
                joint_position=bool(rec.position),
                nodes=nodes,
                every=int(rec.every),
                histories=bool(rec.histories),
                start=float(rec.start),
                progress=cb,
                events=bool(events),
                impact_log=bool(rec.impact_log),
            )
        except (SimulationDivergedError, SimulationInterrupted) as exc:
            wall = _time.perf_counter() - t0
            exc.result = Result(exc.partial, self, method, float(dt), wall, error=exc)
            if raise_on_failure or isinstance(exc, SimulationInterrupted):
                raise
            return exc.result
        finally:
            if bar is not None:
                bar.close()
        return Result(raw, self, method, float(dt), _time.perf_counter() - t0)

    def _joint_index(self, name: str) -> int:
        names = self._core.joint_names
        if name not in names:
            raise InvalidParameterError(f"unknown joint {name!r}; the model has {names}")
        return names.index(name)

    def __repr__(self) -> str:
        return f"Model(links={self.link_names}, bodies={self.body_names}, joints={self.joint_names})"
