"""Monte Carlo studies: many variants of any model, run in parallel, with results that survive a kill.

A :class:`Study` is a builder (a scene of :mod:`flexclear.scenes`, or any importable function
that returns a :class:`flexclear.Model` and whose keyword arguments are the study's parameters),
the parameters to vary (each a fixed list of values or a distribution), a sampling design and the
run settings. Running it gives a :class:`StudyResult`: a pandas DataFrame with one row per sample
(its inputs, its outputs per clearance joint, ``"<joint>.<output>"``, and its status), summaries,
exceedance probabilities with confidence intervals, and plots.

>>> from flexclear.study import Study, Uniform
>>> study = Study("slider_yoke", vary={"clearance": Uniform(0.0, 1e-3)}, samples=1000, seed=1,
...               t_end=0.5, dt=1e-5)
>>> result = study.run(store="clearance-study")   # resumable; Ctrl-C keeps finished samples
>>> result.summary()
>>> result.exceedance("bearing.max_force", 50.0)    # P(max force > 50 N) with a 95 % interval

The samples run in one process on a thread pool (``threads=``), or on a Dask cluster when a
``dask.distributed.Client`` is passed (``client=``): chunks of samples per task. Every chunk runs
as one Rust batch with the GIL released: samples the constant stepper runs and that share the
contact-free factorization step in lockstep lanes; any other sample (a model in moving frames,
on the Newton stepper) runs as one lane, its outputs those of its own ``Model.simulate``. A
sample's result does not depend on where or with how many threads it ran, so the same study gives
identical results serially, threaded and on Dask.

Needs pandas, pyarrow (for ``store=``) and scipy (for the Latin hypercube and Sobol designs and the
normal-family distributions); ``pip install flexclear[study]``.

The parts, one module each: :mod:`.distributions`, :mod:`.definition` (:class:`Study`),
:mod:`.runner` (one chunk of samples through the Rust batch), :mod:`.store` (Parquet parts, the
lock), :mod:`.results` (:class:`StudyResult`), :mod:`.study_file` (:func:`load`) and
:mod:`.report` (:func:`write_report`).
"""

from __future__ import annotations

from .definition import (
    DEFAULT_OUTPUTS,
    DESIGNS,
    LINK_OUTPUTS,
    MAX_SAMPLES,
    MODE_OUTPUTS,
    OUTPUTS,
    RESOLVED_STEPS_PER_CONTACT,
    RUN_OPTIONS,
    RUN_PARAMETERS,
    SLIDER_OUTPUTS,
    Study,
)
from .distributions import (
    Distribution,
    LogNormal,
    Normal,
    TruncatedNormal,
    Uniform,
    Values,
    distribution_from_dict,
)
from .report import write_report
from .results import StudyResult, open_store
from .store import FLUSH_SECONDS, LOCK_FILE
from .study_file import load

__all__ = [
    "DESIGNS",
    "OUTPUTS",
    "DEFAULT_OUTPUTS",
    "RESOLVED_STEPS_PER_CONTACT",
    "MODE_OUTPUTS",
    "SLIDER_OUTPUTS",
    "LINK_OUTPUTS",
    "LogNormal",
    "Normal",
    "Study",
    "StudyResult",
    "TruncatedNormal",
    "Uniform",
    "Values",
    "distribution_from_dict",
    "load",
    "open_store",
    "write_report",
    "Distribution",
    "FLUSH_SECONDS",
    "LOCK_FILE",
    "MAX_SAMPLES",
    "RUN_OPTIONS",
    "RUN_PARAMETERS",
]
