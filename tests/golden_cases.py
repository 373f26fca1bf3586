"""The golden cases: today's results of the slider-yoke (every coupling, fixed steps and events,
the Monte Carlo batch with lanes 1 and 8) and of the moving-frame scenes, kept as scalars (17
significant digits) and SHA-256 hashes of the histories' float64 bytes.

One list serves ``scripts/golden.py`` (write, check, compare two files) and
``tests/test_golden.py``. A case is a function of the ``flexclear`` module; the few calls that
differ between the API before and after the one-Model change are spelled both ways, so the same
values can be computed on either side of a refactoring and compared bitwise.
"""

from __future__ import annotations

import hashlib
import platform
from pathlib import Path
from typing import Any, Callable

import numpy as np

GOLDEN_FILE = Path(__file__).parent / "data" / "golden.json"


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=np.float64)).tobytes())
    return h.hexdigest()


def cpu_level() -> str:
    """The x86-64 micro-architecture level of this CPU (v1..v4) from /proc/cpuinfo, with the
    machine name: results are compared bitwise only between machines of the same level."""
    try:
        flags = set()
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                flags = set(line.split(":", 1)[1].split())
                break
    except OSError:
        return platform.machine()
    level = "x86-64-v1"
    if {"sse4_2", "ssse3", "popcnt", "cx16"} <= flags:
        level = "x86-64-v2"
    if level == "x86-64-v2" and {"avx2", "fma", "bmi1", "bmi2", "movbe"} <= flags:
        level = "x86-64-v3"
    if level == "x86-64-v3" and {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"} <= flags:
        level = "x86-64-v4"
    return f"{platform.machine()} {level}" if flags else platform.machine()


def _joint(j) -> dict:
    return {
        "max_penetration": j.max_penetration,
        "max_force": j.max_force,
        "impacts": j.impacts,
        "history": digest(j.penetration, j.force),
    }


def _run(model, fc, t_end, dt, method="modified", **kw):
    return model.simulate(t_end, dt, method, raise_on_failure=False, **kw)


def _yoke(fc, clearance, method, iterate=False, events=False, t_end=0.02, dt=1e-5):
    r = _run(
        fc.scenes.slider_yoke(clearance=clearance), fc, t_end, dt, method, iterate=iterate, events=events
    )
    j = r.joint("bearing")
    return {
        **_joint(j),
        "contact_time": j.contact_time,
        "rms_force": j.rms_force,
        "time_of_max_penetration": j.time_of_max_penetration,
        "steps": r.stats["steps"],
        "event_steps": r.stats["event_steps"],
        "complete": r.complete,
        "end_time": r.end_time,
    }


def _stiff(fc, method):
    r = _run(fc.scenes.slider_yoke_stiff(), fc, 0.01, 1e-5, method)
    return {**_joint(r.joint("bearing")), "complete": r.complete, "end_time": r.end_time}


def _batch(fc, lanes):
    models = [fc.scenes.slider_yoke(clearance=c)._core for c in np.linspace(0.0, 1e-3, 8)]
    outs, _stats, pending = fc._core.run_batch(
        models, [0.02] * 8, [1e-5] * 8, threads=1, lanes=lanes, method="modified", histories=False
    )
    assert pending is None
    keys = ("max_penetration", "max_force", "impacts", "contact_time", "max_impact_velocity", "rms_force")
    return {f"{k}[{i}]": getattr(o["extremes"][0], k) for i, o in enumerate(outs) for k in keys}


def _moving(fc, build, link, joint, t_end, dt, **kw):
    """A moving-frame scene with the midspan (or tip) of ``link`` and ``joint`` (if any)."""
    model = build()
    if hasattr(fc, "Mechanism"):  # the API before the one-Model change
        r = model.simulate(t_end, dt, midspan=True, **kw)
    else:
        r = model.simulate(t_end, dt, record=fc.Record(midspan=True), **kw)
    lr = r.link(link)
    out = {
        "midspan": digest(lr.midspan),
        "displacements": digest(lr.u, lr.v, lr.theta),
        "last_v": float(lr.v[-1, -1]),
        "steps": r.stats["steps"],
        "factorizations": r.stats["factorizations"],
        "iterations": r.stats["iterations"],
    }
    if joint:
        j = r.joint(joint)
        out.update(max_penetration=j.max_penetration, max_force=j.max_force, impacts=j.impacts)
        out["history"] = digest(j.penetration, j.force)
    return out


def _frequencies(fc):
    """Eigenvalues come from LAPACK through numpy: compared to 1e-12 relative, never bitwise."""
    spin = fc.scenes.spin_up(rotation=fc.Rotation.constant(2.0))
    if hasattr(fc, "Mechanism"):
        w = spin.frequencies(0.0, count=3)
    else:
        w = 2 * np.pi * spin.natural_frequencies(3)
    f = fc.scenes.slider_yoke().natural_frequencies(3)
    return {"slider_yoke_hz": [float(x) for x in f], "spin_up_rad_s": [float(x) for x in w]}


CASES: dict[str, Callable[[Any], dict]] = {
    "yoke-1e-4-force": lambda fc: _yoke(fc, 1e-4, "force"),
    "yoke-1e-4-modified": lambda fc: _yoke(fc, 1e-4, "modified"),
    "yoke-1e-4-iterated": lambda fc: _yoke(fc, 1e-4, "modified", iterate=True),
    "yoke-1e-4-gap": lambda fc: _yoke(fc, 1e-4, "gap"),
    "yoke-1e-4-modified-events": lambda fc: _yoke(fc, 1e-4, "modified", events=True),
    "yoke-1e-4-iterated-events": lambda fc: _yoke(fc, 1e-4, "modified", iterate=True, events=True),
    "yoke-1e-4-force-events": lambda fc: _yoke(fc, 1e-4, "force", events=True),
    "yoke-0-modified": lambda fc: _yoke(fc, 0.0, "modified"),
    "yoke-1e-3-modified": lambda fc: _yoke(fc, 1e-3, "modified", t_end=0.05),
    "stiff-modified": lambda fc: _stiff(fc, "modified"),
    "stiff-force": lambda fc: _stiff(fc, "force"),
    "batch-lanes-1": lambda fc: _batch(fc, 1),
    "batch-lanes-8": lambda fc: _batch(fc, 8),
    "spin-up": lambda fc: _moving(fc, fc.scenes.spin_up, "beam", None, 2.0, 1e-3),
    "slider-crank": lambda fc: _moving(fc, fc.scenes.slider_crank, "rod", None, 0.01, 1e-5),
    "slider-crank-crank-pin": lambda fc: _moving(
        fc, lambda: fc.scenes.slider_crank(clearance_at="crank_pin"), "rod", "crank_pin", 0.01, 1e-5
    ),
    "slider-crank-slider-pin": lambda fc: _moving(
        fc, lambda: fc.scenes.slider_crank(clearance_at="slider_pin"), "rod", "slider_pin", 0.01, 1e-5
    ),
    "slider-crank-crank-pin-events": lambda fc: _moving(
        fc,
        lambda: fc.scenes.slider_crank(clearance_at="crank_pin"),
        "rod",
        "crank_pin",
        0.01,
        1e-5,
        events=True,
    ),
    "four-bar": lambda fc: _moving(fc, fc.scenes.four_bar, "coupler", None, 0.02, 1e-4),
    "four-bar-flexible-rocker": lambda fc: _moving(
        fc, lambda: fc.scenes.four_bar(flexible_rocker=True, rocker_elements=4), "rocker", None, 0.02, 1e-4
    ),
    "frequencies": _frequencies,
}

#: Cases whose values are compared to a relative tolerance even on the machine level they were
#: made on.
NOT_BITWISE = {"frequencies"}

#: Relative tolerance of the non-bitwise comparison, per case (default 1e-12). Eigenvalues come
#: from LAPACK through numpy, whose BLAS picks its kernels by CPU at run time: a backward-stable
#: eigensolver moves an eigenvalue by about eps times the largest one, so the spin-up's lowest
#: frequency (3 rad/s under a spectrum reaching 1e5 rad/s) moves by up to ~1e-11 relative
#: between machines (9.8e-12 seen between two machines of one CPU level). 1e-9 still catches
#: any change of the model or of the assembly (those move it by far more than round-off).
RELATIVE = {"frequencies": 1e-9}


def compute(fc, names=None) -> dict:
    return {name: CASES[name](fc) for name in (names or CASES)}


def compare(expected: Any, got: Any, bitwise: bool, path: str = "", rel: float = 1e-12) -> list[str]:
    """Differences between two case values: exact (and equal hashes) when ``bitwise``, else floats
    to ``rel`` relative and hashes skipped (other CPUs round differently)."""
    if isinstance(expected, dict):
        diffs = []
        for k in sorted(set(expected) | set(got)):
            if k not in expected or k not in got:
                diffs.append(f"{path}{k}: present on one side only")
            else:
                diffs += compare(expected[k], got[k], bitwise, f"{path}{k}.", rel)
        return diffs
    if isinstance(expected, list):
        if len(expected) != len(got):
            return [f"{path[:-1]}: {len(expected)} values, now {len(got)}"]
        return [
            d
            for i, (a, b) in enumerate(zip(expected, got))
            for d in compare(a, b, bitwise, f"{path}{i}.", rel)
        ]
    name = path[:-1]
    if isinstance(expected, str):
        if bitwise and expected != got:
            return [f"{name}: hash {expected[:12]} -> {got[:12]}"]
        return []
    if isinstance(expected, float) or isinstance(got, float):
        a, b = float(expected), float(got)
        if bitwise:
            same = a == b or (np.isnan(a) and np.isnan(b))
        else:
            same = (np.isnan(a) and np.isnan(b)) or abs(a - b) <= rel * max(abs(a), abs(b), 1e-300)
        return [] if same else [f"{name}: {a!r} -> {b!r} (rel {abs(a - b) / max(abs(a), 1e-300):.3g})"]
    return [] if expected == got else [f"{name}: {expected!r} -> {got!r}"]
