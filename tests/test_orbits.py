"""Journal orbits of chosen study samples (the montecarlo report's orbit figure)."""

from __future__ import annotations

import flexclear
import numpy as np
import pytest
from flexclear.reports.orbits import orbit_samples, orbit_section, plot_orbits
from flexclear.study import Study


@pytest.fixture(scope="module")
def crank_study():
    study = Study(
        "slider_crank",
        vary={"clearance": [1e-4, 2.5e-4, 5e-4], "crank_speed": [150.0, 120.0, 180.0]},
        design="given",
        fixed={"clearance_at": "crank_pin"},
        t_end=0.01,
        dt=1e-5,
        outputs=["max_force", "max_penetration"],
    )
    return study.run(threads=1, progress=False)


def test_orbit_samples_span_the_output(crank_study):
    col = "crank_pin.max_force"
    picks = orbit_samples(crank_study, 3)
    values = crank_study.frame.loc[picks, col]
    assert values.iloc[0] == crank_study.frame[col].min()
    assert values.iloc[-1] == crank_study.frame[col].max()
    assert len(set(picks)) == 3
    assert orbit_samples(crank_study, 1) == [picks[0]]
    assert orbit_samples(crank_study, 10) == picks  # no more than the samples that finished


def test_orbit_rerun_is_the_sample_itself(crank_study, tmp_path):
    path, rows = plot_orbits(crank_study, tmp_path, count=3)
    assert path is not None and path.exists() and path.stat().st_size > 10_000
    frame = crank_study.frame
    for r in rows:
        s = r["sample"]
        # the same model, step and settings: the re-run's extremes are the study's, bitwise
        assert r["max_force"] == frame.loc[s, "crank_pin.max_force"]
        assert r["max_penetration"] == frame.loc[s, "crank_pin.max_penetration"]
        # the clearance read back from |q| - penetration is the sample's input
        assert r["clearance"] == pytest.approx(frame.loc[s, "clearance"], rel=1e-9)
        # the orbit reaches the wall by the largest penetration, and no further
        assert r["orbit_radius"] == pytest.approx(r["clearance"] + max(r["max_penetration"], 0.0), rel=1e-9)
    lines = orbit_section(path, rows, "crank_pin")
    assert lines[0] == "## Journal orbits (crank_pin)" and any("orbits.png" in x for x in lines)


def test_orbit_arguments_are_checked(crank_study, tmp_path):
    with pytest.raises(flexclear.InvalidParameterError, match="count"):
        orbit_samples(crank_study, 0)
    with pytest.raises(flexclear.InvalidParameterError, match="output"):
        orbit_samples(crank_study, 2, output="nope")
    with pytest.raises(flexclear.InvalidParameterError, match="joint"):
        plot_orbits(crank_study, tmp_path, joint="nope")
    assert np.isfinite(crank_study.frame["crank_pin.max_force"]).all()


def _reduced_study_report(tmp_path, study_file: str, samples: str, t_end: str) -> tuple[str, object]:
    """``flexclear montecarlo --orbits 2`` on a reference study file of benches/studies with its
    sample count and run length replaced (``samples``, ``t_end``: ``(old, new)`` line parts);
    returns the report's text and the output folder."""
    from pathlib import Path

    from flexclear.cli import main

    ref = (Path(__file__).parent.parent / "benches" / "studies" / study_file).read_text()
    small = ref.replace(*samples).replace(*t_end)
    assert small != ref
    (tmp_path / "s.toml").write_text(small)
    out = tmp_path / "out"
    assert (
        main(["montecarlo", str(tmp_path / "s.toml"), "--out", str(out), "--no-progress", "--orbits", "2"])
        == 0
    )
    return (out / "report.md").read_text(), out


def test_montecarlo_cli_draws_orbits(tmp_path):
    report, out = _reduced_study_report(
        tmp_path,
        "slider_crank_clearance.toml",
        ("samples = 256", "samples = 4"),
        ("t_end = 0.1 ", "t_end = 0.005 "),
    )
    assert "## Journal orbits (crank_pin)" in report and (out / "orbits.png").exists()


def test_the_four_bar_study_file_runs_from_the_cli(tmp_path):
    # benches/studies/four_bar_clearance.toml, reduced to 4 samples of 10 ms: a four-bar with a
    # clearance joint runs as a study from a study file (issue 14, "Done when")
    report, out = _reduced_study_report(
        tmp_path,
        "four_bar_clearance.toml",
        ("samples = 128", "samples = 4"),
        ("t_end = 0.126 ", "t_end = 0.01 "),
    )
    assert "## Journal orbits (rocker_pin)" in report and (out / "orbits.png").exists()
    assert "- 4 samples: 4 ok" in report and "| rocker_pin.max_force | 4 |" in report
    # the file's step resolves the rocker pin's contacts (about 4 us, 28 steps)
    assert "## Resolution: steps per contact period" in report and "Unresolved:" not in report


def test_the_six_bar_study_of_ones_own_linkage_runs_from_the_cli(tmp_path, monkeypatch):
    # benches/studies/watt_six_bar_clearance.toml with its builder module beside it (copied
    # together), reduced to 3 samples of 5 ms: a linkage of one's own, solved and built by
    # flexclear.Linkage for each sample, runs as a study from a study file
    import shutil
    import sys
    from pathlib import Path

    from flexclear.cli import main

    monkeypatch.setattr(sys, "path", list(sys.path))
    studies = Path(__file__).parent.parent / "benches" / "studies"
    folder = tmp_path / "mine"
    folder.mkdir()
    shutil.copy(studies / "watt_six_bar.py", folder)
    ref = (studies / "watt_six_bar_clearance.toml").read_text()
    small = ref.replace("samples = 64", "samples = 3").replace("t_end = 0.1 ", "t_end = 0.005 ")
    small = small.replace("span = 0.1 ", "span = 0.005 ")
    assert small.count("0.005") == 2
    (folder / "s.toml").write_text(small)
    out = tmp_path / "out"
    assert main(["montecarlo", str(folder / "s.toml"), "--out", str(out), "--no-progress"]) == 0
    report = (out / "report.md").read_text()
    assert "- 3 samples: 3 ok" in report and "| C.max_force | 3 |" in report
    assert "| rod.max_midspan | 3 |" in report
    sys.modules.pop("watt_six_bar", None)


def test_the_cli_warns_of_a_step_that_does_not_resolve_the_contacts(tmp_path, capsys):
    # the four-bar study file at its former dt of 1e-5 s: 1.4 steps a contact
    report, _ = _reduced_study_report(
        tmp_path,
        "four_bar_clearance.toml",
        ("samples = 128", "samples = 2"),
        ("dt = 1.5625e-7", "dt = 1e-5"),
    )
    assert "Unresolved:" in report
    err = capsys.readouterr().err
    assert "warning: Unresolved: 2 of 2 samples take fewer than 10 steps per natural contact period" in err
    assert "at rocker_pin (median" in err
