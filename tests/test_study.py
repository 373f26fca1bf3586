"""Monte Carlo studies: determinism (serial, threaded, Dask), kill-and-resume, failures as data,
the designs' marginals, study files and the command line.

Studies here are small (tens of samples, tens of ms simulated); the large runs live in
``benches/montecarlo.py``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import flexclear
import numpy as np
import pandas as pd
import pytest
from flexclear.study import (
    LogNormal,
    Normal,
    Study,
    TruncatedNormal,
    Uniform,
    Values,
    load,
    open_store,
    write_report,
)
from scipy import stats


def small_study(**kw) -> Study:
    args = dict(
        vary={"clearance": Uniform(0.0, 1e-3), "bearing_stiffness": LogNormal(1.2e6, 0.3)},
        samples=24,
        seed=7,
        t_end=0.03,
        dt=1e-5,
    )
    args.update(kw)
    return Study("slider_yoke", **args)


def same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Identical results: every column but the wall-clock time, bit for bit."""
    pd.testing.assert_frame_equal(a.drop(columns="wall_time"), b.drop(columns="wall_time"), check_exact=True)


# -- determinism --------------------------------------------------------------------------------


def test_same_seed_same_results_serial_and_threaded():
    s = small_study()
    serial = s.run(threads=1, progress=False)
    threaded = s.run(threads=2, progress=False, chunk_size=5)
    again = small_study().run(threads=2, progress=False)
    assert (serial.frame["status"] == "ok").all()
    same(serial.frame, threaded.frame)
    same(serial.frame, again.frame)
    # a different seed draws different samples
    other = small_study(seed=8).inputs()
    assert not np.allclose(other["clearance"], s.inputs()["clearance"])


def test_lockstep_lanes_do_not_change_results():
    """Samples sharing one factorization run in lockstep groups (default up to 4 lanes); each lane
    is bitwise its single run, so any lane count, chunking and thread count gives the same frame."""
    s = small_study()
    alone = s.run(threads=1, progress=False, lanes=1)
    assert (alone.frame["status"] == "ok").all()
    for threads, lanes, chunk in [(2, 0, None), (1, 4, 5), (2, 8, 7), (2, 3, 24)]:
        same(alone.frame, s.run(threads=threads, progress=False, lanes=lanes, chunk_size=chunk).frame)
    with pytest.raises(flexclear.InvalidParameterError, match="lanes"):
        s.run(threads=1, progress=False, lanes=9)


def test_batch_equals_model_simulate():
    """A study's outputs are those of Model.simulate with the same parameters."""
    s = small_study(samples=3)
    res = s.run(threads=2, progress=False)
    for i, row in res.frame.iterrows():
        model = flexclear.scenes.slider_yoke(
            clearance=row["clearance"], bearing_stiffness=row["bearing_stiffness"]
        )
        j = model.simulate(0.03, 1e-5, record=flexclear.Record(histories=False), progress=False).joint(
            "bearing"
        )
        for o in ("max_penetration", "max_force", "impacts", "contact_time", "max_velocity", "rms_force"):
            assert row[f"bearing.{o}"] == getattr(j, o), (i, o)
        # the impact speed is a speed at an impact, so never above the peak speed
        assert 0 <= row["bearing.max_impact_velocity"] <= row["bearing.max_velocity"]
        assert row["bearing.rms_force"] <= row["bearing.max_force"]


def test_study_with_events_equals_model_simulate_with_events():
    """`run_options={"events": True}` reaches every sample: its outputs are bitwise those of
    Model.simulate(..., events=True), whatever lanes are asked (event runs step alone), and the
    entry spike differs from the fixed-step one (the cut is taken)."""
    s = small_study(samples=4, run_options={"iterate": True, "events": True})
    res = s.run(threads=2, progress=False, lanes=8)
    fixed = small_study(samples=4, run_options={"iterate": True}).run(threads=2, progress=False)
    assert (res.frame["status"] == "ok").all()
    for i, row in res.frame.iterrows():
        model = flexclear.scenes.slider_yoke(
            clearance=row["clearance"], bearing_stiffness=row["bearing_stiffness"]
        )
        r = model.simulate(
            0.03, 1e-5, iterate=True, events=True, record=flexclear.Record(histories=False), progress=False
        )
        j = r.joint("bearing")
        for o in ("max_penetration", "max_force", "impacts", "contact_time", "max_impact_velocity"):
            assert row[f"bearing.{o}"] == getattr(j, o), (i, o)
        if j.impacts:
            assert r.stats["event_steps"] >= 1
            assert row["bearing.max_force"] != fixed.frame.loc[i, "bearing.max_force"]


def test_dask_local_cluster_gives_identical_results():
    distributed = pytest.importorskip("distributed")
    s = small_study()
    local = s.run(threads=2, progress=False)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = s.run(client=client, chunk_size=5, progress=False)
    same(local.frame, remote.frame)


# -- nothing lost ---------------------------------------------------------------------------------

STUDY_FILE = textwrap.dedent(
    """
    scene = "slider_yoke"
    samples = {samples}
    seed = 11
    outputs = ["max_penetration", "max_force", "impacts"]

    [run]
    t_end = {t_end}
    dt = 1e-5

    [vary.clearance]
    distribution = "uniform"
    low = 0.0
    high = 1e-3

    [report]
    thresholds = {{ max_force = 20.0 }}
    """
)


def write_study(tmp_path: Path, samples: int, t_end: float) -> Path:
    p = tmp_path / "study.toml"
    p.write_text(STUDY_FILE.format(samples=samples, t_end=t_end))
    return p


def start_cli(study: Path, out: Path) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "flexclear.cli", "montecarlo", str(study), "--out", str(out)]
    cmd += ["--threads", "1", "--chunk-size", "2", "--no-progress"]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_parts(out: Path, proc: subprocess.Popen, count: int, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while len(list(out.glob("part-*.parquet"))) < count:
        assert proc.poll() is None, "the study finished before it could be stopped; make it longer"
        assert time.monotonic() - t0 < timeout, "no parts written"
        time.sleep(0.02)


@pytest.mark.parametrize("how", ["kill", "ctrl-c"])
def test_killed_or_interrupted_study_resumes_to_the_uninterrupted_result(tmp_path, how):
    # long enough (about 100 chunks of 2 samples) that the stop lands mid-study on a fast machine
    study_file = write_study(tmp_path, samples=200, t_end=0.1)
    out = tmp_path / "run"
    proc = start_cli(study_file, out)
    wait_for_parts(out, proc, 3)
    if how == "kill":
        proc.kill()  # SIGKILL: no chance to clean up
    else:
        proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if how == "ctrl-c":
        assert proc.returncode == 130, err
        assert "resume" in err
    else:
        assert proc.returncode == -signal.SIGKILL
    partial = open_store(out)
    assert 0 < len(partial.frame) < 200
    finished_before = set(partial.frame.index)

    study = load(study_file)
    resumed = study.run(store=out, threads=2, progress=False)
    assert len(resumed.frame) == 200
    # the samples finished before the stop were read back, not recomputed
    for i in finished_before:
        assert resumed.frame.loc[i, "wall_time"] == partial.frame.loc[i, "wall_time"]
    uninterrupted = load(study_file).run(threads=2, progress=False)
    same(resumed.frame, uninterrupted.frame)
    assert not list(out.glob("*.tmp"))


def test_cli_writes_results_and_report(tmp_path):
    study_file = write_study(tmp_path, samples=8, t_end=0.02)
    out = tmp_path / "res"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "flexclear.cli",
            "montecarlo",
            str(study_file),
            "--out",
            str(out),
            "--no-progress",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    report = (out / "report.md").read_text()
    assert "Exceedance" in report and "| max_force | 20 |" in report
    for png in ("histograms.png", "outputs_vs_clearance.png", "exceedance_bearing.max_force.png"):
        assert (out / png).stat().st_size > 1000
    assert len(open_store(out).frame) == 8


def test_plots_carry_the_power_of_ten_in_the_label_not_at_the_axis_end():
    """A power-of-ten factor (drawn at the axis's end, where a long label ran into it) goes into
    the label's unit; axes without one keep their labels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from flexclear.study.definition import _scale_into_labels, _sci_ticks

    fig, (a, b, c) = plt.subplots(1, 3)
    a.plot([2e5, 9e5], [1.0, 2.0])
    a.set_xlabel("slider.acceleration_deviation_max [m/s^2]")
    b.plot([2e-5, 9e-5], [3e-4, 7e-4])
    b.set_xlabel("shift")
    b.set_ylabel("crank_pin.max_penetration [m]")
    c.plot([1.0, 3.0], [10.0, 40.0])
    c.set_xlabel("crank_pin.impacts [count]")
    for ax in (a, b, c):
        _sci_ticks(ax, "both")
    _scale_into_labels(fig)
    minus = "\u2212" if matplotlib.rcParams["axes.unicode_minus"] else "-"
    assert a.get_xlabel() == "slider.acceleration_deviation_max [1e5 m/s^2]"
    assert b.get_xlabel() == f"shift [1e{minus}5]"
    assert b.get_ylabel() == f"crank_pin.max_penetration [1e{minus}4 m]"
    assert c.get_xlabel() == "crank_pin.impacts [count]" and c.get_ylabel() == ""
    fig.canvas.draw()
    assert not any(
        axis.get_offset_text().get_visible() and axis.get_offset_text().get_text()
        for ax in (a, b, c)
        for axis in (ax.xaxis, ax.yaxis)
    )
    plt.close(fig)


def test_store_refuses_a_different_study(tmp_path):
    small_study(samples=2, t_end=0.005).run(store=tmp_path, progress=False)
    with pytest.raises(flexclear.InvalidParameterError, match="different study"):
        small_study(samples=3, t_end=0.005).run(store=tmp_path, progress=False)


# -- failures are data ------------------------------------------------------------------------------


def test_diverging_and_invalid_samples_are_flagged_and_the_batch_goes_on():
    # Stiff bearing, force method at dt 1e-5: the lagged contact force is unstable (Fig. 5(b)).
    s = Study(
        "slider_yoke_stiff",
        vary={"bearing_stiffness": Values([1.2e6, 1e10]), "clearance": Values([-1e-5, 1e-5])},
        design="grid",
        method="force",
        t_end=0.01,
        dt=1e-5,
    )
    res = s.run(threads=2, progress=False)
    f = res.frame
    assert len(f) == 4
    invalid = f[f["clearance"] < 0]
    assert (invalid["status"] == "invalid").all()
    assert invalid["message"].str.contains("clearance").all()
    ok = f[(f["clearance"] > 0) & (f["bearing_stiffness"] < 1e9)]
    assert (ok["status"] == "ok").all() and ok["bearing.max_force"].notna().all()
    bad = f[(f["clearance"] > 0) & (f["bearing_stiffness"] > 1e9)]
    assert (bad["status"] == "diverged").all()
    assert bad["message"].str.contains("step").all()
    assert bad["bearing.max_force"].isna().all()
    assert len(res.ok) == 1 and len(res.failed) == 3

    # retried with dt / 10 = 1e-6, where the force method is stable: recorded as such
    retried = Study(
        "slider_yoke_stiff",
        vary={"bearing_stiffness": Values([1e10])},
        design="grid",
        method="force",
        t_end=0.01,
        dt=1e-5,
        retries=2,
        retry_factor=0.1,
    ).run(progress=False)
    row = retried.frame.iloc[0]
    assert row["status"] == "ok" and row["retries"] == 1 and row["dt_used"] == pytest.approx(1e-6)


# -- designs and marginals -------------------------------------------------------------------------


def test_given_design_runs_exactly_the_samples_given_row_by_row():
    inputs = pd.DataFrame({"clearance": [1e-4, 3e-4, 2e-4], "elements": [6.0, 8.0, 6.0]})
    s = Study.from_inputs("slider_yoke", inputs, t_end=0.004, dt=1e-5)
    assert (s.design, s.samples) == ("given", 3)
    x = s.inputs()
    assert list(x["clearance"]) == [1e-4, 3e-4, 2e-4]
    assert list(x["elements"]) == [6, 8, 6] and x["elements"].dtype.kind == "i"
    # the definition survives the round trip through plain data (what a store keeps)
    again = Study.from_dict(s.to_dict())
    assert again.fingerprint() == s.fingerprint() and again.inputs().equals(x)
    # each sample is the run of its own row: the same as a single-sample study of that row
    res = s.run(progress=False, threads=2)
    one = Study.from_inputs("slider_yoke", {"clearance": [3e-4], "elements": [8]}, t_end=0.004, dt=1e-5)
    row = one.run(progress=False).frame.iloc[0]
    assert res.frame.loc[1, "bearing.max_penetration"] == row["bearing.max_penetration"]


def test_given_design_errors_name_what_is_wrong():
    with pytest.raises(flexclear.InvalidParameterError, match="one length"):
        Study("slider_yoke", vary={"clearance": [1e-4, 2e-4], "amplitude": [0.01]}, design="given")
    with pytest.raises(flexclear.InvalidParameterError, match="each a list"):
        Study("slider_yoke", vary={"clearance": Uniform(1e-4, 2e-4)}, design="given")
    with pytest.raises(flexclear.InvalidParameterError, match="at least one parameter"):
        Study("slider_yoke", design="given")
    with pytest.raises(flexclear.InvalidParameterError, match="come from inputs"):
        Study.from_inputs("slider_yoke", {"clearance": [1e-4]}, samples=3)
    with pytest.raises(flexclear.InvalidParameterError, match="mapping name"):
        Study.from_inputs("slider_yoke", {"clearance": ["a"]})


def test_latin_hypercube_puts_one_sample_in_each_stratum():
    n = 50
    s = Study(
        "slider_yoke",
        vary={"clearance": Uniform(0.0, 1.0), "amplitude": Uniform(0.005, 0.015)},
        samples=n,
        design="lhs",
    )
    x = s.inputs()
    assert sorted(np.floor(x["clearance"] * n).astype(int)) == list(range(n))
    assert sorted(np.floor((x["amplitude"] - 0.005) / 0.01 * n).astype(int)) == list(range(n))


@pytest.mark.parametrize("design", ["random", "lhs", "sobol"])
def test_designs_have_the_stated_marginals(design):
    # Kolmogorov-Smirnov against each stated distribution. The draws are fixed by the seed, so
    # this cannot flake; p > 0.01 is the usual acceptance for a correct sampler.
    n = 1024
    dists = {
        "clearance": Uniform(0.0, 1e-3),
        "bearing_stiffness": LogNormal(1.2e6, 0.5),
        "frequency": Normal(6.0, 0.3),
        "amplitude": TruncatedNormal(0.01, 0.002, 0.008, 0.011),
    }
    x = Study("slider_yoke", vary=dists, samples=n, design=design, seed=3).inputs()
    refs = {
        "clearance": stats.uniform(0.0, 1e-3),
        "bearing_stiffness": stats.lognorm(0.5, scale=1.2e6),
        "frequency": stats.norm(6.0, 0.3),
        "amplitude": stats.truncnorm((0.008 - 0.01) / 0.002, (0.011 - 0.01) / 0.002, loc=0.01, scale=0.002),
    }
    for k, ref in refs.items():
        assert stats.kstest(x[k], ref.cdf).pvalue > 0.01, k
    assert x["amplitude"].between(0.008, 0.011).all()


def test_grid_is_the_full_product_and_lists_are_drawn_uniformly():
    g = Study(
        "slider_yoke",
        vary={"clearance": [0.0, 1e-5, 1e-4], "elements": Values([8, 12]), "frequency": Uniform(5.0, 7.0)},
        design="grid",
        levels=4,
    ).inputs()
    assert len(g) == 3 * 2 * 4
    assert len(g.drop_duplicates()) == len(g)
    assert set(g["frequency"]) == {5.25, 5.75, 6.25, 6.75}  # quantile midpoints of the levels
    assert g["elements"].dtype.kind == "i"
    r = Study("slider_yoke", vary={"elements": [8, 10, 12, 14]}, samples=4000, seed=1).inputs()
    counts = r["elements"].value_counts()
    assert set(counts.index) == {8, 10, 12, 14}
    # each of 4 values has probability 1/4: within 4 binomial standard deviations
    assert (abs(counts - 1000) < 4 * np.sqrt(4000 * 0.25 * 0.75)).all()


# -- bad input -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"vary": {"clearence": Uniform(0, 1)}}, "unknown parameter 'clearence'"),
        ({"vary": {"clearance": {"distribution": "beta", "a": 1}}}, "distribution = 'beta'"),
        ({"vary": {"clearance": {"distribution": "uniform", "low": 0.0}}}, "missing \\['high'\\]"),
        ({"vary": {"clearance": Uniform(0, 1)}, "design": "halton"}, "design"),
        ({"samples": 0}, "samples"),
        ({"dt": -1.0}, "dt"),
        ({"outputs": ["max_stress"]}, "outputs"),
        ({"joints": "hinge"}, "joints"),
        ({"fixed": {"clearance": 1e-5}, "vary": {"clearance": [0.0]}}, "both varied and fixed"),
    ],
)
def test_bad_study_definitions_raise_naming_the_problem(kwargs, match):
    with pytest.raises(flexclear.InvalidParameterError, match=match):
        Study("slider_yoke", **kwargs)


def test_bad_distributions_raise():
    with pytest.raises(ValueError, match="low"):
        Uniform(1.0, 0.0)
    with pytest.raises(ValueError, match="std"):
        Normal(0.0, -1.0)
    with pytest.raises(ValueError, match="median"):
        LogNormal(0.0, 0.1)
    with pytest.raises(ValueError, match="empty"):
        Values([])
    with pytest.raises(ValueError, match="finite"):
        Uniform(0.0, float("inf"))


def test_study_file_errors_are_clear(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('scene = "slider_yoke"\nsampels = 10\n')
    r = subprocess.run(
        [sys.executable, "-m", "flexclear.cli", "montecarlo", str(p)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2
    assert "sampels" in r.stderr
    p.write_text(
        'scene = "slider_yoke"\n[vary.clearance]\ndistribution = "uniform"\nlow = 0.0\nhigh = -1.0\n'
    )
    with pytest.raises(flexclear.InvalidParameterError, match="vary.clearance"):
        load(p)


def test_a_study_files_own_builder_is_found_next_to_it(tmp_path, monkeypatch):
    # a user's linkage module beside the study file, run from elsewhere: the `flexclear`
    # command does not search the current directory, so the file's folder is searched
    monkeypatch.setattr(sys, "path", list(sys.path))
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "my_quick_return.py").write_text(
        "import flexclear as fc\n"
        "from flexclear import Linkage, Rotation\n"
        "def build(clearance=2e-4, speed=40.0):\n"
        "    lk = Linkage().ground('O2', (0.0, 0.0)).ground('O4', (0.254, 0.0))\n"
        "    lk.crank('crank', 'O2', 'A', length=0.0508, driver=Rotation.constant(speed))\n"
        "    lk.point('B', near=(0.15, 0.26))\n"
        "    lk.link('coupler', 'A', 'B', length=0.2794).link('rocker', 'O4', 'B', length=0.2794)\n"
        "    f = lk.frames(0.004)\n"
        "    m = fc.Model()\n"
        "    m.add_body('crank', frame=f['crank']).add_body('rocker', frame=f['rocker'])\n"
        "    m.add_link('coupler', length=0.2794, elements=4, youngs_modulus=7.1e10, density=2710.0,\n"
        "               area=8.06e-5, inertia=6.78e-11, frame=f['coupler'])\n"
        "    m.add_joint('crank_pin', 'coupler', 0, body='crank', point=(0.0508, 0.0),\n"
        "                clearance=clearance, stiffness=5e7, damping=500.0)\n"
        "    m.add_pin('rocker_pin', 'coupler', 4, body='rocker', point=(0.2794, 0.0))\n"
        "    return m\n"
    )
    study_file = folder / "study.toml"
    study_file.write_text(
        'build = "my_quick_return:build"\nsamples = 3\nt_end = 0.004\ndt = 1e-5\n'
        "[vary]\nspeed = [30.0, 40.0, 50.0]\n"
    )
    monkeypatch.chdir(tmp_path)
    res = load(study_file).run(threads=1, progress=False, store=folder / "store")
    assert list(res.frame["status"]) == ["ok"] * 3
    assert np.all(res.frame["crank_pin.max_force"] > 0)
    # its store read back in a fresh session (flexclear compare): the module beside the store
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p != str(folder)])
    monkeypatch.delitem(sys.modules, "my_quick_return")
    assert load(folder / "store").build == "my_quick_return:build"
    # a module that is nowhere says where it was looked for
    study_file.write_text('build = "not_a_module_anywhere:build"\nsamples = 1\n[vary]\nspeed = [30.0]\n')
    with pytest.raises(flexclear.InvalidParameterError, match="cannot be imported.*in its own folder"):
        load(study_file)


# -- outputs ---------------------------------------------------------------------------------------


def test_summary_exceedance_and_histories():
    res = small_study(samples=12, history_every=10).run(progress=False)
    summ = res.summary()
    assert list(summ.index) == res.study.output_columns == [f"bearing.{o}" for o in res.study.outputs]
    assert (summ["min"] <= summ["q0.5"]).all() and (summ["q0.5"] <= summ["max"]).all()
    e = res.exceedance("max_force", float(np.median(res.array("max_force"))))
    assert e["n"] == 12 and e["exceed"] == 6
    assert e["low"] < 0.5 < e["high"]
    # a decimated history: every 10th step of 3000, plus the initial state
    h = res.frame["bearing.penetration_history"].iloc[0]
    assert len(h) == 301
    assert np.max(h) == pytest.approx(res.frame["bearing.max_penetration"].iloc[0], abs=2e-6)
    all_out = res.exceedance("max_force", -1.0)
    assert all_out["probability"] == 1.0 and all_out["high"] == 1.0 and all_out["low"] > 0.7


def test_progress_callback_counts_every_sample():
    seen = []
    small_study(samples=10).run(progress=lambda done, total: seen.append((done, total)), chunk_size=3)
    assert seen[-1] == (10, 10)
    assert all(b >= a for (a, _), (b, _) in zip(seen, seen[1:]))


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    yield
    assert os.getcwd() == str(tmp_path)


# -- studies of any model ------------------------------------------------------------------------


def _any_model_studies():
    import study_builders

    four_bar = Study(
        study_builders.four_bar_with_clearance,
        vary={"clearance": Uniform(1e-4, 5e-4), "stiffness": LogNormal(5e7, 0.3)},
        samples=6,
        seed=3,
        t_end=0.003,
        dt=1e-5,
    )
    crank = Study(
        "slider_crank",
        fixed={"clearance_at": "crank_pin"},
        vary={"clearance": Uniform(1e-4, 5e-4)},
        samples=6,
        seed=4,
        t_end=0.002,
        dt=1e-5,
    )
    return four_bar, crank


def test_studies_of_user_built_and_moving_frame_models_are_thread_count_independent():
    for s in _any_model_studies():
        one = s.run(threads=1, progress=False)
        two = s.run(threads=2, progress=False, chunk_size=4)
        assert (one.frame["status"] == "ok").all(), one.failed
        joint = s.joints[0]
        assert joint == "crank_pin" and f"{joint}.max_force" in one.frame
        assert (one.frame[f"{joint}.max_force"] > 0).all()
        same(one.frame, two.frame)
    # the builder is stored by name, so the definition round-trips as plain data
    assert s.build == "slider_crank"
    four_bar, _ = _any_model_studies()
    assert four_bar.build == "study_builders:four_bar_with_clearance"
    assert Study.from_dict(four_bar.to_dict()).fingerprint() == four_bar.fingerprint()


def test_studies_of_any_model_on_dask_are_identical():
    distributed = pytest.importorskip("distributed")
    studies = _any_model_studies()
    local = [s.run(threads=2, progress=False) for s in studies]
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = [s.run(client=client, chunk_size=3, progress=False) for s in studies]
    for a, b in zip(local, remote):
        same(a.frame, b.frame)


def _closure_builder():
    def build(clearance: float = 1e-4):
        return flexclear.scenes.slider_yoke(clearance=clearance)

    return build


def test_lambdas_and_closures_are_refused_as_builders():
    with pytest.raises(flexclear.InvalidParameterError, match="lambda"):
        Study(lambda clearance=1e-4: flexclear.scenes.slider_yoke(clearance=clearance))
    with pytest.raises(flexclear.InvalidParameterError, match="build"):
        Study(_closure_builder())
    with pytest.raises(flexclear.InvalidParameterError, match="cannot be imported"):
        Study("no_such_module:build")


def test_a_model_without_clearance_joint_says_how_to_give_it_one():
    with pytest.raises(flexclear.InvalidParameterError, match="clearance_at"):
        Study("slider_crank")


def test_a_failed_moving_frame_sample_stays_its_own_row():
    # The force method on the slider-crank's crank pin fails at dt = 1e-5 s within 2 ms (the
    # lagged coupling pumps energy into the impacts); the implicit default completes the same
    # samples.
    s = Study(
        "slider_crank",
        fixed={"clearance_at": "crank_pin"},
        vary={"clearance": [2e-4, 5e-4]},
        design="grid",
        t_end=0.002,
        dt=1e-5,
        method="force",
    )
    res = s.run(threads=2, progress=False)
    # (a diverged state, or a Newton step that no longer converges on the way there)
    assert res.frame["status"].isin(["diverged", "unconverged"]).all()
    assert res.frame["crank_pin.max_force"].isna().all()
    assert (res.frame["message"].str.len() > 0).all()
    ok = Study(**{**s.to_dict(), "method": "modified", "vary": {"clearance": [2e-4, 5e-4]}}).run(
        progress=False
    )
    assert (ok.frame["status"] == "ok").all()


@pytest.fixture
def batched(monkeypatch):
    """The models given to the Rust batch during the test, in order (run_batch spied on)."""
    models = []
    run_batch = flexclear._core.run_batch

    def spy(given, *args, **kwargs):
        models.extend(given)
        return run_batch(given, *args, **kwargs)

    monkeypatch.setattr(flexclear._core, "run_batch", spy)
    return models


def test_a_moving_frame_model_the_constant_stepper_runs_goes_to_the_batch(batched):
    # the slider-yoke with a zero gravity set (a feature of the moving-frame formulation) plans as
    # constant: its samples run in the Rust batch (lanes, shared analysis), bitwise as the
    # scene's
    vary = {"clearance": Uniform(5e-5, 2e-4)}
    kw = dict(samples=6, seed=3, t_end=0.02, dt=1e-5)
    moved = Study("study_builders:slider_yoke_in_moving_frames", vary, **kw)
    plain = Study("slider_yoke", vary, **kw)
    model = moved._scene_fn(clearance=1e-4)
    assert model.engine == "translating" and model._core.stepper == "constant"
    a = moved.run(threads=2, progress=False)
    assert len(batched) == 6 and all(isinstance(m, flexclear._core.Mechanism) for m in batched)
    b = plain.run(threads=2, progress=False)
    assert (a.frame["status"] == "ok").all()
    for c in ("bearing.max_penetration", "bearing.max_force", "bearing.impacts"):
        assert np.array_equal(a.frame[c].to_numpy(), b.frame[c].to_numpy()), c


def test_a_slider_crank_study_runs_through_the_batch_as_single_simulates(batched):
    # every sample goes to the Rust batch (a sample that needs the Newton stepper runs there as
    # one lane), and its outputs are those of Model.simulate with its parameters, bitwise
    study = Study(
        "slider_crank",
        fixed={"clearance_at": "crank_pin"},
        vary={"clearance": Uniform(1e-4, 5e-4)},
        samples=4,
        seed=4,
        t_end=0.002,
        dt=1e-5,
    )
    res = study.run(threads=2, progress=False)
    assert len(batched) == 4 and all(m.stepper == "newton" for m in batched)
    assert (res.frame["status"] == "ok").all(), res.failed
    for i, row in res.frame.iterrows():
        model = flexclear.scenes.slider_crank(clearance_at="crank_pin", clearance=row["clearance"])
        r = model.simulate(0.002, 1e-5, record=flexclear.Record(histories=False), progress=False)
        assert r.stats["stepper"] == "newton"
        j = r.joint("crank_pin")
        for o in study.outputs:
            assert row[f"crank_pin.{o}"] == getattr(j, o), (i, o)


def test_the_batch_refuses_what_is_not_a_mechanism_by_name():
    with pytest.raises(flexclear.InvalidParameterError, match=r"models\[0\].*a Mechanism"):
        flexclear._core.run_batch(["yoke"], [0.01], [1e-5])


def _four_bar_study(**kw) -> Study:
    # the four-bar's rocker pin: first impact near 1.45 ms, natural contact period about 4.3 us
    return Study(
        "four_bar",
        outputs=["max_force", "contact_period"],
        fixed={"clearance_at": "rocker_pin", "bearing_stiffness": 5e7},
        vary={"clearance": Uniform(1.4e-4, 1.6e-4)},
        samples=2,
        seed=5,
        t_end=0.003,
        **kw,
    )


def test_resolution_flags_a_step_too_long_for_the_contact(tmp_path):
    coarse = _four_bar_study(dt=1e-5).run(threads=1, progress=False)
    fine = _four_bar_study(dt=2.5e-7).run(threads=1, progress=False)
    for res in (coarse, fine):
        assert (res.frame["status"] == "ok").all()
    # the steps per period are the period over the step the sample ran at
    steps = coarse.array("rocker_pin.contact_period") / 1e-5
    a, b = coarse.resolution().loc["rocker_pin"], fine.resolution().loc["rocker_pin"]
    assert a["impacted"] == 2 and a["median_steps"] == pytest.approx(np.median(steps), rel=1e-12)
    # 1e-5 s is under two steps a contact; 2.5e-7 s over ten (the period itself is off at 1e-5 s,
    # the sampled peak penetration deeper than the true one)
    assert a["median_steps"] < 2 and a["unresolved"] == 2
    assert b["median_steps"] > 10 and b["unresolved"] == 0
    # one sentence per joint with unresolved samples, the report's and the CLI's
    (sentence,) = coarse.unresolved()
    assert sentence.startswith("Unresolved: 2 of 2 samples") and "at rocker_pin (median 1." in sentence
    assert fine.unresolved() == []
    write_report(coarse, tmp_path / "coarse")
    write_report(fine, tmp_path / "fine")
    text = (tmp_path / "coarse" / "report.md").read_text()
    assert "## Resolution: steps per contact period" in text and sentence in text
    text = (tmp_path / "fine" / "report.md").read_text()
    assert "## Resolution: steps per contact period" in text and "Unresolved:" not in text


def test_resolution_of_a_tol_study_is_its_pilot(tmp_path):
    res = _four_bar_study(tol=1e-3, dt=1e-4).run(threads=1, progress=False)
    assert res.resolution().empty
    write_report(res, tmp_path)
    text = (tmp_path / "report.md").read_text()
    assert "## Resolution: the accuracy pilot" in text
    for column, value in res.accuracy["accuracy"].items():
        assert f"| {column} | {value:.3g} |" in text
    # the way to the distributions' answer, with this study's tolerances
    assert "`flexclear converge STUDY.toml --tol 0.001 0.0001`" in text
    # without contact_period a fixed-step study has no resolution section
    res = Study("slider_yoke", samples=1, t_end=0.002, dt=1e-5).run(threads=1, progress=False)
    assert res.resolution().empty
    write_report(res, tmp_path / "yoke")
    assert "## Resolution" not in (tmp_path / "yoke" / "report.md").read_text()
