"""Study files: :func:`load` reads a TOML file or a store's ``study.json``."""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Union

from ..errors import (
    InvalidParameterError,
)
from .definition import Study
from .distributions import _check_finite


def _find_builder(build: Any, folder: Path) -> None:
    """Makes a study file's ``"module:function"`` builder importable the way a script's own
    modules are: when ``module`` is not found on ``sys.path``, the study file's folder, then the
    current directory, is put in front of it where the module's file or package is there (the
    ``flexclear`` command, unlike ``python -m``, does not search the current directory). Dask
    workers started from this process inherit the path; remote ones need the module installed."""
    if not isinstance(build, str) or ":" not in build:
        return
    top = build.partition(":")[0].split(".")[0]
    if not top.isidentifier():
        return
    try:
        if importlib.util.find_spec(top) is not None:
            return
    except (ImportError, ValueError):
        return
    for place in (folder.resolve(), Path.cwd()):
        if (place / f"{top}.py").is_file() or (place / top / "__init__.py").is_file():
            if str(place) not in sys.path:
                sys.path.insert(0, str(place))
            importlib.invalidate_caches()
            return


def load(path: Union[str, os.PathLike]) -> Study:
    """A study from a TOML file or a store's ``study.json``.

    A study file holds :class:`Study`'s arguments at top level (``build``: a scene name or
    ``"module:function"``, the module found as installed, else next to the study file or in the
    current directory; ``samples``,
    ``design``, ``seed``, ``outputs``, ...), the run settings in ``[run]`` (``t_end``, ``dt``,
    ``method``, ``start``, ``retries``, ...), fixed scene keywords in ``[fixed]``, one entry per
    varied parameter in ``[vary]`` (a list, or a table with ``distribution`` and its
    parameters), and optionally ``[report] thresholds = {max_force = 40.0}`` for the exceedance
    table of the report (kept in ``study.report_thresholds``). Unknown keys, parameters or
    distributions raise :class:`~flexclear.InvalidParameterError`.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "study.json"
    if not path.exists():
        raise InvalidParameterError(f"study file {str(path)!r} does not exist")
    if path.suffix == ".json":
        stored = json.loads(path.read_text())
        # a store's builder of one's own: beside the store or in the current directory
        _find_builder(stored.get("study", {}).get("build"), path.parent.parent)
        study = Study.from_dict(stored["study"])
        study.report_thresholds = dict(stored.get("report_thresholds", {}))
        return study
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11
        import tomli as tomllib
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise InvalidParameterError(f"{path}: not valid TOML: {e}") from None
    run = data.pop("run", {}) or {}
    report = data.pop("report", {}) or {}
    if not isinstance(run, Mapping) or not isinstance(report, Mapping):
        raise InvalidParameterError(f"{path}: [run] and [report] must be tables")
    unknown = sorted(set(report) - {"thresholds"})
    if unknown:
        raise InvalidParameterError(f"{path}: unknown [report] keys {unknown}; allowed: ['thresholds']")
    both = sorted(set(data) & set(run))
    if both:
        raise InvalidParameterError(f"{path}: {both} given both at top level and in [run]")
    _find_builder(data.get("build"), path.parent)
    study = Study.from_dict({**data, **run})
    thresholds = dict(report.get("thresholds", {}))
    for k, v in thresholds.items():
        try:
            study.column(k)
        except InvalidParameterError:
            raise InvalidParameterError(
                f"{path}: [report.thresholds] {k!r} is not an output of the study; "
                f"allowed: {study.output_columns}"
            ) from None
        _check_finite(f"report.thresholds.{k}", value=v)
    study.report_thresholds = thresholds
    return study
