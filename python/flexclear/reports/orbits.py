"""Journal-centre orbits of chosen samples of a study, for its report.

A study keeps running extremes per sample, not histories (memory O(outputs)). To show how the
journal moves inside the clearance of a few representative samples, :func:`plot_orbits` picks the
samples at the smallest, the median and the largest value of an output (by default the peak
contact force of the study's first joint), runs each again from its stored inputs with the journal
position recorded, and draws the orbit: the journal centre relative to the bearing centre, with
the clearance circle. A re-run gives the same numbers as the study's run of that sample (same
model, settings and step, including the step a retry ended with), so the orbit is the sample's own.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Union

import numpy as np


def orbit_samples(result, count: int = 3, output: Optional[str] = None) -> list[int]:
    """Samples of ``result`` (a :class:`flexclear.study.StudyResult`) to draw: ``count`` (>= 1)
    samples spread over the ranks of ``output`` (a column such as ``"crank_pin.max_force"``;
    default: the first joint's ``max_force``, else its first output), smallest and largest
    included, among the samples that finished. Fewer when fewer finished."""
    if not isinstance(count, (int, np.integer)) or isinstance(count, bool) or count < 1:
        from ..errors import InvalidParameterError

        raise InvalidParameterError(f"invalid parameter `count` = {count!r}: allowed an integer >= 1")
    study = result.study
    ok = result.ok
    if output is None:
        first = study.joints[0]
        output = f"{first}.max_force" if "max_force" in study.outputs else study.column(study.outputs[0])
    if output not in ok.columns:
        from ..errors import InvalidParameterError

        raise InvalidParameterError(
            f"invalid parameter `output` = {output!r}: allowed one of {sorted(study.output_columns)}"
        )
    values = ok[output].dropna().sort_values(kind="stable")
    if values.empty:
        return []
    n = len(values)
    picks = sorted({int(round(r)) for r in np.linspace(0, n - 1, min(count, n))})
    return [int(values.index[p]) for p in picks]


def _rerun(study, row, joint: str):
    """The sample of ``row`` (its stored inputs and the step it ended with) run again with the
    journal position of ``joint`` recorded."""
    from ..result import Record
    from ..study.definition import _RUN_OPTION_ALIASES

    params = {k: row[k] for k in study.vary}
    model = study._scene_fn(**study._scene_kwargs(params))
    t_end = float(params.get("t_end", study.t_end))
    dt = float(row["dt_used"])
    record = Record(joints=[joint], position=True, start=study.start)
    options = {_RUN_OPTION_ALIASES.get(k, k): v for k, v in study.run_options.items()}
    return model.simulate(t_end, dt, study.method, record=record, progress=False, **options)


def plot_orbits(
    result,
    folder: Union[str, Path],
    count: int = 3,
    output: Optional[str] = None,
    joint: Optional[str] = None,
) -> tuple[Optional[Path], list[dict]]:
    """Draws the journal-centre orbits of ``count`` samples of ``result`` chosen by
    :func:`orbit_samples` into ``folder/orbits.png`` (one panel per sample: relative position in
    micrometres, the clearance circle dashed, the sample's inputs and peak force in the title).

    ``joint`` is the clearance joint to draw (default: the study's first). Returns the figure's
    path (``None`` when no sample finished) and one dict per drawn sample (``sample``, its inputs,
    ``clearance`` m, ``max_force`` N, ``max_penetration`` m, ``orbit_radius`` m: the largest
    ``|q|`` of the re-run)."""
    study = result.study
    joint = joint or study.joints[0]
    if joint not in study.joints:
        from ..errors import InvalidParameterError

        raise InvalidParameterError(f"invalid parameter `joint` = {joint!r}: allowed one of {study.joints}")
    samples = orbit_samples(result, count, output)
    if not samples:
        return None, []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    fig, axes = plt.subplots(1, len(samples), figsize=(4.2 * len(samples), 4.4), squeeze=False)
    for ax, s in zip(axes[0], samples):
        row = result.frame.loc[s]
        res = _rerun(study, row, joint)
        j = res.joint(joint)
        qx, qy = np.asarray(j.qx), np.asarray(j.qy)
        r = np.hypot(qx, qy)
        # penetration = |q| - c at every record: the clearance of this sample, m
        c = float(np.median(r - np.asarray(j.penetration))) if len(r) else float("nan")
        info = {"sample": int(s), **{k: float(row[k]) for k in study.vary}}
        info.update(
            clearance=c,
            max_force=float(j.max_force),
            max_penetration=float(j.max_penetration),
            orbit_radius=float(r.max()) if len(r) else float("nan"),
        )
        rows.append(info)
        ax.plot(qx * 1e6, qy * 1e6, lw=0.6)
        phi = np.linspace(0.0, 2.0 * np.pi, 361)
        ax.plot(c * 1e6 * np.cos(phi), c * 1e6 * np.sin(phi), "k--", lw=0.8, label="clearance circle")
        ax.set_aspect("equal")
        ax.set_xlabel("journal x relative to bearing (um)")
        ax.set_ylabel("journal y relative to bearing (um)")
        pairs = [f"{k}={row[k]:.3g}" for k in study.vary]
        varied = "\n".join(", ".join(pairs[i : i + 2]) for i in range(0, len(pairs), 2))
        ax.set_title(f"sample {s}, peak force {j.max_force:.4g} N\n{varied}", fontsize=7)
    axes[0][0].legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "orbits.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path, rows


def orbit_section(path: Optional[Path], rows: list[dict], joint: str) -> list[str]:
    """The report's Markdown lines for :func:`plot_orbits`' figure and table."""
    if path is None:
        return []
    lines = [
        f"## Journal orbits ({joint})",
        "",
        "Samples at the smallest, median and largest peak of the chosen output, run again with the "
        "journal position recorded: the journal centre relative to the bearing centre, and the "
        "clearance circle (a point outside it is a penetration).",
        "",
        "| sample | clearance (m) | peak force (N) | peak penetration (m) | largest abs(q) (m) |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['sample']} | {r['clearance']:.4g} | {r['max_force']:.4g} | "
            f"{r['max_penetration']:.4g} | {r['orbit_radius']:.4g} |"
        )
    lines += ["", f"![orbits]({path.name})", ""]
    return lines
