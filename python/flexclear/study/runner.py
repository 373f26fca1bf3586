"""One chunk of samples: models built, one Rust batch run with the GIL released, rows of outputs
out. Shared by the local and the Dask paths; the ideal-joint runs behind the sliders'
deviations."""

from __future__ import annotations

import json
import os
import threading
import time
from typing import Any, Optional

import numpy as np

from .. import _core
from ..errors import (
    FlexclearError,
)
from .definition import (
    _JOINT_PARAMETERS,
    _RUN_OPTION_ALIASES,
    SLIDER_OUTPUTS,
    Study,
    _batch_scheme,
    _tol_integrator,
)


def _run_rows(study: Study, ids: list, rows: list, pool: tuple, progress=None):
    """Runs the samples ``ids`` with inputs ``rows`` on ``pool = (threads, lanes)``; returns
    (DataFrame, pending exception). Every sample goes to one Rust batch, which runs each on the
    stepper its plan picks: lockstep lanes for samples the constant stepper runs and that share
    a factorization, one lane each for the others (a sample that needs Newton gives the outcome
    of its single ``simulate``)."""
    threads, lanes = pool
    import pandas as pd

    from ..model import check_window

    records: list[dict] = []
    batch: list[tuple[int, Any, float, float]] = []
    for i, row in zip(ids, rows):
        rec: dict[str, Any] = {"sample": int(i)}
        rec.update(row)
        try:
            build_kwargs = study._scene_kwargs(row)
            model = study._scene_fn(**build_kwargs)
            if study.sliders:
                model._build_kwargs = build_kwargs  # for the ideal run of the same structure
        except FlexclearError as e:
            rec.update(status="invalid", message=str(e), dt_used=float("nan"), retries=0, wall_time=0.0)
            records.append(rec)
            continue
        job = (len(records), model, float(row.get("t_end", study.t_end)), float(row.get("dt", study.dt)))
        try:  # a varied t_end or dt may leave no step after `start`
            check_window(study.start, job[2], job[3], "start")
        except FlexclearError as e:
            rec.update(status="invalid", message=str(e), dt_used=job[3], retries=0, wall_time=0.0)
            records.append(rec)
            continue
        batch.append(job)
        records.append(rec)
    hist = study.history_every is not None
    outcomes: dict[int, dict] = {}
    pending = None

    simulate_options = {_RUN_OPTION_ALIASES.get(k, k): v for k, v in study.run_options.items()}
    simulate_options.pop("memory_limit", None)  # checked once for the whole study
    batch_options = {k: v for k, v in simulate_options.items() if v is not None}
    if "iter_tol" in batch_options:
        batch_options["tol"] = batch_options.pop("iter_tol")
    if study.tol is not None and batch and all(job[1].engine == "translating" for job in batch):
        # tol= runs of translating models take Model.simulate's default integrator there
        integrator, rho_inf = _tol_integrator(batch_options, True)
        batch_options.update(integrator=integrator, rho_inf=rho_inf)
    scheme = _batch_scheme(batch_options)
    for key in ("integrator", "rho_inf", "hht_alpha"):
        batch_options.pop(key, None)
    batch_options.update(scheme)
    halving = batch_options.pop("step_halving", 0)
    if halving:
        # the constant stepper has no Newton iteration to halve: refused per sample, as
        # Model.simulate refuses it
        from ..model import _bad

        message = str(_bad("step_halving", halving, "0 while every link translates (no Newton to halve)"))
        for k, m, *_ in batch:
            if m.engine == "translating":
                records[k].update(status="invalid", message=message, dt_used=float("nan"), retries=0)
                records[k]["wall_time"] = 0.0
        batch = [job for job in batch if job[1].engine != "translating"]
    if batch and study.sliders:
        # slider outputs compare each sample with its ideal-joint mechanism through Result
        # objects: these samples run one per thread through Model.simulate
        done = [0]

        def one_done() -> None:
            done[0] += 1
            if progress is not None:
                progress(done[0])

        outs_by_job, pending = _run_moving(study, batch, threads, one_done, simulate_options)
        outcomes.update(outs_by_job)
        batch = []
    if batch:
        outs, _stats, pending = _core.run_batch(
            [m._core for _, m, _, _ in batch],
            [t for _, _, t, _ in batch],
            [d for _, _, _, d in batch],
            threads=threads,
            lanes=lanes,
            retries=study.retries,
            retry_factor=study.retry_factor,
            method=study.method,
            joints=study._joint_indices,
            every=study.history_every or 1,
            histories=hist,
            joint_position=study.orbit,
            contact_modes=study._modes,
            link_peaks=study.links,
            start=study.start,
            progress=progress,
            step_halving=halving,
            accuracy=study.tol,
            **batch_options,
        )
        for (k, *_), out in zip(batch, outs):
            outcomes[k] = out
    for k, out in outcomes.items():
        rec = records[k]
        status = out["status"]
        rec.update(
            status=status,
            message=out["message"],
            dt_used=out["dt"],
            retries=out["retries"],
            wall_time=out["wall_time"],
        )
        for n, vals in (out.get("sliders") or {}).items():
            for o, v in vals.items():
                rec[f"{n}.{o}"] = v
        peaks = out.get("links") or []
        for n, li in zip(study._link_names, study._link_indices):
            if status == "ok" and li < len(peaks):
                rec[f"{n}.max_midspan"], rec[f"{n}.max_axial_force"] = map(float, peaks[li])
        for j, ji in zip(study.joints, study._joint_indices):
            ext = out["extremes"][ji] if out["extremes"] and status == "ok" else None
            for o in study.outputs:
                rec[f"{j}.{o}"] = float(getattr(ext, o)) if ext is not None else float("nan")
            if hist:
                h = next((h for h in out["joints"] if h["joint"] == ji), None) if status == "ok" else None
                rec[f"{j}.penetration_history"] = h["penetration"] if h is not None else np.empty(0)
                rec[f"{j}.force_history"] = h["force"] if h is not None else np.empty(0)
                if study.orbit:
                    rec[f"{j}.qx_history"] = h["qx"] if h is not None else np.empty(0)
                    rec[f"{j}.qy_history"] = h["qy"] if h is not None else np.empty(0)
    keep = [r for r in records if r.get("status") not in (None, "interrupted", "not_run")]
    for r in keep:
        for c in study.output_columns:
            r.setdefault(c, float("nan"))
        if hist:
            for j in study.joints:
                for ch in _history_channels(study):
                    r.setdefault(f"{j}.{ch}_history", np.empty(0))
    frame = pd.DataFrame.from_records(keep, columns=_columns(study))
    frame = frame.set_index("sample")
    return frame, pending


class _IdealRuns:
    """The ideal-joint runs of one batch of samples of ``Study(sliders=True)``: one per structure
    (the build's parameters other than the clearance joint's, ``t_end`` and ``dt``), made by the
    first sample of its structure that asks for it, outside any lock shared with other
    structures (the other samples of the structure wait for it; other structures' runs go on in
    parallel), and dropped from the cache once the last sample of its structure that the batch
    expects (:meth:`expect`) has taken it (:meth:`release`; that sample keeps it while it runs):
    a batch holds about one ideal run per worker thread, not one per structure (their slider
    histories are O(steps))."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.lock = threading.Lock()
        self.runs: dict = {}
        self.pending: dict = {}

    @staticmethod
    def key(kwargs: dict, t_end: float, dt: float) -> tuple:
        kw = {k: v for k, v in kwargs.items() if k not in _JOINT_PARAMETERS}
        kw["clearance_at"] = None
        return (json.dumps(kw, sort_keys=True, default=repr), float(t_end), float(dt)), kw

    def expect(self, kwargs: Optional[dict], t_end: float, dt: float) -> None:
        """Counts one more sample of ``kwargs``' structure in the batch."""
        if kwargs is not None:
            key = self.key(kwargs, t_end, dt)[0]
            with self.lock:
                self.pending[key] = self.pending.get(key, 0) + 1

    def get(self, kwargs: Optional[dict], t_end: float, dt: float, options: dict):
        """The ideal run of the sample built with ``kwargs`` (a :class:`Result` with its slider
        histories and their shared core reference); None when it failed or without ``kwargs``."""
        if kwargs is None:
            return None
        from concurrent.futures import Future

        from ..result import Record

        key, kw = self.key(kwargs, t_end, dt)
        with self.lock:
            fut = self.runs.get(key)
            owner = fut is None
            if owner:
                fut = self.runs[key] = Future()
                self.study._ideal_made += 1
        if owner:
            # the slider histories only: the reference every sample of the structure compares
            # with online (Record.slider_reference)
            record = Record(
                histories=False, displacements=False, sliders=True, every=self.study.history_every or 1
            )
            try:
                run = self.study._scene_fn(**kw).simulate(t_end, dt, record=record, progress=False, **options)
                run._slider_reference()  # the core's shared copy, built once here
            except FlexclearError:
                run = None
            except BaseException as e:  # the waiting samples see it too
                fut.set_exception(e)
                raise
            fut.set_result(run)
        return fut.result()

    def release(self, kwargs: Optional[dict], t_end: float, dt: float) -> None:
        """One sample of ``kwargs``' structure is done with its ideal run: dropped after the last."""
        if kwargs is None:
            return
        key = self.key(kwargs, t_end, dt)[0]
        with self.lock:
            left = self.pending.get(key, 0) - 1
            if left > 0:
                self.pending[key] = left
            else:
                self.pending.pop(key, None)
                self.runs.pop(key, None)


def _run_one_moving(
    study: Study, model, t_end: float, dt: float, options: dict, ideals: Optional[_IdealRuns] = None
) -> dict:
    """One moving-frame sample, with retries at a smaller step after a divergence or a step that
    does not converge; the outcome in the layout of the Rust batch. ``ideals``: the batch's
    ideal-joint runs (``sliders``; a cache of its own when not given)."""
    from ..result import Record

    hist = study.history_every is not None
    dt0 = dt
    if study.tol is not None:
        options = {**options, "tol": study.tol}
    ideal = None
    if study.sliders:
        ideals = ideals or _IdealRuns(study)
        build = getattr(model, "_build_kwargs", None)
        try:
            ideal = ideals.get(build, t_end, dt0, options)
        finally:
            ideals.release(build, t_end, dt0)
    retries = 0
    t0 = time.perf_counter()
    while True:
        # the slider deviations: online against the ideal run (O(1) memory per slider) while the
        # grids line up; after a retry at a smaller step they do not, and the sample keeps its
        # slider histories for the history-based comparison (the ideal run interpolated onto
        # its times, _slider_outputs)
        online = ideal is not None and dt == dt0
        record = Record(
            joints=study.joints,
            displacements=False,
            histories=hist,
            every=study.history_every or 1,
            start=study.start,
            position=study.orbit,
            contact_modes=study._modes,
            link_peaks=study.links,
            sliders=study.sliders and ideal is not None and not online,
            slider_reference=ideal if online else None,
        )
        try:
            res = model.simulate(t_end, dt, study.method, record=record, progress=False, **options)
        except FlexclearError as e:
            from ..errors import ConvergenceError, SimulationDivergedError, SingularMatrixError

            failed = isinstance(e, (SimulationDivergedError, ConvergenceError))
            above_floor = dt * study.retry_factor >= _core.RETRY_MIN_STEP_RATIO * dt0
            if failed and retries < study.retries and above_floor:
                retries += 1
                dt *= study.retry_factor
                continue
            status = (
                "diverged"
                if isinstance(e, SimulationDivergedError)
                else "unconverged"
                if isinstance(e, ConvergenceError)
                else "singular"
                if isinstance(e, SingularMatrixError)
                else "invalid"
            )
            return _outcome(status, str(e), dt, retries, time.perf_counter() - t0)
        extremes = list(res._raw.extremes)  # the JointExtremes of the batch's rows, joint order
        joints = []
        if hist:
            for ji, name in zip(study._joint_indices, study.joints):
                j = res.joint(name)
                h = {"joint": ji, "penetration": j.penetration, "force": j.force}
                if study.orbit:
                    h["qx"], h["qy"] = j.orbit()
                joints.append(h)
        out = _outcome("ok", "", dt, retries, time.perf_counter() - t0)
        # the links' running peaks in the layout of the Rust batch (NaN where not tracked)
        links = [(h.max_midspan, h.max_axial_force) for h in res._raw.links]
        out.update(extremes=extremes, joints=joints, links=links)
        if study.sliders:
            out["sliders"] = {
                n: _online_slider_outputs(res, n) if online else _slider_outputs(res, ideal, n, study.start)
                for n in study._slider_names
            }
        return out


def _online_slider_outputs(res, name: str) -> dict:
    """:data:`SLIDER_OUTPUTS` of slider ``name`` of run ``res``, which accumulated its deviations
    from the ideal run online (``Record.slider_reference``)."""
    s = res.slider(name)
    return {o: float(getattr(s, o)) for o in SLIDER_OUTPUTS}


_SLIDER_CH = ("position", "velocity", "acceleration")


def _slider_outputs(res, ideal, name: str, start: float) -> dict:
    """:data:`SLIDER_OUTPUTS` of slider ``name`` of run ``res`` against the ideal run ``ideal``
    over the recorded samples from ``start`` (s); the ideal run interpolated onto the run's
    times where the grids differ (after a retry at a smaller step)."""
    s = res.slider(name)
    out = {"max_acceleration": s.max_acceleration}
    i = ideal.slider(name) if ideal is not None else None
    if i is None:  # no ideal run: no deviation (nor slider histories: they were not kept)
        out.update({f"{ch}_deviation_{m}": float("nan") for ch in _SLIDER_CH for m in ("mean", "max")})
        return out
    keep = res.time >= start
    for ch in _SLIDER_CH:
        x = getattr(s, ch)
        if not x.size:
            dev = np.full(1, np.nan)
        elif np.array_equal(ideal.time, res.time):
            dev = np.abs(x - getattr(i, ch))[keep]
        else:
            dev = np.abs(x - np.interp(res.time, ideal.time, getattr(i, ch)))[keep]
        out[f"{ch}_deviation_mean"] = float(np.mean(dev))
        out[f"{ch}_deviation_max"] = float(np.max(dev))
    return out


def _outcome(status: str, message: str, dt: float, retries: int, wall: float) -> dict:
    return {
        "status": status,
        "message": message,
        "dt": dt,
        "retries": retries,
        "wall_time": wall,
        "extremes": [],
        "joints": [],
    }


def _run_moving(study: Study, jobs: list, threads: int, one_done, options: dict):
    """Moving-frame samples on ``threads`` worker threads (0 = one per core); each run releases
    the GIL. Returns ``({record index: outcome}, pending exception)``; on Ctrl-C the samples not
    started are dropped and the finished ones kept."""
    from concurrent.futures import ThreadPoolExecutor, as_completed

    workers = threads if threads > 0 else (os.cpu_count() or 1)
    out: dict[int, dict] = {}
    ideals = _IdealRuns(study)
    for _, m, t, d in jobs:
        ideals.expect(getattr(m, "_build_kwargs", None), t, d)
    with ThreadPoolExecutor(max_workers=min(workers, len(jobs))) as ex:
        futures = {ex.submit(_run_one_moving, study, m, t, d, options, ideals): k for k, m, t, d in jobs}
        try:
            for fut in as_completed(futures):
                out[futures[fut]] = fut.result()
                one_done()
        except KeyboardInterrupt as e:
            for f in futures:
                f.cancel()
            for f, k in futures.items():
                if f.done() and not f.cancelled() and f.exception() is None:
                    out[k] = f.result()
            return out, e
    return out, None


def _run_rows_task(definition: dict, ids: list, rows: list, pool: tuple):
    """A Dask task: one chunk of samples as one Rust batch (the study travels as plain data)."""
    frame, pending = _run_rows(Study.from_dict(definition), ids, rows, pool)
    if pending is not None:
        raise pending
    return frame


def _columns(study: Study) -> list[str]:
    cols = ["sample", *study.vary, "status", "message", "dt_used", "retries", "wall_time"]
    cols += study.output_columns
    if study.history_every is not None:
        for j in study.joints:
            cols += [f"{j}.{ch}_history" for ch in _history_channels(study)]
    return cols


def _history_channels(study: Study) -> tuple[str, ...]:
    """The history columns per joint (``"<joint>.<channel>_history"``)."""
    return ("penetration", "force", "qx", "qy") if study.orbit else ("penetration", "force")


def _concat(frames: list, study: Study):
    import pandas as pd

    if not frames:
        return pd.DataFrame(columns=_columns(study)).set_index("sample")
    return pd.concat(frames).sort_index()
