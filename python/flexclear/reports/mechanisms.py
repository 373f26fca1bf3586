"""Reports of the kineto-elastodynamic scenes: ``flexclear spin-up``, ``flexclear slider-crank`` and
``flexclear four-bar``. Each function runs its scene, writes PNG plots and ``summary.md`` into an
output folder and returns the path of the summary. Plots use matplotlib's Agg backend.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from .. import scenes
from ..errors import FlexclearError
from ..frames import Rotation
from ..result import Record, Result

Log = Callable[[str], None]

#: Root eigenvalue of the first clamped-free Euler-Bernoulli mode, (beta_1 L)^2 = 1.8751^2.
CANTILEVER_BETA1_SQ = 1.875104068711961**2


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _quiet(_: str) -> None:
    pass


def _run(mech, t_end: float, dt: float, **kw) -> tuple[Result, Optional[FlexclearError]]:
    """Runs ``mech``; on a failure returns the partial result carried by the exception."""
    try:
        return mech.simulate(t_end, dt, **kw), None
    except FlexclearError as e:
        res = getattr(e, "result", None)
        if res is None:
            raise
        return res, e


def _status(err: Optional[FlexclearError], res: Result) -> str:
    return "complete" if err is None else f"{type(err).__name__} at t = {res.end_time:.4g} s"


def _fmt(x: float, unit: str = "", digits: int = 4) -> str:
    return f"{x:.{digits}g}{(' ' + unit) if unit else ''}"


def read_reference(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Reads a frequency table for the spin-up plot: comma-separated, ``#`` comment lines, one
    header line, then rows ``lambda, w1, w2, ...`` in the classic nondimensional form
    ``lambda = Omega / w_ref``, ``w_i / w_ref`` with ``w_ref = sqrt(EI / (rho A L^4))``. Returns
    ``(lambda, W)`` with ``W`` of shape (rows, modes)."""
    rows = []
    header_seen = False
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if not header_seen:
            header_seen = True
            try:
                [float(v) for v in line.split(",")]
            except ValueError:
                continue  # the header
        rows.append([float(v) if v.strip() else math.nan for v in line.split(",")])
    if not rows:
        raise FlexclearError(f"{path}: no data rows")
    a = np.array(rows, dtype=float)
    return a[:, 0], a[:, 1:]


# ---------------------------------------------------------------------------------------------
# Spin-up
# ---------------------------------------------------------------------------------------------


def spin_up_report(
    out: Path,
    *,
    dt: float = 1e-3,
    t_end: float = 20.0,
    elements: int = 10,
    data: str = "kane",
    speeds: int = 41,
    max_speed: Optional[float] = None,
    reference: Optional[Path] = None,
    reference_flapwise: bool = True,
    log: Log = _quiet,
) -> Path:
    """Spin-up of a cantilever with and without geometric stiffening, and its in-plane
    frequencies against a constant hub speed.

    Writes ``spin_up_tip.png`` (tip deflection in the hub frame; the unstiffened run is plotted up
    to where it stopped), ``spin_up_frequencies.png`` (first two in-plane frequencies of the
    stiffened model, Coriolis coupling included and dropped, and the unstiffened first mode) and
    ``summary.md``. ``reference``: a table read by :func:`read_reference`, overlaid as in-plane
    frequencies (``w_in^2 = w_flap^2 - Omega^2`` when ``reference_flapwise``).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    runs = {}
    for geometric in (True, False):
        mech = scenes.spin_up(data=data, elements=elements, geometric=geometric)
        t0 = time.perf_counter()
        res, err = _run(mech, t_end, dt)
        runs[geometric] = (mech, res, err, time.perf_counter() - t0)
        log(f"spin-up geometric={geometric}: {res!r}")
    p = runs[True][0].parameters
    w_ref = math.sqrt(p["youngs_modulus"] * p["inertia"] / (p["density"] * p["area"] * p["length"] ** 4))
    big_w = p["final_rate"]
    rot = Rotation.spin_up(final_rate=big_w, ramp_time=p["ramp_time"])

    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    colors = {True: "C0", False: "C3"}
    labels = {True: "with geometric stiffness", False: "without (linear)"}
    for geometric in (True, False):
        _, res, err, _ = runs[geometric]
        tip = res.link("beam").tip
        lab = labels[geometric] + (f" (stopped at {res.end_time:.2f} s)" if err is not None else "")
        axes[0].plot(res.time, tip, color=colors[geometric], label=lab)
        if geometric:
            axes[1].plot(res.time, tip, color=colors[geometric], label=lab)
    axes[0].set_ylabel("tip deflection, m")
    axes[0].set_title(
        f"Spin-up ({data} data): W = {big_w:g} rad/s over T = {p['ramp_time']:g} s, dt = {dt:g} s"
    )
    axes[0].legend(loc="lower left", fontsize=8)
    axes[0].grid(alpha=0.3)
    axes[1].set_ylabel("tip deflection, m")
    axes[1].set_xlabel("time, s")
    axes[1].grid(alpha=0.3)
    ax2 = axes[1].twinx()
    tt = runs[True][1].time
    ax2.plot(tt, [rot.at(t)[1] for t in tt], color="0.5", ls="--", lw=1, label="hub rate")
    ax2.set_ylabel("hub rate, rad/s")
    axes[1].legend(loc="lower right", fontsize=8)
    ax2.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "spin_up_tip.png", dpi=120)
    plt.close(fig)

    # Frequencies at constant speed.
    top = max_speed if max_speed is not None else 2.5 * big_w
    omegas = np.linspace(0.0, top, speeds)
    f_cor = np.full((speeds, 2), np.nan)
    f_nocor = np.full((speeds, 2), np.nan)
    f_lin = np.full(speeds, np.nan)
    for i, om in enumerate(omegas):
        mech = scenes.spin_up(data=data, elements=elements, rotation=Rotation.constant(float(om)))
        f = 2 * np.pi * mech.natural_frequencies(2)
        f_cor[i, : len(f)] = f
        f = 2 * np.pi * mech.natural_frequencies(2, coriolis=False)
        f_nocor[i, : len(f)] = f
        lin = scenes.spin_up(
            data=data, elements=elements, geometric=False, rotation=Rotation.constant(float(om))
        )
        # Signed squared first frequency of the unstiffened model (Coriolis dropped): it
        # crosses zero where the linear model loses stability.
        mm, _, kk, _ = lin._core.linearize(0.0, lin.static_state(0.0))
        f_lin[i] = np.min(np.linalg.eigvals(np.linalg.solve(mm, kk)).real)
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for k in range(2):
        ax.plot(omegas, f_cor[:, k], color=f"C{k}", label=f"mode {k + 1}, with Coriolis")
        ax.plot(omegas, f_nocor[:, k], color=f"C{k}", ls=":", label=f"mode {k + 1}, Coriolis dropped")
    lin_real = np.where(f_lin > 0, np.sqrt(np.clip(f_lin, 0, None)), np.nan)
    ax.plot(omegas, lin_real, color="C3", ls="--", label="mode 1 without geometric stiffness")
    crossing = None
    neg = np.nonzero(f_lin <= 0)[0]
    if neg.size and neg[0] > 0:
        i = neg[0]
        a, b = f_lin[i - 1], f_lin[i]
        # w^2 is close to linear in Omega^2 (w^2 = w0^2 - Omega^2 for the unstiffened beam).
        crossing = math.sqrt(omegas[i - 1] ** 2 + (omegas[i] ** 2 - omegas[i - 1] ** 2) * a / (a - b))
        ax.axvline(crossing, color="C3", lw=0.8, alpha=0.6)
    ref_note = ""
    if reference is not None:
        lam, table = read_reference(Path(reference))
        om_ref = lam * w_ref
        for k in range(min(2, table.shape[1])):
            w = table[:, k] * w_ref
            w_in = np.sqrt(np.clip(w**2 - om_ref**2, 0, None)) if reference_flapwise else w
            ax.plot(om_ref, w_in, "ko", ms=4, mfc="none", label="reference" if k == 0 else None)
        ref_note = f"Reference overlaid from `{reference}`" + (
            " (flapwise, converted by w_in^2 = w_flap^2 - Omega^2)." if reference_flapwise else "."
        )
    ax.set_xlabel("hub speed Omega, rad/s")
    ax.set_ylabel("in-plane natural frequency, rad/s")
    ax.set_yscale("log")
    ax.set_title(f"In-plane frequencies of the spinning cantilever ({data} data, {elements} elements)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "spin_up_frequencies.png", dpi=120)
    plt.close(fig)

    # Summary.
    mech_s, res_s, err_s, sec_s = runs[True]
    mech_l, res_l, err_l, sec_l = runs[False]
    tip_s = res_s.link("beam").tip
    tip_l = res_l.link("beam").tip
    late = res_s.time >= min(p["ramp_time"], res_s.end_time)
    f0 = f_cor[0, 0]
    analytic = CANTILEVER_BETA1_SQ * w_ref
    lines = [
        f"# Spin-up ({data} data)",
        "",
        f"L = {p['length']:g} m, E = {p['youngs_modulus']:g} Pa, rho = {p['density']:g} kg/m^3, "
        f"A = {p['area']:g} m^2, I = {p['inertia']:g} m^4; {elements} elements; hub spun up to "
        f"W = {big_w:g} rad/s over T = {p['ramp_time']:g} s; dt = {dt:g} s, t_end = {t_end:g} s.",
        "",
        "| run | status | max abs tip, m | tip at end, m | wall, s |",
        "|---|---|---|---|---|",
        f"| with geometric stiffness | {_status(err_s, res_s)} | "
        f"{_fmt(np.max(np.abs(tip_s)))} | {_fmt(tip_s[-1])} | {sec_s:.2f} |",
        f"| without | {_status(err_l, res_l)} | "
        f"{_fmt(np.max(np.abs(tip_l)))} | {_fmt(tip_l[-1])} | {sec_l:.2f} |",
        "",
        f"With stiffening, after the ramp (t >= {p['ramp_time']:g} s) the tip stays within "
        f"[{_fmt(tip_s[late].min())}, {_fmt(tip_s[late].max())}] m."
        if np.any(late)
        else "",
        "",
        "## In-plane frequencies (constant hub speed)",
        "",
        f"At rest: FE {f0:.5f} rad/s vs Euler-Bernoulli cantilever 1.8751^2 sqrt(EI/(rho A L^4)) = "
        f"{analytic:.5f} rad/s ({100 * (f0 / analytic - 1):+.4f} %).",
        "",
        "| Omega, rad/s | mode 1, rad/s | mode 2, rad/s | mode 1 without Coriolis | mode 1 unstiffened |",
        "|---|---|---|---|---|",
    ]
    for i in np.unique(np.linspace(0, speeds - 1, min(speeds, 6)).round().astype(int)):
        lines.append(
            f"| {omegas[i]:.3g} | {f_cor[i, 0]:.4f} | {f_cor[i, 1]:.4f} | {f_nocor[i, 0]:.4f} | "
            f"{'unstable' if f_lin[i] <= 0 else f'{math.sqrt(f_lin[i]):.4f}'} |"
        )
    lines += [
        "",
        f"Without geometric stiffness the first in-plane frequency vanishes at Omega = {crossing:.4f} rad/s "
        f"(the rest frequency is {f0:.4f} rad/s): above it the linear model is unstable."
        if crossing is not None
        else "The unstiffened first frequency did not vanish over the speed range.",
        ref_note,
        "",
        "Plots: `spin_up_tip.png`, `spin_up_frequencies.png`.",
        "",
    ]
    path = out / "summary.md"
    path.write_text("\n".join(lines))
    return path


# ---------------------------------------------------------------------------------------------
# Slider-crank
# ---------------------------------------------------------------------------------------------


def slider_crank_report(
    out: Path,
    *,
    dt: float = 1e-5,
    t_end: float = 0.1,
    elements: int = 8,
    clearance_at: Optional[str] = None,
    clearance: float = 5e-4,
    method: str = "modified",
    log: Log = _quiet,
) -> Path:
    """Simeon's flexible slider-crank: rod midspan deflection and axial force over the run; with
    ``clearance_at``, the clearance variant beside it and its contact force and penetration.

    Writes ``slider_crank_rod.png``, ``slider_crank_contact.png`` (with a clearance) and
    ``summary.md``.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    variants = [("ideal pins", scenes.slider_crank(elements=elements))]
    if clearance_at is not None:
        variants.append(
            (
                f"clearance {clearance * 1e3:g} mm at {clearance_at}",
                scenes.slider_crank(elements=elements, clearance_at=clearance_at, clearance=clearance),
            )
        )
    runs = []
    for label, mech in variants:
        t0 = time.perf_counter()
        res, err = _run(mech, t_end, dt, method=method, record=Record(midspan=True, axial_force=True))
        runs.append((label, mech, res, err, time.perf_counter() - t0))
        log(f"slider-crank {label}: {res!r}")
    mid_el = elements // 2
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    for k, (label, _, res, err, _) in enumerate(runs):
        rod = res.link("rod")
        lab = label + (f" (stopped at {res.end_time:.4f} s)" if err is not None else "")
        axes[0].plot(res.time * 1e3, rod.midspan * 1e3, color=f"C{k}", lw=1, label=lab)
        axes[1].plot(res.time * 1e3, rod.axial_force[:, mid_el], color=f"C{k}", lw=1, label=lab)
    w = variants[0][1].parameters["crank_speed"]
    axes[0].set_ylabel("rod midspan deflection, mm")
    axes[0].set_title(
        f"Flexible slider-crank (Simeon 1996): crank {w:g} rad/s, {elements} elements, dt = {dt:g} s"
    )
    axes[1].set_ylabel(f"axial force, element {mid_el + 1}, N")
    axes[1].set_xlabel("time, ms")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "slider_crank_rod.png", dpi=120)
    plt.close(fig)

    if clearance_at is not None:
        label, mech, res, err, _ = runs[1]
        j = res.joint(clearance_at)
        fig, axes = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
        axes[0].plot(res.time * 1e3, j.force, lw=0.8)
        axes[0].set_ylabel("contact force, N")
        axes[0].set_title(f"Slider-crank, {label}")
        axes[1].plot(res.time * 1e3, j.penetration * 1e6, lw=0.8)
        axes[1].axhline(0, color="0.5", lw=0.6)
        axes[1].set_ylabel("penetration (negative: open), um")
        axes[1].set_xlabel("time, ms")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / "slider_crank_contact.png", dpi=120)
        plt.close(fig)

    p = variants[0][1].parameters
    euler = math.pi**2 * p["youngs_modulus"] * p["inertia"] / p["rod_length"] ** 2
    lines = [
        "# Flexible slider-crank (Simeon 1996)",
        "",
        f"Crank {p['crank_length']:g} m at {p['crank_speed']:g} rad/s, rod {p['rod_length']:g} m, "
        f"{p['side'] * 1e3:g} x {p['side'] * 1e3:g} mm steel (E = {p['youngs_modulus']:g} Pa, "
        f"rho = {p['density']:g} kg/m^3), slider {p['slider_mass']:g} kg; {elements} elements; "
        f"dt = {dt:g} s, t_end = {t_end:g} s; from rest in the moving frames.",
        "",
        "| variant | status | max abs midspan, mm | max tension, N | max compression, N | wall, s |",
        "|---|---|---|---|---|---|",
    ]
    for label, _, res, err, sec in runs:
        rod = res.link("rod")
        n = rod.axial_force[:, mid_el]
        lines.append(
            f"| {label} | {_status(err, res)} | {np.max(np.abs(rod.midspan)) * 1e3:.4g} | "
            f"{max(n.max(), 0):.4g} | {max(-n.min(), 0):.4g} | {sec:.2f} |"
        )
    lines += [
        "",
        f"Euler load of the pinned-pinned rod pi^2 EI / L^2 = {euler:.4g} N. The fast ripple of the axial "
        "force is the rod's axial mode (about 3 kHz with the slider), set off by starting from an "
        "undeformed rod and undamped like Simeon's rod; contact damping removes it in the clearance variant.",
    ]
    if clearance_at is not None:
        label, mech, res, err, _ = runs[1]
        j = res.joint(clearance_at)
        q = mech.parameters
        lines += [
            "",
            f"Clearance joint `{clearance_at}`: c = {q['clearance']:g} m, "
            f"K_B = {q['bearing_stiffness']:.4g} N/m (Hertz secant at {q['reference_penetration']:g} m), "
            f"C_B = {q['bearing_damping']:.4g} N s/m ({q['bearing_damping_ratio']:g} of critical for "
            f"{q['effective_mass']:.4g} kg); method {method}: "
            f"max contact force {j.max_force:.4g} N, max penetration {j.max_penetration * 1e6:.4g} um, "
            f"{j.impacts} impacts.",
        ]
    lines += [
        "",
        "Plots: `slider_crank_rod.png`" + (", `slider_crank_contact.png`." if clearance_at else "."),
        "",
    ]
    path = out / "summary.md"
    path.write_text("\n".join(lines))
    return path


# ---------------------------------------------------------------------------------------------
# Four-bar
# ---------------------------------------------------------------------------------------------


def four_bar_report(
    out: Path,
    *,
    dt: float = 1e-4,
    t_end: Optional[float] = None,
    elements: int = 6,
    crank_speed: float = 100.0,
    flexible_rocker: bool = False,
    log: Log = _quiet,
) -> Path:
    """The four-bar with a flexible coupler: coupler midspan deflection and axial force against
    the crank angle. ``t_end`` defaults to three crank turns. Writes ``four_bar_coupler.png`` and
    ``summary.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    mech = scenes.four_bar(elements=elements, crank_speed=crank_speed, flexible_rocker=flexible_rocker)
    turn = 2 * math.pi / abs(crank_speed)
    if t_end is None:
        t_end = 3 * turn
    t0 = time.perf_counter()
    res, err = _run(mech, t_end, dt, record=Record(midspan=True, axial_force=True))
    sec = time.perf_counter() - t0
    log(f"four-bar: {res!r}")
    cpl = res.link("coupler")
    angle = np.degrees(crank_speed * res.time)
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    axes[0].plot(angle, cpl.midspan * 1e3, lw=1)
    axes[0].set_ylabel("coupler midspan deflection, mm")
    axes[0].set_title(
        f"Four-bar, flexible coupler{' and rocker' if flexible_rocker else ''}: crank {crank_speed:g} rad/s, "
        f"dt = {dt:g} s"
    )
    axes[1].plot(angle, cpl.axial_force[:, elements // 2], lw=1)
    axes[1].set_ylabel(f"coupler axial force, element {elements // 2 + 1}, N")
    axes[1].set_xlabel("crank angle, deg")
    for ax in axes:
        ax.grid(alpha=0.3)
        for k in range(1, int(angle[-1] // 360) + 1):
            ax.axvline(360 * k, color="0.6", lw=0.6)
    fig.tight_layout()
    fig.savefig(out / "four_bar_coupler.png", dpi=120)
    plt.close(fig)
    p = mech.parameters
    f = 2 * np.pi * mech.natural_frequencies(2)
    last = res.time >= res.end_time - turn
    lines = [
        "# Four-bar with a flexible coupler",
        "",
        f"Ground {p['ground_length']:g} m, crank {p['crank_length']:g} m, coupler {p['coupler_length']:g} m, "
        f"rocker {p['rocker_length']:g} m (illustrative Grashof crank-rocker); aluminium strip "
        f"{p['width'] * 1e3:g} x {p['depth'] * 1e3:g} mm (depth in the plane); crank {crank_speed:g} rad/s; "
        f"{elements} coupler elements{'; flexible rocker' if flexible_rocker else ''}; dt = {dt:g} s, "
        f"t_end = {t_end:.4g} s ({t_end / turn:.3g} crank turns).",
        "",
        f"Status: {_status(err, res)} ({sec:.2f} s wall).",
        f"Coupler midspan deflection: max abs {np.max(np.abs(cpl.midspan)) * 1e3:.4g} mm; over the last turn "
        f"[{cpl.midspan[last].min() * 1e3:.4g}, {cpl.midspan[last].max() * 1e3:.4g}] mm.",
        f"Coupler axial force (middle element): [{cpl.axial_force[:, elements // 2].min():.4g}, "
        f"{cpl.axial_force[:, elements // 2].max():.4g}] N.",
        "Lowest natural frequencies at t = 0 (linearized, crank speed held): "
        + ", ".join(f"{x:.4g}" for x in f)
        + " rad/s.",
        "",
        "Plot: `four_bar_coupler.png`.",
        "",
    ]
    path = out / "summary.md"
    path.write_text("\n".join(lines))
    return path
