"""Kineto-elastodynamics of whole mechanisms: flexible links in moving frames.

A :class:`Mechanism` is a set of flexible links, each with a prescribed frame motion (a spinning
hub, a slider-crank, a four-bar, a table), joined by ideal pins, supports, sliders and clearance
joints. Elastic displacements are solved for in each link's frame with the full element equation
of Hong & Kim (1993), eq. 9 (METHOD.md section 2)::

    M Qdd + (D1 + D2 + M_COR) Qd + (K1 + K2 + K3 + M_IC) Q = f - M_R a_R

Each link carries only the terms its motion calls for (Coriolis and inertia coupling only when
its frame rotates, geometric stiffness only when it rotates or is axially loaded, the inertia
load only when its frame moves); ``stats["terms"]`` of a result lists them, and every switch can
be forced per link. Units are SI throughout.

Frames and angle drivers are :class:`flexclear.Frame` and :class:`flexclear.Rotation`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _core
from .errors import ConvergenceError, FlexclearError, InvalidParameterError, ModelError

Frame = _core.Frame
Rotation = _core.Rotation

NodeRef = tuple[str, int]


@dataclasses.dataclass
class LinkResult:
    """Histories of one link.

    Attributes
    ----------
    name : str
        Link name.
    x : ndarray
        Undeformed node positions along the link, m.
    frame : ndarray, shape (n, 4)
        Frame origin x, y (m), angle (rad) and rate (rad/s) at each record.
    u, v, theta : ndarray, shape (n, nodes)
        Nodal displacements in the link frame: axial (m), transverse (m), rotation (rad).
        Empty when not recorded.
    axial_force : ndarray, shape (n, elements)
        Element axial force, N (tension positive). Empty unless ``axial_force=True``.
    midspan : ndarray
        Transverse deflection at mid-length relative to the chord through the end nodes, m.
        Empty unless ``midspan=True``.
    kinetic, strain, momentum : ndarray
        Kinetic energy of the absolute motion (J), linear strain energy ``Q^T K1 Q / 2`` (J) and
        angular momentum about the frame origin (kg m^2/s). Empty unless ``energy=True``.
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

    @property
    def tip(self) -> np.ndarray:
        """Transverse displacement of the last node, m."""
        return self.v[:, -1] if self.v.size else np.empty(0)

    def global_positions(self) -> tuple[np.ndarray, np.ndarray]:
        """Deformed node positions in global axes, ``(X, Y)`` each of shape (n, nodes), m."""
        if not self.u.size:
            raise InvalidParameterError("displacements were not recorded (simulate(..., displacements=True))")
        ox, oy, ang = self.frame[:, 0:1], self.frame[:, 1:2], self.frame[:, 2:3]
        lx = self.x[None, :] + self.u
        ly = self.v
        c, s = np.cos(ang), np.sin(ang)
        return ox + c * lx - s * ly, oy + s * lx + c * ly


@dataclasses.dataclass
class MechanismJointResult:
    """Histories of one clearance joint: penetration (m, negative when open), force (N) and
    the extremes over every step."""

    name: str
    penetration: np.ndarray
    force: np.ndarray
    max_penetration: float
    max_force: float
    impacts: int


class MechanismResult:
    """Output of :meth:`Mechanism.simulate`.

    Attributes
    ----------
    time : ndarray
        Recorded times, s.
    stats : dict
        ``steps``, ``factorizations`` (numeric refactorizations of the Jacobian),
        ``iterations``, ``max_iterations``, ``halved_substeps``, ``event_steps``,
        ``event_fallbacks``, ``unknowns``, ``bandwidth`` and ``terms`` (per link, the terms that
        were active).
    complete : bool
        False when the run stopped early; see :attr:`error`.
    """

    def __init__(self, raw: dict, mech: Mechanism, dt: float, error: Optional[FlexclearError] = None):
        self._raw = raw
        self.time: np.ndarray = raw["time"]
        self.stats: dict = raw["stats"]
        self.dt = dt
        self.end_time: float = raw["t"]
        self.error = error
        self.complete = error is None
        self._links = {}
        for name, n_el, length, h in zip(mech.link_names, mech._elements, mech._lengths, raw["links"]):
            d = h["displacements"]
            nodes = n_el + 1
            self._links[name] = LinkResult(
                name=name,
                x=np.linspace(0.0, length, nodes),
                frame=h["frame"],
                u=d[:, 0::3] if d.size else np.empty((0, nodes)),
                v=d[:, 1::3] if d.size else np.empty((0, nodes)),
                theta=d[:, 2::3] if d.size else np.empty((0, nodes)),
                axial_force=h["axial_force"],
                midspan=h["midspan"],
                kinetic=h["kinetic"],
                strain=h["strain"],
                momentum=h["momentum"],
            )
        self._joints = {
            name: MechanismJointResult(
                name, j["penetration"], j["force"], j["max_penetration"], j["max_force"], j["impacts"]
            )
            for name, j in zip(mech.joint_names, raw["joints"])
        }

    def link(self, name: str) -> LinkResult:
        """Histories of link ``name``."""
        if name not in self._links:
            raise InvalidParameterError(f"unknown link {name!r}; the mechanism has {list(self._links)}")
        return self._links[name]

    def joint(self, name: str) -> MechanismJointResult:
        """Histories of clearance joint ``name``."""
        if name not in self._joints:
            raise InvalidParameterError(f"unknown joint {name!r}; the mechanism has {list(self._joints)}")
        return self._joints[name]

    def __repr__(self) -> str:
        status = "complete" if self.complete else f"stopped early: {self.error}"
        steps = self.stats["steps"]
        return f"MechanismResult(dt={self.dt:g} s, t_end={self.end_time:g} s, steps={steps}, {status})"


Target = Union[NodeRef, str, tuple]


class Mechanism:
    """A planar mechanism of flexible links in moving frames (kineto-elastodynamics).

    Build it link by link, then join the links::

        import flexclear as fc
        m = fc.Mechanism()
        hub = fc.Frame.rotating(fc.Rotation.spin_up(final_rate=4.0, ramp_time=15.0))
        m.add_link("beam", length=8.0, elements=10, youngs_modulus=6.8952e10, density=2766.67,
                   area=7.2968e-5, inertia=8.2189e-9, frame=hub)
        m.clamp("beam", 0)
        res = m.simulate(t_end=20.0, dt=1e-3)
        res.link("beam").tip          # tip deflection in the hub frame, m

    Node references are ``(link name, node index)``; node 0 is the frame origin.
    """

    def __init__(self) -> None:
        self._core = _core.Mechanism()
        self._elements: list[int] = []
        self._lengths: list[float] = []
        self._sliders: list[str] = []
        #: Inputs and derived values of the scene that built this mechanism (empty otherwise).
        self.parameters: dict[str, Any] = {}

    @classmethod
    def _wrap(cls, core: Any, parameters: Optional[dict] = None) -> Mechanism:
        """A mechanism around a core one built in Rust (a scene), open to further building."""
        m = cls()
        m._core = core
        m._elements = list(core.link_elements)
        m._lengths = list(core.link_lengths)
        m._sliders = list(core.slider_names)
        m.parameters = dict(parameters or {})
        return m

    # -- building ---------------------------------------------------------------------------
    @property
    def link_names(self) -> list[str]:
        """Link names in order."""
        return list(self._core.link_names)

    @property
    def joint_names(self) -> list[str]:
        """Clearance joint names in order."""
        return list(self._core.joint_names)

    def _link(self, name: str) -> int:
        names = self.link_names
        if name not in names:
            raise ModelError(f"unknown link {name!r}; the mechanism has {names}")
        return names.index(name)

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
        frame: Frame,
        damping: float = 0.0,
        coriolis: Optional[bool] = None,
        inertia_coupling: Optional[bool] = None,
        geometric: Optional[bool] = None,
        inertia_load: Optional[bool] = None,
        initial_displacement: Optional[np.ndarray] = None,
        initial_velocity: Optional[np.ndarray] = None,
    ) -> Mechanism:
        """Adds a straight flexible link along the x axis of ``frame``.

        Parameters
        ----------
        name : str
            Unique name.
        length : float
            L, m.
        elements : int
            Number of beam elements, 1 ..= 1000000.
        youngs_modulus, density, area, inertia : float
            E (Pa), rho (kg/m^3), A (m^2), I (m^4).
        frame : Frame
            Prescribed motion of the link frame.
        damping : float
            Kelvin-Voigt coefficient eta, Pa s (D1 = (eta/E) K1).
        coriolis, inertia_coupling, geometric, inertia_load : bool or None
            Force a term on or off; None chooses from the frame's motion.
        initial_displacement, initial_velocity : array of 3 (elements + 1) floats, optional
            ``[u, v, theta]`` per node in the link frame (m, rad; m/s, rad/s).
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
            frame,
            float(damping),
            coriolis,
            inertia_coupling,
            geometric,
            inertia_load,
            as_arr(initial_displacement),
            as_arr(initial_velocity),
        )
        self._elements.append(int(elements))
        self._lengths.append(float(length))
        return self

    def add_slider(self, name: str, *, mass: float, path: Frame, angle: float = 0.0) -> Mechanism:
        """Adds a slider block of ``mass`` (kg) on a straight guide at global ``angle`` (rad)
        whose pin follows the origin of ``path`` (e.g. ``Frame.slider_crank(..., link="slider")``)."""
        self._core.add_slider(name, float(mass), float(angle), path)
        self._sliders.append(name)
        return self

    def _target(self, target: Any) -> dict:
        if isinstance(target, str):
            if target not in self._sliders:
                raise ModelError(f"unknown slider {target!r}; the mechanism has {self._sliders}")
            return {"target": "slider", "slider": self._sliders.index(target)}
        if isinstance(target, tuple) and len(target) == 2 and isinstance(target[0], str):
            return {"target": "node", "target_link": self._link(target[0]), "target_node": int(target[1])}
        if isinstance(target, tuple) and len(target) in (2, 3) and isinstance(target[0], _core.Frame):
            pt = tuple(float(v) for v in target[1])
            return {
                "target": "body",
                "frame": target[0],
                "point": pt,
                "body": target[2] if len(target) == 3 else "body",
            }
        raise InvalidParameterError(
            f"target {target!r}: expected (link name, node), a slider name, or (Frame, (x, y)[, body name])"
        )

    def pin(self, name: str, node: NodeRef, target: Target) -> Mechanism:
        """Ideal revolute joint between ``node`` and ``target``: another node ``(link, node)``,
        a slider name, or a rigid-body point ``(frame, (x, y))`` (body frame, m). Translations
        are shared, rotations free. The nominal motions must keep both sides together."""
        self._core.add_pin(name, self._link(node[0]), int(node[1]), **self._target(target))
        return self

    def clearance(
        self,
        name: str,
        node: NodeRef,
        target: Target,
        *,
        clearance: float,
        stiffness: float,
        damping: float,
        damping_law: str = "viscous",
        no_tension: bool = False,
    ) -> Mechanism:
        """Revolute joint with radial ``clearance`` (m): journal at ``node``, bearing at
        ``target`` (as for :meth:`pin`), spring-dashpot bearing ``stiffness`` (N/m) and
        ``damping`` (N s/m)."""
        self._core.add_clearance(
            name,
            self._link(node[0]),
            int(node[1]),
            clearance=float(clearance),
            stiffness=float(stiffness),
            damping=float(damping),
            damping_law=damping_law,
            no_tension=no_tension,
            **self._target(target),
        )
        return self

    def support(
        self, link: str, node: int, *, u: bool = True, v: bool = True, theta: bool = False
    ) -> Mechanism:
        """Holds the chosen elastic DOFs of a node at zero in its link frame."""
        self._core.add_support(self._link(link), int(node), u, v, theta)
        return self

    def clamp(self, link: str, node: int) -> Mechanism:
        """Clamps a node to its frame (u = v = theta = 0): a cantilever root at a hub."""
        return self.support(link, node, u=True, v=True, theta=True)

    def mass(self, link: str, node: int, mass: float) -> Mechanism:
        """A point mass (kg) at a node."""
        self._core.add_mass(self._link(link), int(node), float(mass))
        return self

    def load(
        self, link: str, node: int, *, fu: float = 0.0, fv: float = 0.0, moment: float = 0.0
    ) -> Mechanism:
        """A constant nodal load in the link frame: axial ``fu`` and transverse ``fv`` (N),
        ``moment`` (N m)."""
        self._core.add_load(self._link(link), int(node), float(fu), float(fv), float(moment))
        return self

    def gravity(self, gx: float, gy: float) -> Mechanism:
        """Gravity in global axes, m/s^2 (none by default)."""
        self._core.set_gravity(float(gx), float(gy))
        return self

    def validate(self, t_end: float) -> None:
        """Checks the whole mechanism over ``[0, t_end]`` (s); raises :class:`ModelError` or
        :class:`InvalidParameterError`."""
        self._core.validate(float(t_end))

    # -- analysis ---------------------------------------------------------------------------
    def dof_map(self) -> list[tuple[int, int, str]]:
        """What each unknown is: ``(link index, node, component)``; components ``u, v, theta``
        (link frame), ``x, y`` (global, shared by pinned nodes) or ``s`` (along a guide)."""
        return self._core.dof_map()

    def static_state(self, t: float = 0.0, *, tol: float = 1e-12, max_iter: int = 50) -> np.ndarray:
        """Equilibrium of the unknowns at time ``t`` with the frame rates and accelerations of
        that instant held (e.g. the centrifugally stretched beam at constant speed), by
        fixed-point iteration on the secant stiffness ``K(F) y = -r``. Raises
        :class:`ConvergenceError` if it does not converge."""
        n = len(self.dof_map())
        y = np.zeros(n)
        for _ in range(max_iter):
            _, _, k, r = self._core.linearize(float(t), y)
            dy = np.linalg.solve(k, -r)
            y = y + dy
            if np.max(np.abs(dy)) <= tol * max(np.max(np.abs(y)), 1e-30):
                return y
        raise ConvergenceError(f"static_state did not converge in {max_iter} iterations (t = {t} s)")

    def frequencies(
        self, t: float = 0.0, *, count: int = 5, coriolis: bool = True, state: Optional[np.ndarray] = None
    ) -> np.ndarray:
        """Natural frequencies (rad/s, ascending) of the motion linearized about ``state``
        (default: :meth:`static_state` at ``t``), with the frame motion of instant ``t`` held:
        for a link spinning at constant speed, the in-plane frequencies with centrifugal
        stiffening (K2, K3) and softening (M_IC). ``coriolis=False`` drops the gyroscopic
        coupling (the inextensible-beam idealization of the classic tables). Undamped: the
        damping of the link is ignored."""
        y = self.static_state(t) if state is None else np.asarray(state, dtype=float)
        m, c, k, _ = self._core.linearize(float(t), y)
        n = m.shape[0]
        # The Coriolis part of C is its skew-symmetric part; material damping (symmetric) is dropped.
        g = 0.5 * (c - c.T) if coriolis else np.zeros_like(c)
        if not np.any(g):
            w2 = np.linalg.eigvals(np.linalg.solve(m, k)).real
            w = np.sqrt(np.clip(np.sort(w2), 0.0, None))
        else:
            a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, g)]])
            lam = np.linalg.eigvals(a)
            w = np.sort(np.abs(lam.imag[lam.imag > 1e-9]))
        return w[w > 1e-6][: int(count)]

    def simulate(
        self,
        t_end: float,
        dt: float,
        *,
        method: str = "modified",
        iterate: Optional[bool] = None,
        tol: float = 1e-8,
        max_iter: int = 25,
        step_halving: int = 0,
        beta: float = 0.25,
        gamma: float = 0.5,
        divergence_limit: Optional[float] = None,
        every: int = 1,
        displacements: bool = True,
        axial_force: bool = False,
        midspan: bool = False,
        energy: bool = False,
        progress: Union[bool, Callable[[float], None], None] = None,
        events: bool = False,
    ) -> MechanismResult:
        """Runs the mechanism from rest in its frames (or the given initial state) to ``t_end``.

        Parameters
        ----------
        t_end, dt : float
            End time and step, s.
        method : {"modified", "force"}
            How clearance joints enter the step (METHOD.md section 4).
        iterate : bool or None
            Treat the contact of clearance joints implicitly (modified method with kappa and the
            spring tangent iterated within the step; the damping from the step start). None (the
            default) chooses True when the mechanism has a clearance joint and ``method`` is
            "modified": the lagged variants pump energy into every impact (measured: +169 % after
            22 undamped impacts of two free links, and a lightly damped slider-crank pin running
            away to MN forces), see ``flexclear.scenes.slider_crank``. False gives the paper's
            lagged-kappa method.
        tol, max_iter : float, int
            Newton tolerance (displacement correction over displacement scale) and cap per step.
        step_halving : int
            How often a step that does not converge may be halved (0: raise
            :class:`ConvergenceError` with time, step and residual).
        beta, gamma : float
            Newmark parameters.
        every : int
            Record every k-th step.
        displacements, axial_force, midspan, energy : bool
            Channels to record (see :class:`LinkResult`).
        progress : bool or callable
            Progress bar (True) or callback ``f(fraction)``.
        events : bool
            Event-aware stepping: a step that opens or closes a clearance joint is redone as two
            substeps cut at the crossing (regula falsi on the penetration), with the accelerations
            restarted there with the new contact status; output stays on the ``dt`` grid; the
            joints are tracked at the cut too (the dashpot spike at entry enters ``max_force``).
            Counted in ``stats["event_steps"]``. See docs/stability.md section 6.

        Raises
        ------
        SimulationDivergedError, ConvergenceError, SimulationInterrupted
            With ``.result`` holding what was recorded until then.
        """
        cb = None
        bar = None
        if callable(progress):
            cb = progress
        elif progress:
            from .model import _progress_callback

            cb, bar = _progress_callback(True, t_end)
        try:
            raw = self._core.simulate(
                float(t_end),
                float(dt),
                method=method,
                iterate=(bool(self.joint_names) and method == "modified")
                if iterate is None
                else bool(iterate),
                tol=float(tol),
                max_iter=int(max_iter),
                step_halving=int(step_halving),
                beta=float(beta),
                gamma=float(gamma),
                divergence_limit=divergence_limit,
                every=int(every),
                displacements=displacements,
                axial_force=axial_force,
                midspan=midspan,
                energy=energy,
                progress=cb,
                events=bool(events),
            )
        except FlexclearError as e:
            partial = getattr(e, "partial", None)
            if partial is not None:
                e.result = MechanismResult(partial, self, dt, error=e)
            raise
        finally:
            if bar is not None:
                bar.close()
        return MechanismResult(raw, self, dt)

    def __repr__(self) -> str:
        return repr(self._core)


def _as_seq(x: Union[float, Sequence[float]]) -> list[float]:
    return [float(v) for v in np.atleast_1d(x)]
