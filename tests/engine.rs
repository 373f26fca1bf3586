//! Engine tests against physics: closed-form element matrices, analytic beam frequencies and
//! deflections, Newmark's energy conservation and order, and the clearance couplings.

use std::sync::Arc;

use flexclear::contact::{Coupling, SpringDamper};
use flexclear::element::BeamElement;
use flexclear::integrator::Newmark;
use flexclear::kinematics::{RotatingFrame, Rotation};
use flexclear::linalg::Cholesky;
use flexclear::model::mechanism::{Clearance, Endpoint, Link, Mechanism};
use flexclear::model::section::BeamSection;
use flexclear::model::Motion;
use flexclear::plan::assembly::System;
use flexclear::plan::translating::Model;
use flexclear::run::simulate;
use flexclear::scenes::SliderYoke;
use flexclear::{Error, Settings, SolverMode};
use nalgebra::DMatrix;

fn element() -> BeamElement {
    BeamElement {
        length: 0.3,
        youngs_modulus: 2e11,
        density: 7800.0,
        area: 1e-4,
        inertia: 8e-10,
        damping: 0.0,
        rotary_inertia: false,
    }
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-300)
}

#[test]
fn element_mass_matches_closed_form() {
    let e = element();
    let (l, ra) = (e.length, e.density * e.area);
    let m = e.mass();
    // axial: rho A l / 6 [2 1; 1 2]; bending: rho A l / 420 [156 22l 54 -13l; ...]
    assert!(close(m[(0, 0)], ra * l / 3.0, 1e-13) && close(m[(0, 3)], ra * l / 6.0, 1e-13));
    let b = ra * l / 420.0;
    let exp = [
        [156.0, 22.0 * l, 54.0, -13.0 * l],
        [22.0 * l, 4.0 * l * l, 13.0 * l, -3.0 * l * l],
        [54.0, 13.0 * l, 156.0, -22.0 * l],
        [-13.0 * l, -3.0 * l * l, -22.0 * l, 4.0 * l * l],
    ];
    let idx = [1, 2, 4, 5];
    for i in 0..4 {
        for j in 0..4 {
            assert!(close(m[(idx[i], idx[j])], b * exp[i][j], 1e-12), "M[{i}][{j}]");
        }
    }
    assert_eq!(m[(0, 1)], 0.0);
}

#[test]
fn element_stiffness_and_geometric_match_closed_form() {
    let e = element();
    let (l, ei, ea) = (e.length, e.youngs_modulus * e.inertia, e.youngs_modulus * e.area);
    let k = e.stiffness();
    assert!(close(k[(0, 0)], ea / l, 1e-13) && close(k[(0, 3)], -ea / l, 1e-13));
    let b = ei / l.powi(3);
    let exp = [
        [12.0, 6.0 * l, -12.0, 6.0 * l],
        [6.0 * l, 4.0 * l * l, -6.0 * l, 2.0 * l * l],
        [-12.0, -6.0 * l, 12.0, -6.0 * l],
        [6.0 * l, 2.0 * l * l, -6.0 * l, 4.0 * l * l],
    ];
    let idx = [1, 2, 4, 5];
    let f = 1234.0;
    let kg = e.geometric_stiffness(f);
    let g = f / (30.0 * l);
    let gexp = [
        [36.0, 3.0 * l, -36.0, 3.0 * l],
        [3.0 * l, 4.0 * l * l, -3.0 * l, -l * l],
        [-36.0, -3.0 * l, 36.0, -3.0 * l],
        [3.0 * l, -l * l, -3.0 * l, 4.0 * l * l],
    ];
    for i in 0..4 {
        for j in 0..4 {
            assert!(close(k[(idx[i], idx[j])], b * exp[i][j], 1e-12), "K[{i}][{j}]");
            assert!(close(kg[(idx[i], idx[j])], g * gexp[i][j], 1e-12), "K2[{i}][{j}]");
        }
    }
    let k3 = e.axial_force_stiffness(f);
    assert!(close(k3[(0, 0)], f / l, 1e-13) && close(k3[(3, 0)], -f / l, 1e-13));
    // skew mass is skew-symmetric; Coriolis vanishes without rotation
    let s = e.skew_mass();
    assert!((s + s.transpose()).norm() < 1e-15 * s.norm());
    assert_eq!(e.coriolis(0.0).norm(), 0.0);
    // the inertia load of a uniform acceleration sums to the element mass
    let [bx, by, _, _] = e.inertia_load_vectors(0.0);
    assert!(close(bx[0] + bx[3], e.density * e.area * l, 1e-13));
    assert!(close(by[1] + by[4], e.density * e.area * l, 1e-13));
}

/// A frame at rest at the origin, angle 0.
fn at_rest() -> Arc<RotatingFrame> {
    Arc::new(RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::Fixed { angle: 0.0 },
    })
}

fn beam(elements: usize) -> Link {
    Link::new(
        "beam",
        BeamSection {
            length: 1.0,
            elements,
            youngs_modulus: 2e11,
            density: 7800.0,
            damping: 0.0,
            area: 1e-4,
            inertia: 1e-9,
        },
        at_rest(),
    )
}

/// The constant stepper's compiled input of a mechanism of free `links` (what the plan derives).
fn translating(links: Vec<Link>) -> Model {
    Mechanism {
        links,
        ..Default::default()
    }
    .to_translating()
    .unwrap()
}

#[test]
fn free_free_beam_frequencies_within_0p1_percent_at_10_elements() {
    let link = beam(10);
    let model = translating(vec![link.clone()]);
    let f = flexclear::modes::natural_frequencies(&model, 3).unwrap();
    let c = (link.section.youngs_modulus * link.section.inertia / (link.section.density * link.section.area)).sqrt()
        / link.section.length.powi(2);
    for (fi, bl) in f.iter().zip([4.730041, 7.853205, 10.995608]) {
        let exact = bl * bl * c / (2.0 * std::f64::consts::PI);
        assert!(close(*fi, exact, 1e-3), "{fi} vs {exact}");
    }
    // h-convergence: 20 elements are closer than 10
    let f20 = flexclear::modes::natural_frequencies(&translating(vec![beam(20)]), 3).unwrap();
    let exact3 = 10.995608f64.powi(2) * c / (2.0 * std::f64::consts::PI);
    assert!((f20[2] - exact3).abs() < (f[2] - exact3).abs());
}

#[test]
fn cantilever_tip_deflection_is_pl3_over_3ei() {
    let link = beam(8);
    let model = translating(vec![link.clone()]);
    let sys = System::assemble(&model);
    let n = sys.n();
    let mut k = DMatrix::zeros(n, n);
    for c in 0..n {
        for p in sys.pattern.col_ptr[c]..sys.pattern.col_ptr[c + 1] {
            k[(sys.pattern.row_idx[p], c)] = sys.stiffness[p];
        }
    }
    let kr = k.view((3, 3), (n - 3, n - 3)).into_owned();
    let mut f = nalgebra::DVector::zeros(n - 3);
    let p = 100.0;
    f[n - 3 - 2] = p; // transverse force at the tip
    let u = kr.lu().solve(&f).unwrap();
    let exact = p * link.section.length.powi(3) / (3.0 * link.section.youngs_modulus * link.section.inertia);
    assert!(close(u[n - 3 - 2], exact, 1e-10), "{} vs {exact}", u[n - 5]);
}

#[test]
fn band_factorization_equals_faers_within_round_off() {
    // the band's own LDL^T (Cholesky::factorize on a chain of beam elements) against faer's
    // simplicial one on the same matrix: the same factor within round-off, so the same solves
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let sys = System::assemble(&model);
    // (beta h^2 = 1e-10, 2.5e-9, 1e-7 s^2: steps of 2e-5 to 6e-4 s)
    for ks in [1e-10, 2.5e-9, 1e-7] {
        let a: Vec<f64> = (0..sys.pattern.nnz())
            .map(|p| sys.mass[p] + ks * sys.stiffness[p])
            .collect();
        let mut band = Cholesky::analyze(&sys.pattern).unwrap();
        let mut faer = Cholesky::analyze(&sys.pattern).unwrap();
        band.factorize(&a, "test").unwrap();
        faer.factorize_faer(&a, "test").unwrap();
        let b: Vec<f64> = (0..sys.n()).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut x1, mut x2, mut x3) = (b.clone(), b.clone(), b.clone());
        band.solve_in_place(&mut x1);
        faer.solve_in_place(&mut x2);
        band.solve_in_place_faer(&mut x3); // the band's factor in faer's layout
        let scale = x2.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..sys.n() {
            assert!(
                (x1[i] - x2[i]).abs() <= 1e-11 * scale,
                "band vs faer at {i}: {} {}",
                x1[i],
                x2[i]
            );
            assert!((x3[i] - x2[i]).abs() <= 1e-11 * scale, "layouts at {i}");
        }
    }
    // an indefinite matrix: the first pivot that is not positive is named
    let mut a: Vec<f64> = (0..sys.pattern.nnz()).map(|p| sys.mass[p]).collect();
    let diag7 = (sys.pattern.col_ptr[7]..sys.pattern.col_ptr[8])
        .find(|&p| sys.pattern.row_idx[p] == 7)
        .unwrap();
    a[diag7] = -1.0;
    let mut band = Cholesky::analyze(&sys.pattern).unwrap();
    match band.factorize(&a, "test") {
        Err(flexclear::error::Error::Singular { index, .. }) => assert!(index <= 7),
        other => panic!("expected Singular, got {other:?}"),
    }
}

#[test]
fn factorization_solves_to_small_residual() {
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let sys = System::assemble(&model);
    let a: Vec<f64> = (0..sys.pattern.nnz())
        .map(|p| sys.mass[p] + 1e-10 * sys.stiffness[p])
        .collect();
    let mut ch = Cholesky::analyze(&sys.pattern).unwrap();
    ch.factorize(&a, "test").unwrap();
    let b: Vec<f64> = (0..sys.n()).map(|i| (i as f64 * 0.37).sin()).collect();
    assert!(ch.is_banded(), "a chain of beam elements is banded");
    let (mut x1, mut x2) = (b.clone(), b.clone());
    ch.solve_in_place(&mut x1);
    ch.solve_in_place_faer(&mut x2);
    for i in 0..sys.n() {
        assert!(
            (x1[i] - x2[i]).abs() <= 1e-12 * x2[i].abs().max(1.0),
            "banded vs faer at {i}"
        );
    }
    let mut r = vec![0.0; sys.n()];
    sys.pattern.mul(&a, &x1, &mut r);
    for i in 0..sys.n() {
        assert!((r[i] - b[i]).abs() <= 1e-10, "residual {}", r[i] - b[i]);
    }
}

#[test]
fn banded_product_equals_sparse_product() {
    for elements in [1, 2, 12, 40] {
        let model = SliderYoke {
            elements,
            geometry: Default::default(),
            ..Default::default()
        }
        .build()
        .unwrap()
        .to_translating()
        .unwrap();
        let sys = System::assemble(&model);
        let band = flexclear::plan::assembly::Band::from_csc(&sys.pattern, &sys.stiffness).expect("a chain is banded");
        assert_eq!(band.half_bandwidth(), 5.min(sys.n() - 1));
        let x: Vec<f64> = (0..sys.n()).map(|i| (i as f64 * 0.71).cos()).collect();
        let w = band.half_bandwidth();
        let mut xpad = vec![0.0; band.padded_len()];
        xpad[w..w + sys.n()].copy_from_slice(&x);
        let (mut y1, mut y2) = (vec![0.0; sys.n()], vec![0.0; sys.n()]);
        band.mul(&xpad, &mut y1);
        sys.pattern.mul(&sys.stiffness, &x, &mut y2);
        let scale = y2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in y1.iter().zip(&y2) {
            assert!((a - b).abs() <= 1e-13 * scale, "{elements} elements: {a} vs {b}");
        }
    }
}

#[test]
fn indefinite_matrix_is_reported_not_solved() {
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let sys = System::assemble(&model);
    let a: Vec<f64> = sys.stiffness.iter().map(|k| -k).collect();
    let mut ch = Cholesky::analyze(&sys.pattern).unwrap();
    assert!(matches!(ch.factorize(&a, "negative K"), Err(Error::Singular { .. })));
}

/// Undamped free vibration of a free-free beam started with a smooth velocity field.
fn free_vibration(dt: f64, t_end: f64) -> (flexclear::RunOutput, Model) {
    free_vibration_with(dt, t_end, Newmark::default())
}

/// As [`free_vibration`], under the scheme `nm`.
fn free_vibration_with(dt: f64, t_end: f64, nm: Newmark) -> (flexclear::RunOutput, Model) {
    let mut link = beam(10);
    let n = link.section.elements + 1;
    let mut v0 = vec![0.0; 3 * n];
    for i in 0..n {
        let x = i as f64 / (n - 1) as f64;
        // a smooth velocity field (slope-consistent rotation rates) so that the mesh's
        // unresolved high modes are barely excited
        v0[3 * i + 1] = (std::f64::consts::PI * x).cos(); // m/s
        v0[3 * i + 2] = -std::f64::consts::PI * (std::f64::consts::PI * x).sin();
        // rad/s
    }
    link.initial_velocity = Some(v0);
    let model = translating(vec![link]);
    let mut s = Settings::new(t_end, dt);
    s.newmark = nm;
    s.record.nodes = vec![(0, 10)];
    (simulate(&model, &s, &mut |_| true).unwrap(), model)
}

fn energy(sys: &System, u: &[f64], v: &[f64]) -> f64 {
    let n = sys.n();
    let (mut ku, mut mv) = (vec![0.0; n], vec![0.0; n]);
    sys.pattern.mul(&sys.stiffness, u, &mut ku);
    sys.pattern.mul(&sys.mass, v, &mut mv);
    0.5 * (0..n).map(|i| u[i] * ku[i] + v[i] * mv[i]).sum::<f64>()
}

#[test]
fn average_acceleration_newmark_conserves_energy_without_damping() {
    let (out, model) = free_vibration(2e-5, 0.05);
    let sys = System::assemble(&model);
    let e0 = energy(
        &sys,
        &vec![0.0; sys.n()],
        model.links[0].initial_velocity.as_ref().unwrap(),
    );
    let e1 = energy(&sys, &out.state[0], &out.state[1]);
    // linear, undamped, average acceleration: energy is an exact invariant up to round-off
    assert!(close(e1, e0, 1e-9), "E0 = {e0}, E1 = {e1}");
}

#[test]
fn newmark_converges_at_second_order() {
    // omega_max dt <= 0.09 for the highest mode of the mesh (28 kHz): the asymptotic range
    let t_end = 0.002;
    let (reference, _) = free_vibration(1.25e-7 / 16.0, t_end);
    let tip = |o: &flexclear::RunOutput| *o.record.nodes[0].v.last().unwrap();
    let r = tip(&reference);
    let errs: Vec<f64> = [5e-7, 2.5e-7, 1.25e-7]
        .iter()
        .map(|&dt| (tip(&free_vibration(dt, t_end).0) - r).abs())
        .collect();
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (3.5..4.6).contains(&ratio),
            "error ratio {ratio} for halved dt, errors {errs:?}"
        );
    }
}

#[test]
fn generalized_alpha_and_hht_converge_at_second_order() {
    // as `newmark_converges_at_second_order`, the reference the scheme's own run at dt/16
    let t_end = 0.002;
    let tip = |o: &flexclear::RunOutput| *o.record.nodes[0].v.last().unwrap();
    let schemes = [
        Newmark::generalized_alpha(0.8).unwrap(),
        Newmark::generalized_alpha(0.0).unwrap(),
        Newmark::hht(-0.3).unwrap(),
    ];
    for nm in schemes {
        let r = tip(&free_vibration_with(1.25e-7 / 16.0, t_end, nm).0);
        let errs: Vec<f64> = [5e-7, 2.5e-7, 1.25e-7]
            .iter()
            .map(|&dt| (tip(&free_vibration_with(dt, t_end, nm).0) - r).abs())
            .collect();
        for w in errs.windows(2) {
            let ratio = w[0] / w[1];
            assert!(
                (3.5..4.6).contains(&ratio),
                "{nm:?}: error ratio {ratio} for halved dt, errors {errs:?}"
            );
        }
    }
}

#[test]
fn generalized_alpha_parameters_follow_chung_hulbert() {
    // rho_inf = 1 and HHT alpha = 0 are average acceleration (the default, bitwise)
    assert_eq!(Newmark::generalized_alpha(1.0).unwrap(), Newmark::default());
    assert_eq!(Newmark::hht(0.0).unwrap(), Newmark::default());
    // rho_inf = 0.5: alpha_m = 0, alpha_f = 1/3, gamma = 5/6, beta = (4/3)^2/4 = 4/9
    let g = Newmark::generalized_alpha(0.5).unwrap();
    assert!((g.alpha_m - 0.0).abs() < 1e-15 && (g.alpha_f - 1.0 / 3.0).abs() < 1e-15);
    assert!((g.gamma - 5.0 / 6.0).abs() < 1e-15 && (g.beta - 4.0 / 9.0).abs() < 1e-15);
    g.validate().unwrap();
    let h = Newmark::hht(-0.3).unwrap();
    assert_eq!((h.alpha_m, h.alpha_f), (0.0, 0.3));
    assert!((h.gamma - 0.8).abs() < 1e-15 && (h.beta - 0.4225).abs() < 1e-15);
    h.validate().unwrap();
    for (e, name) in [
        (Newmark::generalized_alpha(1.5).unwrap_err(), "rho_inf"),
        (Newmark::generalized_alpha(f64::NAN).unwrap_err(), "rho_inf"),
        (Newmark::hht(-0.5).unwrap_err(), "hht_alpha"),
        (Newmark::hht(0.1).unwrap_err(), "hht_alpha"),
        (Newmark { gamma: 0.6, ..g }.validate().unwrap_err(), "gamma"),
        (Newmark { alpha_f: 0.7, ..g }.validate().unwrap_err(), "alpha_f"),
    ] {
        assert!(
            matches!(&e, Error::InvalidParameter { name: n, .. } if n == name),
            "{e}"
        );
    }
}

#[test]
fn zero_clearance_stiff_joint_makes_the_slider_follow_the_yoke() {
    let model = SliderYoke {
        clearance: 0.0,
        bearing_stiffness: Some(1e9),
        ..Default::default()
    }
    .build()
    .unwrap()
    .to_translating()
    .unwrap();
    let mut s = Settings::new(0.2, 1e-5);
    s.record.joint_position = true;
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    let h = &out.record.joints[0];
    let worst = h.qx.iter().zip(&h.qy).map(|(x, y)| x.hypot(*y)).fold(0.0, f64::max);
    // the end of the slider stays within 1e-6 of the yoke amplitude (0.01 m) of the yoke
    assert!(worst < 1e-8, "largest journal offset {worst} m");
}

fn penetration(method: Coupling, solver: SolverMode, dt: f64, t_end: f64, sy: SliderYoke) -> Vec<f64> {
    let model = sy.build().unwrap().to_translating().unwrap();
    let mut s = Settings::new(t_end, dt);
    s.coupling = method;
    s.solver = solver;
    s.record.every = (1e-5 / dt).round() as usize;
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    out.record.joints[0].penetration.clone()
}

#[test]
fn force_and_modified_methods_agree_at_dt_1e_6() {
    let sy = SliderYoke {
        clearance: 1e-4,
        ..Default::default()
    };
    let a = penetration(Coupling::Force, SolverMode::Woodbury, 1e-6, 0.17, sy.clone());
    let b = penetration(Coupling::default(), SolverMode::Woodbury, 1e-6, 0.17, sy);
    let range = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    // both are first-order-consistent discretizations of one law: at dt 1e-6 they agree to 1 % of
    // the penetration range over one excitation cycle with 6 impacts
    assert!(diff < 0.01 * range, "max difference {diff} m of range {range} m");
}

#[test]
fn woodbury_and_refactorization_give_the_same_answer() {
    for (kb, iterate) in [(None, false), (Some(1e10), true), (Some(1e13), false)] {
        let sy = SliderYoke {
            clearance: 1e-5,
            bearing_stiffness: kb,
            ..Default::default()
        };
        let c = Coupling::Modified {
            iterate,
            tol: 1e-12,
            max_iter: 50,
        };
        // 5 ms: the first impacts; later, rattling amplifies round-off differences
        let a = penetration(c, SolverMode::Woodbury, 1e-6, 0.005, sy.clone());
        let b = penetration(c, SolverMode::Refactor, 1e-6, 0.005, sy);
        let scale = a.iter().fold(1e-12f64, |m, x| m.max(x.abs()));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-7 * scale, "K_B {kb:?}: {x} vs {y}");
        }
    }
}

/// The force method lags a contact stiffness K_B by one step: its stability depends on
/// omega_c dt (omega_c^2 = K_B / end mass), so it is stable for a soft bearing and unstable for a
/// stiff one at the same step, while the modified method, with K_B inside the effective matrix,
/// stays bounded in both cases.
#[test]
fn lagged_force_loses_stability_with_stiff_bearing_modified_does_not() {
    let run = |kb: f64, c: Coupling, dt: f64| {
        let model = SliderYoke {
            clearance: 1e-5,
            bearing_stiffness: Some(kb),
            ..Default::default()
        }
        .build()
        .unwrap()
        .to_translating()
        .unwrap();
        let mut s = Settings::new(0.03, dt);
        s.coupling = c;
        s.record.histories = false;
        s.divergence_limit = Some(1.0);
        simulate(&model, &s, &mut |_| true)
    };
    assert!(run(1.2e6, Coupling::Force, 1e-5).is_ok());
    assert!(run(1.2e6, Coupling::default(), 1e-5).is_ok());
    let f = run(1e10, Coupling::Force, 1e-5).unwrap_err();
    assert!(matches!(f.error, Error::Diverged { .. }));
    assert!(f.output.stats.steps > 0 && f.output.stats.steps < 3000);
    assert!(
        run(1e10, Coupling::Force, 1e-6).is_ok(),
        "the force method is stable once omega_c dt is small"
    );
    let m = run(1e10, Coupling::default(), 1e-5).unwrap();
    assert!(m.record.extremes[0].max_penetration < 1e-5, "bounded penetration");
}

#[test]
fn gap_element_keeps_penetration_small_and_counts_impacts() {
    let model = SliderYoke {
        clearance: 1e-4,
        ..Default::default()
    }
    .build()
    .unwrap()
    .to_translating()
    .unwrap();
    let mut s = Settings::new(0.2, 1e-5);
    s.coupling = Coupling::Gap {
        stiffness: None,
        damping: 0.0,
        max_iter: 20,
    };
    s.record.histories = false;
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    let e = out.record.extremes[0];
    assert!(e.impacts > 0 && e.max_penetration > 0.0);
    // 1000 x the adjacent element's 12EI/l^3 is ~1e4 times K_B: the gap penetrates far less than
    // the soft bearing's 1e-6..1e-5 m
    assert!(e.max_penetration < 1e-7, "{}", e.max_penetration);
}

#[test]
fn extremes_only_keep_no_history() {
    let model = SliderYoke {
        clearance: 1e-5,
        ..Default::default()
    }
    .build()
    .unwrap()
    .to_translating()
    .unwrap();
    let mut s = Settings::new(0.1, 1e-6);
    s.record.histories = false;
    let out = simulate(&model, &s, &mut |_| true).unwrap();
    assert!(out.record.time.capacity() == 0 && out.record.joints.is_empty());
    assert_eq!(out.stats.steps, 100_000);
}

#[test]
fn bad_input_names_the_parameter() {
    let mut m = SliderYoke::default().build().unwrap().to_translating().unwrap();
    m.links[0].section.length = -1.0;
    match m.validate() {
        Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "links[0].length"),
        other => panic!("{other:?}"),
    }
    let mut m = SliderYoke::default().build().unwrap().to_translating().unwrap();
    m.joints[0].node = 99;
    assert!(matches!(m.validate(), Err(Error::InvalidParameter { .. })));
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let s = Settings::new(0.1, f64::NAN);
    assert!(matches!(
        simulate(&model, &s, &mut |_| true).unwrap_err().error,
        Error::InvalidParameter { .. }
    ));
    let law = Arc::new(SpringDamper {
        stiffness: -1.0,
        damping: 0.0,
        damping_law: Default::default(),
        no_tension: false,
    });
    let bad = Mechanism {
        links: vec![beam(2)],
        joints: vec![Clearance {
            friction: None,
            name: "j".into(),
            journal: Endpoint::Node { link: 0, node: 0 },
            bearing: Endpoint::Body {
                frame: at_rest(),
                point: [0.0; 2],
                name: "g".into(),
            },
            clearance: 0.0,
            law,
        }],
        ..Default::default()
    }
    .to_translating()
    .unwrap();
    match bad.validate() {
        Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "joints[0].law.stiffness"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn interrupt_stops_with_partial_output() {
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let s = Settings::new(1.0, 1e-5);
    let fail = simulate(&model, &s, &mut |frac| frac < 0.2).unwrap_err();
    assert!(matches!(fail.error, Error::Interrupted { .. }));
    assert!(fail.output.record.time.len() > 1000);
}

/// Two unconnected links with different damping ratios take the general damping path (separate
/// C product); each must move exactly as it does alone (proportional path).
#[test]
fn general_damping_path_matches_proportional_path_link_by_link() {
    let mk = |name: &str, eta: f64| {
        let mut l = beam(6);
        l.name = name.into();
        l.section.damping = eta;
        let n = l.section.elements + 1;
        l.initial_velocity = Some(
            (0..3 * n)
                .map(|i| if i % 3 == 1 { (i as f64 * 0.4).sin() } else { 0.0 })
                .collect(),
        );
        l
    };
    let (a, b) = (mk("a", 2e5), mk("b", 7e5));
    let run = |links: Vec<Link>, nodes: Vec<(usize, usize)>| {
        let model = translating(links);
        let mut s = Settings::new(2e-3, 1e-6);
        s.record.nodes = nodes;
        simulate(&model, &s, &mut |_| true).unwrap()
    };
    let both = run(vec![a.clone(), b.clone()], vec![(0, 6), (1, 6)]);
    let alone_a = run(vec![a], vec![(0, 6)]);
    let alone_b = run(vec![b], vec![(0, 6)]);
    for (h, r) in [
        (&both.record.nodes[0], &alone_a.record.nodes[0]),
        (&both.record.nodes[1], &alone_b.record.nodes[0]),
    ] {
        let scale = r.v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(scale > 0.0);
        for (x, y) in h.v.iter().zip(&r.v) {
            assert!((x - y).abs() <= 1e-9 * scale, "{x} vs {y}");
        }
    }
}

#[test]
fn the_truncation_fraction_is_refused_outside_zero_to_one() {
    for f in [-0.1, 1.0, f64::NAN, f64::INFINITY] {
        let mut s = Settings::new(0.01, 1e-4);
        s.newton.truncation_fraction = f;
        match s.validate_run() {
            Err(Error::InvalidParameter { name, allowed, .. }) => {
                assert_eq!((name.as_str(), allowed.as_str()), ("truncation_fraction", "in [0, 1)"))
            }
            other => panic!("{f}: {other:?}"),
        }
    }
    let mut s = Settings::new(0.01, 1e-4);
    s.newton.truncation_fraction = 0.0;
    s.validate_run().unwrap();
}
