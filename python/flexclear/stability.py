"""Stability of the contact couplings under average-acceleration Newmark: the theory of a lagged
contact force (and a lagged kappa) and the measured largest stable step on the slider-yoke.

The derivation is in ``docs/stability.md``. In short: a contact spring ``k_l`` and dashpot ``c_l``
evaluated one step late (force method; the lagged kappa of the modified method lags the spring
part ``K_B (1 - kappa)``), with the rest of the system implicit, gives an amplification matrix
whose spectral radius is, for a single DOF of mass ``m`` and small ``Omega = omega dt``,
``rho ~ 1 + Omega^2 (k_l/k) / 2 - zeta Omega``: with no damping the lagged spring is unstable at
every step, and with damping the largest stable step is about ``c / k_l`` (``C_B/K_B`` for the
force method), whatever the mass.

Everything here is for analysis and reports; nothing in the engine depends on it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Optional

import numpy as np

from . import scenes
from .errors import SimulationDivergedError
from .linear import slider_yoke_matrices
from .model import Record

#: The couplings of the stability map, as ``(label, simulate keywords)``.
VARIANTS = (
    ("force", {"method": "force"}),
    ("modified, kappa lagged", {"method": "modified"}),
    ("modified, kappa iterated", {"method": "modified", "iterate": True}),
    ("gap", {"method": "gap"}),
)


# -- theory -------------------------------------------------------------------------------------
def amplification(
    M: np.ndarray,
    K: np.ndarray,
    C: np.ndarray,
    dt: float,
    dof: int,
    *,
    k_lag: float = 0.0,
    c_lag: float = 0.0,
    k_imp: float = 0.0,
    c_imp: float = 0.0,
    beta: float = 0.25,
    gamma: float = 0.5,
) -> np.ndarray:
    """Amplification matrix ``A`` of Newmark, ``[u, v, a]_{n+1} = A [u, v, a]_n``, for

    ``M a_{n+1} + (C + c_imp e e^T) v_{n+1} + (K + k_imp e e^T) u_{n+1} = -e e^T (k_lag u_n + c_lag v_n)``

    with ``e`` the unit vector of DOF ``dof``: a contact spring and dashpot on one DOF, split into
    a part in the step's matrix (implicit) and a part evaluated at the last state (lagged)."""
    n = M.shape[0]
    E = np.zeros((n, n))
    E[dof, dof] = 1.0
    Kp = K + k_imp * E
    Cp = C + c_imp * E
    S = M + gamma * dt * Cp + beta * dt * dt * Kp
    Si = np.linalg.inv(S)
    Au = -Si @ (Kp + k_lag * E)
    Av = -Si @ (Cp + dt * Kp + c_lag * E)
    Aa = -Si @ (dt * (1 - gamma) * Cp + dt * dt * (0.5 - beta) * Kp)
    eye = np.eye(n)
    b2 = beta * dt * dt
    g1 = gamma * dt
    return np.block(
        [
            [eye + b2 * Au, dt * eye + b2 * Av, dt * dt * (0.5 - beta) * eye + b2 * Aa],
            [g1 * Au, eye + g1 * Av, dt * (1 - gamma) * eye + g1 * Aa],
            [Au, Av, Aa],
        ]
    )


def coupling_split(label: str, stiffness: float, damping: float, kappa: float = 0.0) -> dict:
    """How each coupling of :data:`VARIANTS` splits a linearized contact (normal stiffness
    ``stiffness`` N/m, dashpot ``damping`` N s/m) into lagged and implicit parts.

    The lagged kappa of the modified method, linearized about a contact state with
    ``kappa = delta/delta_r``, puts ``kappa K_B`` in the matrix and lags ``(1 - kappa) K_B``;
    ``kappa = 0`` (contact entry, penetration much smaller than the clearance) is the worst case.
    Iterated kappa and the gap element (status iterated, normal along the motion) are fully
    implicit once their iteration converges."""
    if label == "force":
        return dict(k_lag=stiffness, c_lag=damping)
    if label == "modified, kappa lagged":
        return dict(k_lag=(1 - kappa) * stiffness, k_imp=kappa * stiffness, c_imp=damping)
    if label in ("modified, kappa iterated", "gap"):
        return dict(k_imp=stiffness, c_imp=damping)
    raise ValueError(f"unknown coupling {label!r}")


def spectral_radius(A: np.ndarray) -> float:
    """Largest eigenvalue modulus."""
    return float(np.max(np.abs(np.linalg.eigvals(A))))


def sdof_radius(omega_dt: float, zeta: float, lag: str = "force") -> float:
    """Spectral radius for one mass on a contact spring and dashpot (no other stiffness):
    ``Omega = omega dt``, ``omega^2 = k/m``, ``zeta = c / (2 m omega)``. ``lag``: ``"force"``
    (spring and dashpot lagged), ``"spring"`` (spring lagged, dashpot implicit: the lagged kappa at
    kappa = 0), ``"none"`` (both implicit)."""
    split = {
        "force": dict(k_lag=1.0, c_lag=2 * zeta),
        "spring": dict(k_lag=1.0, c_imp=2 * zeta),
        "none": dict(k_imp=1.0, c_imp=2 * zeta),
    }[lag]
    one = np.ones((1, 1))
    return spectral_radius(amplification(one, 0 * one, 0 * one, omega_dt, 0, **split))


def iteration_factor(
    M: np.ndarray, K: np.ndarray, C: np.ndarray, dt: float, dof: int, stiffness: float, damping: float
) -> float:
    """Contraction factor of the fixed-point iteration of kappa within a step, at kappa = 0: the
    joint displacement responds to a change of kappa K_B q by ``beta dt^2 K_B [S^-1]_ee`` with ``S``
    the step matrix holding the dashpot. The iteration converges (to the implicit step) when this
    is below 1; above it, it oscillates and the step is accepted at ``max_iter``."""
    n = M.shape[0]
    S = M + 0.5 * dt * C + 0.25 * dt * dt * K
    S[dof, dof] += 0.5 * dt * damping
    e = np.zeros(n)
    e[dof] = 1.0
    return float(0.25 * dt * dt * stiffness * np.linalg.solve(S, e)[dof])


def _transverse(mats, ground_hz: float = 1.0):
    """Transverse (v, theta) block of the slider, with a grounding spring at ``ground_hz`` on
    every DOF so that the free-free rigid modes are simple oscillators instead of Jordan blocks
    (eigenvalue 1, defective; its computed modulus would be off by ~1e-8)."""
    idx = np.array([i for i in range(mats.M.shape[0]) if i % 3 != 0])
    M = mats.M[np.ix_(idx, idx)]
    K = mats.K[np.ix_(idx, idx)] + (2 * math.pi * ground_hz) ** 2 * np.diag(np.diag(M))
    C = mats.C[np.ix_(idx, idx)]
    return M, K, C


def theory_dt_max(
    model,
    label: str,
    *,
    contact_time: Optional[float] = None,
    growth: float = 10.0,
    dts: Optional[np.ndarray] = None,
) -> dict:
    """Largest stable step of coupling ``label`` for a slider-yoke ``model`` from the linearized
    FE model (slider transverse DOFs, joint in permanent contact along y, kappa = 0 for the lagged
    kappa), on a log grid ``dts`` (default 1e-9 .. 1e-3 s, 24 per decade).

    Returns ``asymptotic`` (largest dt below which every grid step has ``rho <= 1 + 1e-9``) and,
    when ``contact_time`` (s) is given, ``window`` (largest dt below which ``rho^(contact_time/dt)
    <= growth``: what a run of finite length can detect), and ``iteration`` (largest dt at which the
    kappa iteration contracts, for the iterated variant)."""
    p = model.parameters
    kb, cb = p["bearing_stiffness"], p["bearing_damping"]
    M, K, C = _transverse(slider_yoke_matrices(model))
    dof = 0  # v of node 0 (the joint) in the transverse block
    dts = np.logspace(-9, -3, 145) if dts is None else np.asarray(dts)
    split = coupling_split(label, kb, cb)
    rho = np.array([spectral_radius(amplification(M, K, C, dt, dof, **split)) for dt in dts])

    def last_ok(ok: np.ndarray) -> float:
        if not ok[0]:
            return 0.0
        bad = np.flatnonzero(~ok)
        return float(dts[-1] if bad.size == 0 else dts[bad[0] - 1])

    out = {"asymptotic": last_ok(rho <= 1 + 1e-9), "rho": rho, "dts": dts}
    if contact_time is not None:
        out["window"] = last_ok(np.log(np.maximum(rho, 1e-300)) * contact_time / dts <= math.log(growth))
    if label == "modified, kappa iterated":
        fac = np.array([iteration_factor(M, K, C, dt, dof, kb, cb) for dt in dts])
        out["iteration"] = last_ok(fac < 1.0)
    return out


# -- measurement --------------------------------------------------------------------------------
@dataclasses.dataclass
class StabilityPoint:
    """Largest stable step of one coupling at one bearing stiffness and damping ratio."""

    variant: str
    stiffness: float
    damping_ratio: float
    damping: float
    dt_max: float  # largest passing step, s (0 if none passed)
    dt_fail: float  # smallest failing step above it, s (inf if none failed)
    reason: str  # why dt_fail failed
    runs: int
    cpu: float  # CPU time of the search, s
    theory: dict = dataclasses.field(default_factory=dict)


def _stiff_model(stiffness: float, damping_ratio: float, clearance: float):
    return scenes.slider_yoke(
        clearance=clearance, bearing_stiffness=stiffness, bearing_damping_ratio=damping_ratio
    )


def _passes(model, kw: dict, t_end: float, dt: float, reference) -> tuple[bool, str]:
    p = model.parameters
    extra = {}
    if kw["method"] == "gap":
        extra = dict(gap_stiffness=p["bearing_stiffness"], gap_damping=p["bearing_damping"])
    try:
        r = model.simulate(t_end, dt, record=Record(histories=False), divergence_limit=0.05, **kw, **extra)
    except SimulationDivergedError as e:
        return False, f"diverged at t = {e.time:.3g} s ({e.dof})"
    j = r.joint("bearing")
    pen_ref, impacts_ref = reference
    if not math.isfinite(j.max_penetration) or j.max_penetration > 10 * pen_ref:
        return False, f"max penetration {j.max_penetration:.3g} m > 10 x converged {pen_ref:.3g} m"
    if j.impacts > 5 * impacts_ref + 10:
        return False, f"spurious chatter: {j.impacts} impacts, converged {impacts_ref}"
    return True, ""


def measure_dt_max(
    stiffness: float,
    damping_ratio: float,
    variant: str,
    *,
    clearance: float = 1e-5,
    t_end: float = 0.02,
    dt_min: float = 1e-8,
    dt_max: float = 1e-4,
    per_decade: int = 3,
    bisections: int = 3,
    reference: Optional[tuple[float, int]] = None,
) -> StabilityPoint:
    """Largest stable step of ``variant`` (a label of :data:`VARIANTS`) on the slider-yoke with
    bearing stiffness ``stiffness`` (N/m) and damping ratio ``damping_ratio`` (of critical, at the
    quarter mass), clearance ``clearance`` (m), over ``t_end`` (s).

    A step passes when the run completes (no divergence, limit 5 cm), its max penetration stays
    below 10 x the converged one and it has at most 5 x (+10) the converged number of impacts (a
    lagged penalty force can also fail by kicking the journal out of contact in every step:
    bounded, but spurious chatter). ``reference = (max penetration, impacts)`` of a converged run
    (iterated kappa at a fine step, computed when not given).

    Steps are tried upwards on a log grid (``per_decade`` per decade) from
    ``max(dt_min, 0.01 / omega_c)``, ``omega_c = sqrt(K_B / (m/4))``, until one fails; the
    interval to the last passing step is then bisected ``bisections`` times (geometrically). So
    the answer is the first loss of stability from below: larger steps can pass again (the
    chatter regime above), which is not counted as stable."""
    model = _stiff_model(stiffness, damping_ratio, clearance)
    kw = dict(VARIANTS)[variant]
    t0 = time.process_time()
    runs = 0
    if reference is None:
        reference = converged_reference(model, t_end)[:2]
        runs += 1
    p = model.parameters
    wc = math.sqrt(stiffness / (p["mass"] / 4))
    lo = max(dt_min, 0.01 / wc)
    n = max(1, round(per_decade * math.log10(dt_max / lo)))
    grid = np.logspace(math.log10(lo), math.log10(dt_max), n + 1)
    ok_dt, fail_dt, reason = 0.0, math.inf, ""
    for dt in grid:
        runs += 1
        ok, why = _passes(model, kw, t_end, float(dt), reference)
        if not ok:
            fail_dt, reason = float(dt), why
            break
        ok_dt = float(dt)
    if ok_dt > 0 and math.isfinite(fail_dt):
        for _ in range(bisections):
            mid = math.sqrt(ok_dt * fail_dt)
            runs += 1
            ok, why = _passes(model, kw, t_end, mid, reference)
            if ok:
                ok_dt = mid
            else:
                fail_dt, reason = mid, why
    return StabilityPoint(
        variant,
        stiffness,
        damping_ratio,
        p["bearing_damping"],
        ok_dt,
        fail_dt,
        reason,
        runs,
        time.process_time() - t0,
    )


def converged_reference(model, t_end: float) -> tuple[float, int, float]:
    """Max penetration (m), impacts and contact time (s) over ``t_end`` of a converged run:
    iterated kappa at ``min(1e-6, 0.05 / omega_c)``, ``omega_c = sqrt(K_B / (m/4))``."""
    p = model.parameters
    wc = math.sqrt(p["bearing_stiffness"] / (p["mass"] / 4))
    dt = t_end / math.ceil(t_end / min(1e-6, 0.05 / wc))
    r = model.simulate(t_end, dt, "modified", iterate=True, record=Record(histories=False))
    j = r.joint("bearing")
    return j.max_penetration, j.impacts, j.contact_time


def stability_map(
    stiffnesses=(1e3, 1e5, 1e7, 1e9, 1e11, 1e13),
    damping_ratios=(0.0, 0.05, 0.5, 5.0),
    variants=tuple(v for v, _ in VARIANTS),
    *,
    clearance: float = 1e-5,
    t_end: float = 0.02,
    log=None,
    **search,
) -> list[StabilityPoint]:
    """Measured and theoretical largest stable step for every (stiffness, damping ratio, variant)."""
    points = []
    for ratio in damping_ratios:
        for kb in stiffnesses:
            model = _stiff_model(kb, ratio, clearance)
            p = model.parameters
            pen, impacts, tc = converged_reference(model, t_end)
            for v in variants:
                pt = measure_dt_max(
                    kb, ratio, v, clearance=clearance, t_end=t_end, reference=(pen, impacts), **search
                )
                pt.theory = {
                    k: val
                    for k, val in theory_dt_max(model, v, contact_time=tc).items()
                    if k not in ("rho", "dts")
                }
                pt.theory["contact_time"] = tc
                pt.theory["sdof_c_over_k"] = p["bearing_damping"] / kb
                points.append(pt)
                if log:
                    log(
                        f"zeta={ratio:g} K_B={kb:.0e} {v:26s} measured {pt.dt_max:.3g} s "
                        f"(fails {pt.dt_fail:.3g}: {pt.reason}); theory {pt.theory}"
                    )
    return points


def plot_map(points: list[StabilityPoint], path: Path) -> None:
    """Largest stable dt vs K_B, one panel per damping ratio: measured (markers) and theory
    (lines: asymptotic rho <= 1 solid, finite window dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ratios = sorted({p.damping_ratio for p in points})
    variants = list(dict.fromkeys(p.variant for p in points))
    fig, axes = plt.subplots(1, len(ratios), figsize=(4.2 * len(ratios), 4.2), sharey=True, squeeze=False)
    colors = dict(zip(variants, ["C3", "C0", "C2", "C1"]))
    for ax, z in zip(axes[0], ratios):
        for v in variants:
            pts = sorted(
                (p for p in points if p.damping_ratio == z and p.variant == v), key=lambda p: p.stiffness
            )
            kb = [p.stiffness for p in pts]
            meas = [p.dt_max if p.dt_max > 0 else np.nan for p in pts]
            ax.loglog(kb, meas, "o", color=colors[v], label=f"{v} (measured)")
            th = [p.theory.get("asymptotic", np.nan) or np.nan for p in pts]
            ax.loglog(kb, th, "-", color=colors[v], alpha=0.7)
            win = [p.theory.get("window", np.nan) or np.nan for p in pts]
            ax.loglog(kb, win, "--", color=colors[v], alpha=0.7)
            if v == "modified, kappa iterated":
                it = [p.theory.get("iteration", np.nan) or np.nan for p in pts]
                ax.loglog(kb, it, ":", color=colors[v], alpha=0.7)
        ax.set_title(f"bearing damping ratio {z:g}")
        ax.set_xlabel("bearing stiffness K_B (N/m)")
        ax.axhline(1e-4, color="k", lw=0.5)
        ax.axhline(1e-8, color="k", lw=0.5)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("largest stable dt (s)")
    axes[0][0].legend(fontsize=7, loc="lower left")
    fig.suptitle(
        "slider-yoke, clearance 1e-5 m: measured (markers) vs theory "
        "(solid rho<=1, dashed finite window, dotted kappa-iteration limit)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = [
    "VARIANTS",
    "StabilityPoint",
    "amplification",
    "coupling_split",
    "iteration_factor",
    "measure_dt_max",
    "plot_map",
    "sdof_radius",
    "spectral_radius",
    "stability_map",
    "theory_dt_max",
]
