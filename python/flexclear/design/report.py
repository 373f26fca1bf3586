"""The ``flexclear design`` report: contact-loss prediction against the full clearance simulation
on the slider-yoke, and the worked optimization example on the slider-crank (markdown + PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from .. import scenes
from ..result import Record
from .contact_loss import agreement, contact_loss, wall_departures
from .continuous import continuous_loss
from .optimize import optimize
from .preload import preloaded_slider_crank

#: Clearances of the sweep, as fractions of the yoke amplitude (Table 1 uses 0.001, 0.01, 0.1).
RATIOS = (0.001, 0.003, 0.01, 0.03, 0.1)


def _polar(fig, pred, title: str):
    """The zero-clearance force of ``pred`` as a polar curve in the first third of ``fig``, the
    predicted loss in red; returns the axes."""
    ax = fig.add_subplot(1, 3, 1)
    fx, fy = pred.force[:, 0], pred.force[:, 1]
    lost = pred._mask()
    ax.plot(fx, fy, color="0.6", lw=0.8)
    ax.plot(np.where(lost, fx, np.nan), np.where(lost, fy, np.nan), "r", lw=1.5)
    ax.plot([0], [0], "k+")
    ax.set_xlabel("F_x [N]")
    ax.set_ylabel("F_y [N]")
    ax.set_title(title)
    return ax


def _timeline(ax, run, joint: str, pred, clearance: float) -> None:
    t = run.time
    pen = run.joint(joint).penetration
    closed = pen > 0
    ax.plot(t, pen * 1e6, "k", lw=0.6, label="penetration [um]")
    ax.fill_between(t, 0, 1, where=closed, transform=ax.get_xaxis_transform(), color="g", alpha=0.25, lw=0)
    for a, b in pred.intervals:
        ax.axvspan(a, b, ymin=0.9, ymax=1.0, color="r", alpha=0.8, lw=0)
    ax.set_xlabel("t [s]")
    ax.set_title(f"clearance run, c = {clearance * 1e6:.0f} um: in contact (green), predicted loss (red bar)")
    ax.legend(loc="lower right", fontsize=8)


def write_report(
    out,
    *,
    t_end: float = 0.2,
    dt: float = 1e-5,
    run_dt: float = 1e-6,
    ratios: Sequence[float] = RATIOS,
    window: float = 4e-3,
    min_contact: float = 5e-3,
    quick: bool = False,
    log: Optional[Callable[[str], None]] = None,
) -> Path:
    """Writes ``design.md`` and PNGs into ``out``: on the slider-yoke, the zero-clearance force
    polar with the predicted loss intervals beside the clearance run's contact timeline (for the
    Table 1 clearance 0.01 Y), and a table of how the predictions meet the clearance runs'
    departures from the wall over a sweep of clearance (``ratios`` x Y). Returns the markdown's
    path. ``t_end``, ``dt`` (zero-clearance run), ``run_dt`` (clearance runs: iterated contact,
    events), ``window`` (s: a departure is matched by a predicted start this close) and
    ``min_contact`` (s: a contact this long counts as continuous) in seconds. Then the worked
    optimization on the slider-crank (:func:`_preload_section`); ``quick`` makes its sweep coarse
    and its optimization short."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    say = log or (lambda s: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    amp = scenes.slider_yoke().parameters["amplitude"]
    rows = []
    figures = []
    for r in ratios:
        c = r * amp
        model = scenes.slider_yoke(clearance=c)
        pred = contact_loss(model, "bearing", t_end, dt)
        run = model.simulate(
            t_end, run_dt, iterate=True, events=True, record=Record(impact_log=True, every=10)
        )
        dep = wall_departures(run, "bearing", min_contact=min_contact)
        a = agreement(pred, dep, window)
        rows.append((r, c, pred, dep, a, run.joint("bearing").impacts))
        say(f"c = {c:.3g} m: {a}")
        if r == 0.01 or len(ratios) == 1:
            fig = plt.figure(figsize=(13, 4.8))
            ax1 = _polar(fig, pred, "zero-clearance bearing force (red: loss predicted)")
            fy = pred.force[:, 1]
            ax1.set_xlim(-1.5 * np.abs(fy).max(), 1.5 * np.abs(fy).max())
            ax2 = fig.add_subplot(1, 3, (2, 3))
            _timeline(ax2, run, "bearing", pred, c)
            ax3 = ax2.twinx()
            ax3.plot(pred.time, pred.normal_force, "b", lw=0.7, label="continuous-contact N [N]")
            ax3.set_ylabel("N [N]", color="b")
            fig.tight_layout()
            name = f"contact_loss_c{c * 1e6:.0f}um.png"
            fig.savefig(out / name, dpi=110)
            plt.close(fig)
            figures.append(name)
    lines = [
        "# Contact-loss prediction against the clearance simulation (slider-yoke)",
        "",
        f"Zero-clearance run: the bearing made stiff (100 x K_B) and critically damped, dt = {dt:g} s, "
        f"0 to {t_end:g} s. Clearance runs: `simulate(method='modified', iterate=True, events=True)` at "
        f"dt = {run_dt:g} s. A departure is the end of a contact lasting >= {min_contact * 1e3:g} ms "
        f"(continuous contact); it is matched when a predicted loss interval starts within "
        f"{window * 1e3:g} ms of it. Criterion: the small-clearance continuous-contact model "
        "(docs/design.md).",
        "",
        "| c [m] | c / Y | departures | matched | missed | false alarms | max offset [ms] | "
        "predicted loss [% of run] | impacts in run |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r, c, pred, _dep, a, imp in rows:
        off = "-" if not np.isfinite(a["max_offset"]) else f"{a['max_offset'] * 1e3:.2f}"
        lines.append(
            f"| {c:.3g} | {r:g} | {a['departures']} | {a['matched']} | {a['missed']} | {a['false']} "
            f"| {off} | {100 * pred.loss_fraction:.1f} | {imp} |"
        )
    total = sum(a["departures"] for *_, a, _ in rows)
    matched = sum(a["matched"] for *_, a, _ in rows)
    lines += ["", f"Agreement over the sweep: {matched} of {total} departures matched.", ""]
    for name in figures:
        lines += [f"![contact loss]({name})", ""]
    lines += _slider_crank_section(out, plt, say, quick)
    lines += _preload_section(out, plt, say, quick)
    path = out / "design.md"
    path.write_text("\n".join(lines))
    return path


def time_agreement(pred, run, joint: str) -> dict:
    """Fractions of the prediction's time grid where the prediction and the clearance run agree
    or not: ``both_contact``, ``both_free``, ``predicted_only`` (loss predicted, the run in
    contact) and ``run_only`` (the run free, no loss predicted); the run is free where its
    penetration (interpolated on the grid) is <= 0."""
    t = pred.time
    lost = pred._mask()
    free = np.interp(t, run.time, run.joint(joint).penetration) <= 0.0
    return {
        "both_contact": float(np.mean(~lost & ~free)),
        "both_free": float(np.mean(lost & free)),
        "predicted_only": float(np.mean(lost & ~free)),
        "run_only": float(np.mean(~lost & free)),
    }


def _contact_modes(run, joint: str, min_contact: float) -> tuple:
    """The run's contact episodes split into impacts (shorter than ``min_contact``, s) and
    continuous contacts: two lists of ``(start, end)`` in s, from the penetration history."""
    t = run.time
    closed = run.joint(joint).penetration > 0.0
    edges = np.flatnonzero(np.diff(closed.astype(np.int8)))
    starts = [t[i + 1] for i in edges if not closed[i]]
    ends = [t[i + 1] for i in edges if closed[i]]
    if closed[0]:
        starts.insert(0, t[0])
    if len(ends) < len(starts):
        ends.append(t[-1])
    episodes = list(zip(starts, ends))
    impacts = [e for e in episodes if e[1] - e[0] < min_contact]
    continuous = [e for e in episodes if e[1] - e[0] >= min_contact]
    return impacts, continuous


#: The keys of :func:`time_agreement`, in the table's order.
FRACTIONS = ("both_contact", "both_free", "predicted_only", "run_only")

#: The continuous-contact runs of the slider-crank sweep (``simulate(method="continuous")``):
#: step (s) and integrator options.
CONTINUOUS_DT = 1e-5
CONTINUOUS_OPTIONS: dict = {"integrator": "generalized-alpha", "rho_inf": 0.5}

#: The slider-crank sweep: crank speeds (rad/s) and crank-pin clearances (m).
SPEEDS = (50.0, 100.0, 150.0)
CLEARANCES = (1e-4, 2.5e-4, 5e-4)


def _slider_crank_section(out: Path, plt, say, quick: bool = False) -> list:
    """Contact-loss prediction against clearance runs of Simeon's slider-crank (crank-pin
    clearance) over crank speed and clearance: a figure for one case and the agreement table."""
    from ..result import Record

    speeds, clearances = ((150.0,), (5e-4,)) if quick else (SPEEDS, CLEARANCES)
    min_contact = 2e-3
    rows = []
    for w in speeds:
        turns = 2 * (2 * np.pi / w)
        for c in clearances:
            model = scenes.slider_crank(clearance_at="crank_pin", clearance=c, crank_speed=w)
            pred = contact_loss(model, "crank_pin", turns, 1e-5)
            run = model.simulate(turns, 1e-6, iterate=True, events=True, record=Record(every=10))
            dep = wall_departures(run, "crank_pin", min_contact=min_contact)
            a = agreement(pred, dep, min_contact)
            frac = time_agreement(pred, run, "crank_pin")
            impacts, continuous = _contact_modes(run, "crank_pin", min_contact)
            cont = continuous_loss(model, "crank_pin", turns, CONTINUOUS_DT, **CONTINUOUS_OPTIONS)
            a_cont = agreement(cont, dep, min_contact)
            frac_cont = time_agreement(cont, run, "crank_pin")
            rows.append((w, c, pred, a, frac, len(impacts), len(continuous), cont, a_cont, frac_cont))
            say(f"slider-crank {w:g} rad/s, c = {c:.3g} m: {a}, {frac}; continuous: {a_cont}, {frac_cont}")
            if (w, c) == (speeds[-1], clearances[-1]):
                fig = plt.figure(figsize=(13, 4.8))
                ax1 = _polar(fig, pred, "zero-clearance crank-pin force (red: loss predicted)")
                ax1.set_aspect("equal", "datalim")
                ax2 = fig.add_subplot(1, 3, (2, 3))
                for lo, hi in continuous:
                    ax2.axvspan(lo, hi, ymin=0.0, ymax=0.08, color="g", alpha=0.7, lw=0)
                for lo, hi in impacts:
                    ax2.axvspan(lo, hi, ymin=0.08, ymax=0.16, color="orange", alpha=0.9, lw=0)
                for lo, hi in pred.intervals:
                    ax2.axvspan(lo, hi, ymin=0.92, ymax=1.0, color="r", alpha=0.8, lw=0)
                for lo, hi in cont.intervals:
                    ax2.axvspan(lo, hi, ymin=0.84, ymax=0.92, color="m", alpha=0.8, lw=0)
                ax2.plot(pred.time, pred.normal_force, "b", lw=0.6, label="small-clearance model N [N]")
                ax2.plot(
                    cont.time,
                    cont.normal_force,
                    "m",
                    lw=0.6,
                    label="continuous-contact run N [N] (method='continuous')",
                )
                ax2.set_xlabel("t [s]")
                ax2.set_ylabel("N [N]")
                ax2.set_title(
                    f"{w:g} rad/s, c = {c * 1e3:g} mm: continuous contact (green), impacts (orange)\n"
                    "predicted loss (red: zero-clearance prediction, magenta: continuous-contact run)",
                    fontsize=9,
                )
                ax2.legend(loc="center right", fontsize=8)
                fig.tight_layout()
                fig.savefig(out / "slider_crank_contact_loss.png", dpi=110)
                plt.close(fig)
    table = [
        "| crank speed [rad/s] | c [mm] | departures | matched | both in contact | both free | "
        "predicted only | run only | predicted intervals | impacts | continuous contacts |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for w, c, pred, a, f, ni, nc, *_ in rows:
        table.append(
            f"| {w:g} | {c * 1e3:g} | {a['departures']} | {a['matched']} | "
            + " | ".join(f"{100 * f[k]:.1f} %" for k in FRACTIONS)
            + f" | {len(pred.intervals)} | {ni} | {nc} |"
        )
    cont_table = [
        "| crank speed [rad/s] | c [mm] | departures | matched | both in contact | both free | "
        "predicted only | run only | loss instants | attachments |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for w, c, _pred, _a, _f, _ni, _nc, cont, a, f in rows:
        log = cont.result.joint("crank_pin").impact_log
        losses = int(np.isfinite(log.duration).sum())
        cont_table.append(
            f"| {w:g} | {c * 1e3:g} | {a['departures']} | {a['matched']} | "
            + " | ".join(f"{100 * f[k]:.1f} %" for k in FRACTIONS)
            + f" | {losses} | {log.time.size} |"
        )
    agree = sum(r[4]["both_contact"] + r[4]["both_free"] for r in rows)
    agree_cont = sum(r[9]["both_contact"] + r[9]["both_free"] for r in rows)
    n_dep = sum(r[3]["departures"] for r in rows)
    m_zero = sum(r[3]["matched"] for r in rows)
    m_cont = sum(r[8]["matched"] for r in rows)
    options = ", ".join(f"{k}={v!r}" for k, v in CONTINUOUS_OPTIONS.items())
    return [
        "# Contact-loss prediction on the slider-crank",
        "",
        "Simeon's slider-crank (undamped rod), clearance at the crank pin, two crank turns from rest. "
        "Zero-clearance run at dt 1e-5 s; clearance runs with iterated kappa and events at dt 1e-6 s. "
        f"A departure ends a contact of >= {min_contact * 1e3:g} ms; time fractions are on the "
        "prediction's grid (free: penetration <= 0).",
        "",
        *table,
        "",
        f"Prediction and run agree (both in contact or both free) {100 * agree / len(rows):.1f} % of the "
        "time on average over the sweep.",
        "",
        "## The continuous-contact model against the same runs",
        "",
        "The whole mechanism run with the crank pin as the continuous-contact (massless-link) model, "
        f"`simulate(method='continuous', {options})` at dt {CONTINUOUS_DT:g} s "
        "(`flexclear.design.continuous_loss`): the journal held on the wall while the normal force is "
        "compressive, free after the loss instant, re-attached by a plastic impact. Counted as the "
        "zero-clearance prediction above (a departure matched by a loss instant within "
        f"{min_contact * 1e3:g} ms; time fractions with the model's free flight as its predicted loss).",
        "",
        *cont_table,
        "",
        f"Departures matched: zero-clearance prediction {m_zero} of {n_dep}, continuous-contact model "
        f"{m_cont} of {n_dep}. Time in agreement on average: zero-clearance prediction "
        f"{100 * agree / len(rows):.1f} %, continuous-contact model {100 * agree_cont / len(rows):.1f} %.",
        "",
        "![slider-crank contact loss](slider_crank_contact_loss.png)",
        "",
    ]


#: The worked example: Simeon's slider-crank, 0.5 mm radial clearance at the crank pin, 50 rad/s.
PRELOAD_CASE = {"clearance_at": "crank_pin", "clearance": 5e-4, "crank_speed": 50.0}


def _preload_section(out: Path, plt, say, quick: bool = False) -> list:
    """Peak crank-pin force against the preload (a sweep at two steps), and the optimizer's answer."""
    from ..result import Record

    turn = 2 * np.pi / PRELOAD_CASE["crank_speed"]
    run_kw: dict = {"iterate": True}

    def peak(p: float, dt: float):
        m = preloaded_slider_crank(p, **PRELOAD_CASE)
        j = m.simulate(3 * turn, dt, record=Record(histories=False, start=turn), **run_kw).joint("crank_pin")
        return j.max_force, j.impacts

    loads = np.array([0.0, 100.0, 200.0, 300.0]) if quick else np.arange(0.0, 401.0, 20.0)
    coarse = np.array([peak(p, 1e-5) for p in loads])
    fine = np.array([peak(p, 1e-5 if quick else 2.5e-6) for p in loads])
    opt = optimize(
        preloaded_slider_crank,
        "crank_pin.max_force",
        {"preload": (0.0, 1000.0)},
        fixed=PRELOAD_CASE,
        t_end=3 * turn,
        dt=1e-5,
        start=turn,
        outputs=["max_force"],
        run_options=run_kw,
        popsize=4 if quick else 6,
        maxiter=1 if quick else 10,
        local_maxfev=3 if quick else 40,
    )
    p_opt = opt.x["preload"]
    at_opt_fine = peak(p_opt, 2.5e-6)
    margin = 1.1 * p_opt
    at_margin = peak(margin, 1e-5), peak(margin, 2.5e-6)
    say(f"preload optimum {p_opt:.1f} N: peak {opt.fun:.1f} N (dt 1e-5), {at_opt_fine[0]:.1f} N at dt 2.5e-6")
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for data, style, label in ((coarse, "o", "dt = 1e-5 s"), (fine, "x", "dt = 2.5e-6 s")):
        hit = data[:, 1] > 0
        ax.plot(loads[hit], data[hit, 0], style, color="r", label=f"{label}, with impacts")
        ax.plot(loads[~hit], data[~hit, 0], style, color="k", label=f"{label}, no impact")
    ax.axvline(p_opt, color="b", lw=0.8, label=f"optimize: {p_opt:.0f} N")
    ax.set_xlabel("preload along the rod [N]")
    ax.set_ylabel("peak crank-pin force, turns 2-3 [N]")
    ax.set_title("slider-crank, 0.5 mm crank-pin clearance, 50 rad/s")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "preload.png", dpi=110)
    plt.close(fig)
    rows = "\n".join(
        f"| {p:.0f} | {a:.1f} | {int(ia)} | {b:.1f} | {int(ib)} |"
        for p, (a, ia), (b, ib) in zip(loads, coarse, fine)
    )
    return [
        "# Worked optimization: the preload that minimizes the peak crank-pin force",
        "",
        "Simeon's slider-crank (`flexclear.design.preloaded_slider_crank`), 0.5 mm radial clearance at "
        "the crank pin, crank at 50 rad/s, a compressive preload along the rod at the slider pin; "
        "peak contact force over turns 2 and 3 (iterated kappa). Below a threshold the journal crosses "
        "the clearance at each load reversal and impacts set the peak (and do not converge with the "
        "step); above it the journal stays on the wall and the peak is the ideal pin force plus the "
        "preload.",
        "",
        "| preload [N] | peak [N], dt 1e-5 | impacts | peak [N], dt 2.5e-6 | impacts |",
        "|---|---|---|---|---|",
        rows,
        "",
        f"`optimize` (differential evolution, {len(opt.batches)} batches, {sum(opt.batches)} runs): "
        f"preload {p_opt:.1f} N, peak {opt.fun:.1f} N at dt 1e-5 s; the same preload at dt 2.5e-6 s: "
        f"{at_opt_fine[0]:.1f} N with {at_opt_fine[1]} impacts. The optimum sits on the edge of the impact "
        f"region, so a design takes a margin: 10 % more ({margin:.0f} N) gives {at_margin[0][0]:.1f} N "
        f"({at_margin[0][1]} impacts) and {at_margin[1][0]:.1f} N ({at_margin[1][1]} impacts) at the two "
        "steps.",
        "",
        "![preload](preload.png)",
        "",
    ]
