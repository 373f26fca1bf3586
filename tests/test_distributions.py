"""Comparing two studies' output distributions (flexclear.analysis.distributions.compare,
StudyResult.compare, ``flexclear compare``).

The statistics are checked on synthetic samples whose distributions are known (the intervals'
coverage over many repeats, a known shift found, pairing that sees a small bias the spread hides);
one real pair of studies checks the plumbing (the same study file at two steps is paired)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from flexclear.analysis.distributions import Convergence, compare, convergence, markdown, plot
from flexclear.cli import main
from flexclear.errors import InvalidParameterError
from flexclear.study import Study, StudyResult, Uniform


def _study() -> Study:
    return Study(
        "slider_crank",
        outputs=["max_force"],
        fixed={"clearance_at": "crank_pin"},
        vary={"clearance": Uniform(1e-4, 5e-4)},
        samples=2,
        t_end=0.002,
        dt=1e-5,
    )


def _result(values, clearance=None) -> StudyResult:
    """A study result whose completed samples have ``crank_pin.max_force`` = ``values`` (and the
    varied clearance ``clearance``, default 1e-4 m + sample id * 1e-7 m)."""
    n = len(values)
    clearance = 1e-4 + 1e-7 * np.arange(n) if clearance is None else clearance
    frame = pd.DataFrame(
        {"clearance": clearance, "status": "ok", "crank_pin.max_force": np.asarray(values, float)},
        index=pd.Index(np.arange(n), name="sample"),
    )
    return StudyResult(_study(), frame, 0.0)


def test_identical_studies_differ_by_nothing():
    x = np.random.default_rng(1).lognormal(0.0, 0.3, 50)
    t = compare(_result(x), _result(x))
    row = t.loc["crank_pin.max_force"]
    assert row["paired"] and row["n_a"] == row["n_b"] == 50
    for s in ("q50", "q90", "mean"):
        assert row[f"{s}_diff"] == row[f"{s}_low"] == row[f"{s}_high"] == 0.0
    assert row["ks_pvalue"] == 1.0 and row["verdict"] == "equivalent"
    # the statistics are the samples' own
    assert row["q50_a"] == np.median(x) and row["mean_b"] == pytest.approx(np.mean(x), rel=1e-15)


def test_intervals_cover_a_zero_difference_at_their_level():
    # two independent draws of one distribution (different inputs: unpaired), 200 times: a 95 %
    # interval of the median's difference must contain 0 in about 95 % of them (a percentile
    # bootstrap of a median on 80 samples is close to its level; 200 repeats give a binomial
    # standard error of 1.5 %, so [0.88, 0.995] fails only for a wrong interval)
    rng = np.random.default_rng(7)
    hits = 0
    for k in range(200):
        a = _result(rng.lognormal(0.0, 0.5, 80), clearance=rng.uniform(1e-4, 5e-4, 80))
        b = _result(rng.lognormal(0.0, 0.5, 80), clearance=rng.uniform(1e-4, 5e-4, 80))
        row = compare(a, b, quantiles=[0.5], resamples=400, seed=k).loc["crank_pin.max_force"]
        assert not row["paired"]
        hits += row["q50_low"] <= 0 <= row["q50_high"]
    assert 0.88 <= hits / 200 <= 0.995


def test_a_shift_of_the_distribution_is_found_and_measured():
    rng = np.random.default_rng(3)
    x = rng.lognormal(0.0, 0.2, 400)
    y = 1.1 * rng.lognormal(0.0, 0.2, 400)  # the reference 10 % larger: a / b - 1 = -9.1 %
    row = compare(_result(x), _result(y, clearance=rng.uniform(1e-4, 5e-4, 400))).loc["crank_pin.max_force"]
    assert not row["paired"] and row["verdict"] == "differs" and row["ks_pvalue"] < 1e-6
    for s in ("q50", "mean"):
        assert row[f"{s}_low"] < 1 / 1.1 - 1 < row[f"{s}_high"] < 0


def test_pairs_see_a_bias_that_the_spread_hides():
    # the same 40 inputs at a coarse and a fine "step": the coarse one 1 % low on every sample,
    # with 0.2 % scatter; the samples' spread (30 %) hides 1 % from an unpaired comparison
    rng = np.random.default_rng(11)
    fine = rng.lognormal(0.0, 0.3, 40)
    coarse = fine * 0.99 * (1 + 0.002 * rng.standard_normal(40))
    row = compare(_result(coarse), _result(fine)).loc["crank_pin.max_force"]
    assert row["paired"] and row["verdict"] == "differs"
    assert row["mean_low"] < -0.01 < row["mean_high"] < -0.009
    # against a tolerance: the pairs' 1 % bias matters at 0.5 % and is within 5 %
    for rtol, verdict in ((0.005, "differs"), (0.05, "equivalent")):
        assert (
            compare(_result(coarse), _result(fine), rtol=rtol).loc["crank_pin.max_force", "verdict"]
            == verdict
        )
    unpaired = _result(fine, clearance=1e-4 + 1e-8 * np.arange(40))  # other inputs: no pairs
    row = compare(_result(coarse), unpaired).loc["crank_pin.max_force"]
    assert not row["paired"] and row["mean_low"] < 0 < row["mean_high"]
    # unpaired, 40 samples of 30 % spread cannot tell 5 % either way
    assert row["verdict"] == "undecided"
    assert compare(_result(coarse), unpaired, rtol=0.05).loc["crank_pin.max_force", "verdict"] == "undecided"


def test_failed_samples_and_nan_outputs_are_left_out():
    x = np.arange(1.0, 11.0)
    a = _result(x)
    a.frame.loc[3, "status"] = "diverged"
    a.frame.loc[3, "crank_pin.max_force"] = np.nan
    a.frame.loc[5, "crank_pin.max_force"] = np.nan
    row = compare(a, _result(x)).loc["crank_pin.max_force"]
    assert row["paired"] and row["n_a"] == row["n_b"] == 8
    assert row["q50_diff"] == 0.0
    lines = markdown(compare(a, _result(x)))
    assert lines[0].startswith("| output | n a / b | paired | q50 a / b - 1 [95 % interval]")
    assert "| crank_pin.max_force | 8 / 8 | yes | +0.00 % [+0.00, +0.00]" in lines[2]
    assert lines[2].endswith("| 1 | the same |")
    a.frame.loc[7, "crank_pin.max_force"] *= 1.5
    assert markdown(compare(a, _result(x)))[2].endswith("| no difference detected |")
    assert markdown(compare(a, _result(x), rtol=0.2), rtol=0.2)[2].endswith("| undecided |")
    assert markdown(compare(a, _result(x), rtol=0.6), rtol=0.6)[2].endswith("| within 60 % |")


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"quantiles": [0.5, 1.0]}, "quantiles"),
        ({"quantiles": []}, "quantiles"),
        ({"confidence": 1.0}, "confidence"),
        ({"rtol": -0.01}, "rtol"),
        ({"resamples": 10}, "resamples"),
        ({"outputs": ["penetration"]}, "outputs"),
    ],
)
def test_bad_options_name_the_parameter(kwargs, name):
    x = np.arange(1.0, 5.0)
    with pytest.raises(InvalidParameterError, match=name):
        compare(_result(x), _result(x), **kwargs)


def test_a_result_is_required():
    with pytest.raises(InvalidParameterError, match="b = list"):
        compare(_result([1.0, 2.0]), [1.0, 2.0])


def test_one_study_file_at_two_steps_is_paired(tmp_path, capsys):
    # two samples of the slider-crank for 2 ms (its first impact) at 1e-5 and 5e-6 s: the same
    # inputs, so paired; the table's statistics are the runs' own
    study = _study()
    coarse = study.run(threads=1, progress=False, store=tmp_path / "coarse")
    fine = Study.from_dict({**study.to_dict(), "dt": 5e-6}).run(
        threads=1, progress=False, store=tmp_path / "fine"
    )
    t = coarse.compare(fine)
    row = t.loc["crank_pin.max_force"]
    assert row["paired"] and row["n_a"] == 2
    x, y = coarse.array("max_force"), fine.array("max_force")
    assert row["mean_diff"] == pytest.approx(np.mean(x) / np.mean(y) - 1, rel=1e-12)
    assert row["q50_a"] == np.median(x) and row["q50_b"] == np.median(y)
    assert (
        main(["compare", str(tmp_path / "coarse"), str(tmp_path / "fine"), "--out", str(tmp_path / "c.md")])
        == 0
    )
    out = capsys.readouterr().out
    assert "| crank_pin.max_force | 2 / 2 | yes |" in out
    assert (tmp_path / "c.md").read_text() == out


def test_convergence_runs_each_setting_on_the_same_samples_against_the_finest():
    study = Study.from_dict(
        {**_study().to_dict(), "samples": 4, "outputs": ["max_force", "max_penetration", "impacts"]}
    )
    seen = []
    c = convergence(study, dts=[5e-6, 1e-5, 2.5e-6], tols=[1e-3], rtol=0.02, threads=1, progress=seen.append)
    assert seen == ["dt=1e-05", "dt=5e-06", "dt=2.5e-06", "tol=0.001"]
    # coarsest first, the reference (the smallest step) last
    assert list(c.results) == ["dt=1e-05", "dt=5e-06", "tol=0.001", "dt=2.5e-06"]
    assert c.reference == "dt=2.5e-06" and list(c.table.index) == list(c.results)
    # the tol setting ran without its accuracy pilot (Study.run(pilot=False))
    assert c.results["tol=0.001"].study.tol == 1e-3 and c.results["tol=0.001"].accuracy is None
    ref = c.table.loc["dt=2.5e-06"]
    assert ref["speedup"] == 1.0 and ref["verdict"] == "" and np.isnan(ref["crank_pin.max_force"])
    for label, r in c.results.items():
        assert len(r.ok) == 4 and np.array_equal(r.array("clearance"), study.inputs()["clearance"].to_numpy())
        assert c.table.loc[label, "cpu"] == pytest.approx(r.frame["wall_time"].sum(), rel=1e-12)
    # the table's numbers are compare's (paired) against the reference
    t = c.comparisons["dt=1e-05"].loc["crank_pin.max_force"]
    assert t["paired"] and c.table.loc["dt=1e-05", "crank_pin.max_force"] == t["mean_diff"]
    # the peak force converges with the step: 5e-6 s nearer the reference than 1e-5 s
    d = c.table["crank_pin.max_force"]
    assert abs(d["dt=5e-06"]) < abs(d["dt=1e-05"])
    # judged by default: the peak force and penetration of the joint
    assert [k for k in c.table.columns if k.endswith("_verdict")] == [
        "crank_pin.max_force_verdict",
        "crank_pin.max_penetration_verdict",
    ]
    lines = c.markdown()
    assert lines[2].startswith(
        "| setting | CPU s | speedup | crank_pin.max_force | crank_pin.max_penetration |"
    )
    assert lines[-1].startswith("Recommended: " if c.recommended else "No setting is shown within 2 %")


def test_the_recommendation_is_the_cheapest_equivalent_setting():
    table = pd.DataFrame(
        {"cpu": [1.0, 2.0, 3.0, 8.0], "speedup": [8.0, 4.0, 2.67, 1.0]},
        index=["dt=1e-05", "tol=0.001", "dt=5e-06", "dt=1e-06"],
    )
    table["verdict"] = ["differs", "equivalent", "equivalent", ""]
    assert Convergence({}, "dt=1e-06", {}, table, 0.02, 0.95).recommended == "tol=0.001"
    table["verdict"] = ["differs", "undecided", "differs", ""]
    assert Convergence({}, "dt=1e-06", {}, table, 0.02, 0.95).recommended is None


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"dts": [1e-5]}, "dts"),
        ({"dts": [1e-5, 1e-5]}, "dts"),
        ({"dts": [1e-5, -1.0]}, "dts"),
        ({"dts": [1e-5], "tols": [2.0]}, "tols"),
        ({"dts": [1e-5, 5e-6], "samples": 1}, "samples"),
    ],
)
def test_convergence_names_a_bad_setting(kwargs, name):
    with pytest.raises(InvalidParameterError, match=name):
        convergence(_study(), **kwargs)


def test_the_converge_command_prints_the_table(tmp_path, capsys):
    f = tmp_path / "crank.toml"
    f.write_text(
        'build = "slider_crank"\nsamples = 8\noutputs = ["max_force", "max_penetration"]\n'
        '[fixed]\nclearance_at = "crank_pin"\n[run]\nt_end = 0.002\ndt = 1e-5\n'
        '[vary.clearance]\ndistribution = "uniform"\nlow = 1e-4\nhigh = 5e-4\n'
    )
    out_md = tmp_path / "converge.md"
    assert (
        main(
            [
                "converge",
                str(f),
                "--dt",
                "1e-5",
                "5e-6",
                "--samples",
                "3",
                "--threads",
                "1",
                "--out",
                str(out_md),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "against dt=5e-06 over the same 3 samples" in out
    assert "| dt=1e-05 |" in out and "| dt=5e-06 | " in out and out == out_md.read_text()


def test_event_aware_steps_take_out_the_dissipations_first_order_error():
    # the first impact (2 ms) of 4 samples: the dissipated energy's plain steps are off at first
    # order (measured -10.7 % at 1e-5 s, -6.3 % at 5e-6 s against 1.25e-6 s), event-aware steps
    # at the same dt much less (+4.0 %, +0.4 %)
    study = Study.from_dict(
        {**_study().to_dict(), "samples": 4, "outputs": ["max_force", "dissipated_energy"]}
    )
    c = convergence(study, dts=[1e-5, 5e-6, 1.25e-6], events=True, threads=1, outputs=["dissipated_energy"])
    assert list(c.results) == ["dt=1e-05", "dt=1e-05 events", "dt=5e-06", "dt=5e-06 events", "dt=1.25e-06"]
    assert c.results["dt=5e-06 events"].study.run_options == {"events": True, "iterate": True}
    d = c.table["crank_pin.dissipated_energy"]
    for dt in ("1e-05", "5e-06"):
        assert abs(d[f"dt={dt} events"]) < abs(d[f"dt={dt}"]) / 2
    # plain steps converge at first order: halving the step about halves the error
    assert abs(d["dt=5e-06"]) < 0.75 * abs(d["dt=1e-05"])


def _is_png(path) -> bool:
    return path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000


def test_the_comparison_is_plotted_with_its_intervals_and_both_distributions(tmp_path):
    rng = np.random.default_rng(3)
    x = rng.lognormal(0.0, 0.3, 60)
    a, b = _result(1.1 * x), _result(x)
    # one output with too few finite values: NaN statistics, plotted without an interval
    a.frame["crank_pin.max_penetration"] = [np.nan] * 59 + [1.0]
    b.frame["crank_pin.max_penetration"] = np.linspace(1, 2, 60)
    table = compare(a, b, outputs=["crank_pin.max_force"], rtol=0.02)
    paths = plot(table, a, b, tmp_path / "plots", rtol=0.02, names=("coarse", "fine"))
    assert [p.name for p in paths] == ["compare.png", "compare_ecdf.png"]
    assert all(_is_png(p) for p in paths)
    # the forest plot's height follows its rows (outputs x statistics): 3 rows here, 6 with NaNs
    a.study = b.study = Study.from_dict({**_study().to_dict(), "outputs": ["max_force", "max_penetration"]})
    both = compare(a, b, rtol=0.02)
    assert both.loc["crank_pin.max_penetration", "verdict"] == "undecided"
    taller = plot(both, a, b, tmp_path / "both")[0]
    from matplotlib.image import imread

    assert imread(taller).shape[0] > imread(paths[0]).shape[0]


def test_the_converge_command_plots_the_trade_of_accuracy_for_time(tmp_path, capsys):
    f = tmp_path / "crank.toml"
    f.write_text(
        'build = "slider_crank"\nsamples = 4\noutputs = ["max_force"]\n'
        '[fixed]\nclearance_at = "crank_pin"\n[run]\nt_end = 0.002\ndt = 1e-5\n'
        '[vary.clearance]\ndistribution = "uniform"\nlow = 1e-4\nhigh = 5e-4\n'
    )
    args = ["converge", str(f), "--dt", "1e-5", "5e-6", "--samples", "3", "--threads", "1"]
    assert main([*args, "--plots", str(tmp_path / "plots")]) == 0
    out = capsys.readouterr().out
    png = tmp_path / "plots" / "convergence.png"
    assert _is_png(png) and f"![convergence]({png.resolve()})" in out
