"""The ``flexclear design`` report: contact-loss prediction against the full clearance simulation
on the slider-yoke (markdown + PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from .. import scenes
from ..result import Record
from .contact_loss import agreement, contact_loss, wall_departures

#: Clearances of the sweep, as fractions of the yoke amplitude (Table 1 uses 0.001, 0.01, 0.1).
RATIOS = (0.001, 0.003, 0.01, 0.03, 0.1)


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
    log: Optional[Callable[[str], None]] = None,
) -> Path:
    """Writes ``design.md`` and PNGs into ``out``: on the slider-yoke, the zero-clearance force
    polar with the predicted loss intervals beside the clearance run's contact timeline (for the
    Table 1 clearance 0.01 Y), and a table of how the predictions meet the clearance runs'
    departures from the wall over a sweep of clearance (``ratios`` x Y). Returns the markdown's
    path. ``t_end``, ``dt`` (zero-clearance run), ``run_dt`` (clearance runs: iterated contact,
    events), ``window`` (s: a departure is matched by a predicted start this close) and
    ``min_contact`` (s: a contact this long counts as continuous) in seconds."""
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
            ax1 = fig.add_subplot(1, 3, 1)
            fx, fy = pred.force[:, 0], pred.force[:, 1]
            lost = pred._mask()
            ax1.plot(fx, fy, color="0.6", lw=0.8)
            ax1.plot(np.where(lost, fx, np.nan), np.where(lost, fy, np.nan), "r", lw=2)
            ax1.plot([0], [0], "k+")
            ax1.set_xlim(-1.5 * np.abs(fy).max(), 1.5 * np.abs(fy).max())
            ax1.set_xlabel("F_x [N]")
            ax1.set_ylabel("F_y [N]")
            ax1.set_title("zero-clearance bearing force (red: loss predicted)")
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
    path = out / "design.md"
    path.write_text("\n".join(lines))
    return path
