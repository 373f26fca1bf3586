"""The Flores slider-crank (issue 15 item 6) against the benchmark's published figures and
invariants (tests/data/flores_slider_crank.csv, from ../shared/CONTACT.md section 4; the data are
the commonly cited values, not checked against the papers' own tables).

- Ideal joints: the mechanism of rigid bodies follows the rigid slider-crank's kinematics; the
  slider acceleration spans -19 419 to +9 696 m/s^2 (to the unit); the largest piston-pin force
  is the slider's ``m_s max|a_s|`` = 2 719 N.
- 0.5 mm clearance: the journal stays within the clearance circle plus the largest penetration;
  the peak contact force exceeds the ideal pin's 2 719 N; the response converges under step
  refinement.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import flexclear as M
import numpy as np
import pytest
from flexclear.reports.flores import rod_forces

_LINES = (Path(__file__).parent / "data" / "flores_slider_crank.csv").read_text().splitlines()
DATA = {
    row[0]: float(row[1])
    for row in csv.reader(line for line in _LINES if not line.startswith("#"))
    if row[0] != "quantity"
}
PERIOD = 60.0 / DATA["crank_speed_rpm"]


def test_the_scene_has_the_benchmark_data():
    model = M.scenes.flores_slider_crank()
    p = model.parameters
    for key in ("crank_length", "rod_length", "rod_mass", "rod_inertia", "slider_mass", "restitution"):
        assert p[key] == DATA[key], key
    assert p["crank_speed"] == pytest.approx(DATA["crank_speed_rpm"] * 2 * math.pi / 60)
    assert p["pin_stiffness"] == pytest.approx(6.61e10, rel=1e-3)
    k, _ = M.contact.pin_in_hole(DATA["bearing_radius"], DATA["journal_radius"], DATA["youngs_modulus"], 0.3)
    assert p["pin_stiffness"] == pytest.approx(k, rel=1e-12)
    assert model.link_names == ["rod"]
    assert model.joint_names == ["piston_pin"]


def test_with_ideal_joints_the_slider_follows_the_rigid_kinematics():
    model = M.scenes.flores_slider_crank(None)
    res = model.simulate(PERIOD, PERIOD / 20000)
    a = res.slider("slider").acceleration
    assert a.min() == pytest.approx(DATA["slider_acc_min"], abs=1.0)
    assert a.max() == pytest.approx(DATA["slider_acc_max"], abs=1.0)
    pin = np.linalg.norm(rod_forces(res, model.parameters)["piston"], axis=1)
    assert pin.max() == pytest.approx(DATA["max_pin_force_ideal"], abs=1.0)


def _clearance_run(dt: float, revolutions: float = 1.0):
    model = M.scenes.flores_slider_crank(5e-4)
    return model.simulate(revolutions * PERIOD, dt, iterate=True, record=M.Record(position=True))


def test_with_the_clearance_the_journal_stays_in_the_circle_and_the_force_exceeds_the_ideal_one():
    res = _clearance_run(2e-6)
    j = res.joint("piston_pin")
    r = np.hypot(j.qx, j.qy)
    assert j.impacts >= 1
    assert r.max() <= 5e-4 + j.max_penetration + 1e-12
    assert r.max() > 5e-4
    assert j.max_force > DATA["max_pin_force_ideal"]
    assert res.stats["iterate"]


def test_the_clearance_run_converges_under_step_refinement():
    # the first half revolution (the first flight across the clearance and the first impacts):
    # the journal orbit and the peak force at dt, dt/2, dt/4
    runs = [_clearance_run(dt, 0.5) for dt in (4e-6, 2e-6, 1e-6)]
    # the orbit at the coarse run's times
    orbit = [
        np.stack([r.joint("piston_pin").qx, r.joint("piston_pin").qy])[:, :: 2**k] for k, r in enumerate(runs)
    ]
    d1 = np.max(np.abs(orbit[0] - orbit[1]))
    d2 = np.max(np.abs(orbit[1] - orbit[2]))
    assert d2 < 0.6 * d1, (d1, d2)
    f = [r.joint("piston_pin").max_force for r in runs]
    assert abs(f[2] - f[1]) < abs(f[1] - f[0]) or abs(f[2] - f[1]) < 0.01 * f[2], f


def test_the_ideal_crank_moment_is_the_power_balance_of_rod_and_slider():
    # at constant crank speed w the drive's power M w is the rate of the kinetic energy of rod
    # and slider (no losses, no gravity): an independent check of the moment of rod_forces
    model = M.scenes.flores_slider_crank(None)
    p = model.parameters
    res = model.simulate(PERIOD, PERIOD / 20000)
    moment = rod_forces(res, p)["moment"]
    t, w = res.time, p["crank_speed"]
    frame = res.link("rod").frame
    psi, psid = frame[:, 2], frame[:, 3]
    c = p["rod_length"] / 2
    v_a = w * p["crank_length"] * np.stack([-np.sin(w * t), np.cos(w * t)], axis=1)
    v_g = v_a + (psid * c)[:, None] * np.stack([-np.sin(psi), np.cos(psi)], axis=1)
    v_s = res.slider("slider").velocity
    energy = (
        0.5 * p["rod_mass"] * (v_g**2).sum(axis=1)
        + 0.5 * p["rod_inertia"] * psid**2
        + 0.5 * p["slider_mass"] * v_s**2
    )
    power_moment = np.gradient(energy, t) / w
    assert np.max(np.abs(power_moment - moment)) < 1e-3 * np.max(np.abs(moment))


def test_the_report_writes_its_figures_and_summary(tmp_path):
    from flexclear.reports.flores import flores_report

    path = flores_report(tmp_path, clearances=(5e-4,), revolutions=(1, 1), dt=4e-6)
    for name in (
        "orbits.png",
        "contact_force.png",
        "slider_acceleration.png",
        "crank_moment.png",
        "flores.csv",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    rows = list(csv.DictReader((tmp_path / "flores.csv").read_text().splitlines()))
    assert [r["law"] for r in rows] == ["LankaraniNikravesh", "KelvinVoigt"]
    assert float(rows[0]["peak_force_N"]) > DATA["max_pin_force_ideal"]
    assert "Ideal joints: slider acceleration -19419 to 9696 m/s^2" in path.read_text()


def test_flores_with_friction_in_the_piston_pin():
    # friction=Coulomb(...) on the 9.5 mm journal: the run takes the Newton stepper and the
    # friction dissipates energy (a positive friction work), the peak force stays of the
    # frictionless run's order
    from flexclear import contact

    m = M.scenes.flores_slider_crank(friction=contact.Coulomb(0.1))
    r = m.simulate(0.003, 1e-6, iterate=True, record=M.Record(contact_modes=True))
    j = r.joint("piston_pin")
    assert r.stats["stepper"] == "newton" and j.friction_energy > 0
    ref = M.scenes.flores_slider_crank().simulate(0.003, 1e-6, iterate=True).joint("piston_pin")
    assert 0.5 * ref.max_force < j.max_force < 2 * ref.max_force
    with pytest.raises(M.InvalidParameterError, match="friction"):
        M.scenes.flores_slider_crank(friction=0.1)
