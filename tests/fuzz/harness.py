"""Fuzzing flexclear through its public API.

A *case* is plain JSON data (so a failing case is reproducible from the file it is written to):
``{"kind": "model" | "scene" | "study" | "linkage", ...}``, made by :func:`generate` from ``(seed, index)``
alone. Objects of the API are tagged dicts: ``{"$rotation": [method, kwargs]}``,
``{"$motion": [function, kwargs]}``, ``{"$frame": [method, kwargs]}``, ``{"$record": kwargs}``,
``{"$dist": [class, args]}``, ``{"$tuple": [...]}``. Non-finite floats are JSON's ``NaN`` and
``Infinity`` (as Python's :mod:`json` writes them).

:func:`execute` runs one case in the calling process and classifies it:

* ``ok``: a finite result (every documented-finite float of the :class:`flexclear.Result` or
  the study frame is finite);
* ``flexclear_error``: an instance of :class:`flexclear.FlexclearError`;
* ``foreign_exception``: any other exception (type, message and case reported);
* ``nan``: a completed run with non-finite values where finite ones are documented.

:class:`Pool` runs cases in worker processes (a time limit per case, ``RLIMIT_AS`` in the child)
and adds the classes ``crash`` (the worker died: a signal, an abort; or a Rust panic surfacing as
``pyo3_runtime.PanicException``) and ``hang`` (the time limit passed; the worker is killed and
restarted).
"""

from __future__ import annotations

import json
import math
import os
import queue
import random
import select
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import warnings
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Optional

OUTCOMES = ("ok", "flexclear_error", "foreign_exception", "nan", "crash", "hang")
#: The classes a clean run has none of.
FAILURES = ("foreign_exception", "nan", "crash", "hang")

TESTS_DIR = str(Path(__file__).resolve().parent.parent)

NAN, INF = float("nan"), float("inf")
_HOSTILE_NUMBERS = [0.0, -1.0, -1e-3, NAN, INF, -INF, 1e300, -1e300, 1e-300, 5e-324, 1e20, 0]
_HOSTILE_TYPES: list[Any] = ["abc", None, [1.0, 2.0], True, {"a": 1}, "1e-3"]
_HOSTILE_INTS: list[Any] = [0, -1, 2.5, 8.0, 10**7, 2**64, -(2**63), NAN, "8", True, None, INF]


# ---------------------------------------------------------------------------------------------
# Generation
# ---------------------------------------------------------------------------------------------


class _Gen:
    """Random parameters, sane with probability ``1 - hostility`` each, hostile otherwise."""

    def __init__(self, rng: random.Random, hostility: float) -> None:
        self.r = rng
        self.h = hostility

    def hostile(self) -> bool:
        return self.r.random() < self.h

    def bad_value(self) -> Any:
        return self.r.choice(_HOSTILE_TYPES) if self.r.random() < 0.2 else self.r.choice(_HOSTILE_NUMBERS)

    def num(self, lo: float, hi: float, *, log: bool = True, zero: float = 0.0) -> Any:
        """A number in ``[lo, hi]`` (log-uniform when ``log``), 0 with probability ``zero``."""
        if self.hostile():
            return self.bad_value()
        if zero and self.r.random() < zero:
            return 0.0
        if log and lo > 0:
            return math.exp(self.r.uniform(math.log(lo), math.log(hi)))
        return self.r.uniform(lo, hi)

    def integer(self, lo: int, hi: int) -> Any:
        if self.hostile():
            return self.r.choice(_HOSTILE_INTS)
        return self.r.randint(lo, hi)

    def flag(self) -> Any:
        if self.hostile():
            return self.r.choice([None, "yes", 2, NAN])
        return self.r.random() < 0.5

    def choice(self, options: list, wrong: Optional[list] = None) -> Any:
        if self.hostile():
            return self.r.choice((wrong or []) + ["nonsense", None, 3, ""])
        return self.r.choice(options)

    def maybe(self, p: float = 0.5) -> bool:
        return self.r.random() < p


def _rotation(g: _Gen) -> dict:
    kind = g.r.choice(["fixed", "constant", "constant", "spin_up", "harmonic", "tabulated"])
    if kind == "fixed":
        kw = {"angle": g.num(-3.0, 3.0, log=False)}
    elif kind == "constant":
        kw = {"rate": g.num(-50.0, 50.0, log=False), "angle0": g.num(-3.0, 3.0, log=False)}
    elif kind == "spin_up":
        kw = {"final_rate": g.num(0.1, 20.0), "ramp_time": g.num(0.01, 2.0)}
    elif kind == "harmonic":
        kw = {"amplitude": g.num(0.0, 1.0, log=False), "frequency": g.num(0.1, 20.0)}
    else:
        n = g.r.randint(0, 5) if g.hostile() else g.r.randint(2, 5)
        t = sorted(g.r.uniform(0.0, 1.0) for _ in range(n))
        if n and not g.hostile():
            t[0], t[-1] = 0.0, 10.0
        kw = {"time": t, "angle": [g.num(-1.0, 1.0, log=False) for _ in range(n + (g.hostile()))]}
    return {"$rotation": [kind, kw]}


def _motion(g: _Gen) -> dict:
    kind = g.r.choice(["fixed", "harmonic", "harmonic", "tabulated"])
    if kind == "fixed":
        kw = {"position": [g.num(-0.1, 0.1, log=False), g.num(-0.1, 0.1, log=False)]}
    elif kind == "harmonic":
        kw = {
            "amplitude": [g.num(0.0, 0.02, log=False), g.num(0.0, 0.02, log=False)],
            "frequency": g.num(0.5, 50.0),
            "phase": g.num(-3.0, 3.0, log=False),
        }
    else:
        n = g.r.randint(0, 4) if g.hostile() else g.r.randint(2, 4)
        t = [10.0 * k / max(n - 1, 1) for k in range(n)]
        if g.hostile():
            g.r.shuffle(t)
        kw = {"time": t, "position": [[g.num(-0.01, 0.01, log=False), 0.0] for _ in range(n)]}
    return {"$motion": [kind, kw]}


def _frame(g: _Gen, link: str) -> dict:
    kind = g.r.choice(["rotating", "rotating", "slider_crank", "four_bar"])
    driver = {"$rotation": ["constant", {"rate": g.num(1.0, 100.0)}]}
    if kind == "rotating":
        kw = {"rotation": _rotation(g), "origin": _motion(g) if g.maybe(0.3) else None}
    elif kind == "slider_crank":
        kw = {
            "crank": g.num(0.05, 0.2),
            "rod": g.num(0.25, 0.5),
            "driver": driver,
            "link": g.choice(["crank", "rod", "slider"], ["coupler"]) if link != "slider" else "slider",
            "offset": g.num(-0.02, 0.02, log=False),
        }
    else:
        kw = {
            "ground": g.num(0.2, 0.3),
            "crank": g.num(0.03, 0.06),
            "coupler": g.num(0.25, 0.3),
            "rocker": g.num(0.25, 0.3),
            "driver": driver,
            "link": g.choice(["crank", "coupler", "rocker"], ["rod"]),
            "branch": g.choice([1.0, -1.0], [0.0, 0.5]),
        }
    return {"$frame": [kind, kw]}


def _record(g: _Gen, t_end: Any, links: list, joints: list) -> dict:
    rec: dict[str, Any] = {}
    if g.maybe(0.3):
        rec["joints"] = g.r.sample(joints, g.r.randint(0, len(joints))) if joints else []
        if g.hostile():
            rec["joints"] = ["no_such_joint"] if g.maybe() else g.bad_value()
    if g.maybe(0.3):
        rec["position"] = g.flag()
    if g.maybe(0.3) and links:
        name, n = g.r.choice(links)
        rec["nodes"] = [[name, g.integer(0, n)] for _ in range(g.r.randint(1, 2))]
    for key in ("displacements", "midspan", "axial_force", "energy", "histories", "impact_log"):
        if g.maybe(0.25):
            rec[key] = g.flag()
    if True in (rec.get("midspan"), rec.get("axial_force")) and not g.hostile():
        rec["displacements"] = True  # they need them (refusing the mix is tested when hostile)
    if g.maybe(0.3):
        rec["every"] = g.integer(1, 50)
    if g.maybe(0.3):
        te = t_end if isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0 else 1.0
        rec["start"] = g.num(0.0, 0.95 * te, log=False)
        if g.hostile():
            rec["start"] = g.r.choice([te, 2 * te, te * (1 - 1e-12), -0.0])
    for key in ("link_peaks", "contact_modes"):
        if g.maybe(0.15):
            rec[key] = g.flag()
    return {"$record": rec, "as_dict": g.maybe(0.3)}


def _run_options(g: _Gen, moving: bool) -> dict:
    kw: dict[str, Any] = {}
    if g.maybe(0.2):
        kw["method"] = g.choice(["modified", "force", "gap"] if not moving else ["modified", "force"])
    if g.maybe(0.3):
        kw["iterate"] = g.flag()
    if g.maybe(0.2):
        kw["events"] = g.flag()
    if g.maybe(0.15):
        kw["iter_tol"] = g.num(1e-14, 1e-4)
    if g.maybe(0.15):
        kw["max_iter"] = g.integer(1, 60)
    if g.maybe(0.15):
        kw["beta"] = g.num(0.05, 0.5, log=False)
        kw["gamma"] = g.num(0.5, 1.0, log=False)
    if g.maybe(0.1):
        kw["solver"] = g.choice(["woodbury", "refactor"])
    if g.maybe(0.15) and moving:
        kw["step_halving"] = g.integer(0, 4)
    if g.maybe(0.1):
        kw["divergence_limit"] = g.num(1e-6, 10.0)
    if g.maybe(0.1):
        kw["memory_limit"] = g.num(1e3, 1e9)
    if g.maybe(0.1) and not moving:
        kw["gap_stiffness"] = g.num(1e4, 1e10)
        kw["gap_damping"] = g.num(0.0, 100.0, log=False)
    if g.maybe(0.3):
        kw["raise_on_failure"] = g.flag()
    # later features (drawn last, so the draws above keep their order)
    if g.maybe(0.06):
        kw["tol"] = g.num(1e-3, 0.5)  # adaptive steps; dt becomes the output grid
        for k in ("beta", "gamma", "iterate", "method", "gap_stiffness", "gap_damping"):
            if not g.hostile():
                kw.pop(k, None)
    if g.maybe(0.08):
        kw["integrator"] = g.choice(["newmark", "generalized-alpha", "hht"])
        if g.maybe():
            kw["rho_inf"] = g.num(0.0, 1.0, log=False)
        if g.maybe(0.3):
            kw["hht_alpha"] = g.num(-1 / 3, 0.0, log=False)
        if not g.hostile():
            kw.pop("beta", None)
            kw.pop("gamma", None)
            if kw.get("integrator") != "generalized-alpha":
                kw.pop("rho_inf", None)
            if kw.get("integrator") != "hht":
                kw.pop("hht_alpha", None)
    if g.maybe(0.05):
        kw["method"] = "continuous"
        if not g.hostile():
            for k in ("tol", "events", "iterate", "gap_stiffness", "gap_damping"):
                kw.pop(k, None)
    return kw


def _times(g: _Gen, dt_lo: float, dt_hi: float, max_steps: int) -> tuple[Any, Any]:
    """``(t_end, dt)``: sane ones keep the run short (at most ``max_steps`` steps); hostile ones
    are hostile in a way that cannot ask for a legitimately long run."""
    dt = math.exp(g.r.uniform(math.log(dt_lo), math.log(dt_hi)))
    t_end = dt * g.r.randint(1, max_steps)
    if g.hostile():
        t_end, dt = g.r.choice(
            [
                (g.bad_value(), dt),
                (t_end, g.bad_value()),
                (1e300, 1e299),
                (dt / 3, dt),
                (t_end, t_end),
                (1e-300, 1e-301),
                (INF, INF),
                (5e-324, 5e-324),
            ]
        )
    return t_end, dt


def _action(g: _Gen, moving: bool, links: list, joints: list, dt_range=(1e-6, 1e-4), steps=1500) -> dict:
    r = g.r.random()
    if r < 0.8:
        t_end, dt = _times(g, *dt_range, steps)
        opts = _run_options(g, moving)
        if "tol" in opts and all(isinstance(x, float) and math.isfinite(x) for x in (t_end, dt)):
            # an adaptive run takes as many steps as its accuracy asks (21.7 million on one
            # random stiff model of 0.09 s): keep it to a few output steps
            t_end = min(t_end, 20 * dt)
        if g.maybe(0.6):
            opts["record"] = _record(g, t_end, links, joints)
        return {"do": "simulate", "t_end": t_end, "dt": dt, "options": opts}
    if r < 0.86:
        return {"do": "static_state", "t": g.num(0.0, 1.0, log=False), "contacts": g.flag()}
    if r < 0.92:
        return {"do": "natural_frequencies", "count": g.integer(1, 6), "t": g.num(0.0, 1.0, log=False)}
    if r < 0.96:
        t_end, dt = _times(g, *dt_range, steps)
        rec = _record(g, t_end, links, joints) if g.maybe() else None
        return {"do": "memory_estimate", "t_end": t_end, "dt": dt, "record": rec}
    return {"do": "dof_map"}


def _model_case(g: _Gen) -> dict:
    ops: list = []
    links: list = []
    bodies: list = []
    sliders: list = []
    joints: list = []
    translating = g.maybe(0.4)
    frames: dict = {}  # link name -> its frame (moving links)
    link_kw: dict = {}  # link name -> its keywords
    for i in range(g.r.randint(1, 3)):
        name = f"L{i}" if not g.hostile() else g.r.choice(["", "L0", None, 7])
        n = g.integer(1, 8)
        area = g.num(1e-5, 1e-3)
        kw: dict[str, Any] = {
            "length": g.num(0.05, 1.0),
            "elements": n,
            "youngs_modulus": g.num(1e9, 3e11),
            "density": g.num(1000.0, 9000.0),
            "area": area,
            "inertia": (area * area / 12.0)
            if isinstance(area, float) and not g.hostile()
            else g.num(1e-12, 1e-7),
        }
        if g.maybe(0.3):
            kw["damping"] = g.num(0.0, 1e5, zero=0.3)
        if translating or g.maybe(0.3):
            if g.maybe(0.4):
                kw["angle"] = g.num(-3.0, 3.0, log=False)
            if g.maybe(0.6):
                kw["motion"] = _motion(g)
            if g.maybe(0.1) and (translating or g.hostile()):  # only the constant stepper has it
                kw["rotary_inertia"] = g.flag()
        else:
            kw["frame"] = _frame(g, name if isinstance(name, str) else "")
            frames[name] = kw["frame"]
        if not translating and g.maybe(0.2):
            for t in ("coriolis", "inertia_coupling", "geometric", "inertia_load"):
                if g.maybe(0.4):
                    kw[t] = g.flag()
        if g.maybe(0.1):
            size = 3 * (n + 1) if isinstance(n, int) and 0 < n < 100 else 3
            if g.hostile():
                size += g.r.choice([-1, 1])
            kw["initial_displacement"] = [g.num(-1e-4, 1e-4, log=False) for _ in range(size)]
        ops.append(["add_link", name, kw])
        if isinstance(name, str) and isinstance(n, int) and 0 < n < 100:
            links.append((name, n))
            link_kw[name] = kw
    for i in range(g.r.randint(0, 2)):
        kw = {}
        if translating or g.maybe(0.5):
            if g.maybe(0.7):
                kw["motion"] = _motion(g)
        else:
            kw["frame"] = _frame(g, "crank")
        ops.append(["add_body", f"B{i}", kw])
        bodies.append(f"B{i}")
    if not translating and g.maybe(0.2):
        ops.append(["add_slider", "S0", {"mass": g.num(0.01, 1.0), "path": _frame(g, "slider")}])
        sliders.append("S0")

    def node_of() -> tuple[Any, Any]:
        if not links or g.hostile():
            return g.r.choice(["nope", "L0"]), g.integer(0, 3)
        name, n = g.r.choice(links)
        return name, g.integer(0, n)

    def shadow(link: str, node: int) -> Optional[dict]:
        """A body that moves with ``link`` (its frame, or its motion) and the point where
        ``node`` sits on it: a joint or pin there closes whatever the link's motion. None where
        the link's keywords are hostile."""
        kw = link_kw[link]
        length, angle = kw["length"], kw.get("angle", 0.0)
        if not all(isinstance(x, float) and math.isfinite(x) for x in (length, angle)):
            return None
        body = f"S_{link}"
        if body not in bodies:
            ops.append(["add_body", body, {k: kw[k] for k in ("frame", "motion") if k in kw}])
            bodies.append(body)
        x = node * length / kw["elements"]
        point = [x, 0.0] if "frame" in kw else [x * math.cos(angle), x * math.sin(angle)]
        return {"body": body, "point": point}

    def other_side(link: Any = None) -> dict:
        """The other side of a joint or pin on ``link``: sane, never ``link`` itself."""
        others = [x for x in links if x[0] != link]
        choices = ["body"] * bool(bodies) + ["target"] * bool(others) + ["slider"] * bool(sliders)
        if not choices and not g.hostile():  # a body to hold it
            ops.append(["add_body", "B0", {}])
            bodies.append("B0")
            choices = ["body"]
        if not choices or g.hostile():
            return g.r.choice([{}, {"body": "nobody"}, {"body": "B0", "target": ["L0", 0]}])
        kind = g.r.choice(choices)
        if kind == "body":
            out: dict[str, Any] = {"body": g.r.choice(bodies)}
            if g.maybe():
                out["point"] = [g.num(-0.1, 0.1, log=False), g.num(-0.1, 0.1, log=False)]
            return out
        if kind == "target":
            if not g.hostile():
                name, n = g.r.choice(others)
                return {"target": [name, g.r.randint(0, n)]}
            return {"target": list(node_of())}
        return {"slider": g.r.choice(sliders)}

    held: set = set()  # links a joint, pin or support holds
    for i in range(g.r.randint(0, 3)):
        link, node = node_of()
        # mostly a joint that starts closed or centred (to a body moving with the link); else
        # anywhere, which tends to start with a large penetration
        side = shadow(link, node) if link in link_kw and isinstance(node, int) and g.maybe(0.7) else None
        kw = {
            "clearance": g.num(1e-6, 1e-3, zero=0.2),
            "stiffness": g.num(1e5, 1e9),
            "damping": g.num(1.0, 1e3, zero=0.2),
            **(side or other_side(link)),
        }
        held.add(link)
        if g.maybe(0.2):
            kw["damping_law"] = g.choice(["viscous", "radial", "literal"])
        if g.maybe(0.1):
            kw["no_tension"] = g.flag()
        if g.maybe(0.08):
            law = g.r.choice(["Coulomb", "LuGre"])
            fkw: dict[str, Any] = {"mu": g.num(0.0, 1.0, log=False)} if law == "Coulomb" else {}
            if law == "LuGre":
                mu = g.num(0.01, 1.0)
                fkw = {
                    "mu": mu,
                    "mu_static": mu * 1.3 if isinstance(mu, float) else mu,
                    "sigma0": g.num(1e3, 1e9),
                }
            kw["friction"] = g.bad_value() if g.hostile() else {"$friction": [law, fkw]}
            kw["journal_radius"] = g.num(1e-3, 2e-2)
        name = f"J{i}"
        ops.append(["add_joint", name, link, node, kw])
        joints.append(name)
    if translating:
        for name, n in links:  # a free link is refused by the model's check: hold each one
            if g.maybe(0.97 if name not in held else 0.3):  # at both ends, or it swings about one
                for node in (0, n):
                    side = shadow(name, node)
                    if side is None:
                        continue
                    kw = {"clearance": g.num(1e-6, 1e-4), "stiffness": g.num(1e6, 1e9), "damping": 10.0}
                    ops.append(["add_joint", f"H{name}.{node}", name, node, {**kw, **side}])
                    joints.append(f"H{name}.{node}")
    else:
        pinned = set()
        for i in range(g.r.randint(0, 2) if g.maybe(0.4) else 0):
            if g.hostile():
                link, node = node_of()
                ops.append(["add_pin", f"P{i}", link, node, other_side(link)])
                continue
            # a pin that closes: node 0 of a link whose frame turns about the origin, to a body
            # fixed there
            about_origin = [
                x
                for x in links
                if x[0] not in pinned
                and (frames.get(x[0]) or {}).get("$frame", [""])[0] == "rotating"
                and frames[x[0]]["$frame"][1].get("origin") is None
            ]
            if not about_origin:
                continue
            link = g.r.choice(about_origin)[0]
            ops.append(["add_body", f"G{i}", {}])
            ops.append(["add_pin", f"P{i}", link, 0, {"body": f"G{i}"}])
            pinned.add(link)
        for name, n in links:  # hold the links (a free link is refused by the model's check)
            if name not in pinned and g.maybe(0.97 if name not in held else 0.6):
                ops.append(["add_support", name, g.r.choice([0, n]), {"theta": g.maybe(0.8)}])
        if g.maybe(0.3):
            link, node = node_of()
            ops.append(["add_support", link, node, {k: g.flag() for k in ("u", "v", "theta") if g.maybe()}])
        if g.maybe(0.15):
            link, node = node_of()
            ops.append(["add_clamp", link, node, {}])
        if g.maybe(0.2):
            link, node = node_of()
            ops.append(["add_mass", link, node, {"mass": g.num(1e-3, 1.0, zero=0.1)}])
        if g.maybe(0.2):
            link, node = node_of()
            kw = {k: g.num(-100.0, 100.0, log=False) for k in ("fu", "fv", "moment") if g.maybe()}
            ops.append(["add_load", link, node, kw])
        if g.maybe(0.2):
            ops.append(
                ["add_gravity", {"gx": g.num(-10.0, 10.0, log=False), "gy": g.num(-10.0, 0.0, log=False)}]
            )
    moving = not translating
    return {"kind": "model", "ops": ops, "action": _action(g, moving, links, joints, steps=1000)}


#: Sane ranges of each scene's keywords, and the run scale: (dt range, max steps).
_SCENES: dict[str, tuple[dict, tuple, int]] = {
    "slider_yoke": (
        {
            "clearance": (1e-6, 1e-3),
            "amplitude": (1e-3, 0.02),
            "frequency": (1.0, 20.0),
            "bearing_stiffness": (1e5, 1e8),
            "bearing_damping": (1.0, 1e3),
            "elements": (2, 16),
            "length": (0.1, 0.5),
            "side": (0.005, 0.02),
            "density": (2000.0, 9000.0),
            "youngs_modulus": (5e10, 3e11),
            "first_frequency": (200.0, 2000.0),
            "damping_ratio": (0.0, 0.1),
            "stiffness_ratio": (10.0, 200.0),
            "bearing_damping_ratio": (0.0, 1.0),
            "damping_law": ["viscous", "radial", "literal"],
            "no_tension": [True, False],
            "geometry": ["end", "both_ends", "mid_span"],
            "rotary_inertia": [True, False],
        },
        (2e-6, 5e-5),
        2000,
    ),
    "slider_yoke_stiff": ({"clearance": (1e-7, 1e-4), "elements": (2, 12)}, (1e-7, 5e-6), 1000),
    "slider_crank": (
        {
            "crank_length": (0.05, 0.2),
            "rod_length": (0.25, 0.5),
            "crank_speed": (10.0, 200.0),
            "side": (0.004, 0.02),
            "youngs_modulus": (5e10, 3e11),
            "density": (2000.0, 9000.0),
            "slider_mass": (0.01, 1.0),
            "elements": (1, 12),
            "damping": (0.0, 1e4),
            "offset": (-0.02, 0.02),
            "clearance_at": [None, "crank_pin", "slider_pin"],
            "clearance": (1e-6, 1e-3),
            "bearing_stiffness": (1e6, 1e9),
            "bearing_damping": (1.0, 1e4),
            "pin_radius": (1e-3, 1e-2),
            "poisson_ratio": (0.0, 0.45),
            "reference_penetration": (1e-6, 1e-4),
            "bearing_damping_ratio": (0.0, 1.0),
            "damping_law": ["viscous", "radial", "literal"],
            "geometric": [None, True, False],
        },
        (1e-6, 5e-5),
        1000,
    ),
    "four_bar": (
        {
            "ground_length": (0.2, 0.3),
            "crank_length": (0.03, 0.06),
            "coupler_length": (0.25, 0.3),
            "rocker_length": (0.25, 0.3),
            "crank_speed": (10.0, 200.0),
            "branch": [1, -1],
            "youngs_modulus": (5e10, 3e11),
            "density": (2000.0, 9000.0),
            "width": (0.01, 0.05),
            "depth": (0.001, 0.01),
            "elements": (1, 10),
            "flexible_rocker": [True, False],
            "rocker_elements": (1, 8),
            "damping": (0.0, 1e4),
            "clearance_at": [None, "crank_pin", "rocker_pin"],
            "clearance": (1e-6, 1e-3),
            "bearing_stiffness": (1e6, 1e9),
            "bearing_damping": (1.0, 1e4),
            "pin_radius": (1e-3, 1e-2),
            "poisson_ratio": (0.0, 0.45),
            "reference_penetration": (1e-6, 1e-4),
            "bearing_damping_ratio": (0.0, 1.0),
            "damping_law": ["viscous", "radial", "literal"],
        },
        (1e-6, 5e-5),
        1000,
    ),
    "spin_up": (
        {
            "data": ["kane", "simo"],
            "length": (1.0, 10.0),
            "youngs_modulus": (1e10, 2e11),
            "density": (1000.0, 8000.0),
            "area": (1e-5, 1e-3),
            "inertia": (1e-9, 1e-6),
            "final_rate": (0.5, 10.0),
            "ramp_time": (1.0, 20.0),
            "elements": (1, 12),
            "geometric": [True, False],
            "damping": (0.0, 1e6),
        },
        (1e-4, 1e-2),
        500,
    ),
}


def _scene_value(g: _Gen, spec: Any) -> Any:
    if isinstance(spec, list):
        return g.choice(spec)
    lo, hi = spec
    if isinstance(lo, int) and isinstance(hi, int):
        return g.integer(lo, hi)
    if lo <= 0:
        return g.num(lo, hi, log=False)
    return g.num(lo, hi)


def _scene_case(g: _Gen) -> dict:
    scene = g.r.choice(list(_SCENES))
    table, dt_range, steps = _SCENES[scene]
    keys = g.r.sample(list(table), g.r.randint(0, min(6, len(table))))
    kwargs = {k: _scene_value(g, table[k]) for k in keys}
    if scene == "spin_up" and g.maybe(0.2):
        kwargs["rotation"] = _rotation(g)
    joints = {"slider_yoke": ["bearing", "bearing_2"], "slider_yoke_stiff": ["bearing"]}.get(scene, [])
    if "clearance_at" in kwargs and isinstance(kwargs["clearance_at"], str):
        joints = [kwargs["clearance_at"]]
    links = {"slider_crank": [("rod", 8)], "four_bar": [("coupler", 6)], "spin_up": [("beam", 10)]}.get(
        scene, [("slider", 12)]
    )
    moving = scene not in ("slider_yoke", "slider_yoke_stiff")
    return {
        "kind": "scene",
        "scene": scene,
        "kwargs": kwargs,
        "action": _action(g, moving, links, joints, dt_range, steps),
    }


_DISTS = ("Uniform", "Normal", "TruncatedNormal", "LogNormal", "Values", "list", "dict")


def _dist(g: _Gen, lo: float, hi: float, integer: bool = False) -> Any:
    kind = g.r.choice(_DISTS)
    mid = 0.5 * (lo + hi)
    if kind == "Uniform":
        return {"$dist": ["Uniform", [g.num(lo, mid, log=False), g.num(mid, hi, log=False)]]}
    if kind == "Normal":
        return {"$dist": ["Normal", [g.num(lo, hi, log=False), g.num(0.01 * mid, 0.1 * mid)]]}
    if kind == "TruncatedNormal":
        return {
            "$dist": ["TruncatedNormal", [mid, g.num(0.01 * mid, 0.2 * mid), g.num(lo, mid), g.num(mid, hi)]]
        }
    if kind == "LogNormal":
        return {"$dist": ["LogNormal", [g.num(lo, hi), g.num(0.05, 0.5)]]}
    values = [g.integer(int(lo), int(hi)) if integer else g.num(lo, hi) for _ in range(g.r.randint(1, 3))]
    if kind == "Values":
        return {"$dist": ["Values", [values]]}
    if kind == "list":
        return values
    if g.hostile():
        return {"distribution": g.choice(["uniform", "normal"]), "low": lo, "mean": mid}
    return {"distribution": "uniform", "low": lo, "high": hi}


def _study_case(g: _Gen) -> dict:
    build = g.r.choice(["slider_yoke", "slider_yoke", "slider_yoke_stiff", "slider_crank", "four_bar"])
    table, dt_range, _ = _SCENES[build]
    fixed: dict[str, Any] = {}
    if build in ("slider_crank", "four_bar"):
        fixed["clearance_at"] = "crank_pin" if not g.hostile() else g.choice(["rocker_pin", None])
    numeric = [k for k, v in table.items() if isinstance(v, tuple)]
    vary = {}
    for k in g.r.sample(numeric, g.r.randint(0, 2)):
        lo, hi = table[k]
        vary[k] = _dist(g, lo, hi, integer=isinstance(lo, int))
    rest = [k for k in table if k not in vary]
    for k in g.r.sample(rest, g.r.randint(0, min(2, len(rest)))):
        fixed[k] = _scene_value(g, table[k])
    if g.maybe(0.1):
        fixed["elements"] = g.r.choice([8.0, 8.5, "8", -2.0])
    dt = math.exp(g.r.uniform(math.log(dt_range[0]), math.log(dt_range[1])))
    t_end = dt * g.r.randint(1, 400)
    if g.maybe(0.1):
        vary["dt"] = _dist(g, dt_range[0], dt_range[1])
    kw: dict[str, Any] = {
        # (no huge hostile count here: a study of 10**7 samples is legitimately big)
        "samples": g.r.randint(1, 6) if not g.hostile() else g.r.choice([0, -1, 2.5, "8", None, True, NAN]),
        "design": g.choice(["random", "lhs", "sobol", "grid"]),
        "seed": g.integer(0, 1000),
        "levels": g.r.randint(1, 3) if not g.hostile() else g.r.choice([0, -1, 2.5, "3", None, 2**64]),
        "t_end": t_end if not g.hostile() else g.bad_value(),
        "dt": dt,
    }
    if g.maybe(0.2):
        kw["method"] = g.choice(["modified", "force"])
    if g.maybe(0.2):
        kw["outputs"] = g.r.sample(list(_OUTPUT_NAMES), g.r.randint(0, 3))
    if g.maybe(0.3):
        kw["start"] = g.num(0.0, 0.9 * t_end, log=False)
    if g.maybe(0.2):
        kw["history_every"] = g.integer(1, 20)
    if g.maybe(0.2):
        kw["retries"] = g.integer(0, 2)
        kw["retry_factor"] = g.num(0.1, 0.9, log=False)
    if g.maybe(0.15):
        kw["links"] = g.flag()
    if g.maybe(0.3):
        opts = _run_options(g, build in ("slider_crank", "four_bar"))
        opts.pop("raise_on_failure", None)
        opts.pop("method", None)
        if g.maybe(0.1):
            opts[g.choice(["tol", "bogus", "record"])] = 1e-8
        kw["run_options"] = opts
    run = {"store": g.maybe(0.3), "lanes": g.integer(0, 8) if g.maybe(0.2) else 0, "chunk_size": None}
    if g.maybe(0.2):
        run["chunk_size"] = g.integer(1, 4)
    after = {
        "summary": g.maybe(0.5),
        "exceedance": [g.r.choice(_OUTPUT_NAMES), g.num(0.0, 100.0, log=False)] if g.maybe(0.3) else None,
        "resume": g.maybe(0.2),
    }
    return {
        "kind": "study",
        "build": build,
        "vary": vary,
        "fixed": fixed,
        "kwargs": kw,
        "run": run,
        "after": after,
    }


_OUTPUT_NAMES = (
    "max_penetration",
    "time_of_max_penetration",
    "max_force",
    "impacts",
    "contact_time",
    "max_velocity",
    "max_impact_velocity",
    "rms_penetration",
    "rms_force",
)


def _linkage_case(g: _Gen) -> dict:
    """A :class:`flexclear.Linkage` (a four-bar, an offset slider-crank, a Watt six-bar or a
    crank-shaper, each with its numbers drawn about a working design) solved for its frames, and
    a short run of a flexible link on them with a clearance joint."""
    w = {"$rotation": ["constant", {"rate": g.num(1.0, 300.0)}]}
    topo = g.r.choice(["four_bar", "slider_crank", "six_bar", "shaper"])
    if topo == "four_bar":
        ops = [
            ["ground", "O2", [0.0, 0.0], {}],
            ["ground", "O4", [g.num(0.2, 0.3), 0.0], {}],
            ["crank", "crank", "O2", "A", {"length": g.num(0.03, 0.06), "driver": w}],
            ["point", "B", {"near": [g.num(0.1, 0.2), g.choice([0.26, -0.26], [0.0])]}],
            ["link", "coupler", "A", "B", {"length": g.num(0.25, 0.3)}],
            ["link", "rocker", "O4", "B", {"length": g.num(0.25, 0.3)}],
        ]
        flexible, ends = "coupler", (("crank", "crank", "A"), ("rocker", "rocker", "B"))
    elif topo == "slider_crank":
        ops = [
            ["ground", "O", [0.0, 0.0], {}],
            ["crank", "crank", "O", "A", {"length": g.num(0.05, 0.2), "driver": w}],
            ["point", "B", {"near": [g.num(0.3, 0.6), 0.0]}],
            ["link", "rod", "A", "B", {"length": g.num(0.25, 0.5)}],
            [
                "slider",
                "slider",
                "B",
                {"through": [0.0, g.num(-0.02, 0.02, log=False)], "angle": g.num(-0.1, 0.1, log=False)},
            ],
        ]
        flexible, ends = "rod", (("crank", "crank", "A"), ("slider", None, "B"))
    elif topo == "six_bar":
        ops = [
            ["ground", "O2", [0.0, 0.0], {}],
            ["ground", "O4", [0.254, 0.0], {}],
            ["ground", "O6", [g.num(0.43, 0.47), 0.05], {}],
            ["crank", "crank", "O2", "A", {"length": g.num(0.04, 0.055), "driver": w}],
            ["point", "B", {"near": [0.15, 0.26]}],
            ["point", "C", {"near": [0.14, 0.06]}],
            ["point", "D", {"near": [0.35, 0.2]}],
            ["link", "coupler", "A", "B", {"length": 0.2794}],
            [
                "body",
                "rocker",
                {"points": {"O4": [0.0, 0.0], "B": [0.2794, 0.0], "C": [0.1, g.num(0.06, 0.1)]}},
            ],
            ["link", "rod", "C", "D", {"length": g.num(0.24, 0.26)}],
            ["link", "output", "O6", "D", {"length": 0.15}],
        ]
        flexible, ends = "rod", (("rocker", "rocker", "C"), ("output", "output", "D"))
    else:
        ops = [
            ["ground", "O4", [0.0, 0.0], {}],
            ["ground", "O2", [0.0, g.num(0.08, 0.12)], {}],
            ["crank", "crank", "O2", "A", {"length": g.num(0.03, 0.06), "driver": w}],
            ["point", "B", {"near": [0.13, 0.27]}],
            ["body", "lever", {"points": {"O4": [0.0, 0.0], "B": [0.3, 0.0]}}],
            ["slot", "block", "A", "O4", "B", {}],
            ["point", "C", {"near": [0.05, 0.35]}],
            ["link", "rod", "B", "C", {"length": g.num(0.2, 0.3)}],
            ["slider", "ram", "C", {"through": [0.0, 0.35], "angle": 0.0}],
        ]
        flexible, ends = "rod", (("lever", "lever", "B"), ("ram", None, "C"))
    return {
        "kind": "linkage",
        "ops": ops,
        "t_end": g.num(0.005, 0.1),
        "spacing": g.num(2e-4, 3e-3),
        "flexible": flexible,
        "ends": ends,
        "clearance": g.num(1e-5, 5e-4),
        "run": g.maybe(0.3),
    }


def generate(seed: int, index: int) -> dict:
    """Case ``index`` of campaign ``seed`` (depends on nothing else)."""
    rng = random.Random(f"flexclear-fuzz:{seed}:{index}")
    # hostility per case: 3 in 7 cases wholly sane (most of those run to the end), the rest
    # from a few hostile values among ~40 to nearly all hostile
    hostility = rng.choice([0.0, 0.0, 0.0, 0.01, 0.03, 0.1, 0.3])
    # 1 case in 20 a linkage, drawn from a stream of its own (the other cases of a campaign are
    # those it had before linkages were fuzzed)
    side = random.Random(f"flexclear-fuzz-linkage:{seed}:{index}")
    if side.random() < 0.05:
        case = _linkage_case(_Gen(side, hostility))
        case["id"] = f"{seed}:{index}"
        return case
    g = _Gen(rng, hostility)
    kind = rng.choices(["model", "scene", "study"], weights=[5, 4, 1])[0]
    case = {"model": _model_case, "scene": _scene_case, "study": _study_case}[kind](g)
    case["id"] = f"{seed}:{index}"
    return case


# ---------------------------------------------------------------------------------------------
# Execution (in the calling process)
# ---------------------------------------------------------------------------------------------


class KnownIssue(Exception):
    """A foreign exception of a known cause that needs a fix outside the Python layer; the case
    is reported as ``foreign_exception`` with ``known`` set to the key of :data:`KNOWN`."""

    def __init__(self, key: str, error: BaseException) -> None:
        super().__init__(f"{type(error).__name__}: {error}")
        self.key, self.error = key, error


#: Known foreign exceptions (key -> reason); each has a strict xfail test in tests/test_fuzz.py.
KNOWN = {}


def _core_call(fn: Callable, kw: dict) -> Any:
    return fn(**kw)


def _decode(v: Any) -> Any:
    """API objects from their tagged JSON form."""
    import flexclear
    from flexclear import motion, study

    if isinstance(v, list):
        return [_decode(x) for x in v]
    if not isinstance(v, dict):
        return v
    if "$tuple" in v:
        return tuple(_decode(x) for x in v["$tuple"])
    if "$rotation" in v:
        kind, kw = v["$rotation"]
        return _core_call(getattr(flexclear.Rotation, kind), _decode(kw))
    if "$motion" in v:
        kind, kw = v["$motion"]
        return getattr(motion, kind)(**_decode(kw))
    if "$frame" in v:
        kind, kw = v["$frame"]
        return _core_call(getattr(flexclear.Frame, kind), _decode(kw))
    if "$record" in v:
        kw = _decode(v["$record"])
        if "nodes" in kw and isinstance(kw["nodes"], list):
            kw["nodes"] = [tuple(x) if isinstance(x, list) else x for x in kw["nodes"]]
        return kw if v.get("as_dict") else flexclear.Record(**kw)
    if "$dist" in v:
        kind, args = v["$dist"]
        return getattr(study, kind)(*_decode(args))
    if "$friction" in v:
        from flexclear import contact

        kind, kw = v["$friction"]
        return getattr(contact, kind)(**_decode(kw))
    return {k: _decode(x) for k, x in v.items()}


def _build_model(case: dict):
    import flexclear

    if case["kind"] == "scene":
        return getattr(flexclear.scenes, case["scene"])(**_decode(case["kwargs"]))
    m = flexclear.Model()
    _replay(m, case["ops"])
    return m


def _replay(target, ops: list) -> None:
    """Calls ``target.<name>(*args, **kwargs)`` for every op ``[name, *args, kwargs]`` of a case
    (a Model's or a Linkage's building calls): list arguments, and the list values of the
    keywords ``target``, ``point`` and ``points``, as tuples; tagged API objects decoded."""
    for op in ops:
        name, *args, kw = op
        args = [tuple(a) if isinstance(a, list) else a for a in args]
        kw = _decode(kw)
        for key in ("target", "point"):
            if isinstance(kw.get(key), list):
                kw[key] = tuple(kw[key])
        if isinstance(kw.get("points"), dict):
            kw["points"] = {k: tuple(v) if isinstance(v, list) else v for k, v in kw["points"].items()}
        getattr(target, name)(*args, **kw)


def _act(model, action: dict) -> Any:
    import numpy as np

    do = action["do"]
    if do == "simulate":
        opts = _decode(action["options"])
        method = opts.pop("method", "modified")
        return model.simulate(action["t_end"], action["dt"], method, progress=False, **opts)
    if do == "static_state":
        y = model.static_state(action["t"], contacts=action["contacts"])
        return {"static_state": np.asarray(y)}
    if do == "natural_frequencies":
        return {"frequencies": model.natural_frequencies(action["count"], t=action["t"])}
    if do == "memory_estimate":
        rec = _decode(action["record"]) if action["record"] is not None else None
        est = model.memory_estimate(action["t_end"], action["dt"], rec)
        if not (isinstance(est, int) and est >= 0):
            return {"memory_estimate": float("nan")}
        return {"memory_estimate": float(est)}
    if do == "dof_map":
        return {"dof_map": float(len(model.dof_map()))}
    raise ValueError(do)


def _nonfinite(name: str, value: Any, out: list) -> None:
    import numpy as np

    if isinstance(value, (bool, np.bool_, str)) or value is None:
        return
    if isinstance(value, (int, np.integer)):
        return
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            out.append(f"{name} = {value}")
        return
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc" and value.size and not np.all(np.isfinite(value)):
            out.append(f"{name}: {int(np.sum(~np.isfinite(value)))} of {value.size} non-finite")
        return
    if isinstance(value, dict):
        for k, v in value.items():
            _nonfinite(f"{name}[{k!r}]", v, out)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _nonfinite(f"{name}[{i}]", v, out)


def check_result(res) -> list[str]:
    """Every documented-finite value of a complete :class:`flexclear.Result` that is not finite
    (an empty list for a clean result). Reading a channel the record did not keep must raise
    :class:`flexclear.RecordingError`; anything else propagates (a foreign exception)."""
    import flexclear
    import numpy as np

    bad: list[str] = []
    _nonfinite("time", res.time, bad)
    _nonfinite("end_time", res.end_time, bad)
    _nonfinite("stats", res.stats, bad)
    if res.state is not None:
        _nonfinite("state", list(res.state), bad)
    if res.time.size and not np.all(np.diff(res.time) > 0):
        bad.append("time is not increasing")
    for name in res.joint_names:
        j = res.joint(name)
        for f in (
            "max_penetration",
            "time_of_max_penetration",
            "max_force",
            "contact_time",
            "max_velocity",
            "max_impact_velocity",
            "rms_penetration",
            "rms_force",
        ):
            _nonfinite(f"joint({name!r}).{f}", getattr(j, f), bad)
        for ch in ("penetration", "force", "qx", "qy"):
            if j.recorded(ch):
                _nonfinite(f"joint({name!r}).{ch}", getattr(j, ch), bad)
            else:
                try:
                    getattr(j, ch)
                except flexclear.RecordingError:
                    pass
                else:
                    bad.append(f"joint({name!r}).{ch}: not recorded but readable")
        if j.impact_log is not None:
            log = j.impact_log
            for f in ("time", "speed", "peak_force", "peak_penetration"):
                _nonfinite(f"joint({name!r}).impact_log.{f}", getattr(log, f), bad)
            # duration: NaN only for an episode still closed at the end (the last one)
            _nonfinite(f"joint({name!r}).impact_log.duration[:-1]", log.duration[:-1], bad)
    for name in res.link_names:
        lk = res.link(name)
        for f in ("x", "frame", "u", "v", "theta", "axial_force", "midspan", "kinetic", "strain", "momentum"):
            _nonfinite(f"link({name!r}).{f}", getattr(lk, f), bad)
        if lk.u.size:
            _nonfinite(f"link({name!r}).global_positions()", list(lk.global_positions()), bad)
    rec = res.record
    if rec is not None and isinstance(rec.nodes, (list, tuple)):
        for link, node in rec.nodes:
            n = res.node(link, node)
            _nonfinite(f"node({link!r}, {node!r})", [n.u, n.v, n.theta], bad)
    frame = res.to_pandas()
    _nonfinite("to_pandas()", frame.to_numpy(dtype=float), bad)
    return bad


def _run_linkage(case: dict) -> list[str]:
    """Solves a linkage case's frames, checks them finite at 7 instants (and the table's times
    given back), and with ``run`` simulates its flexible link on them for up to 5 ms with a
    clearance joint at its first end and a pin at the other (the model built by hand, or by
    ``Linkage.model`` in the cases of even index)."""
    import flexclear
    import numpy as np

    lk = flexclear.Linkage()
    _replay(lk, case["ops"])
    frames = lk.frames(case["t_end"], spacing=case["spacing"])
    bad: list[str] = []
    for name, f in frames.items():
        for t in np.linspace(0.0, float(case["t_end"]), 7):
            o, v, a, *angle = f.at(t)
            _nonfinite(f"frames[{name!r}].at({t:g})", [*o, *v, *a, *angle], bad)
    if not case["run"] or bad:
        return bad
    link, ends = case["flexible"], case["ends"]
    section = dict(elements=4, youngs_modulus=7e10, density=2700.0, area=8e-5, inertia=7e-11)
    bearing = dict(clearance=case["clearance"], stiffness=5e7, damping=500.0)
    if int(str(case.get("id", "0:0")).rpartition(":")[2] or 0) % 2 == 0:
        # every other case builds its model with Linkage.model
        m = lk.model(
            case["t_end"],
            flexible={link: section},
            clearances={ends[0][2]: bearing},
            slider_masses={body: 0.1 for body, frame, _ in ends if frame is None},
            spacing=case["spacing"],
        )
    else:
        length = next(op[-1]["length"] for op in case["ops"] if op[0] == "link" and op[1] == link)
        m = flexclear.Model()
        for body, frame, _ in ends:
            if frame is not None:
                m.add_body(body, frame=frames[frame])
            else:
                m.add_slider(body, mass=0.1, path=frames[body])
        m.add_link(link, length=length, frame=frames[link], **section)
        points = lk.solve([0.0])
        for k, (body, frame, point) in enumerate(ends):
            node = 0 if k == 0 else section["elements"]
            if frame is None:
                m.add_pin(f"end{k}", link, node, slider=body)
                continue
            # the end's point in the body's frame at t = 0
            o, _, _, angle, _, _ = frames[frame].at(0.0)
            d = points[point][0][0] - np.asarray(o)
            local = (
                d[0] * np.cos(angle) + d[1] * np.sin(angle),
                -d[0] * np.sin(angle) + d[1] * np.cos(angle),
            )
            if k == 0:
                m.add_joint(f"end{k}", link, node, body=body, point=local, **bearing)
            else:
                m.add_pin(f"end{k}", link, node, body=body, point=local)
    res = m.simulate(min(float(case["t_end"]), 5e-3), 1e-5, progress=False)
    return bad + check_result(res)


def _run_study(case: dict, workdir: str) -> list[str]:
    import numpy as np
    from flexclear import study

    s = study.Study(
        case["build"],
        vary=_decode(case["vary"]),
        fixed=_decode(case["fixed"]),
        **_decode(case["kwargs"]),
    )
    run = case["run"]
    store = None
    if run["store"]:
        store = tempfile.mkdtemp(dir=workdir)
    kw = dict(store=store, threads=1, progress=False, lanes=run["lanes"], chunk_size=run["chunk_size"])
    res = s.run(**kw)
    if case["after"]["resume"] and store is not None:
        again = s.run(**kw)
        if len(again.frame) != len(res.frame):
            return [f"resume: {len(again.frame)} rows, first run {len(res.frame)}"]
    bad: list[str] = []
    frame = res.frame
    if len(frame) != len(s.inputs()):
        bad.append(f"{len(frame)} rows for {len(s.inputs())} samples")
    if not frame.index.is_unique:
        bad.append("sample index not unique")
    ok = res.ok
    for col in s.output_columns:
        _nonfinite(f"ok[{col!r}]", ok[col].to_numpy(dtype=float), bad)
    for col in ("dt_used", "wall_time"):
        if col in ok:
            _nonfinite(f"ok[{col!r}]", ok[col].to_numpy(dtype=float), bad)
    if case["after"]["summary"]:
        summ = res.summary()
        if len(ok) > 1:
            _nonfinite("summary()", summ.to_numpy(dtype=float), bad)
    ex = case["after"]["exceedance"]
    if ex is not None and len(ok):
        out = res.exceedance(ex[0] if len(s.joints) == 1 else f"{s.joints[0]}.{ex[0]}", ex[1])
        _nonfinite("exceedance()", np.asarray([out["probability"], out["low"], out["high"]]), bad)
    return bad


def execute(case: dict, workdir: Optional[str] = None) -> dict:
    """Runs one case here; returns ``{"outcome", "detail", ...}`` (never raises, except for a
    crash, which kills the process)."""
    import flexclear

    t0 = time.perf_counter()
    out: dict[str, Any] = {}
    if case["kind"] == "_selftest":  # the harness's own test: a crash or a hang on demand
        if case["do"] == "abort":
            os.abort()
        time.sleep(case["seconds"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if case["kind"] == "_selftest":
                out = {"outcome": "ok", "detail": ""}
            elif case["kind"] == "linkage":
                bad = _run_linkage(case)
                out = {"outcome": "nan" if bad else "ok", "detail": "; ".join(bad[:8])}
            elif case["kind"] == "study":
                bad = _run_study(case, workdir or tempfile.gettempdir())
                out = {"outcome": "nan" if bad else "ok", "detail": "; ".join(bad[:8])}
            else:
                model = _build_model(case)
                res = _act(model, case["action"])
                if isinstance(res, flexclear.Result):
                    if res.complete:
                        bad = check_result(res)
                        out = {"outcome": "nan" if bad else "ok", "detail": "; ".join(bad[:8])}
                    else:  # raise_on_failure=False: the run stopped with a flexclear error
                        err = res.error
                        out = {
                            "outcome": "flexclear_error",
                            "type": type(err).__name__,
                            "detail": str(err)[:600],
                        }
                        if not isinstance(err, flexclear.FlexclearError):
                            out["outcome"] = "foreign_exception"
                else:
                    bad = []
                    _nonfinite(case["action"]["do"], res, bad)
                    out = {"outcome": "nan" if bad else "ok", "detail": "; ".join(bad[:8])}
        except BaseException as e:  # noqa: BLE001 - classifying every outcome is the point
            name = type(e).__name__
            if isinstance(e, KnownIssue):
                err = e.error
                out = {"outcome": "foreign_exception", "type": type(err).__name__, "detail": str(err)[:600]}
                out["known"] = e.key
            elif name == "PanicException":
                out = {"outcome": "crash", "type": name, "detail": f"Rust panic: {e}"[:600]}
            elif isinstance(e, flexclear.FlexclearError):
                out = {"outcome": "flexclear_error", "type": name, "detail": str(e)[:600]}
            else:
                tb = traceback.format_exc(limit=-6)
                out = {"outcome": "foreign_exception", "type": name, "detail": str(e)[:600], "traceback": tb}
    out["warnings"] = sorted({f"{w.category.__name__}: {str(w.message)[:200]}" for w in caught})
    out["seconds"] = round(time.perf_counter() - t0, 3)
    return out


# ---------------------------------------------------------------------------------------------
# Worker processes
# ---------------------------------------------------------------------------------------------


def worker_main() -> None:
    """The worker: one case per line on stdin, one outcome per line on the original stdout (file
    descriptor 1 is pointed at stderr, so nothing the library prints can corrupt the protocol)."""
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    workdir = tempfile.mkdtemp(prefix="flexclear-fuzz-")
    import flexclear  # noqa: F401 - import once, before the first case's clock

    for line in sys.stdin:
        case = json.loads(line)
        print(f"== case {case.get('id')}", file=sys.stderr, flush=True)
        result = execute(case, workdir)
        out.write(json.dumps(result) + "\n")
        out.flush()


def _limit_memory(limit: int) -> Callable[[], None]:
    def apply() -> None:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    return apply


class _Worker:
    def __init__(self, env: dict, memory: int, python: str) -> None:
        self.env, self.memory, self.python = env, memory, python
        self.proc: Optional[subprocess.Popen] = None
        self.err: Any = None
        self.buf = b""

    def start(self) -> None:
        self.stop()
        self.err = tempfile.TemporaryFile()
        self.buf = b""
        code = (
            f"import sys; sys.path.insert(0, {TESTS_DIR!r}); "
            "from fuzz.harness import worker_main; worker_main()"
        )
        self.proc = subprocess.Popen(
            [self.python, "-c", code],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.err,
            env=self.env,
            preexec_fn=_limit_memory(self.memory),
        )

    def stderr_tail(self, n: int = 1500) -> str:
        self.err.seek(0)
        text = self.err.read().decode(errors="replace")
        return text[-n:]

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        if self.proc is not None:
            self.proc.wait()
            for f in (self.proc.stdin, self.proc.stdout):
                try:
                    f.close()
                except OSError:
                    pass
        if self.err is not None:
            self.err.close()
        self.proc, self.err = None, None

    def run(self, case: dict, timeout: float) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        assert self.proc is not None and self.proc.stdin is not None and self.proc.stdout is not None
        self.err.seek(0)
        self.err.truncate()
        t0 = time.monotonic()
        try:
            self.proc.stdin.write((json.dumps(case) + "\n").encode())
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass
        fd = self.proc.stdout.fileno()
        while b"\n" not in self.buf:
            left = timeout - (time.monotonic() - t0)
            if left <= 0:
                self.stop()
                return {"outcome": "hang", "detail": f"no answer within {timeout:g} s", "seconds": timeout}
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                continue
            chunk = os.read(fd, 65536)
            if not chunk:  # the worker died
                code = self.proc.wait()
                tail = self.stderr_tail()
                self.stop()
                how = f"signal {-code}" if code < 0 else f"exit status {code}"
                return {
                    "outcome": "crash",
                    "type": how,
                    "detail": f"the worker died ({how}); stderr tail: {tail}",
                    "seconds": round(time.monotonic() - t0, 3),
                }
            self.buf += chunk
        line, _, self.buf = self.buf.partition(b"\n")
        return json.loads(line)


class Pool:
    """``jobs`` worker processes running cases, each with ``timeout`` s and ``memory`` bytes of
    address space (``RLIMIT_AS``); a worker that crashes or hangs is replaced."""

    def __init__(
        self,
        jobs: int = 2,
        timeout: float = 60.0,
        memory: int = 4 * 2**30,
        python: str = sys.executable,
        memory_limit_env: str = "1G",
    ) -> None:
        import flexclear

        python_dir = str(Path(flexclear.__file__).resolve().parent.parent)
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([python_dir, TESTS_DIR, env.get("PYTHONPATH", "")]).rstrip(
            os.pathsep
        )
        # flexclear's own memory planner refuses histories above this, before the rlimit is hit
        env["FLEXCLEAR_MEMORY_LIMIT"] = memory_limit_env
        env.setdefault("RAYON_NUM_THREADS", "1")
        env.setdefault("OMP_NUM_THREADS", "1")
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        env["PYTHONWARNINGS"] = "ignore"
        self.jobs, self.timeout = jobs, timeout
        self.workers = [_Worker(env, memory, python) for _ in range(jobs)]

    def map(self, cases: Iterable[dict]) -> Iterator[tuple[dict, dict]]:
        """``(case, outcome)`` pairs as they finish (not in order)."""
        todo: queue.Queue = queue.Queue()
        done: queue.Queue = queue.Queue()
        n = 0
        for c in cases:
            todo.put(c)
            n += 1

        def loop(w: _Worker) -> None:
            while True:
                try:
                    case = todo.get_nowait()
                except queue.Empty:
                    break
                try:
                    outcome = w.run(case, self.timeout)
                except Exception as e:  # noqa: BLE001 - a harness failure must not stop the run
                    w.stop()
                    outcome = {"outcome": "crash", "type": "harness", "detail": repr(e)}
                done.put((case, outcome))
            w.stop()

        threads = [threading.Thread(target=loop, args=(w,), daemon=True) for w in self.workers]
        for t in threads:
            t.start()
        for _ in range(n):
            yield done.get()
        for t in threads:
            t.join()


def summarize(outcomes: Iterable[dict]) -> dict:
    """Counts by outcome class; known foreign exceptions (see :data:`KNOWN`) are counted apart as
    ``"known:<key>"`` as well."""
    counts = {k: 0 for k in OUTCOMES}
    for o in outcomes:
        counts[o["outcome"]] = counts.get(o["outcome"], 0) + 1
        if o.get("known"):
            counts[f"known:{o['known']}"] = counts.get(f"known:{o['known']}", 0) + 1
    return counts


def unexpected(outcome: dict) -> bool:
    """A failure that is not a known issue."""
    return outcome["outcome"] in FAILURES and not outcome.get("known")


if __name__ == "__main__":  # pragma: no cover - run one case: python harness.py '<case json>'
    print(json.dumps(execute(json.loads(sys.argv[1]))))
