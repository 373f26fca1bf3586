""":class:`StudyResult` (summaries, exceedance probabilities, plots) and :func:`open_store`."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .._numbers import is_real
from ..errors import (
    InvalidParameterError,
)
from .definition import RESOLVED_STEPS_PER_CONTACT, Study, _label, _panel_grid, _scale_into_labels, _sci_ticks
from .runner import _concat
from .store import _Store
from .study_file import load


class StudyResult:
    """The outcome of a study.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per sample (index ``sample``): the varied inputs, ``status`` ("ok",
        "diverged", "invalid", "singular"), ``message``, ``dt_used`` (s), ``retries``,
        ``wall_time`` (s) and the outputs (NaN for a failed sample).
    wall_time : float
        Wall-clock time of this call, s.
    """

    def __init__(self, study: Study, frame, wall_time: float, accuracy: Optional[dict] = None) -> None:
        self.study = study
        self.frame = frame
        self.wall_time = wall_time
        #: The pilot of a study with ``tol`` (see :meth:`Study.pilot`): the achieved accuracy
        #: per output and the settings that ran; None without ``tol``.
        self.accuracy = accuracy

    @property
    def ok(self):
        """The rows of the samples that completed."""
        return self.frame[self.frame["status"] == "ok"]

    @property
    def failed(self):
        """The rows of the samples that did not complete, with their status and message."""
        return self.frame[self.frame["status"] != "ok"]

    def array(self, column: str) -> np.ndarray:
        """One column as a numpy array (all samples, in sample order); an output may be named
        bare when the study has one joint."""
        if column not in self.frame.columns:
            column = self.study.column(column)
        return self.frame[column].to_numpy()

    def summary(self, quantiles: Sequence[float] = (0.05, 0.5, 0.95)):
        """Mean, std, min, quantiles and max of every output over the completed samples."""
        import pandas as pd

        ok = self.ok
        rows = {}
        for o in self.study.output_columns:
            x = ok[o].to_numpy(dtype=float)
            row = {"count": x.size, "mean": np.mean(x) if x.size else np.nan}
            row["std"] = np.std(x, ddof=1) if x.size > 1 else np.nan
            row["min"] = np.min(x) if x.size else np.nan
            for q in quantiles:
                row[f"q{q:g}"] = np.quantile(x, q) if x.size else np.nan
            row["max"] = np.max(x) if x.size else np.nan
            rows[o] = row
        return pd.DataFrame.from_dict(rows, orient="index")

    def resolution(self):
        """Whether the fixed step of each completed sample resolves its joints' impacts: per
        clearance joint whose ``contact_period`` the study keeps, a row with ``impacted`` (samples
        with an impact), ``median_steps`` (the median over those of ``contact_period /
        dt_used``, the steps per natural contact period) and ``unresolved`` (those with fewer
        than :data:`RESOLVED_STEPS_PER_CONTACT`; their peak force and penetration are lower
        bounds, and their dissipated energy further off). Empty for a study with ``tol``
        (its steps follow the contact; :attr:`accuracy` is its check) or without the output.

        Returns
        -------
        pandas.DataFrame
            Index: joint names; columns ``impacted``, ``median_steps``, ``unresolved``.
        """
        import pandas as pd

        rows = {}
        if self.study.tol is None and "contact_period" in self.study.outputs:
            ok = self.ok
            dt = ok["dt_used"].to_numpy(dtype=float)
            for joint in self.study.joints:
                period = ok[f"{joint}.contact_period"].to_numpy(dtype=float)
                hit = np.isfinite(period)
                steps = period[hit] / dt[hit]
                rows[joint] = {
                    "impacted": int(hit.sum()),
                    "median_steps": float(np.median(steps)) if steps.size else np.nan,
                    "unresolved": int(np.sum(steps < RESOLVED_STEPS_PER_CONTACT)),
                }
        columns = ["impacted", "median_steps", "unresolved"]
        return pd.DataFrame.from_dict(rows, orient="index", columns=columns)

    def unresolved(self) -> list[str]:
        """One sentence per joint whose contacts the fixed step leaves unresolved in some samples
        (:meth:`resolution`): how many, the median steps per contact period, what that means for
        the outputs and what resolves them. Empty when every sample resolves its contacts (and
        for a study with ``tol``). The report's Resolution section and ``flexclear montecarlo``'s
        warnings print these."""
        return [
            f"Unresolved: {int(row['unresolved'])} of {int(row['impacted'])} samples take fewer than "
            f"{RESOLVED_STEPS_PER_CONTACT} steps per natural contact period (pi d / v of the deepest "
            f"impact) at {joint} (median {row['median_steps']:.3g}): their peak forces and "
            "penetrations are lower bounds and their dissipated energies further off; a smaller dt "
            "or a tol resolves them (flexclear converge compares the choices)."
            for joint, row in self.resolution().iterrows()
            if row["unresolved"] > 0
        ]

    def compare(self, reference: StudyResult, **options):
        """Whether this study's output distributions are those of ``reference`` (e.g. the same
        study file at a finer step, or ``tol / 10``): per output, the relative differences of the
        median, the 90 % quantile and the mean with bootstrap intervals (over the pairs when both
        ran the same inputs), the Kolmogorov-Smirnov p-value and a verdict against ``rtol``
        (differs, equivalent or undecided). Single samples of a rattling joint are chaotic;
        their distribution is what a step must resolve. ``options``: ``outputs``,
        ``quantiles``, ``confidence``, ``rtol``, ``resamples``, ``seed``; see
        :func:`flexclear.analysis.distributions.compare`, which returns the table (a pandas
        DataFrame, one row per output)."""
        from ..analysis.distributions import compare

        return compare(self, reference, **options)

    def exceedance(self, output: str, threshold: float, confidence: float = 0.95) -> dict:
        """Probability that ``output`` (``"<joint>.<output>"``, or the bare output name when the
        study has one joint) exceeds ``threshold``, with a Clopper-Pearson interval.

        Returns a dict ``{"probability", "low", "high", "exceed", "n"}`` over the completed
        samples (exact binomial interval at ``confidence``, valid for any n and for 0 or n
        exceedances).
        """
        from scipy import stats

        output = self.study.column(output)
        real = is_real(threshold)
        if not (real and not math.isnan(threshold)):
            raise InvalidParameterError(f"threshold = {threshold!r} is not allowed; allowed: a number")
        if not (isinstance(confidence, (int, float)) and 0 < confidence < 1):
            raise InvalidParameterError(f"confidence = {confidence!r} is not allowed; allowed: 0 < c < 1")
        x = self.ok[output].to_numpy(dtype=float)
        if x.size == 0:
            raise InvalidParameterError(
                f"exceedance of {output!r}: no completed sample to estimate it from "
                f"({len(self.frame)} samples, none 'ok'); allowed: a result with a completed sample"
            )
        n, k = x.size, int(np.sum(x > threshold))
        a = 1 - confidence
        low = stats.beta.ppf(a / 2, k, n - k + 1) if k > 0 else 0.0
        high = stats.beta.ppf(1 - a / 2, k + 1, n - k) if k < n else 1.0
        return {
            "probability": k / n if n else float("nan"),
            "low": float(low),
            "high": float(high),
            "exceed": k,
            "n": n,
        }

    def plot(self, folder: Union[str, os.PathLike], exceedance: Optional[Sequence[str]] = None) -> list[Path]:
        """Saves histograms of the outputs, outputs against each varied input, and exceedance
        curves (``1 - ECDF`` with 95 % pointwise intervals) as PNG files; returns their paths."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        ok = self.ok
        outs = self.study.output_columns
        paths = []
        fig, panels, nrow = _panel_grid(len(outs), 3, (4.2, 3.2))
        for ax, o in zip(panels, outs):
            ax.hist(ok[o].to_numpy(dtype=float), bins=40, color="C0")
            ax.set_xlabel(_label(o))
            ax.set_ylabel("samples")
            _sci_ticks(ax, "x")
        fig.suptitle(f"{self.study.build}: {len(ok)} samples ({len(self.failed)} failed)")
        _scale_into_labels(fig)
        # room above the top row for the title
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / (3.2 * nrow)))
        paths.append(folder / "histograms.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
        for k in self.study.vary:
            fig, panels, _ = _panel_grid(len(outs), 3, (4.2, 3.2))
            for ax, o in zip(panels, outs):
                ax.plot(ok[k], ok[o], ".", ms=2, alpha=0.6)
                bad = self.failed
                if len(bad):
                    ax.plot(bad[k], np.zeros(len(bad)), "x", color="C3", ms=4, label="failed")
                ax.set_xlabel(_label(k))
                ax.set_ylabel(_label(o))
                _sci_ticks(ax, "both")
            _scale_into_labels(fig)
            fig.tight_layout()
            paths.append(folder / f"outputs_vs_{k}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
        default = [c for c in outs if c.rsplit(".", 1)[-1] in ("max_force", "max_penetration")]
        for o in [self.study.column(e) for e in exceedance] if exceedance else default:
            x = np.sort(ok[o].to_numpy(dtype=float))
            n = x.size
            if n == 0:
                continue
            p = 1.0 - np.arange(1, n + 1) / n
            half = 1.96 * np.sqrt(np.maximum(p * (1 - p), 1.0 / n) / n)
            fig, ax = plt.subplots(figsize=(5.5, 4))
            ax.step(x, p, where="post", label="P(output > x)")
            ax.fill_between(
                x, np.clip(p - half, 0, 1), np.clip(p + half, 0, 1), step="post", alpha=0.25, label="95 %"
            )
            ax.set_yscale("log")
            ax.set_ylim(max(0.5 / n, 1e-6), 1.05)
            ax.set_xlabel(_label(o))
            ax.set_ylabel("exceedance probability")
            ax.legend()
            ax.grid(True, which="both", alpha=0.3)
            fig.tight_layout()
            paths.append(folder / f"exceedance_{o}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
        return paths

    def __repr__(self) -> str:
        counts = self.frame["status"].value_counts().to_dict() if len(self.frame) else {}
        return (
            f"StudyResult({self.study.build!r}, samples={len(self.frame)}, status={counts}, "
            f"wall_time={self.wall_time:.2f} s)"
        )


def open_store(path: Union[str, os.PathLike]) -> StudyResult:
    """The results stored in ``path`` so far (finished or not), without running anything.

    Takes no lock, so it may be called while a writer runs (to watch a long study): every file
    of a store is written to a temporary name, flushed to the disk and renamed whole, so a read
    sees each part whole or not at all, and each sample once (a sample in two parts with
    different results raises :class:`StoreError`)."""
    study = load(path)
    store = _Store(Path(path), study, write=False)
    return StudyResult(study, _concat(store.read(), study), 0.0)
