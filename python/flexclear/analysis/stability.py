"""Stability of the contact couplings under average-acceleration Newmark: the theory of a lagged
contact force (and a lagged kappa) and the measured largest stable step on the slider-yoke.

The derivation is in ``docs/stability.md``. In short: a contact spring ``k_l`` and dashpot ``c_l``
evaluated one step late (force method; the lagged kappa of the modified method lags the spring
part ``K_B (1 - kappa)``), with the rest of the system implicit, gives an amplification matrix
whose spectral radius is, for a single DOF of mass ``m`` and small ``Omega = omega dt``,
``rho ~ 1 + Omega^2 (k_l/k) / 2 - zeta Omega``: with no damping the lagged spring is unstable at
every step, and with damping the largest stable step is about ``c / k_l`` (``C_B/K_B`` for the
force method), whatever the mass.

The measurement (:func:`classify_run`, :func:`measure_limits`, :func:`stability_map`) tells an
unstable run (a perturbation grows: twin runs separate, or a bounded chatter fed by energy the
contact injects) from an inaccurate one (bounded and insensitive, but its peak penetration misses
the converged one by more than :data:`ACCURACY`) and reports both limits per coupling.

Everything here is for analysis and reports; nothing in the engine depends on it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from pathlib import Path
from typing import Optional

import numpy as np

from .. import scenes
from ..errors import FlexclearError, SimulationDivergedError
from ..result import Record
from .linear import link_matrices, slider_yoke_matrices

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
    damping_dofs: Optional[tuple] = None,
) -> np.ndarray:
    """Amplification matrix ``A`` of Newmark, ``[u, v, a]_{n+1} = A [u, v, a]_n``, for

    ``M a_{n+1} + (C + c_imp E_c) v_{n+1} + (K + k_imp e e^T) u_{n+1} = -k_lag e e^T u_n - c_lag E_c v_n``

    with ``e`` the unit vector of DOF ``dof``: a contact spring and dashpot on one DOF, split into
    a part in the step's matrix (implicit) and a part evaluated at the last state (lagged).
    ``E_c = e e^T``, or the sum over ``damping_dofs`` when the dashpot also acts on other DOFs (a
    viscous law ``-C_B qdot`` damps the tangential relative velocity too)."""
    n = M.shape[0]
    E = np.zeros((n, n))
    E[dof, dof] = 1.0
    Ec = E.copy()
    for d in damping_dofs or ():
        Ec[d, d] = 1.0
    Kp = K + k_imp * E
    Cp = C + c_imp * Ec
    S = M + gamma * dt * Cp + beta * dt * dt * Kp
    Si = np.linalg.inv(S)
    Au = -Si @ (Kp + k_lag * E)
    Av = -Si @ (Cp + dt * Kp + c_lag * Ec)
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


def theory_limits(
    M: np.ndarray,
    K: np.ndarray,
    C: np.ndarray,
    dof: int,
    stiffness: float,
    damping: float,
    label: str,
    *,
    contact_time: Optional[float] = None,
    growth: float = 10.0,
    dts: Optional[np.ndarray] = None,
    damping_dofs: Optional[tuple] = None,
) -> dict:
    """Largest stable step of coupling ``label`` for the linear system ``M, K, C`` with a contact
    spring ``stiffness`` (N/m) and dashpot ``damping`` (N s/m) on DOF ``dof`` (the dashpot also on
    ``damping_dofs``, see :func:`amplification`) in permanent contact (kappa = 0 for the lagged
    kappa), on a log grid ``dts`` (default 1e-9 .. 1e-3 s, 24 per decade).

    Returns ``asymptotic`` (largest dt below which every grid step has ``rho <= 1 + 1e-9``) and,
    when ``contact_time`` (s) is given, ``window`` (largest dt below which ``rho^(contact_time/dt)
    <= growth``: what a run of finite length can detect), and ``iteration`` (largest dt at which the
    kappa iteration contracts, for the iterated variant)."""
    dts = np.logspace(-9, -3, 145) if dts is None else np.asarray(dts)
    split = coupling_split(label, stiffness, damping)
    rho = np.array(
        [spectral_radius(amplification(M, K, C, dt, dof, damping_dofs=damping_dofs, **split)) for dt in dts]
    )

    def last_ok(ok: np.ndarray) -> float:
        if not ok[0]:
            return 0.0
        bad = np.flatnonzero(~ok)
        return float(dts[-1] if bad.size == 0 else dts[bad[0] - 1])

    out = {"asymptotic": last_ok(rho <= 1 + 1e-9), "rho": rho, "dts": dts}
    if contact_time is not None:
        out["window"] = last_ok(np.log(np.maximum(rho, 1e-300)) * contact_time / dts <= math.log(growth))
    if label == "modified, kappa iterated":
        fac = np.array([iteration_factor(M, K, C, dt, dof, stiffness, damping) for dt in dts])
        out["iteration"] = last_ok(fac < 1.0)
    return out


def theory_dt_max(
    model,
    label: str,
    *,
    contact_time: Optional[float] = None,
    growth: float = 10.0,
    dts: Optional[np.ndarray] = None,
) -> dict:
    """:func:`theory_limits` for a slider-yoke ``model``: the linearized FE slider (transverse
    DOFs, a 1 Hz grounding spring, see ``_transverse``), joint in permanent contact along y."""
    p = model.parameters
    M, K, C = _transverse(slider_yoke_matrices(model))
    dof = 0  # v of node 0 (the joint) in the transverse block
    return theory_limits(
        M,
        K,
        C,
        dof,
        p["bearing_stiffness"],
        p["bearing_damping"],
        label,
        contact_time=contact_time,
        growth=growth,
        dts=dts,
    )


# -- measurement --------------------------------------------------------------------------------
#: Relative change of the yoke amplitude in the twin run of :func:`classify_run` (it perturbs the
#: initial velocity and the forcing by the same fraction).
PERTURBATION = 1e-8
#: A run is unstable when its twin separation exceeds this multiple of the converged pair's (the
#: growth allowed in the theory's finite-window limit, ``rho^(contact_time/dt) <= 10``).
GROWTH = 10.0
#: Accuracy tolerance: the peak penetration within this fraction of the converged one.
ACCURACY = 0.10
#: Spurious chatter: more contact episodes (closings) than ``CHATTER[0] x converged + CHATTER[1]``.
CHATTER = (5, 10)
#: A contact is a net energy source when the work it returns exceeds this fraction of the work it
#: exchanges (the crossing error of a passive contact, ``K_B (v dt)^2/8`` per crossing, cancels
#: between entries and exits). On the slider-yoke map the stable implicit runs have balances of
#: -0.03 .. +1 except one gap run whose status iteration hit its cap 390 times (-0.34); the lagged
#: runs that chatter, -0.21 .. -0.82.
ACTIVE = 0.05


@dataclasses.dataclass
class Reference:
    """The converged run a measured run is compared with (:func:`converged_reference`)."""

    dt: float  # step of the baseline pair, s
    max_penetration: float  # m, iterated kappa with events at dt/2
    impacts: int  # contact episodes (every closing: JointResult.contact_episodes)
    contact_time: float  # s
    convergence: float  # relative change of the max penetration from dt to dt/2 (both with events)
    separation: float  # largest twin separation of the baseline pair (iterated kappa at dt), m


@dataclasses.dataclass
class RunCheck:
    """Classification of one run at one step (:func:`classify_run`)."""

    dt: float
    stable: bool
    accurate: bool
    growth: float  # twin separation / the converged pair's (inf when a run diverged)
    penetration_error: float  # max penetration / converged - 1 (nan when diverged)
    impacts: int  # contact episodes (every closing: JointResult.contact_episodes)
    net_work: float  # contact work balance: absorbed - returned, over exchanged (-1 .. 1)
    unconverged: int  # steps accepted at the iteration cap (both runs)
    reason: str  # why unstable, else why inaccurate, else ""


@dataclasses.dataclass
class StabilityPoint:
    """Largest stable and largest accurate step of one coupling at one bearing stiffness and
    damping ratio (:func:`measure_limits`)."""

    variant: str
    stiffness: float
    damping_ratio: float
    damping: float
    dt_stable: float  # largest stable step, s (0 if none was stable)
    dt_unstable: float  # smallest unstable step above it, s (inf if none was)
    why_unstable: str
    dt_accurate: float  # largest stable step meeting ACCURACY, s (nan: reference not converged)
    dt_inaccurate: float  # smallest step above it that failed (inf if none did)
    why_inaccurate: str
    runs: int
    cpu: float  # CPU time of the search, s
    checks: list = dataclasses.field(default_factory=list)  # every RunCheck, as dicts
    theory: dict = dataclasses.field(default_factory=dict)
    reference: dict = dataclasses.field(default_factory=dict)


def _stiff_model(stiffness: float, damping_ratio: float, clearance: float, perturbation: float = 0.0):
    p0 = scenes.slider_yoke().parameters
    return scenes.slider_yoke(
        clearance=clearance,
        bearing_stiffness=stiffness,
        bearing_damping_ratio=damping_ratio,
        amplitude=p0["amplitude"] * (1 + perturbation),
    )


def _run(model, kw: dict, t_end: float, dt: float, histories: bool = True, events: bool = False):
    """Slider-yoke run: ``(bearing JointResult, stats)``, or a string saying why it failed
    (diverged: limit 5 cm)."""
    p = model.parameters
    extra = {}
    if kw["method"] == "gap":
        extra = dict(gap_stiffness=p["bearing_stiffness"], gap_damping=p["bearing_damping"])
    rec = Record(joints=["bearing"]) if histories else Record(histories=False)
    try:
        r = model.simulate(t_end, dt, record=rec, divergence_limit=0.05, events=events, **kw, **extra)
    except SimulationDivergedError as e:
        return f"diverged at t = {e.time:.3g} s"
    return r.joint("bearing"), r.stats


def contact_work_balance(penetration: np.ndarray, force: np.ndarray) -> float:
    """Net energy the contact absorbs over a run, as a fraction of the energy it exchanges:
    ``sum w / sum |w|`` with ``w_n = (F_n + F_{n+1})/2 (delta_{n+1} - delta_n)``, the work of the
    force magnitudes ``F`` (the force in each step's equation) along the penetration ``delta``:
    the trapezoidal work of average-acceleration Newmark along the contact normal. A passive
    contact (spring returns what it took, dashpot dissipates) gives ``>= 0`` up to the crossing
    error; a coupling that injects energy gives a negative value. (Normal component only: the
    slider-yoke's relative motion at the bearing is nearly radial.)"""
    w = 0.5 * (force[1:] + force[:-1]) * np.diff(penetration)
    tot = float(np.abs(w).sum())
    return float(w.sum()) / tot if tot > 0 else 0.0


def classify_run(build, kw: dict, t_end: float, dt: float, reference: Reference, run=_run) -> RunCheck:
    """Runs coupling ``kw`` (keywords of ``simulate``) at step ``dt`` on ``build(0.0)`` and on its
    twin ``build(PERTURBATION)`` (``build(eps)``: the scene with the yoke amplitude scaled by
    ``1 + eps``), and classifies the run against the converged ``reference``:

    **unstable** when it diverges (limit 5 cm), or the twins' largest penetration difference
    exceeds ``GROWTH`` x the converged pair's (a perturbation grows: to first order the
    separation is the product of the step Jacobians applied to the initial perturbation, the
    quantity whose growth rate the spectral radius measures; the converged pair carries the
    physical sensitivity, impacts included), or it chatters spuriously (more than ``CHATTER`` x
    the converged run's closings, ``contact_episodes``) while its contact is a net energy source
    (:func:`contact_work_balance` below ``-ACTIVE``): a linear instability that the opening of the
    contact saturates into a bounded, insensitive chatter;

    **inaccurate** (but stable) when its max penetration is off the converged one by more than
    ``ACCURACY`` (or the reference did not converge to a third of that: ``accurate`` is then
    False and the reason says so).

    ``run(model, kw, t_end, dt)`` returns ``(joint result, stats)`` or a string saying why the run
    failed (default: the slider-yoke's :func:`_run`); a failed run is not stable."""
    a = run(build(0.0), kw, t_end, dt)
    b = run(build(PERTURBATION), kw, t_end, dt) if not isinstance(a, str) else a
    if isinstance(a, str) or isinstance(b, str):
        why = a if isinstance(a, str) else f"twin run: {b}"
        return RunCheck(dt, False, False, math.inf, math.nan, -1, math.nan, -1, why)
    (ja, sa), (jb, sb) = a, b
    growth = float(np.max(np.abs(ja.penetration - jb.penetration))) / reference.separation
    err = ja.max_penetration / reference.max_penetration - 1
    net = contact_work_balance(ja.penetration, ja.force)
    unconv = int(sa.get("unconverged_steps", 0)) + int(sb.get("unconverged_steps", 0))
    chatter = ja.contact_episodes > CHATTER[0] * reference.impacts + CHATTER[1]
    reason = ""
    if growth > GROWTH:
        reason = f"perturbation grows {growth:.3g} x the converged run's"
    elif chatter and net < -ACTIVE:
        reason = (
            f"spurious chatter ({ja.contact_episodes} closings, converged {reference.impacts}) with the "
            f"contact a net energy source (work balance {net:+.2f})"
        )
    stable = not reason
    accurate = stable and abs(err) <= ACCURACY and reference.convergence <= ACCURACY / 3
    if stable and not accurate:
        if reference.convergence > ACCURACY / 3:
            reason = f"reference not converged ({reference.convergence:.2g} from dt to dt/2)"
        else:
            reason = f"max penetration {err:+.3g} off the converged {reference.max_penetration:.3g} m"
    return RunCheck(dt, stable, accurate, growth, err, ja.contact_episodes, net, unconv, reason)


def converged_reference(build, t_end: float, max_steps: int = 4_000_000) -> Reference:
    """The converged run for :func:`classify_run`: iterated kappa with event-aware stepping (entries
    located within the step: without events the peak of a heavily damped contact scatters by
    +-5 % with the step) at ``dt = min(1e-6, 0.05 / omega_c)``, ``omega_c = sqrt(K_B / (m/4))``,
    and at ``dt/2``, halving both while they differ by more than ``ACCURACY / 3`` in max penetration
    and the finer run stays within ``max_steps``. The max penetration, closings
    (``contact_episodes``, in the field ``impacts``) and contact time come from the finer run,
    ``convergence`` is the last relative difference; the baseline twin separation is that of the
    fixed-step pair at ``dt`` (event cuts found to a tolerance would add noise to it)."""
    model = build(0.0)
    p = model.parameters
    wc = math.sqrt(p["bearing_stiffness"] / (p["mass"] / 4))
    dt = t_end / math.ceil(t_end / min(1e-6, 0.05 / wc))
    kw = dict(method="modified", iterate=True)
    coarse, _ = _run(model, kw, t_end, dt, histories=False, events=True)
    fine, _ = _run(model, kw, t_end, dt / 2, histories=False, events=True)

    def conv():
        return abs(coarse.max_penetration / fine.max_penetration - 1)

    while conv() > ACCURACY / 3 and t_end / (dt / 4) <= max_steps:
        dt /= 2
        coarse, (fine, _) = fine, _run(model, kw, t_end, dt / 2, histories=False, events=True)
    return _reference(build, kw, t_end, dt, fine, coarse, fine.contact_time, _run)


def _reference(build, kw, t_end, dt, fine, coarse, contact_time, run) -> Reference:
    (ja, _), (jb, _) = run(build(0.0), kw, t_end, dt), run(build(PERTURBATION), kw, t_end, dt)
    sep = float(np.max(np.abs(ja.penetration - jb.penetration)))
    return Reference(
        dt,
        fine.max_penetration,
        fine.contact_episodes,
        contact_time,
        abs(coarse.max_penetration / fine.max_penetration - 1),
        max(sep, 1e-300),
    )


def measure_limits(
    build,
    variant: str,
    reference: Reference,
    *,
    t_end: float = 0.02,
    dt_min: float = 1e-8,
    dt_max: float = 1e-4,
    per_decade: int = 3,
    bisections: int = 3,
    run=_run,
    omega: Optional[float] = None,
) -> tuple[float, float, str, float, float, str, list[RunCheck]]:
    """Largest stable and largest accurate step of ``variant`` (a label of :data:`VARIANTS`) on
    ``build(eps)`` (see :func:`classify_run`; ``run`` as there).

    Steps are tried upwards on a log grid (``per_decade`` per decade) from
    ``max(dt_min, 0.01 / omega)``, ``omega`` the contact frequency (default
    ``sqrt(K_B / (m/4))`` of the slider-yoke), to ``dt_max`` until one is
    unstable; each limit (last stable, last stable-and-accurate before the first failure) is then
    bisected ``bisections`` times (geometrically). Both are the first loss from below: larger
    steps can pass again (a saturated chatter regime), which is not counted. An unstable grid
    step whose next grid step is stable is reported as isolated and skipped: a growing mode
    persists at larger steps (the spectral radius and the kappa-iteration factor grow with dt),
    while an isolated failure is a discontinuity of the step map (an open/closed decision at the
    iteration cap that the perturbation flips: the separation jumps by a fixed amount whatever the
    perturbation's size). Returns
    ``(dt_stable, dt_unstable, why, dt_accurate, dt_inaccurate, why, checks)``."""
    kw = dict(VARIANTS)[variant] if isinstance(variant, str) else variant
    if omega is None:
        p = build(0.0).parameters
        omega = math.sqrt(p["bearing_stiffness"] / (p["mass"] / 4))
    lo = max(dt_min, 0.01 / omega)
    n = max(1, round(per_decade * math.log10(dt_max / lo)))
    grid = np.logspace(math.log10(lo), math.log10(dt_max), n + 1)
    checks: list[RunCheck] = []
    done: dict[float, RunCheck] = {}

    def check(dt: float) -> RunCheck:
        if float(dt) not in done:
            done[float(dt)] = classify_run(build, kw, t_end, float(dt), reference, run)
            checks.append(done[float(dt)])
        return done[float(dt)]

    s_ok, s_bad, s_why = 0.0, math.inf, ""
    a_ok, a_bad, a_why = 0.0, math.inf, ""
    isolated: list[float] = []
    for i, dt in enumerate(grid):
        c = check(dt)
        if math.isinf(a_bad):
            if c.accurate:
                a_ok = c.dt
            else:
                a_bad, a_why = c.dt, c.reason
        if not c.stable:
            # a growing mode persists at larger steps (rho and the kappa-iteration factor grow
            # with dt); a failure with a stable next grid step is a discontinuity of the step map
            # (a status decision the perturbation flips), reported but not taken as the limit
            if i + 1 < len(grid) and check(grid[i + 1]).stable:
                isolated.append(c.dt)
                continue
            s_bad, s_why = c.dt, c.reason
            break
        s_ok = c.dt
    for ok_bad in ("s", "a"):
        for _ in range(bisections):
            ok, bad = (s_ok, s_bad) if ok_bad == "s" else (a_ok, a_bad)
            if not (ok > 0 and math.isfinite(bad)):
                break
            c = check(math.sqrt(ok * bad))
            if ok_bad == "s":
                s_ok, s_bad, s_why = (c.dt, s_bad, s_why) if c.stable else (s_ok, c.dt, c.reason)
            else:
                a_ok, a_bad, a_why = (c.dt, a_bad, a_why) if c.accurate else (a_ok, c.dt, c.reason)
    if reference.convergence > ACCURACY / 3:
        a_ok = math.nan
    if isolated:
        s_why += f" (isolated failures below: {', '.join(f'{d:.3g}' for d in isolated)} s)"
    return s_ok, s_bad, s_why, a_ok, a_bad, a_why, checks


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
    """Measured largest stable and largest accurate step and the theory for every
    (stiffness, damping ratio, variant) on the slider-yoke."""
    points = []
    for ratio in damping_ratios:
        for kb in stiffnesses:

            def build(eps: float, kb=kb, ratio=ratio):
                return _stiff_model(kb, ratio, clearance, eps)

            model = build(0.0)
            p = model.parameters
            t0 = time.process_time()
            ref = converged_reference(build, t_end)
            if log:
                log(f"zeta={ratio:g} K_B={kb:.0e} reference {ref} ({time.process_time() - t0:.1f} s)")
            for v in variants:
                t0 = time.process_time()
                limits = measure_limits(build, v, ref, t_end=t_end, **search)
                theory = theory_dt_max(model, v, contact_time=ref.contact_time)
                theory["sdof_c_over_k"] = p["bearing_damping"] / kb
                points.append(_point(v, kb, ratio, p["bearing_damping"], limits, t0, theory, ref, log))
    return points


def _point(variant, stiffness, ratio, damping, limits, t0, theory, ref, log) -> StabilityPoint:
    """The :class:`StabilityPoint` of :func:`measure_limits`' result ``limits`` (its search
    started at CPU time ``t0``), with ``theory`` (its ``rho``/``dts`` arrays left out) and the
    reference ``ref``; logged when ``log`` is given."""
    s_ok, s_bad, s_why, a_ok, a_bad, a_why, checks = limits
    pt = StabilityPoint(
        variant,
        stiffness,
        ratio,
        damping,
        s_ok,
        s_bad,
        s_why,
        a_ok,
        a_bad,
        a_why,
        2 * len(checks),
        time.process_time() - t0,
        [dataclasses.asdict(c) for c in checks],
        {k: val for k, val in theory.items() if k not in ("rho", "dts")},
        dataclasses.asdict(ref),
    )
    if log:
        log(
            f"  {variant:26s} stable {s_ok:.3g} (fails {s_bad:.3g}: {s_why}); accurate {a_ok:.3g} "
            f"(fails {a_bad:.3g}: {a_why}); theory {pt.theory}; {pt.cpu:.1f} s"
        )
    return pt


# -- KED: the flexible slider-crank with a clearance at the crank pin --------------------------
#: The couplings of the KED map (``Model.simulate`` keywords): the default implicit contact,
#: the paper's lagged kappa and the force method.
KED_VARIANTS = (
    ("implicit (iterated)", {"method": "modified", "iterate": True}),
    ("modified, kappa lagged", {"method": "modified", "iterate": False}),
    ("force", {"method": "force"}),
)


def _ked_model(stiffness: float, damping_ratio: float, perturbation: float = 0.0):
    """``scenes.slider_crank`` with the clearance at the crank pin, K_B ``stiffness`` and C_B
    for ``damping_ratio`` of critical at the scene's effective mass; the twin perturbs the crank
    speed (150 rad/s) by the fraction ``perturbation``."""
    return scenes.slider_crank(
        clearance_at="crank_pin",
        bearing_stiffness=stiffness,
        bearing_damping_ratio=damping_ratio,
        crank_speed=150.0 * (1 + perturbation),
    )


def _ked_run(model, kw: dict, t_end: float, dt: float):
    """Slider-crank run: ``(crank-pin joint result, stats)`` or why it failed (divergence, limit
    5 cm; Newton not converged; effective matrix not positive definite)."""
    try:
        r = model.simulate(t_end, dt, record=Record(displacements=False), divergence_limit=0.05, **kw)
    except FlexclearError as e:
        return f"{type(e).__name__}: {str(e)[:80]}"
    return r.joint("crank_pin"), {"unconverged_steps": 0}


def ked_matrices(model) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]:
    """Linearization of a :func:`flexclear.scenes.slider_crank` model for the contact at the crank
    pin: the rod's FE matrices (consistent mass, Kelvin-Voigt damping) along the dead-centre line
    (rod along the guide), the slider mass on the axial DOF of its end, its transverse DOF held by
    the guide, a 1 Hz grounding spring on every DOF (rigid modes as simple oscillators, as in
    ``_transverse``). The contact spring acts on the axial DOF of rod node 0 (the rod carries the
    crank-pin force mostly along its axis); the viscous dashpot ``-C_B qdot`` also on its
    transverse DOF (the tangential relative velocity), whose effective mass is 4 x smaller (0.0014
    against 0.0055 kg): that is where the lagged dashpot of the force method goes unstable. Frame
    motion (centrifugal, Coriolis) and the axial-force terms are left out. Returns
    ``(M, K, C, (axial dof, transverse dof))``."""
    p = model.parameters
    geometry = (p["rod_length"], p["elements"], p["youngs_modulus"], p["density"], p["area"], p["inertia"])
    mats = link_matrices(*geometry, p["damping"])
    n = mats.M.shape[0]
    M, K, C = mats.M.copy(), mats.K.copy(), mats.C.copy()
    M[n - 3, n - 3] += p["slider_mass"]
    keep = np.array([i for i in range(n) if i != n - 2])
    M, K, C = (A[np.ix_(keep, keep)] for A in (M, K, C))
    K = K + (2 * math.pi) ** 2 * np.diag(np.diag(M))
    return M, K, C, (0, 1)


def _ked_omega(model) -> float:
    """Contact frequency at the crank pin, rad/s: ``sqrt(K_B / m_eff)`` with the effective mass
    ``1 / [M^-1]_ee`` of :func:`ked_matrices` (0.0055 kg; the scene's C_B uses half the rod)."""
    M, _, _, dofs = ked_matrices(model)
    return math.sqrt(model.parameters["bearing_stiffness"] * np.linalg.inv(M)[dofs[0], dofs[0]])


def ked_reference(
    stiffness: float, damping_ratio: float, t_end: float, max_steps: int = 2_000_000
) -> Reference:
    """Converged slider-crank run: implicit contact at ``dt = min(1e-6, 0.05 / omega_c)`` and
    ``dt/2`` (``omega_c`` of ``_ked_omega``), halved as in :func:`converged_reference`; the
    reference values come from the finer run, the twin separation from the pair at ``dt``."""
    build = functools.partial(_ked_model, stiffness, damping_ratio)
    wc = _ked_omega(build(0.0))
    dt = t_end / math.ceil(t_end / min(1e-6, 0.05 / wc))
    kw = dict(KED_VARIANTS)["implicit (iterated)"]

    def run(step: float):
        r = _ked_run(build(0.0), kw, t_end, step)
        if isinstance(r, str):
            raise RuntimeError(f"the KED reference at dt = {step:g} s failed: {r}")
        return r[0]

    coarse, fine = run(dt), run(dt / 2)

    def conv() -> float:
        return abs(coarse.max_penetration / fine.max_penetration - 1)

    while conv() > ACCURACY / 3 and 4 * t_end <= max_steps * dt:
        dt /= 2
        coarse, fine = fine, run(dt / 2)
    contact_time = float(np.count_nonzero(fine.penetration[1:] > 0)) * dt / 2
    return _reference(build, kw, t_end, dt, fine, coarse, contact_time, _ked_run)


def ked_stability_map(
    stiffnesses=(1e7, 1e9, 1e11),
    damping_ratios=(0.0, 0.2),
    *,
    t_end: float = 0.0013,
    log=None,
    **search,
) -> list[StabilityPoint]:
    """Largest stable and largest accurate step of :data:`KED_VARIANTS` on the slider-crank with a
    crank-pin clearance (0.5 mm) over ``t_end`` s from rest, beside the theory of
    :func:`ked_matrices`. Same classification as :func:`stability_map`. The default 1.3 ms holds
    the first impact (contact from 0.47 to about 0.65 ms) and the flight after it: the rebounds
    that follow (from about 1.35 ms) turn into bursts of micro-impacts on stiff bearings (over 100
    by 5 ms at K_B = 1e11), whose twin separation is physical and not reproducible from one step
    to another, so no baseline would hold."""
    points = []
    for ratio in damping_ratios:
        for kb in stiffnesses:
            build = functools.partial(_ked_model, kb, ratio)
            p = build(0.0).parameters
            t0 = time.process_time()
            ref = ked_reference(kb, ratio, t_end)
            if log:
                log(f"KED zeta={ratio:g} K_B={kb:.0e} reference {ref} ({time.process_time() - t0:.1f} s)")
            M, K, C, dofs = ked_matrices(build(0.0))
            for v, kw in KED_VARIANTS:
                t0 = time.process_time()
                limits = measure_limits(
                    build,
                    kw,
                    ref,
                    t_end=t_end,
                    run=_ked_run,
                    omega=_ked_omega(build(0.0)),
                    **search,
                )
                # the implicit KED contact is solved by Newton (no fixed-point iteration of kappa
                # whose contraction limits it): fully implicit, as the gap element's split
                label = "gap" if kw.get("iterate") else v
                th = theory_limits(
                    M,
                    K,
                    C,
                    dofs[0],
                    kb,
                    p["bearing_damping"],
                    label,
                    contact_time=ref.contact_time,
                    damping_dofs=dofs,
                )
                th["effective_mass"] = [float(1 / np.linalg.inv(M)[d, d]) for d in dofs]
                points.append(_point(v, kb, ratio, p["bearing_damping"], limits, t0, th, ref, log))
    return points


def plot_map(points: list[StabilityPoint], path: Path, scene: str = "slider-yoke, clearance 1e-5 m") -> None:
    """Largest stable dt (filled markers; a down triangle at the first step tried when that one was
    already unstable) and largest accurate dt (open markers) vs K_B, one panel per damping ratio,
    beside the theory (lines: asymptotic rho <= 1 solid, finite window dashed,
    kappa-iteration limit dotted)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ratios = sorted({p.damping_ratio for p in points})
    variants = list(dict.fromkeys(p.variant for p in points))
    fig, axes = plt.subplots(1, len(ratios), figsize=(4.6 * len(ratios), 4.8), sharey=True, squeeze=False)
    palette = {"force": "C3", "modified, kappa lagged": "C0", "modified, kappa iterated": "C2", "gap": "C1"}
    palette["implicit (iterated)"] = "C2"
    colors = {v: palette.get(v, f"C{4 + i}") for i, v in enumerate(variants)}
    shift = dict(zip(variants, [0.94, 0.98, 1.02, 1.06]))  # so coinciding markers stay visible
    for ax, z in zip(axes[0], ratios):
        for v in variants:
            pts = sorted(
                (p for p in points if p.damping_ratio == z and p.variant == v), key=lambda p: p.stiffness
            )
            kb = np.array([p.stiffness for p in pts])
            stable = [p.dt_stable if p.dt_stable > 0 else np.nan for p in pts]
            acc = [p.dt_accurate if p.dt_accurate > 0 else np.nan for p in pts]
            ax.loglog(kb * shift[v], stable, "o", color=colors[v], label=f"{v}: stable")
            # unstable already at the first step tried: a down triangle there
            below = [(p.stiffness * shift[v], p.checks[0]["dt"]) for p in pts if p.dt_stable == 0]
            if below:
                ax.loglog(*zip(*below), "v", color=colors[v], ms=7)
            ax.loglog(kb * shift[v], acc, "o", mfc="none", ms=9, color=colors[v], label=f"{v}: accurate")
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
    axes[0][0].set_ylabel("largest dt (s)")
    axes[0][0].legend(fontsize=6, loc="lower left")
    fig.suptitle(
        f"{scene}: measured stable (filled) and accurate to {ACCURACY:.0%} in peak penetration (open)\n"
        "theory: solid rho <= 1, dashed finite window, dotted secant kappa-iteration limit "
        "(the engine now iterates by Newton)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _short(x: float) -> str:
    """``2.1e-06`` -> ``2.1e-6``."""
    return f"{x:.2g}".replace("e-0", "e-").replace("e+0", "e").replace("e+", "e")


def markdown_table(points) -> str:
    """The table of docs/stability.md section 2 (or 2.1) from :class:`StabilityPoint` s (or their
    dicts, as in the bench's JSON): per damping ratio and K_B, each coupling's largest stable /
    largest accurate step (s) and, in brackets, the lagged-coupling theory (asymptotic ``rho <= 1``,
    ``w`` the finite window where it differs by more than 5 %; ``stable`` for the implicit
    couplings). ``>= 1e-4``: every step tried passed; ``< x``: the first step tried (x) failed;
    ``n/a``: the reference did not converge. Rows where every coupling passed every step are left
    out."""
    pts = [p if isinstance(p, dict) else dataclasses.asdict(p) for p in points]
    cols = list(dict.fromkeys(p["variant"] for p in pts))
    lagged = {"force", "modified, kappa lagged"}

    def limit(p: dict, ok: float, bad: float) -> str:
        first = min((c["dt"] for c in p["checks"]), default=math.nan)
        if ok is None or math.isnan(ok):
            return "n/a"
        if ok == 0:
            return f"< {_short(first)}"
        if math.isinf(bad) and ok >= 9.9e-5:
            return ">= 1e-4"
        return _short(ok)

    def cell(p: dict) -> str:
        th = p["theory"]
        asym = th.get("asymptotic", math.nan)
        win = th.get("window", asym)
        if p["variant"] in lagged and asym < 1e-3:
            t = _short(asym) if asym > 0 else "0"
            if abs(win - asym) > 0.05 * asym:
                t += f", w {_short(win)}"
        else:
            t = "stable"
        stable = limit(p, p["dt_stable"], p["dt_unstable"])
        return f"{stable} / {limit(p, p['dt_accurate'], p['dt_inaccurate'])} ({t})"

    rows: dict = {}
    for p in pts:
        rows.setdefault((p["damping_ratio"], p["stiffness"]), {})[p["variant"]] = p
    lines = ["| zeta | K_B (N/m) | " + " | ".join(cols) + " |", "|---|---|" + "---|" * len(cols)]
    for (z, k), r in sorted(rows.items()):
        if all(r[c]["dt_stable"] >= 9.9e-5 and math.isinf(r[c]["dt_unstable"]) for c in r):
            continue
        cells = " | ".join(cell(r[c]) if c in r else "-" for c in cols)
        lines.append(f"| {z:g} | {_short(k)} | {cells} |")
    return "\n".join(lines)


__all__ = [
    "ACCURACY",
    "GROWTH",
    "KED_VARIANTS",
    "PERTURBATION",
    "VARIANTS",
    "Reference",
    "RunCheck",
    "StabilityPoint",
    "amplification",
    "coupling_split",
    "iteration_factor",
    "ked_matrices",
    "ked_reference",
    "ked_stability_map",
    "classify_run",
    "contact_work_balance",
    "converged_reference",
    "markdown_table",
    "measure_limits",
    "plot_map",
    "sdof_radius",
    "spectral_radius",
    "stability_map",
    "theory_dt_max",
    "theory_limits",
]
