"""Rigid-body kinematics of a planar linkage of one's own, solved for the frames of its links.

A mechanism in flexclear moves its links in prescribed frames (:class:`flexclear.Frame`): the
nominal, rigid motion on which the links deform and the clearance joints rattle. The scenes have
their frames in closed form (``Frame.slider_crank``, ``Frame.four_bar``); for any other linkage
of revolute joints and sliders (a six-bar, a quick-return, an offset slider-crank with a rocker),
:class:`Linkage` solves the loop closures at the instants of a table and returns each link's
frame as a tabulated one (interpolated by quintic Hermite polynomials through the solved
positions, velocities and accelerations: error ``O(h^6)`` in the table's spacing ``h``)::

    lk = Linkage()
    lk.ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0))
    lk.crank("crank", "O2", "A", length=0.0508, driver=Rotation.constant(100.0))
    lk.point("B", near=(0.2, 0.27))                   # where B is at t = 0, roughly (the branch)
    lk.link("coupler", "A", "B", length=0.2794)
    lk.link("rocker", "O4", "B", length=0.2794)
    frames = lk.frames(t_end=0.1)                      # {"crank": Frame, "coupler": ..., ...}

:meth:`Linkage.model` builds the :class:`flexclear.Model` on those frames (chosen links flexible,
clearance joints at chosen points, pins elsewhere)::

    m = lk.model(0.1, flexible={"coupler": dict(elements=6, youngs_modulus=7.1e10, density=2710.0,
                                                area=8.06e-5, inertia=6.78e-11)},
                 clearances={"A": dict(clearance=2.5e-4, stiffness=5e7, damping=500.0)})

A link's frame has its origin at the link's first point and its x axis towards the second, so a
flexible link added with ``Model.add_link(..., frame=frames[name])`` lies from node 0 at the
first point to its last node at the second; a body (``Model.add_body(name, frame=...)``) has its
points at the coordinates it was given (a crank's tip at ``(length, 0)``); a slider's frame
(``Model.add_slider(..., path=...)``) follows its point along the guide.

Positions are solved by Newton's method from the previous instant (from the ``near`` guesses at
t = 0), velocities and accelerations from the constraints' first and second time derivatives (the
same Jacobian), so they are exact up to the solver's tolerance, not differences. A linkage that
cannot be assembled (lengths that do not close, a dead point where the Jacobian is singular) raises
:class:`flexclear.ModelError` naming the instant.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from typing import Any, Optional

import numpy as np

from . import _core
from . import motion as _motion
from .errors import ModelError
from .frames import Frame, Rotation
from .motion import _bad, _pair

#: Newton's tolerance on the constraints, as a fraction of the linkage's size.
TOLERANCE: float = _core.LINKAGE_TOLERANCE
#: Largest condition number of the constraint Jacobian before a position counts as a dead point.
MAX_CONDITION: float = _core.LINKAGE_MAX_CONDITION


class Linkage:
    """A planar linkage of rigid links joined by revolute joints at named points, with sliders
    on straight guides, driven by one or more cranks. Units: m, rad, s. See the module's text.

    Every method returns the linkage, so calls chain.
    """

    def __init__(self) -> None:
        self._ground: dict[str, tuple[float, float]] = {}
        self._near: dict[str, tuple[float, float]] = {}
        # name -> (pivot, tip, length, driver)
        self._cranks: dict[str, tuple[str, str, float, Rotation]] = {}
        # name -> {point: (x, y) in the body's frame}, the first two points setting its frame
        self._bodies: dict[str, dict[str, tuple[float, float]]] = {}
        # name -> (point, through, direction)
        self._sliders: dict[str, tuple[str, tuple[float, float], float]] = {}
        # name -> (point, a, b): the point on the line through points a and b of a link
        self._slots: dict[str, tuple[str, str, str]] = {}

    # -- building ------------------------------------------------------------------------------

    def ground(self, name: str, at: Sequence[float]) -> Linkage:
        """A fixed point ``name`` at global ``at`` (m)."""
        self._new_point(name)
        self._ground[name] = _point(f"ground {name!r} at", at)
        return self

    def point(self, name: str, near: Sequence[float]) -> Linkage:
        """A moving point ``name`` (a joint between links, or a slider's pin), about at global
        ``near`` (m) at t = 0: the guess from which the assembly is solved, which picks the
        branch (e.g. a four-bar's open or crossed form)."""
        self._new_point(name)
        self._near[name] = _point(f"point {name!r} near", near)
        return self

    def crank(self, name: str, pivot: str, tip: str, *, length: float, driver: Rotation) -> Linkage:
        """A driven link ``name`` turning about the ground point ``pivot`` at the angle of
        ``driver`` (rad, from the global x axis); its tip ``tip`` (a new point) is at ``length``
        (m) along it. Its frame: origin at the pivot, x axis through the tip."""
        self._new_link(name)
        if pivot not in self._ground:
            raise _bad(f"crank {name!r} pivot", pivot, f"a ground point (have {sorted(self._ground)})")
        if not isinstance(driver, Rotation):
            raise _bad(f"crank {name!r} driver", driver, "a flexclear.Rotation")
        length = _positive(f"crank {name!r} length", length)
        self._new_point(tip)
        self._cranks[name] = (pivot, tip, length, driver)
        return self

    def link(self, name: str, a: str, b: str, *, length: float) -> Linkage:
        """A binary link ``name`` of ``length`` (m) between points ``a`` and ``b`` (declared
        before). Its frame: origin at ``a``, x axis towards ``b``."""
        if a == b:
            raise _bad(f"link {name!r} b", b, f"a point other than a = {a!r}")
        return self.body(name, {a: (0.0, 0.0), b: (_positive(f"link {name!r} length", length), 0.0)})

    def body(self, name: str, points: Mapping[str, Sequence[float]]) -> Linkage:
        """A rigid link ``name`` holding two or three of the declared points, each at its
        coordinates in the link's own frame (m) (a ternary link of a six-bar: three). The
        frame's angle is that of the line from the first point to the second."""
        self._new_link(name)
        if not isinstance(points, Mapping) or not 2 <= len(points) <= 3:
            raise _bad(f"body {name!r} points", points, "a mapping of 2 or 3 point names to (x, y), m")
        local = {}
        for p, xy in points.items():
            self._known_point(f"body {name!r} point", p)
            local[p] = _point(f"body {name!r} point {p!r}", xy)
        xy = list(local.values())
        if any(math.dist(xy[i], xy[j]) <= 0 for i in range(len(xy)) for j in range(i + 1, len(xy))):
            raise _bad(
                f"body {name!r} points", points, "points apart from one another (the first two set its frame)"
            )
        self._bodies[name] = local
        return self

    def slider(
        self, name: str, point: str, *, through: Sequence[float] = (0.0, 0.0), angle: float = 0.0
    ) -> Linkage:
        """A slider ``name`` whose pin ``point`` (declared before) moves on the straight guide
        through ``through`` (m) at global ``angle`` (rad). Its frame: origin at the pin, angle
        ``angle`` (it does not turn)."""
        self._new_link(name)
        self._known_point(f"slider {name!r} point", point)
        angle = _finite(f"slider {name!r} angle", angle)
        self._sliders[name] = (point, _point(f"slider {name!r} through", through), angle)
        return self

    def slot(self, name: str, point: str, a: str, b: str) -> Linkage:
        """A block ``name`` whose pin ``point`` slides along the line through the points ``a``
        and ``b`` of a moving link (a slotted lever, as in a quick-return or a crank-shaper); the
        three points declared before, ``a`` and ``b`` apart on one link. Its frame: origin at the
        pin, x axis along the line from ``a`` to ``b`` (the block turns with the lever)."""
        self._new_link(name)
        for what, p in (("point", point), ("a", a), ("b", b)):
            self._known_point(f"slot {name!r} {what}", p)
        if self._span(a, b) is None:
            raise _bad(
                f"slot {name!r} b",
                b,
                f"a point of the same link as a = {a!r} (the line must turn with a link)",
            )
        if point in (a, b):
            raise _bad(f"slot {name!r} point", point, "a point other than a and b")
        self._slots[name] = (point, a, b)
        return self

    # -- solving -------------------------------------------------------------------------------

    def solve(self, times: Sequence[float]) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Every point's global position (m), velocity (m/s) and acceleration (m/s^2) at the
        increasing ``times`` (s), each of shape ``(len(times), 2)``, solved in turn from the
        ``near`` guesses.

        Raises
        ------
        InvalidParameterError
            ``times`` not finite and increasing.
        ModelError
            The constraints are not as many as the moving points' coordinates, a point belongs
            to no link, or at some instant the linkage does not assemble (the lengths do not
            close, or a dead point).
        """
        t = np.asarray(times, dtype=float)
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise _bad("times", times, "finite, strictly increasing times, s")
        moving = list(self._near)
        cons = self._constraints_of(moving)
        self._check_count(moving, cons)
        names = [*moving, *(p for p in self._all_points() if p not in self._near)]
        at = {p: i for i, p in enumerate(names)}
        scale = max([1e-3, *(abs(c) for xy in [*self._ground.values(), *self._near.values()] for c in xy)])
        pos, vel, acc = _core.solve_linkage(
            np.ascontiguousarray(t),
            [c for p in moving for c in self._near[p]],
            len(moving),
            len(names),
            [(at[c[1]], at[c[2]], c[3]) for c in cons if c[0] == "d"],
            [(at[c[1]], c[2], c[3]) for c in cons if c[0] == "s"],
            [(at[c[1]], at[c[2]], at[c[3]], c[4]) for c in cons if c[0] == "l"],
            [(at[p], xy) for p, xy in self._ground.items()],
            [(name, self._ground[c[0]], at[c[1]], c[2], c[3]) for name, c in self._cranks.items()],
            scale,
        )
        return {p: tuple(np.ascontiguousarray(a[:, i]) for a in (pos, vel, acc)) for p, i in at.items()}

    def frames(self, t_end: float, *, spacing: float = 1e-3, start: float = 0.0) -> dict[str, Frame]:
        """The frame of every crank, link, body and slider over ``[start, t_end]`` (s), tabulated
        every ``spacing`` (s; default 1e-3: a mechanism turning at 150 rad/s then keeps its pins
        closed to about 1e-10 of its size between the samples); the table covers ``t_end``.

        Raises
        ------
        InvalidParameterError
            ``t_end``, ``spacing`` or ``start`` out of range (``0 < spacing``, ``start < t_end``,
            at most 1e6 samples).
        ModelError
            As :meth:`solve`, or a link whose frame is not finite at some instant (its two points
            closer than double precision resolves, or rates beyond it), naming the link and the
            instant.
        """
        t_end = _finite("t_end", t_end)
        start = _finite("start", start)
        spacing = _positive("spacing", spacing)
        if not start < t_end:
            raise _bad("t_end", t_end, f"a time after start = {start} s")
        n = _intervals(t_end - start, spacing)
        times = start + spacing * np.arange(max(n, 1) + 1)
        # the table ends at t_end (its last interval shorter where spacing does not divide it)
        times[-1] = min(times[-1], t_end)
        sol = self.solve(times)
        frames: dict[str, Frame] = {}
        for name, (pivot, tip, _, _) in self._cranks.items():
            frames[name] = _frame(name, times, sol[pivot], sol[tip], (0.0, 0.0), (1.0, 0.0))
        for name, local in self._bodies.items():
            (p0, l0), (p1, l1) = list(local.items())[:2]
            frames[name] = _frame(name, times, sol[p0], sol[p1], l0, l1)
        for name, (point, a, b) in self._slots.items():
            shifted = _shifted(sol[point], sol[a], sol[b])
            frames[name] = _frame(name, times, sol[point], shifted, (0.0, 0.0), (1.0, 0.0))
        for name, (point, _, angle) in self._sliders.items():
            origin = _motion.tabulated(times, *sol[point])
            frames[name] = Frame.rotating(Rotation.fixed(angle), origin=origin)
        return frames

    def model(
        self,
        t_end: float,
        *,
        flexible: Mapping[str, Mapping[str, Any]],
        clearances: Optional[Mapping[str, Mapping[str, Any]]] = None,
        slider_masses: Optional[Mapping[str, float]] = None,
        spacing: float = 1e-3,
        start: float = 0.0,
    ):
        """A :class:`flexclear.Model` of this linkage over ``[start, t_end]`` (s), its frames
        solved by :meth:`frames` (``spacing``, s): the links named in ``flexible`` are beam links,
        every other link moves rigidly on its frame, and each end of a flexible link is joined to
        what else holds its point.

        Parameters
        ----------
        flexible : mapping
            Binary link name (made by :meth:`link`) -> the keyword arguments of
            :meth:`flexclear.Model.add_link` but ``length``, ``frame``, ``motion`` and ``angle``,
            which the linkage sets: ``elements``, ``youngs_modulus`` (Pa), ``density`` (kg/m^3),
            ``area`` (m^2), ``inertia`` (m^4), optionally ``damping``, ``geometric``, ... Node 0
            is at the link's first point, node ``elements`` at its second.
        clearances : mapping, optional
            Point name -> the keyword arguments of :meth:`flexclear.Model.add_joint` (``clearance``
            in m with ``stiffness`` in N/m and ``damping`` in N s/m, or ``law=``; ``friction``,
            ...): the joints at that point are clearance joints; every other joint at a flexible
            link's end is an ideal pin.
        slider_masses : mapping, optional
            Slider name -> its block's mass (kg > 0), for each slider whose pin is a flexible
            link's end (the slider then has its own unknown along the guide).

        Each end ``P`` of a flexible link is joined, in this order, to the ground (a body
        ``"ground"``, fixed) when ``P`` is a ground point; to the first crank, rigid link or slot
        block holding ``P`` (at ``P``'s coordinates in that link's frame); to the slider whose pin
        ``P`` is; else to the other flexible link ending at ``P``. The joint is named ``P`` (``P:link``
        where several flexible links end at ``P``), so ``Result.joint("A")`` is the joint at A.

        Raises
        ------
        InvalidParameterError
            A name that is not a binary link, a point that ends no flexible link, a missing or
            bad slider mass, or an argument the linkage sets; and as :meth:`flexclear.Model.add_link`,
            :meth:`~flexclear.Model.add_joint`.
        ModelError
            As :meth:`frames`.
        """
        from .model import Model

        if not isinstance(flexible, Mapping) or not flexible:
            raise _bad(
                "flexible",
                flexible,
                "a mapping of one binary link name or more to Model.add_link's arguments",
            )
        clearances = {} if clearances is None else clearances
        slider_masses = {} if slider_masses is None else slider_masses
        for what, given in (("clearances", clearances), ("slider_masses", slider_masses)):
            if not isinstance(given, Mapping):
                raise _bad(what, given, "a mapping (or None)")
        ends: dict[str, list[tuple[str, int]]] = {}
        links: dict[str, tuple[float, dict]] = {}
        for name, kw in flexible.items():
            local = self._bodies.get(name)
            if local is None or not _binary(local):
                binary = [n for n, pts in self._bodies.items() if _binary(pts)]
                raise _bad("flexible", name, f"a binary link made by Linkage.link (have {binary})")
            if not isinstance(kw, Mapping):
                raise _bad(f"flexible[{name!r}]", kw, "a mapping of Model.add_link's keyword arguments")
            taken = sorted({"length", "frame", "motion", "angle"} & set(kw))
            if taken:
                raise _bad(f"flexible[{name!r}][{taken[0]!r}]", kw[taken[0]], "none: the linkage sets it")
            _known_keywords(
                f"flexible[{name!r}]", kw, Model.add_link, {"name", "length", "frame", "motion", "angle"}
            )
            (a, _), (b, (length, _)) = local.items()
            links[name] = (length, dict(kw))
            ends.setdefault(a, []).append((name, 0))
            ends.setdefault(b, []).append((name, -1))  # its last node, once the link is made
        for point, kw in clearances.items():
            if point not in ends:
                raise _bad("clearances", point, f"a point at a flexible link's end (have {sorted(ends)})")
            if not isinstance(kw, Mapping):
                raise _bad(f"clearances[{point!r}]", kw, "a mapping of Model.add_joint's keyword arguments")
            _known_keywords(
                f"clearances[{point!r}]",
                kw,
                Model.add_joint,
                {"name", "link", "node", "body", "point", "target", "slider"},
            )
        for slider in slider_masses:
            if slider not in self._sliders:
                raise _bad("slider_masses", slider, f"a slider of the linkage (have {sorted(self._sliders)})")
        frames = self.frames(t_end, spacing=spacing, start=start)
        m = Model()
        for name, (length, kw) in links.items():
            m.add_link(name, length=length, frame=frames[name], **kw)
        # add_link took `elements` as a valid count
        ends = {
            p: [(n, int(links[n][1]["elements"]) if k < 0 else k) for n, k in held]
            for p, held in ends.items()
        }
        ground = "ground" if "ground" not in frames else "ground_"
        added: set[str] = set()

        def body(name: str, frame) -> str:
            if name not in added:
                if frame is None:
                    m.add_body(name)  # fixed at the origin: points in global coordinates
                else:
                    m.add_body(name, frame=frame)
                added.add(name)
            return name

        for point, held in ends.items():
            side = self._holder(point, frames, body, ground, m, links, slider_masses)
            if side is None:
                # only flexible links end here: the first is the others' bearing
                (first, node0), held = held[0], held[1:]
                side = {"target": (first, node0)}
            for link, node in held:
                name = point if len(ends[point]) == 1 else f"{point}:{link}"
                if point in clearances:
                    m.add_joint(name, link, node, **side, **clearances[point])
                else:
                    m.add_pin(name, link, node, **side)
        return m

    def _holder(self, point, frames, body, ground, m, flexible, slider_masses) -> Optional[dict]:
        """The bearing side (``add_joint``'s keyword arguments) of a joint at a flexible link's
        end ``point``: the ground, a rigid link (not one of ``flexible``) holding it, or a slider;
        None when only flexible links end there (bodies and sliders are added to the model ``m``
        as they are first used)."""
        if point in self._ground:
            return {"body": body(ground, None), "point": self._ground[point]}
        for name, (_, tip, length, _) in self._cranks.items():
            if point == tip:
                return {"body": body(name, frames[name]), "point": (length, 0.0)}
        for name, local in self._bodies.items():
            if point in local and name not in flexible:
                return {"body": body(name, frames[name]), "point": local[point]}
        for name, (pin, _, _) in self._slots.items():
            if point == pin:
                return {"body": body(name, frames[name]), "point": (0.0, 0.0)}
        for name, (pin, _, angle) in self._sliders.items():
            if point == pin:
                if name not in m.slider_names:
                    if name not in slider_masses:
                        raise _bad(
                            "slider_masses",
                            dict(slider_masses),
                            f"a mass for slider {name!r} (kg > 0): a flexible link ends on it",
                        )
                    m.add_slider(name, mass=slider_masses[name], path=frames[name], angle=angle)
                return {"slider": name}
        return None

    def plot(self, path, t_end: float, *, poses: int = 6, spacing: Optional[float] = None):
        """Saves a drawing of the linkage to ``path`` (PNG, ...) and returns it: the links at
        ``poses`` instants evenly over ``[0, t_end]`` (s; the first drawn darkest), the paths of
        the moving points over the whole interval, the ground points and the sliders' guides. A
        look at it shows whether the ``near`` guesses picked the intended branch.

        ``spacing`` (s) is that of the points' paths (default ``t_end / 400``).

        Raises
        ------
        InvalidParameterError
            ``t_end``, ``poses`` or ``spacing`` out of range.
        ModelError
            As :meth:`solve`.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t_end = _positive("t_end", t_end)
        if isinstance(poses, bool) or not isinstance(poses, int) or not 1 <= poses <= 100:
            raise _bad("poses", poses, "an integer in [1, 100]")
        spacing = t_end / 400 if spacing is None else _positive("spacing", spacing)
        times = np.linspace(0.0, t_end, _intervals(t_end, spacing) + 1)
        sol = self.solve(times)
        fig, ax = plt.subplots(figsize=(7, 5.5))
        for p in self._near:
            ax.plot(*sol[p][0].T, lw=0.8, color="0.6")
        for _, tip, _, _ in self._cranks.values():
            ax.plot(*sol[tip][0].T, lw=0.8, color="0.6")
        shown = np.linspace(0, times.size - 1, poses).round().astype(int)
        for rank, k in enumerate(shown):
            shade = 0.15 + 0.65 * rank / max(poses - 1, 1)
            color = (shade, shade, 0.35 + 0.65 * shade)
            at = {p: xva[0][k] for p, xva in sol.items()}.__getitem__
            for pivot, tip, _, _ in self._cranks.values():
                ax.plot(*np.array([at(pivot), at(tip)]).T, "-o", color=color, lw=2.2, ms=3)
            for local in self._bodies.values():
                pts = [at(p) for p in local]
                ring = pts + [pts[0]] if len(pts) == 3 else pts
                ax.plot(*np.array(ring).T, "-o", color=color, lw=2.2, ms=3)
            for point, _, _ in self._sliders.values():
                ax.plot(*at(point), "s", color=color, ms=7, mfc="none")
            for point, _, _ in self._slots.values():
                ax.plot(*at(point), "D", color=color, ms=6, mfc="none")
        every = np.concatenate([sol[p][0] for p in sol])
        reach = max(np.abs(every).max(), 1e-3)
        for through, angle in ((s[1], s[2]) for s in self._sliders.values()):
            e = np.array([math.cos(angle), math.sin(angle)])
            line = np.array([np.asarray(through) - 2 * reach * e, np.asarray(through) + 2 * reach * e])
            ax.plot(*line.T, "--", color="0.4", lw=0.8)
        for name, xy in self._ground.items():
            ax.plot(*xy, "^", color="k", ms=9)
            ax.annotate(name, xy, textcoords="offset points", xytext=(4, -12), fontsize=8)
        for p in [*self._near, *(c[1] for c in self._cranks.values())]:
            ax.annotate(p, sol[p][0][0], textcoords="offset points", xytext=(4, 4), fontsize=8)
        pad = 0.08 * max(np.ptp(every[:, 0]), np.ptp(every[:, 1]), 1e-3)
        ax.set_xlim(every[:, 0].min() - pad, every[:, 0].max() + pad)
        ax.set_ylim(every[:, 1].min() - pad, every[:, 1].max() + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(
            f"{poses} poses over 0 to {t_end:g} s (first darkest); grey: the points' paths", fontsize=9
        )
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path

    # -- internals -----------------------------------------------------------------------------

    def _all_points(self) -> list[str]:
        return [*self._ground, *(c[1] for c in self._cranks.values()), *self._near]

    def _new_point(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise _bad("point name", name, "a non-empty string")
        if name in self._all_points():
            raise _bad("point name", name, "a name not used by another point")

    def _known_point(self, what: str, name: str) -> None:
        if name not in self._all_points():
            raise _bad(what, name, f"a point declared before (have {self._all_points()})")

    def _new_link(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise _bad("link name", name, "a non-empty string")
        if name in self._cranks or name in self._bodies or name in self._sliders or name in self._slots:
            raise _bad("link name", name, "a name not used by another link")

    def _check_count(self, moving: list[str], cons: list[tuple]) -> None:
        held = {p for local in self._bodies.values() for p in local}
        held |= {s[0] for s in self._sliders.values()} | {s[0] for s in self._slots.values()}
        loose = [p for p in moving if p not in held]
        if loose:
            raise ModelError(f"linkage: point(s) {loose} belong to no link")
        n = len(cons)
        if n != 2 * len(moving):
            raise ModelError(
                f"linkage: {n} constraints for {len(moving)} moving points ({2 * len(moving)} coordinates): "
                "a linkage of mobility one per crank needs as many; "
                + ("add links or sliders" if n < 2 * len(moving) else "remove a link (over-constrained)")
            )

    def _constraints_of(self, moving: list[str]) -> list[tuple]:
        """The constraints: ("d", p, q, length) for two points of a body, one of them moving;
        ("s", p, through, direction) for a slider's pin; ("l", p, a, b, |b - a|) for a slot's
        pin on the line through a and b."""
        cons: list[tuple] = []
        mov = set(moving)
        for local in self._bodies.values():
            names = list(local)
            for i in range(len(names)):
                for j in range(i + 1, len(names)):
                    p, q = names[i], names[j]
                    if p in mov or q in mov:
                        cons.append(("d", p, q, math.dist(local[p], local[q])))
        for point, through, angle in self._sliders.values():
            if point in mov:
                cons.append(("s", point, through, (math.cos(angle), math.sin(angle))))
        for point, a, b in self._slots.values():
            cons.append(("l", point, a, b, self._span(a, b)))
        return cons

    def _span(self, a: str, b: str) -> Optional[float]:
        """The distance (m) between points ``a`` and ``b`` of one link (a body or a crank), or
        None when no link holds both."""
        for local in self._bodies.values():
            if a in local and b in local:
                return math.dist(local[a], local[b])
        for pivot, tip, length, _ in self._cranks.values():
            if {a, b} == {pivot, tip}:
                return length
        return None


def _binary(local: Mapping[str, tuple[float, float]]) -> bool:
    """Whether a link's points (in its frame) are those :meth:`Linkage.link` makes: two, the
    first at the origin and the second on the positive x axis (a beam from node 0 to its last
    node)."""
    if len(local) != 2:
        return False
    (x0, y0), (x1, y1) = local.values()
    return x0 == y0 == y1 == 0.0 and x1 > 0.0


def _known_keywords(what: str, given: Mapping[str, Any], method, fixed: set[str]) -> None:
    """Raises InvalidParameterError naming ``what[key]`` for a key of ``given`` that ``method``
    does not take as a keyword, or that the linkage sets itself (``fixed``)."""
    allowed = sorted(set(inspect.signature(method).parameters) - {"self"} - fixed)
    for key in given:
        if key not in allowed:
            raise _bad(
                f"{what}[{key!r}]", given[key], f"a keyword of {method.__qualname__}: one of {allowed}"
            )


def _cross(u: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Row-wise ``u x w`` of arrays of 2-vectors."""
    return u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]


def _shifted(p, a, b):
    """The motion (positions, velocities, accelerations) of ``p + (b - a)``."""
    return tuple(p[k] + b[k] - a[k] for k in range(3))


def _frame(name: str, times, first, second, l0, l1) -> Frame:
    """The tabulated frame of link ``name`` whose points at local ``l0`` and ``l1`` move as
    ``first`` and ``second`` (each positions, velocities, accelerations over ``times``).

    Raises ModelError naming the link and the instant where its angle, rate or angular
    acceleration is not finite (two points closer than double precision resolves, e.g. a crank
    1e-300 m long), and InvalidParameterError (``spacing``) when the link turns more than 1 rad
    between two samples: the angle is unwrapped between them, and the interpolation's error grows
    as the sixth power of the turn."""
    (p0, v0, a0), (p1, v1, a1) = first, second
    with np.errstate(all="ignore"):
        d, dv, da = p1 - p0, v1 - v0, a1 - a0
        r2 = np.einsum("ij,ij->i", d, d)
        rate = _cross(d, dv) / r2
        accel = _cross(d, da) / r2 - 2 * rate * np.einsum("ij,ij->i", d, dv) / r2
    bad = ~(np.isfinite(rate) & np.isfinite(accel) & (r2 > 0))
    if bad.any():
        k = int(np.argmax(bad))
        raise ModelError(
            f"linkage: link {name!r} has no finite frame at t = {times[k]:.6g} s (its points "
            f"{math.sqrt(r2[k]) if np.isfinite(r2[k]) else r2[k]:.3g} m apart, their relative speed "
            f"{float(np.hypot(*dv[k])):.3g} m/s): lengths or rates beyond double precision"
        )
    h = float(times[1] - times[0]) if len(times) > 1 else 0.0
    fastest = float(np.max(np.abs(rate)))
    if fastest * h > 1.0:
        raise _bad(
            "spacing",
            h,
            f"at most {1 / fastest:.3g} s: link {name!r} turns at up to {fastest:.4g} rad/s, "
            f"{fastest * h:.3g} rad a sample (1 at most)",
        )
    angle = np.unwrap(np.arctan2(d[:, 1], d[:, 0])) - math.atan2(l1[1] - l0[1], l1[0] - l0[0])
    # origin = first - R(angle) l0, differentiated
    c, s = np.cos(angle), np.sin(angle)
    rl = np.stack([c * l0[0] - s * l0[1], s * l0[0] + c * l0[1]], axis=1)
    jrl = np.stack([-rl[:, 1], rl[:, 0]], axis=1)  # the axis J R l0
    origin = p0 - rl
    vel = v0 - rate[:, None] * jrl
    acc = a0 - accel[:, None] * jrl + (rate * rate)[:, None] * rl
    return Frame.rotating(
        Rotation.tabulated(times, angle, rate, accel), origin=_motion.tabulated(times, origin, vel, acc)
    )


def _intervals(span: float, spacing: float) -> int:
    """The intervals of ``spacing`` (s) that cover ``span`` (s); at most 1e6, else an
    InvalidParameterError naming ``spacing`` (counted as a float first: a spacing of 5e-324 s
    makes it infinite)."""
    count = span / spacing
    if not count <= 1e6:
        raise _bad("spacing", spacing, f"at least (t_end - start) / 1e6 = {span / 1e6:g} s")
    return math.ceil(count - 1e-9)


def _point(name: str, xy: Any) -> tuple[float, float]:
    p = _pair(name, xy, "m")
    if not all(math.isfinite(c) for c in p):
        raise _bad(name, xy, "a pair of finite numbers (x, y), m")
    return p


def _finite(name: str, x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise _bad(name, x, "a finite number") from None
    if isinstance(x, bool) or not math.isfinite(v):
        raise _bad(name, x, "a finite number")
    return v


def _positive(name: str, x: Any) -> float:
    v = _finite(name, x)
    if v <= 0:
        raise _bad(name, x, "a finite number > 0")
    return v


__all__ = ["Linkage", "MAX_CONDITION", "TOLERANCE"]
