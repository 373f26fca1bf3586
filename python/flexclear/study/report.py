""":func:`write_report`: a study's Markdown report with its plots."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Optional, Union

from .definition import LINK_OUTPUTS, OUTPUTS, SLIDER_OUTPUTS
from .results import StudyResult


def write_report(
    result: StudyResult, folder: Union[str, os.PathLike], thresholds: Optional[Mapping] = None
) -> Path:
    """Writes ``report.md`` (definition, status counts, throughput, summary, exceedance table,
    failures) and the plots of :meth:`StudyResult.plot` into ``folder``; returns the report path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    study = result.study
    thresholds = dict(thresholds or {})
    pngs = result.plot(folder, exceedance=list(thresholds) or None)
    frame = result.frame
    counts = frame["status"].value_counts().to_dict() if len(frame) else {}
    lines = [f"# Monte Carlo study: {study.build}", ""]
    lines += ["## Definition", "", "```json", json.dumps(study.to_dict(), indent=2, default=float), "```", ""]
    lines += ["## Samples", ""]
    lines += [f"- {len(frame)} samples: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))]
    retried = int((frame["retries"] > 0).sum()) if len(frame) else 0
    lines += [f"- {retried} retried with a smaller step"]
    if len(frame):
        cpu = float(frame["wall_time"].sum())
        lines += [
            f"- CPU time in the runs: {cpu:.2f} s ({len(frame) / max(cpu, 1e-12):.1f} samples/s per thread)"
        ]
    if result.wall_time > 0:
        lines += [f"- wall time of this call: {result.wall_time:.2f} s"]
    lines += _resolution_section(result)
    lines += ["", "## Outputs over the completed samples", ""]
    summ = result.summary()
    cols = list(summ.columns)
    lines += ["| output | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for name, row in summ.iterrows():
        lines += [f"| {name} | " + " | ".join(f"{row[c]:.4g}" for c in cols) + " |"]
    units = [f"{k}: {OUTPUTS[k]}" for k in study.outputs]
    if study._slider_names:
        units += [f"{k}: {v}" for k, v in SLIDER_OUTPUTS.items()]
    if study._link_names:
        units += [f"{k}: {v}" for k, v in LINK_OUTPUTS.items()]
    lines += ["", "Units: " + "; ".join(units), ""]
    if thresholds:
        lines += ["## Exceedance (Clopper-Pearson 95 % interval)", ""]
        lines += ["| output | threshold | P(exceed) | 95 % interval | exceed / n |", "|---|---|---|---|---|"]
        for k, v in thresholds.items():
            e = result.exceedance(k, v)
            interval = f"[{e['low']:.4g}, {e['high']:.4g}]"
            lines += [f"| {k} | {v:g} | {e['probability']:.4g} | {interval} | {e['exceed']} / {e['n']} |"]
        lines += [""]
    bad = result.failed
    if len(bad):
        lines += ["## Failed samples (first 20)", "", "| sample | status | message |", "|---|---|---|"]
        for i, row in bad.head(20).iterrows():
            lines += [f"| {i} | {row['status']} | {str(row['message']).replace('|', '/')} |"]
        lines += [""]
    lines += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in pngs] + [""]
    path = folder / "report.md"
    path.write_text("\n".join(lines))
    return path


def _resolution_section(result: StudyResult) -> list[str]:
    """The report's lines on whether the samples resolve their contacts: the pilot of a study
    with ``tol``, the steps per contact period of a fixed-step one (:meth:`StudyResult.resolution`)."""
    pilot = result.accuracy
    if pilot is not None:
        lines = ["", "## Resolution: the accuracy pilot", ""]
        lines += [
            f"The first {pilot['samples']} samples ran at tol = {pilot['tol']:g} and at tol / 10; the "
            "largest relative difference of each output between the two (relative to its largest magnitude):",
            "",
            "| output | relative difference |",
            "|---|---|",
        ]
        lines += [f"| {k} | {v:.3g} |" for k, v in pilot["accuracy"].items()]
        verdict = "within" if pilot["met"] else "not within"
        lines += [
            "",
            f"Peak forces and penetrations: {verdict} tol. A joint that rattles is chaotic: its single "
            "samples' peaks move with any change of the step sequence while their distribution stays; "
            "where they are not within tol, compare the distributions at tol and tol / 10 over more "
            f"samples (`flexclear converge STUDY.toml --tol {pilot['tol']:g} {pilot['tol'] / 10:g}`, "
            "paired bootstrap intervals).",
        ]
        return lines
    table = result.resolution()
    if table.empty:
        return []
    lines = ["", "## Resolution: steps per contact period", ""]
    lines += ["| joint | samples with an impact | median steps per contact period | unresolved |"]
    lines += ["|---|---|---|---|"]
    for joint, row in table.iterrows():
        impacted, unresolved = int(row["impacted"]), int(row["unresolved"])
        lines += [f"| {joint} | {impacted} | {row['median_steps']:.3g} | {unresolved} |"]
    for sentence in result.unresolved():
        lines += ["", sentence]
    return lines
