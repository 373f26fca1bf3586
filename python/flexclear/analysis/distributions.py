"""Whether two studies of the same mechanism give the same output distributions: a study at a
coarse step (or a loose ``tol``) against the same study at a finer one, or two designs.

Single samples of a rattling joint are chaotic: a change of the step sequence moves each sample's
peak force by 5-20 % while the distribution over the samples stays. So a step is fine enough for
a Monte Carlo study when the *distributions* agree, which :func:`compare` tests: for every output
the two studies share, the relative difference of chosen quantiles and of the mean, each with a
bootstrap confidence interval, and the two-sample Kolmogorov-Smirnov p-value. With a relative
tolerance ``rtol`` each output gets a verdict: it *differs* when an interval lies wholly outside
``[-rtol, rtol]``, it is *equivalent* when every interval lies inside, and it is *undecided*
otherwise (more samples would narrow the intervals).

When both studies ran the same inputs (same sample ids with equal varied parameters, e.g. one
study file run at two steps), the bootstrap resamples the *pairs*: a difference common to every
sample (a bias of the step) is then measured against the pairs' scatter instead of the
distributions' spread, which takes far fewer samples to see. Otherwise the two sets are
resampled independently.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Optional

import numpy as np

from .._numbers import is_real
from ..errors import InvalidParameterError

#: Bootstrap resamples of :func:`compare` unless asked otherwise.
RESAMPLES = 2000


def compare(
    a,
    b,
    *,
    outputs: Optional[Sequence[str]] = None,
    quantiles: Sequence[float] = (0.5, 0.9),
    confidence: float = 0.95,
    rtol: float = 0.0,
    resamples: int = RESAMPLES,
    seed: int = 0,
):
    """The output distributions of study result ``a`` against those of ``b`` (the reference).

    Parameters
    ----------
    a, b : flexclear.study.StudyResult
        The completed samples of each enter (``StudyResult.ok``); ``b`` is the reference (e.g.
        the finer step).
    outputs : sequence of str, optional
        Output columns (``"<joint>.<output>"``, bare names for a single joint); default: every
        output column the two studies share.
    quantiles : sequence of float
        Quantiles compared, each in (0, 1). Default: the median and the 90 % quantile.
    confidence : float
        Level of the bootstrap intervals, in (0, 1). Default 0.95.
    rtol : float
        Relative difference that matters, >= 0 (e.g. 0.02 for 2 %). Default 0: any difference
        the intervals show.
    resamples : int
        Bootstrap resamples, >= 100. Default :data:`RESAMPLES`.
    seed : int
        Seed of the bootstrap (the same seed gives the same intervals).

    Returns
    -------
    pandas.DataFrame
        One row per output. ``n_a``, ``n_b``: the finite values of each; ``paired``: whether the
        pairs were resampled (the same inputs in both, at least 2 pairs). For each quantile
        ``q`` (named ``q50``, ``q90``, ...) and for the mean (``mean``): ``<stat>_a``,
        ``<stat>_b``, the relative difference ``<stat>_diff = <stat>_a / <stat>_b - 1`` and its
        interval ``<stat>_low``, ``<stat>_high`` (percentile bootstrap; NaN where ``b``'s
        statistic is 0). ``ks_pvalue``: two-sample Kolmogorov-Smirnov (a small value: the
        distributions differ somewhere). ``verdict``: ``"differs"`` (some interval wholly outside
        ``[-rtol, rtol]``), ``"equivalent"`` (every interval inside it) or ``"undecided"``.

    Raises
    ------
    InvalidParameterError
        Naming the parameter: ``a`` or ``b`` not a study result, ``outputs`` naming a column
        one of them lacks (or none shared), ``quantiles``, ``confidence``, ``rtol``,
        ``resamples`` out of range.
    """
    import pandas as pd
    from scipy import stats

    from ..study import StudyResult

    for name, r in (("a", a), ("b", b)):
        if not isinstance(r, StudyResult):
            raise InvalidParameterError(f"{name} = {type(r).__name__} is not allowed; allowed: a StudyResult")
    qs = _check_quantiles(quantiles)
    if not (_real(confidence) and 0 < confidence < 1):
        raise InvalidParameterError(f"confidence = {confidence!r} is not allowed; allowed: a level in (0, 1)")
    if not (_real(rtol) and rtol >= 0):
        raise InvalidParameterError(f"rtol = {rtol!r} is not allowed; allowed: a relative difference >= 0")
    if isinstance(resamples, bool) or not isinstance(resamples, (int, np.integer)) or resamples < 100:
        raise InvalidParameterError(f"resamples = {resamples!r} is not allowed; allowed: an integer >= 100")
    columns = _columns(a, b, outputs)
    ok_a, ok_b = a.ok, b.ok
    pairs = _pairs(a, b, ok_a, ok_b)
    rng = np.random.default_rng(seed)
    tail = 100 * (1 - confidence) / 2
    names = [f"q{100 * q:g}" for q in qs] + ["mean"]
    rows = {}
    for col in columns:
        if pairs is not None:
            x = ok_a.loc[pairs, col].to_numpy(dtype=float)
            y = ok_b.loc[pairs, col].to_numpy(dtype=float)
            keep = np.isfinite(x) & np.isfinite(y)
            x, y = x[keep], y[keep]
            paired = x.size >= 2
        else:
            x = ok_a[col].to_numpy(dtype=float)
            y = ok_b[col].to_numpy(dtype=float)
            x, y = x[np.isfinite(x)], y[np.isfinite(y)]
            paired = False
        row = {"n_a": int(x.size), "n_b": int(y.size), "paired": paired}
        if x.size < 2 or y.size < 2:
            for s in names:
                row.update({f"{s}_{k}": np.nan for k in ("a", "b", "diff", "low", "high")})
            row.update(ks_pvalue=np.nan, verdict="undecided")
            rows[col] = row
            continue
        if paired:
            idx = rng.integers(0, x.size, size=(resamples, x.size))
            xb, yb = x[idx], y[idx]
        else:
            xb = x[rng.integers(0, x.size, size=(resamples, x.size))]
            yb = y[rng.integers(0, y.size, size=(resamples, y.size))]
        verdicts = []
        for s, q in zip(names, [*qs, None]):
            sa, sb = (np.mean(x), np.mean(y)) if q is None else (np.quantile(x, q), np.quantile(y, q))
            ba, bb = (
                (xb.mean(axis=1), yb.mean(axis=1))
                if q is None
                else (np.quantile(xb, q, axis=1), np.quantile(yb, q, axis=1))
            )
            diff, low, high = np.nan, np.nan, np.nan
            if sb != 0:
                diff = sa / sb - 1
                with np.errstate(divide="ignore", invalid="ignore"):
                    boot = ba / bb - 1
                boot = boot[np.isfinite(boot)]
                if boot.size:
                    low, high = np.percentile(boot, [tail, 100 - tail])
            verdicts.append(_interval_verdict(low, high, rtol))
            row.update({f"{s}_a": sa, f"{s}_b": sb, f"{s}_diff": diff, f"{s}_low": low, f"{s}_high": high})
        row["ks_pvalue"] = float(stats.ks_2samp(x, y).pvalue)
        row["verdict"] = _combined(verdicts)
        rows[col] = row
    return pd.DataFrame.from_dict(rows, orient="index")


def _interval_verdict(low: float, high: float, rtol: float) -> str:
    """One interval of a relative difference against ``[-rtol, rtol]``: ``"differs"`` wholly
    outside, ``"equivalent"`` wholly inside, else (or NaN) ``"undecided"``."""
    if low > rtol or high < -rtol:
        return "differs"
    return "equivalent" if -rtol <= low and high <= rtol else "undecided"


def _combined(verdicts: Sequence[str]) -> str:
    """Several verdicts as one: ``"differs"`` if one does, ``"equivalent"`` if all are, else
    ``"undecided"`` (a statistic's intervals into an output's verdict, an output's into a
    setting's)."""
    if "differs" in verdicts:
        return "differs"
    return "equivalent" if all(v == "equivalent" for v in verdicts) else "undecided"


def markdown(table, confidence: float = 0.95, rtol: float = 0.0) -> list[str]:
    """Lines of a Markdown table of :func:`compare`'s result (made with ``confidence`` and
    ``rtol``): per output and statistic the relative difference with its interval (percent), the
    KS p-value and the verdict."""
    stats_ = [c[: -len("_diff")] for c in table.columns if c.endswith("_diff")]
    head = " | ".join(f"{s} a / b - 1 [{100 * confidence:g} % interval]" for s in stats_)
    lines = [f"| output | n a / b | paired | {head} | KS p | verdict |"]
    lines.append("|---" * (len(stats_) + 5) + "|")
    for col, row in table.iterrows():
        cells = [
            f"{100 * row[f'{s}_diff']:+.2f} % [{100 * row[f'{s}_low']:+.2f}, {100 * row[f'{s}_high']:+.2f}]"
            for s in stats_
        ]
        verdict = {
            "differs": f"differs by more than {100 * rtol:g} %" if rtol else "differs",
            "equivalent": f"within {100 * rtol:g} %" if rtol else "the same",
            "undecided": "undecided" if rtol else "no difference detected",
        }[row["verdict"]]
        lines.append(
            f"| {col} | {row['n_a']} / {row['n_b']} | {'yes' if row['paired'] else 'no'} | "
            + " | ".join(cells)
            + f" | {row['ks_pvalue']:.3g} | {verdict} |"
        )
    return lines


def plot(table, a, b, folder, *, confidence: float = 0.95, rtol: float = 0.0, names=("A", "B")) -> list:
    """Saves :func:`compare`'s ``table`` of studies ``a`` and ``b`` as two PNG files in ``folder``
    and returns their paths.

    - ``compare.png``: per output and statistic, the relative difference ``a / b - 1`` (%) with
      its interval, the band ``[-rtol, rtol]`` shaded; an interval wholly outside the band is a
      difference, one wholly inside it an equivalence.
    - ``compare_ecdf.png``: per output, the two empirical distribution functions of the completed
      samples' finite values, with their medians.

    ``names`` label ``a`` and ``b`` (``b`` the reference).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..study.definition import _label, _panel_grid, _scale_into_labels, _sci_ticks

    folder = _folder(folder)
    stats_ = [c[: -len("_diff")] for c in table.columns if c.endswith("_diff")]
    outputs = list(table.index)
    rows = [(o, s) for o in outputs for s in stats_]
    fig, ax = plt.subplots(figsize=(7.5, 1.2 + 0.32 * len(rows)))
    if rtol > 0:
        ax.axvspan(-100 * rtol, 100 * rtol, color="C2", alpha=0.15, label=f"within {100 * rtol:g} %")
    ax.axvline(0.0, color="0.3", lw=0.8)
    for k, s in enumerate(stats_):
        ys = [len(rows) - 1 - i for i, (_, st) in enumerate(rows) if st == s]
        col = table[f"{s}_diff"].to_numpy(float) * 100
        lo = table[f"{s}_low"].to_numpy(float) * 100
        hi = table[f"{s}_high"].to_numpy(float) * 100
        err = np.vstack([col - lo, hi - col])
        ax.errorbar(
            col,
            ys,
            xerr=np.where(np.isfinite(err), err, 0.0),
            fmt="o",
            ms=4,
            capsize=3,
            color=f"C{k}",
            label=s,
        )
    for i, (o, s) in enumerate(rows):
        if not np.isfinite(table.loc[o, f"{s}_diff"]):
            ax.text(
                0.0,
                len(rows) - 1 - i,
                "  no value (too few finite samples, or b's is 0)",
                va="center",
                fontsize=7,
                color="0.4",
            )
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([f"{o} {s}" for o, s in reversed(rows)], fontsize=8)
    ax.set_xlabel(f"{names[0]} / {names[1]} - 1 [%], {100 * confidence:g} % bootstrap intervals")
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"{names[0]} against {names[1]} (the reference)", fontsize=10)
    fig.tight_layout()
    paths = [folder / "compare.png"]
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    fig, panels, _ = _panel_grid(len(outputs), 3, (4.2, 3.2))
    for ax, o in zip(panels, outputs):
        for k, (r, name) in enumerate(((a, names[0]), (b, names[1]))):
            x = np.sort(r.ok[o].to_numpy(dtype=float))
            x = x[np.isfinite(x)]
            if x.size:
                ax.step(
                    x,
                    np.arange(1, x.size + 1) / x.size,
                    where="post",
                    color=f"C{k}",
                    lw=2.4 if k == 0 else 1.2,
                    label=f"{name} (n = {x.size})",
                )
                ax.axvline(np.median(x), color=f"C{k}", ls=":", lw=1)
        ax.set_xlabel(_label(o))
        ax.set_ylabel("fraction of samples <= x")
        _sci_ticks(ax, "x")
        ax.legend(fontsize=8)
    _scale_into_labels(fig)
    fig.tight_layout()
    paths.append(folder / "compare_ecdf.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def _folder(folder):
    from pathlib import Path

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _real(x) -> bool:
    """A finite real number (:func:`flexclear._numbers.is_real`, the package's one test)."""
    return is_real(x) and bool(np.isfinite(x))


def _check_quantiles(quantiles) -> list[float]:
    try:
        qs = [float(q) for q in quantiles]
    except (TypeError, ValueError):
        qs = []
    if not qs or not all(_real(q) and 0 < q < 1 for q in qs):
        raise InvalidParameterError(
            f"quantiles = {quantiles!r} is not allowed; allowed: a non-empty sequence of levels in (0, 1)"
        )
    return qs


def _columns(a, b, outputs) -> list[str]:
    if outputs is None:
        shared = [c for c in a.study.output_columns if c in set(b.study.output_columns)]
        if not shared:
            raise InvalidParameterError(
                "outputs = None is not allowed here; allowed: the studies share no output column "
                f"(a: {list(a.study.output_columns)}, b: {list(b.study.output_columns)})"
            )
        return shared
    if isinstance(outputs, str):
        outputs = [outputs]
    columns = []
    for o in outputs:
        names = []
        for r in (a, b):
            try:
                names.append(r.study.column(o))
            except InvalidParameterError:
                names.append(None)
        if names[0] is None or names[0] != names[1] or names[0] not in b.frame.columns:
            raise InvalidParameterError(
                f"outputs = {o!r} is not allowed; allowed: an output column of both studies "
                f"(a: {list(a.study.output_columns)}, b: {list(b.study.output_columns)})"
            )
        columns.append(names[0])
    return columns


def _pairs(a, b, ok_a, ok_b):
    """The sample ids both completed with equal varied inputs, or None when the studies do not
    run the same inputs (a sample id in both with different inputs, or different varied
    parameters)."""
    vary = list(a.study.vary)
    if vary != list(b.study.vary):
        return None
    common = ok_a.index.intersection(ok_b.index)
    if len(common) < 2:
        return None
    both = a.frame.index.intersection(b.frame.index)
    for v in vary:
        if not np.array_equal(a.frame.loc[both, v].to_numpy(), b.frame.loc[both, v].to_numpy()):
            return None
    return common


#: Outputs :func:`convergence` judges by default (per joint): the peak contact force and
#: penetration, the outputs every clearance study keeps.
CONVERGENCE_OUTPUTS = ("max_force", "max_penetration")


class Convergence:
    """What :func:`convergence` found: the study at each setting against the finest.

    Attributes
    ----------
    results : dict
        Setting label (``"dt=1e-05"``, ``"tol=0.001"``) -> :class:`~flexclear.study.StudyResult`,
        coarsest first, the reference last.
    reference : str
        The label of the finest setting, against which the others are compared.
    comparisons : dict
        Label -> :func:`compare`'s table against the reference (every setting but the reference).
    table : pandas.DataFrame
        One row per setting: ``cpu`` (s, the samples' summed run time), ``speedup`` (the
        reference's CPU time over this one's), per judged output ``<output>`` (the paired mean's
        relative difference), ``<output>_low``, ``<output>_high`` (its interval) and
        ``<output>_verdict``, and ``verdict`` (``"differs"`` if one output differs,
        ``"equivalent"`` if all are, else ``"undecided"``; the reference's row is empty).
    recommended : str or None
        The cheapest setting whose verdict is ``"equivalent"``; None if none is.
    rtol, confidence : float
        As asked.
    """

    def __init__(self, results, reference, comparisons, table, rtol, confidence):
        self.results = results
        self.reference = reference
        self.comparisons = comparisons
        self.table = table
        self.rtol = rtol
        self.confidence = confidence
        ok = table[table["verdict"] == "equivalent"]
        self.recommended = None if ok.empty else str(ok["cpu"].idxmin())

    def markdown(self) -> list[str]:
        """Lines of a Markdown report: the table and the recommendation."""
        outputs = [c[: -len("_verdict")] for c in self.table.columns if c.endswith("_verdict")]
        n = len(self.results[self.reference].ok)
        lines = [
            f"Each setting against {self.reference} over the same {n} samples: the mean of the paired "
            f"relative differences with its {100 * self.confidence:g} % bootstrap interval; the verdict "
            f"(within {100 * self.rtol:g} %, differs by more, or undecided) takes the median and the "
            "90 % quantile too.",
            "",
            "| setting | CPU s | speedup | " + " | ".join(outputs) + " | verdict |",
            "|---" * (len(outputs) + 4) + "|",
        ]
        for label, row in self.table.iterrows():
            if label == self.reference:
                cells = ["reference"] * len(outputs)
                verdict = ""
            else:
                cells = [
                    f"{100 * row[o]:+.2f} % [{100 * row[f'{o}_low']:+.2f}, {100 * row[f'{o}_high']:+.2f}]"
                    for o in outputs
                ]
                verdict = row["verdict"]
            lines.append(
                f"| {label} | {row['cpu']:.3g} | {row['speedup']:.3g}x | "
                + " | ".join(cells)
                + f" | {verdict} |"
            )
        lines.append("")
        if self.recommended is None:
            lines.append(
                f"No setting is shown within {100 * self.rtol:g} % of the reference: refine further, "
                "or run more samples where the verdict is undecided."
            )
        else:
            lines.append(
                f"Recommended: {self.recommended}, the cheapest within {100 * self.rtol:g} % of the "
                "reference. The reference's own error is not measured: include a setting finer than "
                "needed and check that it agrees with the reference."
            )
        return lines

    def plot(self, folder) -> list:
        """Saves ``convergence.png`` in ``folder`` and returns its path: per judged output, each
        setting's paired mean relative difference from the reference (%, with its interval)
        against its CPU time (s, log scale), labelled, the band ``[-rtol, rtol]`` shaded and the
        recommended setting ringed: the trade of accuracy for time at a glance."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import NullFormatter

        from ..study.definition import _panel_grid

        outputs = [c[: -len("_verdict")] for c in self.table.columns if c.endswith("_verdict")]
        folder = _folder(folder)
        fig, panels, nrow = _panel_grid(len(outputs), 2, (5.6, 4.0))
        kinds = {"tol": "C1", "events": "C2", "dt": "C0"}
        for ax, o in zip(panels, outputs):
            ax.axhspan(-100 * self.rtol, 100 * self.rtol, color="C2", alpha=0.12)
            ax.axhline(0.0, color="0.3", lw=0.8)
            for i, (label, row) in enumerate(self.table.iterrows()):
                kind = "tol" if label.startswith("tol") else "events" if label.endswith("events") else "dt"
                x = row["cpu"]
                if label == self.reference:
                    ax.plot([x], [0.0], "*", ms=12, color="k")
                    ax.annotate(
                        f"{label} (reference)",
                        (x, 0.0),
                        textcoords="offset points",
                        xytext=(4, 6),
                        fontsize=7,
                    )
                    continue
                y, lo, hi = (100 * row[k] for k in (o, f"{o}_low", f"{o}_high"))
                if not np.isfinite(y):
                    continue
                err = [[y - lo], [hi - y]] if np.isfinite(lo) and np.isfinite(hi) else None
                ax.errorbar([x], [y], yerr=err, fmt="o", ms=5, capsize=3, color=kinds[kind])
                if label == self.recommended:
                    ax.plot([x], [y], "o", ms=13, mfc="none", mec="k")
                # labels of neighbouring settings above and below their points, apart
                ax.annotate(
                    label, (x, y), textcoords="offset points", xytext=(5, 4 if i % 2 else -11), fontsize=7
                )
            ax.set_xscale("log")
            # ticks at the settings' own times (a range of a decade or less gets no labels else)
            cpus = []
            for c in sorted(set(self.table["cpu"].to_numpy(float))):
                if not cpus or c > 1.15 * cpus[-1]:  # labels apart
                    cpus.append(c)
            ax.set_xticks(cpus, [f"{c:.3g}" for c in cpus], fontsize=7, rotation=30)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.margins(x=0.2)
            ax.set_xlabel("CPU time of the samples [s]")
            ax.set_ylabel("mean relative difference [%]")
            ax.set_title(o, fontsize=9)
            ax.grid(True, which="both", alpha=0.3)
        rec = (
            "none within the band" if self.recommended is None else f"recommended {self.recommended} (ringed)"
        )
        fig.suptitle(
            f"Against {self.reference}: {100 * self.confidence:g} % intervals, band +-{100 * self.rtol:g} %; "
            f"{rec}",
            fontsize=9,
        )
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.05 / nrow))
        path = folder / "convergence.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return [path]


def convergence(
    study,
    *,
    dts: Sequence[float] = (),
    tols: Sequence[float] = (),
    samples: Optional[int] = 32,
    outputs: Optional[Sequence[str]] = None,
    rtol: float = 0.02,
    confidence: float = 0.95,
    events: bool = False,
    threads: int = 0,
    progress=None,
) -> Convergence:
    """Runs ``study`` at each fixed step of ``dts`` and each tolerance of ``tols`` on the same
    samples and compares each with the finest (the smallest step if any, else the smallest
    tolerance): which setting is the cheapest whose output distributions are within ``rtol`` of
    the reference's?

    Parameters
    ----------
    study : flexclear.study.Study
        The study; its ``dt`` is the output step of the ``tols`` runs.
    dts : sequence of float
        Fixed steps, s (each > 0).
    tols : sequence of float
        Tolerances (each in (0, 1)); at least two settings in all.
    samples : int or None
        The first ``samples`` of the study's design (its seed and design), default 32; None for
        all of them. Every setting runs the same inputs, so the comparisons are paired.
    outputs : sequence of str, optional
        Outputs judged; default the peak force and penetration of every joint
        (:data:`CONVERGENCE_OUTPUTS`).
    rtol, confidence : float
        As in :func:`compare`; default 2 % and 95 %.
    events : bool
        Also run each step but the finest with event-aware steps (``run_options`` ``events`` and
        ``iterate``: the steps that open or close a contact cut at the crossing), labelled
        ``"dt=1e-05 events"``: they take out the first-order error of the contact's entries and
        exits (in the dissipated energy, above all) for a few per cent more CPU.
    threads : int
        Worker threads (0 = one per core).
    progress : callable, optional
        ``progress(label)`` before each setting runs.

    Returns
    -------
    Convergence

    Raises
    ------
    InvalidParameterError
        Naming ``dts``, ``tols`` or ``samples`` (fewer than two settings, a step or tolerance out
        of range, fewer than 2 samples), or as :func:`compare`.
    """
    import pandas as pd

    from ..study import Study

    if not isinstance(study, Study):
        raise InvalidParameterError(f"study = {type(study).__name__} is not allowed; allowed: a Study")
    dts, tols = list(dts), list(tols)
    if not all(_real(x) and x > 0 for x in dts):
        raise InvalidParameterError(f"dts = {dts!r} is not allowed; allowed: steps > 0, s")
    if not all(_real(x) and 0 < x < 1 for x in tols):
        raise InvalidParameterError(f"tols = {tols!r} is not allowed; allowed: tolerances in (0, 1)")
    if len(set(dts)) + len(set(tols)) < 2:
        raise InvalidParameterError(
            f"dts = {dts!r}, tols = {tols!r} is not allowed; allowed: at least two settings in all"
        )
    n = study.samples if samples is None else samples
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InvalidParameterError(
            f"samples = {samples!r} is not allowed; allowed: an integer >= 2, or None"
        )
    n = min(int(n), study.samples)
    base = {k: v for k, v in study.to_dict().items() if k != "tol"}
    base["samples"] = n
    steps = sorted(set(dts), reverse=True)
    settings = []
    cut = {**(base.get("run_options") or {}), "events": True, "iterate": True}
    for k, x in enumerate(steps):
        settings.append((f"dt={x:g}", {**base, "dt": float(x)}))
        if events and k < len(steps) - 1:
            settings.append((f"dt={x:g} events", {**base, "dt": float(x), "run_options": cut}))
    by_tol = [(f"tol={x:g}", {**base, "tol": float(x)}) for x in sorted(set(tols), reverse=True)]
    reference = settings[-1][0] if steps else by_tol[-1][0]
    settings += by_tol
    results = {}
    for label, definition in settings:
        if progress is not None:
            progress(label)
        results[label] = Study.from_dict(definition).run(threads=threads, progress=False, pilot=False)
    # the reference last
    results = {k: v for k, v in results.items() if k != reference} | {reference: results[reference]}
    ref = results[reference]
    if outputs is None:
        outputs = [f"{j}.{o}" for j in study.joints for o in CONVERGENCE_OUTPUTS if o in study.outputs]
    columns = _columns(ref, ref, outputs)
    comparisons = {
        label: compare(r, ref, outputs=columns, rtol=rtol, confidence=confidence)
        for label, r in results.items()
        if label != reference
    }
    cpu_ref = float(ref.frame["wall_time"].sum())
    rows = {}
    for label, r in results.items():
        cpu = float(r.frame["wall_time"].sum())
        row = {"cpu": cpu, "speedup": cpu_ref / cpu if cpu > 0 else np.nan}
        t = comparisons.get(label)
        for col in columns:
            c = {} if t is None else t.loc[col]
            row.update(
                {
                    col: c.get("mean_diff", np.nan),
                    f"{col}_low": c.get("mean_low", np.nan),
                    f"{col}_high": c.get("mean_high", np.nan),
                    f"{col}_verdict": c.get("verdict", ""),
                }
            )
        row["verdict"] = "" if t is None else _combined(list(t.loc[columns, "verdict"]))
        rows[label] = row
    table = pd.DataFrame.from_dict(rows, orient="index")
    return Convergence(results, reference, comparisons, table, rtol, confidence)
