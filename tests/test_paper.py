"""The paper's slider-yoke results against the published Table 1 (tests/data)."""

import csv
import math
from pathlib import Path

import flexclear
import numpy as np
import pytest
from flexclear import Record

DATA = Path(__file__).parent / "data" / "hong_kim_1993_table1.csv"


def published_rows():
    with DATA.open() as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


@pytest.mark.parametrize("method", ["modified", "force"])
@pytest.mark.parametrize("row", published_rows(), ids=lambda r: f"ratio={r['ratio']}")
def test_table1_within_1_db_of_the_analytic_column(row, method):
    # docs/scenes.md: C_dmax over the last 10 of 30 cycles at dt = 1e-5 s. The reconstruction was fitted
    # to this column within 0.7 dB with one parameter set; 1 dB is the stated tolerance.
    y = 0.010
    model = flexclear.scenes.slider_yoke(clearance=float(row["ratio"]) * y)
    f = model.parameters["frequency"]
    res = model.simulate(30 / f, 1e-5, method, record=Record(histories=False, start=20 / f))
    db = 20 * math.log10(res.joint("bearing").max_penetration / y)
    assert db == pytest.approx(float(row["analytic_db"]), abs=1.0)


def test_paper_table1_constant_matches_the_data_file():
    from flexclear.reports.paper import PAPER_TABLE1

    for row, const in zip(published_rows(), PAPER_TABLE1):
        assert [float(v) for v in row.values()] == list(const)


def test_slider_first_frequency_is_880_hz():
    # E is calibrated with (beta1 L)^2 = 22.3733; 12 elements give the first mode within 0.01 %
    f = flexclear.scenes.slider_yoke().natural_frequencies(2)
    assert f[0] == pytest.approx(880.0, rel=1e-4)
    assert f[1] / f[0] == pytest.approx((7.853205 / 4.730041) ** 2, rel=1e-3)


def test_methods_agree_at_small_step_and_impact_forces_appear():
    model = flexclear.scenes.slider_yoke(clearance=1e-4)
    a = model.simulate(1 / 6, 1e-6, "modified", record=Record(every=10))
    b = model.simulate(1 / 6, 1e-6, "force", record=Record(every=10))
    pa, pb = a.joint("bearing").penetration, b.joint("bearing").penetration
    assert np.max(np.abs(pa - pb)) < 0.01 * np.max(np.abs(pa))
    # impacts: the force exceeds the quasi-static bearing load (m/4) Y (2 pi f)^2 ~ 1.2 N
    assert a.joint("bearing").impacts >= 2
    assert a.joint("bearing").max_force > 3 * 1.21


def test_stiff_variant_force_method_diverges_and_keeps_partial_result():
    model = flexclear.scenes.slider_yoke_stiff()
    with pytest.raises(flexclear.SimulationDivergedError) as info:
        model.simulate(0.03, 1e-5, "force", divergence_limit=1.0)
    e = info.value
    # The first sign is the bearing's penetration (checked every step) or a slider DOF (checked at
    # a stride), whichever exceeds the limit first.
    assert 0 < e.time < 0.03 and e.step > 0 and ("bearing" in e.dof or "slider" in e.dof)
    assert not e.result.complete
    assert e.result.time.size == e.step  # samples recorded up to the failing stride
    assert np.all(np.isfinite(e.result.joint("bearing").penetration[:-20]))
    # the modified method stays bounded at the same step
    res = model.simulate(0.03, 1e-5, "modified")
    assert res.complete and res.joint("bearing").max_penetration < 1e-5
    # and a diverged run can be returned instead of raised
    part = model.simulate(0.03, 1e-5, "force", divergence_limit=1.0, raise_on_failure=False)
    assert not part.complete and isinstance(part.error, flexclear.SimulationDivergedError)
