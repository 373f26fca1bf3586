//! Validation of the KED engine (links in moving frames) against physics: rotating-cantilever
//! frequencies (Southwell-type curves), geometric stiffening in the spin-up of Kane, Ryan &
//! Banerjee (1987), the axially loaded pinned-pinned beam, the energy balance of a driven rotating
//! beam, rigid-kinematics limits of multi-link mechanisms, term selection and error reporting.
//!
//! Every test states its tolerance and why. Run with `cargo test --profile dev-opt --test integration newton::`.

use std::sync::Arc;

use flexclear::contact::{Coupling, DampingLaw, SpringDamper};
use flexclear::element::BeamElement;
use flexclear::integrator::newton::{simulate_mechanism, NewtonRun};
use flexclear::kinematics::{FourBar, FourBarFrame, FourBarLink, FrameKinematics, Rotation, SliderCrank};
use flexclear::model::mechanism::{Clearance, Endpoint, Link, Mechanism, NodalLoad, Pin, Support};
use flexclear::record::{LinkChannels, RecordSpec, SliderReference};
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin};
use flexclear::Error;
use flexclear::RunOutput;
use flexclear::Settings;
use nalgebra::{DMatrix, DVector};

use crate::common::{fixed_frame, hub, link};

// ------------------------------------------------------------------------------------------------
// Helpers
// ------------------------------------------------------------------------------------------------

/// One link clamped at node 0 (the frame origin).
fn clamped(l: Link) -> Mechanism {
    Mechanism {
        links: vec![l],
        supports: vec![Support {
            link: 0,
            node: 0,
            fixed: [true; 3],
        }],
        ..Default::default()
    }
}

/// Equilibrium of the unknowns at `t` with the frame motion of that instant held, by the
/// fixed-point iteration `K(F(y)) dy = -r(y)` of `Mechanism.static_state` in Python.
fn static_state(run: &mut NewtonRun, t: f64) -> Vec<f64> {
    let n = run.unknowns();
    let mut y = DVector::<f64>::zeros(n);
    let yd = vec![0.0; n];
    for _ in 0..100 {
        let [_, _, k, r] = run.linearize(t, y.as_slice(), &yd).unwrap();
        let k = DMatrix::from_row_slice(n, n, &k);
        let dy = k.lu().solve(&(-DVector::from_vec(r))).expect("K(F) is singular");
        y += &dy;
        if dy.amax() <= 1e-13 * y.amax().max(1e-300) {
            return y.as_slice().to_vec();
        }
    }
    panic!("static state did not converge");
}

/// Undamped natural frequencies (rad/s, ascending) of `M ydd + K y = 0` at the static state of
/// `t`, the gyroscopic (Coriolis) coupling dropped: eigenvalues of `L^-1 K L^-T`, `M = L L^T`.
fn frequencies_without_coriolis(mech: &Mechanism, t: f64) -> Vec<f64> {
    let settings = Settings::new(1.0, 1e-3);
    let mut run = NewtonRun::new(mech, &settings).unwrap();
    let y = static_state(&mut run, t);
    let n = run.unknowns();
    let [m, _c, k, _] = run.linearize(t, &y, &vec![0.0; n]).unwrap();
    let m = DMatrix::from_row_slice(n, n, &m);
    let k = DMatrix::from_row_slice(n, n, &k);
    let l = m.cholesky().expect("mass matrix not positive definite").l();
    let li = l.clone().try_inverse().unwrap();
    let a = &li * k * li.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let mut w2: Vec<f64> = a.symmetric_eigen().eigenvalues.iter().copied().collect();
    w2.sort_by(|a, b| a.partial_cmp(b).unwrap());
    w2.into_iter().map(|x| x.max(0.0).sqrt()).collect()
}

/// Reads `tests/data/<name>`: comment lines start with `#`, then a header, then numbers.
fn read_csv(name: &str) -> Vec<Vec<f64>> {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with('#'), "{path} must name its source in a header comment");
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect()
}

/// Non-dimensional flapwise frequency `lambda_n = omega sqrt(rho A L^4/EI)` of a uniform
/// cantilever clamped on the axis of rotation (hub radius 0) spinning at non-dimensional speed
/// `s = Omega sqrt(rho A L^4/EI)`, by the Frobenius power series of
/// `w'''' - (T w')' = lambda^2 w`, `T = s^2 (1 - xi^2)/2` (the method of Wright et al. 1982):
/// `w = sum a_k xi^k` with `a_0 = a_1 = 0` (clamp), two solutions (`a_2 = 1` or `a_3 = 1`) and the
/// free-end conditions `w''(1) = 0`, `w'''(1) - T(1) w'(1) = w'''(1) = 0`; the n-th root of the
/// 2x2 determinant by scanning and bisection. The series of an entire function: 400 terms leave
/// truncation far below 1e-12 for lambda < 100.
fn frobenius_flapwise(s: f64, mode: usize) -> f64 {
    const TERMS: usize = 400;
    let det = |lam: f64| {
        let mut ends = [[0.0f64; 2]; 2];
        for (sol, start) in [(0usize, 2usize), (1, 3)] {
            let mut a = vec![0.0f64; TERMS + 4];
            a[start] = 1.0;
            for k in 0..TERMS {
                let kf = k as f64;
                a[k + 4] = (0.5 * s * s * (kf + 1.0) * (kf + 2.0) * a[k + 2]
                    + (lam * lam - 0.5 * s * s * kf * (kf + 1.0)) * a[k])
                    / ((kf + 1.0) * (kf + 2.0) * (kf + 3.0) * (kf + 4.0));
            }
            let (mut w2, mut w3) = (0.0, 0.0);
            for (k, ak) in a.iter().enumerate() {
                let kf = k as f64;
                w2 += kf * (kf - 1.0) * ak;
                w3 += kf * (kf - 1.0) * (kf - 2.0) * ak;
            }
            ends[sol] = [w2, w3];
        }
        ends[0][0] * ends[1][1] - ends[1][0] * ends[0][1]
    };
    let mut found = 0;
    let (mut lo, mut flo) = (0.5, det(0.5));
    loop {
        let hi = lo + 0.01;
        let fhi = det(hi);
        if flo.signum() != fhi.signum() {
            found += 1;
            if found == mode {
                let (mut a, mut b, mut fa) = (lo, hi, flo);
                for _ in 0..200 {
                    let c = 0.5 * (a + b);
                    let fc = det(c);
                    if fc.signum() == fa.signum() {
                        a = c;
                        fa = fc;
                    } else {
                        b = c;
                    }
                }
                return 0.5 * (a + b);
            }
        }
        lo = hi;
        flo = fhi;
        assert!(lo < 200.0, "no root found");
    }
}

// ------------------------------------------------------------------------------------------------
// 1. Rotating cantilever: in-plane frequencies against rotation speed
// ------------------------------------------------------------------------------------------------

/// A cantilever of unit length, EI = 1, rho A = 1 on a hub of radius 0 spinning at `speed`
/// (rad/s = the non-dimensional speed), EA = 1e8 (axially stiff: the centrifugal tension at the
/// fastest speed, 72, stretches it by 7e-7, so extensibility moves the frequencies by ~1e-6).
fn unit_rotating_cantilever(speed: f64, elements: usize) -> Mechanism {
    clamped(link(
        "beam",
        1.0,
        elements,
        1e8,
        1.0,
        1.0,
        1e-8,
        hub(Rotation::Constant {
            angle0: 0.0,
            rate: speed,
        }),
    ))
}

#[test]
fn frobenius_reference_matches_the_static_cantilever_table() {
    // Checks the reference solver on the tabulated non-rotating roots (4-5 significant digits
    // in the table: tolerance half a unit of its last digit, 5e-5).
    for row in read_csv("cantilever_frequencies.csv") {
        let (mode, lam) = (row[0] as usize, row[1]);
        let f = frobenius_flapwise(0.0, mode);
        assert!((f - lam).abs() <= 5e-5, "mode {mode}: Frobenius {f} vs table {lam}");
    }
}

#[test]
fn rotating_cantilever_in_plane_frequencies_follow_the_flapwise_curve() {
    // In the plane of rotation the centrifugal softening -Omega^2 M (M_IC) adds to the flapwise
    // problem, so omega_in^2 = omega_flap^2 - Omega^2. The classic tables (and the Frobenius
    // reference) treat an inextensible beam without Coriolis coupling: the gyroscopic term is
    // dropped here (eigenvalues of M^-1 K at the centrifugally stretched static state).
    //
    // Tolerance. The FE error has two parts: Hermite bending, O(h^4), and the element-constant
    // axial force F = EA (u2 - u1)/l in K2, which approximates the parabolic centrifugal tension
    // to O(h^2) and dominates once Omega > 0 (measured order 1.99-2.01 between 12 and 24
    // elements, 2.4 for mode 2 at Omega_bar = 1 where the O(h^4) part still counts). Hence
    // (a) at 24 elements the relative error is below 1e-3 (measured: at most 5.3e-4, mode 2 at
    //     Omega_bar = 12);
    // (b) it is at most 1.3 x its Richardson estimate |lambda_24 - lambda_12| / 3 (the error is
    //     the O(h^2) term; measured ratio <= 1.01 for Omega > 0);
    // (c) the Richardson-extrapolated value (4 lambda_24 - lambda_12)/3 agrees to 1e-5 relative
    //     (measured <= 4e-6: the O(h^4) remainder and the 1e-6 effect of extensibility).
    for k in 0..=12 {
        let s = k as f64;
        for mode in 1..=2 {
            let reference = frobenius_flapwise(s, mode);
            let omega_in = |n: usize| frequencies_without_coriolis(&unit_rotating_cantilever(s, n), 0.0)[mode - 1];
            let (w12, w24) = (omega_in(12), omega_in(24));
            let (l12, l24) = ((w12 * w12 + s * s).sqrt(), (w24 * w24 + s * s).sqrt());
            let e24 = (l24 - reference).abs();
            let richardson = (l24 - l12).abs() / 3.0;
            let extrapolated = l24 + (l24 - l12) / 3.0;
            println!(
                "Omega_bar {s:4.1} mode {mode}: omega_in {w24:.5}; sqrt(omega_in^2 + Omega^2) = {l24:.5} (24 el.), {extrapolated:.5} (extrapolated) vs Frobenius {reference:.5}"
            );
            assert!(
                e24 <= 1e-3 * reference,
                "Omega_bar {s}, mode {mode}: {l24} vs {reference}"
            );
            if s > 0.0 {
                assert!(
                    e24 <= 1.3 * richardson,
                    "Omega_bar {s}, mode {mode}: error {e24:e}, estimate {richardson:e}"
                );
            }
            assert!(
                (extrapolated - reference).abs() <= 1e-5 * reference,
                "Omega_bar {s}, mode {mode}: extrapolated {extrapolated} vs {reference}"
            );
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 2. Spin-up (Kane, Ryan & Banerjee 1987)
// ------------------------------------------------------------------------------------------------

/// Kane's beam (docs/scenes.md scene 2): L = 8 m, 10 elements, spun up to `rate` over `ramp` s.
fn kane_beam(rate: f64, ramp: f64, geometric: Option<bool>) -> Mechanism {
    let mut l = link(
        "beam",
        8.0,
        10,
        6.8952e10,
        2766.67,
        7.2968e-5,
        8.2189e-9,
        hub(Rotation::SpinUp {
            angle0: 0.0,
            final_rate: rate,
            ramp_time: ramp,
        }),
    );
    l.terms.geometric = geometric;
    clamped(l)
}

/// Tip transverse deflection (link frame) at every record, m.
fn tip_v(out: &RunOutput) -> Vec<f64> {
    let h = &out.record.links[0];
    let per = h.displacements.len() / out.record.time.len();
    h.displacements.chunks(per).map(|w| w[per - 2]).collect()
}

#[test]
fn spin_up_stays_bounded_with_geometric_stiffening_and_diverges_without() {
    // First bending frequency 3.516 sqrt(EI/(rho A L^4)) = 2.91 rad/s < W = 4 rad/s.
    let mut settings = Settings::new(20.0, 2e-3);
    settings.record.every = 25;
    let with = simulate_mechanism(&kane_beam(4.0, 15.0, None), &settings, &mut |_| true).unwrap();
    assert!(with.stats.terms[0].contains("K2"), "{:?}", with.stats.terms);
    let v = tip_v(&with);
    let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let settle: f64 = with
        .record
        .time
        .iter()
        .zip(&v)
        .filter(|(t, _)| **t >= 16.0)
        .fold(0.0f64, |m, (_, x)| m.max(x.abs()));
    let (i_peak, _) = v.iter().enumerate().fold(
        (0, 0.0f64),
        |(im, m), (i, x)| if x.abs() > m { (i, x.abs()) } else { (im, m) },
    );
    println!(
        "with K2: peak |tip v| = {peak:.4} m at t = {:.2} s (tip lags: v = {:.4} m); after the ramp (t >= 16 s) |v| <= {settle:.4} m",
        with.record.time[i_peak], v[i_peak]
    );
    // Bounded: the lag stays a small fraction of the length, below L/10 = 0.8 m (for scale: the
    // quasi-static tip deflection under the peak angular acceleration 2W/T, without stiffening,
    // is 11 rho A (2W/T) L^5 / (120 EI) = 0.57 m). The tip trails the rotation (v < 0). No
    // published number for the peak could be found to compare with (Kane et al. give a plot).
    assert!(peak < 0.8, "peak tip deflection {peak} m");
    assert!(v[i_peak] < 0.0);
    // Converged in time: halving the step moves the peak by less than 0.5 % (Newmark is second
    // order and the ramp is slow, 15 s against a 2.2 s first period).
    let mut fine = settings.clone();
    fine.dt = 1e-3;
    fine.record.every = 50;
    let v_fine = tip_v(&simulate_mechanism(&kane_beam(4.0, 15.0, None), &fine, &mut |_| true).unwrap());
    let peak_fine = v_fine.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    println!("peak at dt = 1e-3: {peak_fine:.5} m, at 2e-3: {peak:.5} m");
    assert!((peak - peak_fine).abs() <= 5e-3 * peak_fine);
    // Settles: after the ramp (acceleration back to zero) the beam vibrates about the stretched,
    // undeflected state with an amplitude well below the lag it had during the ramp.
    assert!(
        settle < 0.25 * peak,
        "after the ramp |v| reaches {settle} m, peak {peak} m"
    );

    // Without K2 (and K3): once the rate exceeds 2.91 rad/s the centrifugal softening -Omega^2 M
    // exceeds the bending stiffness of the first mode and the deflection grows exponentially
    // (rate sqrt(W^2 - 2.91^2) = 2.7 1/s over the last ~8 s): the run hits the divergence limit
    // (10 L = 80 m) or ends beyond 100 x the bounded peak.
    match simulate_mechanism(&kane_beam(4.0, 15.0, Some(false)), &settings, &mut |_| true) {
        Err(f) => {
            println!("without K2: {}", f.error);
            assert!(matches!(f.error, Error::Diverged { .. }), "{}", f.error);
            let t = match f.error {
                Error::Diverged { time, .. } => time,
                _ => unreachable!(),
            };
            assert!(t > 8.0, "diverged at {t} s, before the rate passed the first frequency");
        }
        Ok(out) => {
            let v = tip_v(&out);
            let last = v.last().unwrap().abs();
            println!("without K2: final |tip v| = {last:.3e} m");
            assert!(last > 100.0 * peak);
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 3. Pinned-pinned beam under an axial end load
// ------------------------------------------------------------------------------------------------

/// A steel beam, L = 1 m, pinned at node 0 (u, v held), on a roller at the last node (v held),
/// with an axial force `p` (N, tension positive) at the last node.
fn pinned_pinned(elements: usize, p: f64) -> Mechanism {
    let mut m = Mechanism {
        links: vec![link("beam", 1.0, elements, 2e11, 7850.0, 1e-4, 1e-9, fixed_frame())],
        supports: vec![
            Support {
                link: 0,
                node: 0,
                fixed: [true, true, false],
            },
            Support {
                link: 0,
                node: elements,
                fixed: [false, true, false],
            },
        ],
        ..Default::default()
    };
    m.loads.push(NodalLoad {
        link: 0,
        node: elements,
        force: [p, 0.0],
        moment: 0.0,
    });
    m
}

#[test]
fn axially_loaded_pinned_beam_frequency_follows_the_load() {
    // omega^2 = omega0^2 (1 + F L^2/(pi^2 EI)), omega0 = pi^2 sqrt(EI/(rho A L^4)), exact for an
    // Euler-Bernoulli beam under a constant axial force F (the sine mode is exact).
    //
    // Which F: the paper's K3 = F int Nu'^T Nu' adds F/l to the axial stiffness, so the static
    // state of the bar satisfies (EA + F) (u2 - u1)/l = P, i.e. F + F^2/EA = P with F = EA u':
    // the axial force in K2 is P/(1 + F/EA), not P. The difference is of the order of the strain
    // (P_cr/EA = pi^2 I/(A L^2) = 1e-4 here) but is amplified near buckling: at P = -0.9 P_cr it
    // moves omega by 4e-4 relative, 40 x the discretization error. So the reference uses the F of
    // the model, and the test also checks that using P instead would be off by that amount
    // (the K3 effect is there, and is what it should be).
    //
    // Tolerance: F is then exact in every element and K2 is the consistent geometric matrix, so
    // the only error is the Hermite discretization, O(h^4). At 16 elements it is 1.0e-6 relative
    // without load; near buckling the same stiffness error is a larger part of the net stiffness
    // (1 + F/P_cr) K1, so the bound is 1.5e-6 / (1 + F/P_cr) (measured 1.0e-5 at P = -0.9 P_cr,
    // bound 1.5e-5). And the error must fall by at least 12 (of the asymptotic 16) from 8 to 16
    // elements.
    let (ei, ea, ra, l): (f64, f64, f64, f64) = (2e11 * 1e-9, 2e11 * 1e-4, 7850.0 * 1e-4, 1.0);
    let pi2 = std::f64::consts::PI.powi(2);
    let w0 = pi2 * (ei / (ra * l * l * l * l)).sqrt();
    let p_cr = pi2 * ei / (l * l);
    for ratio in [-0.9, -0.5, -0.2, 0.0, 0.5, 1.0, 3.0] {
        let p = ratio * p_cr;
        let f = 0.5 * ea * ((1.0 + 4.0 * p / ea).sqrt() - 1.0);
        let exact = w0 * (1.0 + f / p_cr).sqrt();
        let with_p = w0 * (1.0 + ratio).sqrt();
        let err = |n: usize| {
            let mech = pinned_pinned(n, p);
            let w = frequencies_without_coriolis(&mech, 0.0)[0];
            (w, (w - exact).abs() / exact)
        };
        let ((w8, e8), (w16, e16)) = (err(8), err(16));
        println!(
            "P/Pcr = {ratio:5.2}: omega_1 = {w16:.5} rad/s (16 el.), {w8:.5} (8 el.); exact with F {exact:.5}, with P {with_p:.5}; rel. err. {e16:.1e} (16), {e8:.1e} (8)"
        );
        let tol = 1.5e-6 / (1.0 + f / p_cr);
        assert!(e16 <= tol, "P/Pcr = {ratio}: {w16} vs {exact}");
        assert!(
            e8 >= 12.0 * e16 || e8 < 1e-9,
            "P/Pcr = {ratio}: errors {e8:e} -> {e16:e}"
        );
        // The K3 shift: omega(F) - omega(P) = -w0^2 (P - F)/(2 P_cr omega) to first order.
        let shift = -(w0 * w0) * (p - f) / (p_cr * (exact + with_p));
        assert!((exact - with_p - shift).abs() <= 1e-3 * shift.abs().max(1e-12) || ratio == 0.0);
    }
    // The load switches the geometric terms on by itself (axially loaded link).
    let settings = Settings::new(1e-3, 1e-4);
    let out = simulate_mechanism(&pinned_pinned(4, 1.0), &settings, &mut |_| true).unwrap();
    assert!(out.stats.terms[0].contains("K2"), "{:?}", out.stats.terms);
}

// ------------------------------------------------------------------------------------------------
// 4. Energy balance of an undamped beam driven by a prescribed rotation
// ------------------------------------------------------------------------------------------------

/// Energy bookkeeping of a clamped hub beam: per record, kinetic + K1 strain energy, the
/// potential of the geometric terms (see the test), the work of the drive and the work of the
/// non-conservative part of the geometric terms.
struct Balance {
    /// T + Q^T K1 Q / 2 (+ the geometric potential when asked).
    energy: Vec<f64>,
    /// Q^T K1 Q / 2, J.
    strain: Vec<f64>,
    /// Work of the drive, int phidot dH, J.
    drive: Vec<f64>,
    /// int sum_e dF/dt (q^T K2u q)/2 dt, J.
    nonconservative: Vec<f64>,
}

fn balance(mech: &Mechanism, out: &RunOutput, geometric: bool) -> Balance {
    let l = &mech.links[0];
    let e: BeamElement = l.element();
    let k2u = e.geometric_stiffness(1.0);
    let (ea, le) = (e.youngs_modulus * e.area, e.length);
    let h = &out.record.links[0];
    let per = 3 * l.nodes();
    let mut b = Balance {
        energy: vec![],
        strain: h.strain.clone(),
        drive: vec![0.0],
        nonconservative: vec![0.0],
    };
    let mut prev: Option<(Vec<f64>, Vec<f64>)> = None;
    for (k, w) in h.displacements.chunks(per).enumerate() {
        let mut forces = vec![0.0; l.section.elements];
        let mut vq = vec![0.0; l.section.elements];
        let mut v_geo = 0.0;
        for el in 0..l.section.elements {
            let q = nalgebra::SVector::<f64, 6>::from_column_slice(&w[3 * el..3 * el + 6]);
            let du = (q[3] - q[0]) / le;
            forces[el] = ea * du;
            vq[el] = q.dot(&(k2u * q));
            v_geo += ea * du.powi(3) * le / 3.0 + 0.5 * forces[el] * vq[el];
        }
        b.energy
            .push(h.kinetic[k] + h.strain[k] + if geometric { v_geo } else { 0.0 });
        if let Some((f0, vq0)) = &prev {
            let rate = |i: usize| h.frame[i][3];
            b.drive
                .push(b.drive[k - 1] + 0.5 * (rate(k - 1) + rate(k)) * (h.momentum[k] - h.momentum[k - 1]));
            let p: f64 = (0..l.section.elements)
                .map(|el| (forces[el] - f0[el]) * 0.25 * (vq[el] + vq0[el]))
                .sum();
            b.nonconservative.push(b.nonconservative[k - 1] + p);
        }
        prev = Some((forces, vq));
    }
    b
}

#[test]
fn driven_rotating_beam_balances_energy_with_the_work_of_the_drive() {
    // With the hub angle prescribed, the drive torque is tau = dH/dt (H: angular momentum about
    // the hub axis; the clamp force acts at the axis) and its power tau phidot, so the work is
    // W(t) = int phidot dH. The semi-discrete equations are Lagrange's equations of the absolute
    // kinetic energy T(q, qd, t) and the strain energy, so d(T + V)/dt = tau phidot exactly.
    //
    // (a) Linear model (geometric = false), spin-up to 2 rad/s (below the first frequency, 2.91
    //     rad/s) over 5 s, then 3 s at constant rate. Newmark's average acceleration conserves
    //     energy exactly for a linear time-invariant system; here the matrices vary with phidot,
    //     which could leave an O(dt^2) defect (and the trapezoidal rule for W one more). Measured:
    //     3.6e-8 of the largest strain energy at dt = 1e-3 and 1.7e-7 at 5e-4, i.e. no visible
    //     O(dt^2) term, only round-off accumulated over 8000-16000 steps on a kinetic energy 37 x
    //     the strain energy. Tolerance 1e-5 of the largest strain energy (the scale of the elastic
    //     motion; the rigid-body energy is 76 J against 2 J), well above that round-off, far
    //     below any modelling error (a missing term moves the balance by O(1)).
    let mut settings = Settings::new(8.0, 1e-3);
    settings.record = RecordSpec {
        every: 1,
        links: LinkChannels {
            displacements: true,
            axial_force: false,
            midspan: false,
            energy: true,
            peaks: false,
        },
        ..RecordSpec::default()
    };
    let defect = |mech: &Mechanism, s: &Settings, geometric: bool| {
        let out = simulate_mechanism(mech, s, &mut |_| true).unwrap();
        let b = balance(mech, &out, geometric);
        let scale = b.strain.iter().fold(0.0f64, |m, x| m.max(*x));
        let (mut worst, mut worst_nc) = (0.0f64, 0.0f64);
        for k in 0..b.energy.len() {
            let d = b.energy[k] - b.energy[0] - b.drive[k];
            worst = worst.max(d.abs());
            worst_nc = worst_nc.max((d - b.nonconservative[k]).abs());
        }
        let nc = b.nonconservative.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        (
            worst / scale,
            worst_nc / scale,
            nc / scale,
            scale,
            *b.drive.last().unwrap(),
        )
    };
    let linear = kane_beam(2.0, 5.0, Some(false));
    let (d1, _, _, scale, work) = defect(&linear, &settings, false);
    let mut half = settings.clone();
    half.dt = 5e-4;
    half.record.every = 2;
    let (d2, _, _, _, _) = defect(&linear, &half, false);
    println!(
        "linear: max strain energy {scale:.4e} J, drive work {work:.4e} J, |E - E0 - W| / max strain = {d1:.2e} (dt 1e-3), {d2:.2e} (dt 5e-4)"
    );
    assert!(d1 <= 1e-5 && d2 <= 1e-5, "energy defect {d1}, {d2}");

    // (b) With the geometric terms (Kane's spin-up to 4 rad/s). The model's internal force is
    //     f_u = K1 u + EA int Nu'^T u'^2, f_v = K1 v + EA int Nv'^T u' v' (K3 and K2 times
    //     F = EA u'). That is not a gradient (d f_v/d u != d f_u/d v = 0: the axial equation has
    //     no v'^2/2 term), so no energy is conserved. Writing
    //     qd . f = d/dt [int EA u'^3/3 + int F v'^2/2] - int (dF/dt) v'^2/2,
    //     the potential of the model is V = Q^T K1 Q/2 + int EA u'^3/3 + int F v'^2/2 and the
    //     balance E(t) - E(0) - W(t) = W_nc(t) = int int (dF/dt) v'^2/2 dx dt must close, up to
    //     the defect of (a) (1e-5 of the strain energy scale). The test also
    //     reports how large W_nc is: the bound on what the paper's K2/K3 fail to conserve.
    let mut s = settings.clone();
    s.t_end = 20.0;
    s.dt = 2e-3;
    let kane = kane_beam(4.0, 15.0, None);
    let (d, d_nc, nc, scale, work) = defect(&kane, &s, true);
    println!(
        "geometric: max strain energy {scale:.4e} J, drive work {work:.4e} J; |E - E0 - W| / max strain = {d:.2e}, with W_nc counted {d_nc:.2e}; max |W_nc| / max strain = {nc:.2e}"
    );
    assert!(d_nc <= 1e-5, "energy defect with W_nc counted: {d_nc}");
    // Measured: the balance closes to 3e-8 with W_nc, while W_nc itself reaches 1.25 x the
    // largest strain energy: the paper's K2/K3 pair is far from conservative. This assertion
    // records that finding (it fails, and should be revisited, if the axial equation ever gets
    // the consistent EA v'^2/2 coupling).
    assert!(nc > 0.1, "W_nc / strain scale = {nc}");
}

// ------------------------------------------------------------------------------------------------
// 5. Bad input and failing steps
// ------------------------------------------------------------------------------------------------

/// Simeon's slider-crank (docs/scenes.md scene 3, [`FlexibleSliderCrank`]): rigid crank 0.15 m at
/// 150 rad/s, flexible rod 0.30 m of 8 x 8 mm steel (Young's modulus `e`), slider 0.075552 kg;
/// pins `"crank_pin"` (rod node 0 to the crank) and `"slider_pin"` (last node to the slider).
fn slider_crank(e: f64, elements: usize) -> Mechanism {
    FlexibleSliderCrank {
        youngs_modulus: e,
        elements,
        ..Default::default()
    }
    .build()
    .unwrap()
}

/// A crank-rocker four-bar (ground 0.3, crank 0.1, coupler 0.35, rocker 0.25 m; Grashof) with a
/// flexible steel coupler (10 x 10 mm, Young's modulus `e`) pinned to the rigid crank and rocker.
fn four_bar(e: f64, lengths: [f64; 4]) -> Mechanism {
    let [g, c, cp, r] = lengths;
    let fb = Arc::new(
        FourBar::new(
            g,
            c,
            cp,
            r,
            1.0,
            Rotation::Constant {
                angle0: 0.0,
                rate: 30.0,
            },
        )
        .unwrap(),
    );
    let frame = |link| -> Arc<dyn FrameKinematics> {
        Arc::new(FourBarFrame {
            mechanism: fb.clone(),
            link,
        })
    };
    let a = 0.01f64;
    Mechanism {
        links: vec![link(
            "coupler",
            cp,
            8,
            e,
            7850.0,
            a * a,
            a.powi(4) / 12.0,
            frame(FourBarLink::Coupler),
        )],
        pins: vec![
            Pin {
                name: "A".into(),
                a: Endpoint::Node { link: 0, node: 0 },
                b: Endpoint::Body {
                    frame: frame(FourBarLink::Crank),
                    point: [c, 0.0],
                    name: "crank".into(),
                },
            },
            Pin {
                name: "B".into(),
                a: Endpoint::Node { link: 0, node: 8 },
                b: Endpoint::Body {
                    frame: frame(FourBarLink::Rocker),
                    point: [r, 0.0],
                    name: "rocker".into(),
                },
            },
        ],
        ..Default::default()
    }
}

/// The error of preparing a run of `mech` over 0.1 s.
fn prepare_error(mech: &Mechanism) -> Error {
    let settings = Settings::new(0.1, 1e-4);
    match NewtonRun::new(mech, &settings) {
        Ok(_) => panic!("the model was accepted"),
        Err(e) => e,
    }
}

#[test]
fn bad_models_are_rejected_with_errors_that_name_the_fault() {
    // Each message must name the offending item (parameter, link, node, pin) and the rule.
    let check = |e: Error, words: &[&str]| {
        let msg = e.to_string();
        println!("{msg}");
        for w in words {
            assert!(msg.contains(w), "{msg:?} does not mention {w:?}");
        }
    };
    // A slider-crank whose rod is shorter than its crank.
    let e = SliderCrank::new(0.15, 0.10, 0.0, Rotation::Constant { angle0: 0.0, rate: 1.0 }).unwrap_err();
    assert!(
        matches!(e, Error::InvalidParameter { ref name, .. } if name == "rod"),
        "{e}"
    );
    check(e, &["rod", "crank"]);
    // A four-bar that does not close: |A - O4| >= 0.8 > coupler + rocker = 0.6.
    let e = prepare_error(&four_bar(2e11, [1.0, 0.2, 0.3, 0.3]));
    assert!(matches!(e, Error::InvalidModel { .. }), "{e}");
    check(e, &["close"]);
    // A link with no joint.
    let mut m = slider_crank(2e11, 4);
    m.links
        .push(link("loose", 0.2, 2, 2e11, 7850.0, 1e-4, 1e-9, fixed_frame()));
    let e = prepare_error(&m);
    assert!(matches!(e, Error::InvalidModel { .. }), "{e}");
    check(e, &["\"loose\"", "no joint"]);
    // A pin on a node the link does not have.
    let mut m = slider_crank(2e11, 4);
    m.pins[1].a = Endpoint::Node { link: 0, node: 7 };
    let e = prepare_error(&m);
    assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
    check(e, &["pins", "7", "0 ..= 4", "\"rod\""]);
    // A pin on a link that does not exist.
    let mut m = slider_crank(2e11, 4);
    m.pins[1].a = Endpoint::Node { link: 3, node: 0 };
    check(prepare_error(&m), &["link #3", "does not exist"]);
    // Over-constrained: a pin joining two nodes of one link.
    let mut m = slider_crank(2e11, 4);
    m.pins.push(Pin {
        name: "C".into(),
        a: Endpoint::Node { link: 0, node: 1 },
        b: Endpoint::Node { link: 0, node: 3 },
    });
    check(prepare_error(&m), &["\"C\"", "same link", "over-constrained"]);
    // Over-constrained: the slider's node also pinned to ground (the crank pivot frame follows
    // the slider pin here so that the pin closes and only the constraint count is wrong).
    let mut m = slider_crank(2e11, 4);
    m.pins.push(Pin {
        name: "ground".into(),
        a: Endpoint::Node { link: 0, node: 4 },
        b: Endpoint::Body {
            frame: m.sliders[0].path.clone(),
            point: [0.0, 0.0],
            name: "guide".into(),
        },
    });
    check(prepare_error(&m), &["\"slider\"", "over-constrained"]);
}

#[test]
fn a_step_that_does_not_converge_reports_where_and_halving_rescues_it() {
    // Kane's spin-up with the geometric terms: Newton with the tangent of the step start (the
    // axial-force dependence of K2, K3 included) converges at a rate set by how much the axial
    // force moves within the step (measured: at dt = 0.02 s two iterations reach 1e-14 in every
    // step; at dt = 0.1 s they reach 1e-10 everywhere but 1e-12 only in the first step).
    let mech = kane_beam(4.0, 15.0, None);
    let mut settings = Settings::new(2.0, 2e-2);
    settings.record.every = 1000;
    // the tolerances below are met as given (not relaxed to a fraction of the steps' error)
    settings.newton.truncation_fraction = 0.0;
    let not_converged = |s: &Settings| -> (f64, u64, usize, f64, f64) {
        let f = simulate_mechanism(&mech, s, &mut |_| true).unwrap_err();
        println!("{}", f.error);
        assert!(f.error.to_string().contains("did not converge"));
        match f.error {
            Error::NotConverged {
                time,
                step,
                iterations,
                residual,
                correction,
            } => {
                // What was recorded until then is kept, up to the start of the failing step.
                assert!((f.output.time - time).abs() < 1e-12 && step >= 1);
                (time, step, iterations, residual, correction)
            }
            e => panic!("expected NotConverged, got {e}"),
        }
    };
    // One iteration per step can never converge a nonlinear step: the first correction is the
    // whole update. The error names the first step, its start time, the iterations done and a
    // finite residual.
    settings.newton.max_iter = 1;
    let (time, step, iterations, residual, correction) = not_converged(&settings);
    assert_eq!((time, step, iterations), (0.0, 1, 1));
    assert!(residual.is_finite() && correction > settings.newton.tol);
    // Two iterations and a tolerance of 1e-12 at dt = 0.1 s: fails at a later step, whose start
    // time it reports.
    settings.dt = 0.1;
    settings.newton.max_iter = 2;
    settings.newton.tol = 1e-12;
    let (time, step, iterations, _, correction) = not_converged(&settings);
    assert!(step > 1 && iterations == 2 && correction > 1e-12);
    assert!(
        (time - (step - 1) as f64 * settings.dt).abs() < 1e-12,
        "time {time} is not the start of step {step}"
    );
    // With step halving allowed the same run completes (halved steps move the axial force less).
    settings.newton.step_halving = 4;
    let out = simulate_mechanism(&mech, &settings, &mut |_| true).unwrap();
    println!(
        "with halving: {} steps, {} halved substeps, max {} iterations",
        out.stats.steps, out.stats.halved_substeps, out.stats.max_iterations
    );
    assert_eq!(out.stats.steps, 20);
    assert!(out.stats.halved_substeps > 0 && out.stats.max_iterations <= 2);
    assert!((out.time - 2.0).abs() < 1e-12);
}

// ------------------------------------------------------------------------------------------------
// 6. Each link gets the terms its motion calls for; no iterations when nothing is nonlinear
// ------------------------------------------------------------------------------------------------

#[test]
fn linear_links_factor_once_and_take_one_solve_per_step() {
    let settings = Settings::new(0.05, 1e-4);
    // A non-rotating cantilever, unloaded axially (a transverse tip load and an initial bend).
    let mut m = clamped(link("beam", 1.0, 8, 2e11, 7850.0, 1e-4, 1e-9, fixed_frame()));
    m.loads.push(NodalLoad {
        link: 0,
        node: 8,
        force: [0.0, 10.0],
        moment: 0.0,
    });
    let out = simulate_mechanism(&m, &settings, &mut |_| true).unwrap();
    println!(
        "{:?}: {} factorizations, {} iterations, {} steps",
        out.stats.terms, out.stats.factorizations, out.stats.iterations, out.stats.steps
    );
    assert_eq!(out.stats.terms, vec!["beam: M, K1".to_string()]);
    // One factorization of the mass matrix for the initial accelerations and one of the
    // effective matrix for the whole run; exactly one solve per step.
    assert_eq!(out.stats.factorizations, 2);
    assert_eq!(out.stats.iterations, out.stats.steps);
    assert_eq!(out.stats.max_iterations, 1);
    // The tip load bends it: the answer is not trivially zero (static tip deflection
    // F L^3/(3 EI) = 0.0167 m, the undamped response oscillates between 0 and twice that).
    let v = tip_v(&out);
    assert!(v.iter().any(|x| *x > 0.02) && v.iter().all(|x| *x < 0.034 && *x > -1e-6));

    // Spinning at constant speed without geometric terms: Coriolis and M_IC are constant, so
    // the Jacobian is factorized once for the run (and once for the initial accelerations).
    let mut l = link(
        "beam",
        1.0,
        8,
        2e11,
        7850.0,
        1e-4,
        1e-9,
        hub(Rotation::Constant {
            angle0: 0.0,
            rate: 10.0,
        }),
    );
    l.terms.geometric = Some(false);
    let out = simulate_mechanism(&clamped(l), &settings, &mut |_| true).unwrap();
    println!(
        "{:?}: {} factorizations, {} iterations",
        out.stats.terms, out.stats.factorizations, out.stats.iterations
    );
    assert_eq!(out.stats.terms, vec!["beam: M, K1, M_COR, M_IC, M_R a_R".to_string()]);
    assert_eq!(out.stats.factorizations, 2);
    assert_eq!(out.stats.iterations, out.stats.steps);

    // The same with the automatic choice: the geometric terms come on, and with them iterations.
    let l = link(
        "beam",
        1.0,
        8,
        2e11,
        7850.0,
        1e-4,
        1e-9,
        hub(Rotation::Constant {
            angle0: 0.0,
            rate: 10.0,
        }),
    );
    let out = simulate_mechanism(&clamped(l), &settings, &mut |_| true).unwrap();
    assert_eq!(
        out.stats.terms,
        vec!["beam: M, K1, K2, K3, M_COR, M_IC, M_R a_R".to_string()]
    );
    assert!(out.stats.iterations > out.stats.steps);
}

// ------------------------------------------------------------------------------------------------
// 7. Multi-link mechanisms: a very stiff link follows the rigid kinematics
// ------------------------------------------------------------------------------------------------

/// Largest |value| of the recorded unknown-level displacements (link frame), m.
fn max_disp(out: &RunOutput) -> (f64, f64) {
    let h = &out.record.links[0];
    let per = h.displacements.len() / out.record.time.len();
    let (mut trans, mut rot) = (0.0f64, 0.0f64);
    for w in h.displacements.chunks(per) {
        for n in w.chunks(3) {
            trans = trans.max(n[0].abs()).max(n[1].abs());
            rot = rot.max(n[2].abs());
        }
    }
    (trans, rot)
}

#[test]
fn stiff_links_follow_the_rigid_kinematics() {
    // The elastic displacements of a link driven by its nominal motion are the response to the
    // inertia loads, of order (load / stiffness): scaling E by 1e3 must scale them by about 1e-3
    // (quasi-statically exactly; the dynamic part of the nominal run, which starts from rest in
    // its frames, is bounded by the same factor because its amplitude is also load/stiffness).
    // Tolerance: the ratio within [0.2e-3, 2e-3] and the stiff displacements below 1e-5 of the
    // link length (measured 5e-6 for the slider-crank), i.e. the stiff mechanism follows the
    // rigid kinematics.
    let settings = Settings::new(0.042, 1e-5); // one crank turn at 150 rad/s
    let soft = simulate_mechanism(&slider_crank(2e11, 6), &settings, &mut |_| true).unwrap();
    let stiff = simulate_mechanism(&slider_crank(2e14, 6), &settings, &mut |_| true).unwrap();
    let (s, k) = (max_disp(&soft).0, max_disp(&stiff).0);
    println!(
        "slider-crank: max |elastic displacement| {s:.3e} m (E), {k:.3e} m (1e3 E), ratio {:.2e}",
        k / s
    );
    assert!(k / s >= 0.2e-3 && k / s <= 2e-3, "ratio {}", k / s);
    assert!(k < 1e-5 * 0.30);

    // A four-bar with a flexible coupler, likewise.
    let g = [0.3, 0.1, 0.35, 0.25];
    let settings = Settings::new(0.21, 1e-4); // one crank turn at 30 rad/s
    let soft = simulate_mechanism(&four_bar(2e11, g), &settings, &mut |_| true).unwrap();
    let stiff = simulate_mechanism(&four_bar(2e14, g), &settings, &mut |_| true).unwrap();
    let (s, k) = (max_disp(&soft).0, max_disp(&stiff).0);
    println!(
        "four-bar: max |elastic displacement| {s:.3e} m (E), {k:.3e} m (1e3 E), ratio {:.2e}",
        k / s
    );
    assert!(k / s >= 0.2e-3 && k / s <= 2e-3, "ratio {}", k / s);
    assert!(k < 1e-5 * 0.35);
}

// ------------------------------------------------------------------------------------------------
// 7. Clearance joints in a mechanism: the contact must be implicit

/// Implicit contact: the modified coupling with kappa iterated (Newton on the contact spring).
fn implicit() -> Coupling {
    Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    }
}

/// A linear spring-dashpot bearing with viscous damping.
fn bearing(stiffness: f64, damping: f64) -> Arc<SpringDamper> {
    Arc::new(SpringDamper {
        stiffness,
        damping,
        damping_law: DampingLaw::Viscous,
        no_tension: false,
    })
}

/// Simeon's slider-crank with the crank pin replaced by a clearance joint of 0.5 mm (the data of
/// `flexclear.scenes.slider_crank(clearance_at="crank_pin", bearing_damping_ratio=0.03)`:
/// K_B = 1.0866e8 N/m, the Hertz secant at 10 um; C_B = 171.9 N s/m, 3 % of critical for half
/// the rod mass, a restitution of about 0.9).
fn slider_crank_with_crank_pin_clearance(geometric: Option<bool>) -> Mechanism {
    FlexibleSliderCrank {
        elements: 8,
        geometric,
        clearance_at: Some(SliderCrankPin::CrankPin),
        clearance: 5e-4,
        bearing_stiffness: Some(1.0866e8),
        bearing_damping: Some(171.9),
        ..Default::default()
    }
    .build()
    .unwrap()
}

#[test]
fn slider_crank_clearance_converges_with_implicit_contact_and_the_lagged_kappa_pumps_energy() {
    // Diagnosis of the reported failures (restitution 0.9 diverging with MN contact forces): the
    // lagged kappa of the modified method (and the force method) apply the contact spring of the
    // last state, too weak while the journal goes in and too strong while it comes out, so each
    // impact adds energy (of order dt over the contact time); with little bearing damping it
    // accumulates. It is not the rod buckling: without the geometric terms the run explodes the
    // same way, and with implicit contact the rod's compression stays below half its Euler load.
    let euler = std::f64::consts::PI.powi(2) * 2e11 * 0.008f64.powi(4) / 12.0 / 0.09; // 7.49 kN
    let run = |dt: f64, coupling: Coupling, geometric: Option<bool>| {
        let mech = slider_crank_with_crank_pin_clearance(geometric);
        let mut s = Settings::new(0.05, dt);
        s.coupling = coupling;
        s.record = RecordSpec {
            every: 1,
            links: LinkChannels {
                displacements: false,
                axial_force: true,
                midspan: false,
                energy: false,
                peaks: false,
            },
            ..RecordSpec::default()
        };
        simulate_mechanism(&mech, &s, &mut |_| true)
    };
    // Implicit contact: peak contact force and penetration converge under dt refinement
    // (measured: 8083, 8218, 8198 N and 74.5, 75.6, 75.4 um at dt = 1e-5, 5e-6, 2.5e-6 s; 8192 N
    // at 1.25e-6 s). Tolerance 3 % on the force and 2 % on the penetration against the finest.
    let mut peaks = Vec::new();
    for dt in [1e-5, 5e-6, 2.5e-6] {
        let out = run(dt, implicit(), None).unwrap();
        let j = &out.record.extremes[0];
        let comp = -out.record.links[0].axial_force.iter().fold(0.0f64, |m, &f| m.min(f));
        println!(
            "implicit dt = {dt:e}: peak force {:.1} N, penetration {:.2} um, {} impacts, rod compression {comp:.0} N (Euler {euler:.0} N), {} iterations in {} steps",
            j.max_force,
            j.max_penetration * 1e6,
            j.impacts,
            out.stats.iterations,
            out.stats.steps
        );
        assert!(comp < 0.5 * euler, "compression {comp} N");
        peaks.push((j.max_force, j.max_penetration));
    }
    let (f_ref, p_ref) = peaks[2];
    for &(f, p) in &peaks[..2] {
        assert!((f / f_ref - 1.0).abs() < 0.03, "peak force {f} vs {f_ref} N");
        assert!((p / p_ref - 1.0).abs() < 0.02, "penetration {p} vs {p_ref} m");
    }
    // The same pin is a spring of K_B = 1.1e8 N/m: a peak of 8.2 kN is a penetration of 75 um,
    // consistent with the recorded one (the damping force adds to the spring's).
    assert!(f_ref > 1.0866e8 * p_ref && f_ref < 1.2 * 1.0866e8 * p_ref);
    // The lagged kappa at dt = 1e-5 s, with the geometric terms off (no buckling possible):
    // the run completes, with contact forces beyond 100 times the converged peak.
    let lagged = Coupling::Modified {
        iterate: false,
        tol: 1e-10,
        max_iter: 50,
    };
    let out = run(1e-5, lagged, Some(false)).unwrap();
    println!(
        "lagged kappa, no geometric terms: peak {:.3e} N",
        out.record.extremes[0].max_force
    );
    assert!(out.record.extremes[0].max_force > 100.0 * f_ref);
    // With them, it fails (measured: diverged at t = 17.6 ms).
    assert!(run(1e-5, lagged, None).is_err());
}

/// Simeon's slider-crank with a flexible crank: link 0 the rod, link 1 the crank (0.15 m, 8 x 8
/// mm steel, 4 elements) in the crank frame, clamped to it at the pivot (node 0). The crank pin
/// joins rod node 0 and crank node 4: an ideal pin, or a clearance joint with `law`.
fn flexible_crank_slider_crank(pin: Option<(f64, Arc<SpringDamper>)>) -> Mechanism {
    let mut m = slider_crank(2e11, 8);
    let crank_frame = match &m.pins[0].b {
        Endpoint::Body { frame, .. } => frame.clone(),
        _ => unreachable!(),
    };
    let a = 0.008f64;
    m.links.push(link(
        "crank",
        0.15,
        4,
        2e11,
        7870.0,
        a * a,
        a.powi(4) / 12.0,
        crank_frame,
    ));
    m.supports.push(Support {
        link: 1,
        node: 0,
        fixed: [true; 3],
    });
    let rod0 = Endpoint::Node { link: 0, node: 0 };
    let crank4 = Endpoint::Node { link: 1, node: 4 };
    m.pins.remove(0);
    match pin {
        None => m.pins.push(Pin {
            name: "A".into(),
            a: rod0,
            b: crank4,
        }),
        Some((clearance, law)) => m.joints.push(Clearance {
            friction: None,
            name: "A".into(),
            journal: rod0,
            bearing: crank4,
            clearance,
            law,
        }),
    }
    m
}

#[test]
fn clearance_between_two_flexible_links_reduces_to_the_ideal_pin_when_stiff_and_tight() {
    // The 2-node pattern of docs/method.md section 4: the journal is the rod's node 0, the bearing the
    // flexible crank's tip. With no clearance and K_B = 1e10 N/m (30 times the axial stiffness
    // EA/l_e = 3.4e8 N/m of a rod element) the joint is a stiff pin.
    // A damping of 20 % of critical (for 0.03 kg, the rod's end mass) keeps the joint's own mode
    // (about 6e5 rad/s) from ringing. Measured over 0 to 0.03 s at dt = 1e-5 s: midspan
    // deflections (rod 10.0 mm, crank 3.4 mm at most: the 8 x 8 mm crank is flexible) differ
    // from the ideal pin's by 0.1 % and 0.3 % of their largest value (tolerance 1 %); the joint
    // carries up to 2.5 kN at a compression of 0.25 um (= F / K_B).
    let run = |m: &Mechanism, coupling: Coupling| {
        let mut s = Settings::new(0.03, 1e-5);
        s.coupling = coupling;
        s.record = RecordSpec {
            every: 10,
            links: LinkChannels {
                displacements: true,
                axial_force: false,
                midspan: true,
                energy: false,
                peaks: false,
            },
            ..RecordSpec::default()
        };
        simulate_mechanism(m, &s, &mut |_| true).unwrap()
    };
    let k_b = 1e10;
    let c_b = 2.0 * 0.2 * (k_b * 0.03f64).sqrt();
    let ideal = run(&flexible_crank_slider_crank(None), Coupling::default());
    let stiff = run(&flexible_crank_slider_crank(Some((0.0, bearing(k_b, c_b)))), implicit());
    let diff = |a: &[f64], b: &[f64]| {
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let d = a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        (d, scale)
    };
    for li in 0..2 {
        let (d, scale) = diff(&ideal.record.links[li].midspan, &stiff.record.links[li].midspan);
        println!("link {li}: midspan max {scale:.4e} m, max difference {d:.3e} m");
        assert!(d < 0.01 * scale, "link {li}: {d} vs {scale}");
    }
    let j = &stiff.record.extremes[0];
    println!(
        "stiff pin: peak force {:.1} N, largest compression {:.3e} m",
        j.max_force, j.max_penetration
    );
    assert!(j.max_penetration < 1e-6);
}

#[test]
fn free_links_meeting_in_a_clearance_joint_keep_energy_and_angular_momentum() {
    // Two free-free steel links (0.3 m, 8 x 8 mm, 6 elements) lie along x on either side of the
    // origin (frames at rest at the origin, angles pi and 0), joined only by an undamped
    // clearance joint between their nodes 0 (c = 0.1 mm, K_B = 1e8 N/m). Link A starts in
    // translation at 1 m/s along its local y (global -y), B at rest. No external force: the
    // contact force pair is equal and opposite and, for the spring, central, so the angular
    // momentum about the origin is conserved exactly; the energy kinetic + strain + K_B delta^2/2
    // is conserved by the average-acceleration rule up to what the contact edge costs within a
    // step. Implicit contact, measured over 0 to 0.01 s at dt = 1e-6 s: 84 impacts, energy
    // within 7e-4 (tolerance 5e-3), angular momentum within 7e-14 of its largest value
    // (tolerance 1e-9). The lagged kappa gains energy at every impact: +169 % after 22 impacts
    // (4 ms; 1.6e5 times the initial energy by 6 ms); the force method likewise (+846 % after 35 impacts).
    let a = 0.008f64;
    let mk = |name: &str, angle: f64| {
        link(
            name,
            0.3,
            6,
            2e11,
            7870.0,
            a * a,
            a.powi(4) / 12.0,
            hub(Rotation::Fixed { angle }),
        )
    };
    let mut la = mk("A", std::f64::consts::PI);
    let mut v0 = vec![0.0; 21];
    for nd in 0..7 {
        v0[3 * nd + 1] = 1.0;
    }
    la.initial_velocity = Some(v0);
    let k_b = 1e8;
    let mech = Mechanism {
        links: vec![la, mk("B", 0.0)],
        joints: vec![Clearance {
            friction: None,
            name: "J".into(),
            journal: Endpoint::Node { link: 0, node: 0 },
            bearing: Endpoint::Node { link: 1, node: 0 },
            clearance: 1e-4,
            law: bearing(k_b, 0.0),
        }],
        ..Default::default()
    };
    let run = |coupling: Coupling, t_end: f64| {
        let mut s = Settings::new(t_end, 1e-6);
        s.coupling = coupling;
        s.record = RecordSpec {
            every: 10,
            links: LinkChannels {
                displacements: false,
                axial_force: false,
                midspan: false,
                energy: true,
                peaks: false,
            },
            ..RecordSpec::default()
        };
        let out = simulate_mechanism(&mech, &s, &mut |_| true).expect("the run completes");
        let n = out.record.time.len();
        let pen = &out.record.joints[0].penetration;
        let energy: Vec<f64> = (0..n)
            .map(|i| {
                let links: f64 = out.record.links.iter().map(|h| h.kinetic[i] + h.strain[i]).sum();
                links + 0.5 * k_b * pen[i].max(0.0).powi(2)
            })
            .collect();
        let momentum: Vec<f64> = (0..n)
            .map(|i| out.record.links.iter().map(|h| h.momentum[i]).sum())
            .collect();
        let e_dev = energy.iter().fold(0.0f64, |m, e| m.max((e / energy[0] - 1.0).abs()));
        let h_scale = out.record.links[0]
            .momentum
            .iter()
            .fold(0.0f64, |m, h| m.max(h.abs()))
            .max(1e-300);
        let h_dev = momentum.iter().fold(0.0f64, |m, h| m.max((h - momentum[0]).abs())) / h_scale;
        println!(
            "{coupling:?}: {} impacts, peak force {:.1} N, energy {:.6e} J -> {:.6e} J (largest deviation {:.3e}), angular momentum deviation {:.3e} of {:.3e}",
            out.record.extremes[0].impacts,
            out.record.extremes[0].max_force,
            energy[0],
            energy[n - 1],
            e_dev,
            h_dev,
            h_scale
        );
        (
            out.record.extremes[0].impacts,
            e_dev,
            h_dev,
            energy[n - 1] / energy[0] - 1.0,
        )
    };
    let (impacts, e_dev, h_dev, _) = run(implicit(), 0.01);
    assert!(impacts >= 20, "{impacts} impacts");
    assert!(e_dev < 5e-3, "energy deviation {e_dev}");
    assert!(h_dev < 1e-9, "angular momentum deviation {h_dev}");
    // Explicit in the contact, the same run gains energy at every impact.
    for coupling in [Coupling::default(), Coupling::Force] {
        let (_, _, h_dev, gain) = run(coupling, 0.004);
        assert!(gain > 0.5, "{coupling:?}: energy gain {gain}");
        assert!(h_dev < 1e-9);
    }
}

/// A slider-crank run of `t_end` s at 1e-5 s with `record`, with the clearance joint at the crank
/// pin (or ideal pins).
fn crank_run(clearance: bool, t_end: f64, record: RecordSpec) -> RunOutput {
    let mech = FlexibleSliderCrank {
        clearance_at: clearance.then_some(SliderCrankPin::CrankPin),
        clearance: 2e-4,
        ..Default::default()
    }
    .build()
    .unwrap();
    let mut settings = Settings::new(t_end, 1e-5);
    settings.record = record;
    simulate_mechanism(&mech, &settings, &mut |_| true).unwrap()
}

/// The reference of a run's slider histories.
fn reference_of(out: &RunOutput) -> Arc<SliderReference> {
    let sliders = (out.record.sliders.iter())
        .map(|s| {
            (
                s.name.clone(),
                [s.position.clone(), s.velocity.clone(), s.acceleration.clone()],
            )
        })
        .collect();
    Arc::new(SliderReference::new(out.record.time.clone(), sliders).unwrap())
}

#[test]
fn slider_deviations_online_equal_those_of_the_histories_and_memory_is_o_outputs() {
    let (every, start) = (3, 1e-3);
    let bare = RecordSpec {
        histories: false,
        every,
        start,
        links: LinkChannels {
            displacements: false,
            ..LinkChannels::default()
        },
        ..RecordSpec::default()
    };
    let ideal = crank_run(
        false,
        4e-3,
        RecordSpec {
            sliders: true,
            ..bare.clone()
        },
    );
    let reference = reference_of(&ideal);
    // the sample with its histories: the deviations the history-based way
    let full = crank_run(
        true,
        4e-3,
        RecordSpec {
            sliders: true,
            slider_reference: Some(reference.clone()),
            ..bare.clone()
        },
    );
    let h = &full.record.sliders[0];
    let keep: Vec<bool> = full.record.time.iter().map(|&t| t >= start).collect();
    for (c, (x, r)) in [
        (&h.position, &reference.sliders[0].1[0]),
        (&h.velocity, &reference.sliders[0].1[1]),
        (&h.acceleration, &reference.sliders[0].1[2]),
    ]
    .into_iter()
    .enumerate()
    {
        let d: Vec<f64> = (x.iter().zip(r).zip(&keep))
            .filter(|(_, &k)| k)
            .map(|((a, b), _)| (a - b).abs())
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let max = d.iter().fold(0.0f64, |m, &v| m.max(v));
        assert!(max > 0.0);
        assert_eq!(h.deviation_peak()[c], max);
        assert!(
            (h.deviation_mean()[c] - mean).abs() <= 1e-14 * mean,
            "{c}: {} {mean}",
            h.deviation_mean()[c]
        );
    }
    // without histories: the same deviations and peak, and nothing per output point
    let run = |t_end: f64, reference: Option<Arc<SliderReference>>| {
        crank_run(
            true,
            t_end,
            RecordSpec {
                slider_reference: reference,
                ..bare.clone()
            },
        )
    };
    let lean = run(4e-3, Some(reference.clone()));
    let s = &lean.record.sliders[0];
    assert_eq!(
        (s.deviation_mean(), s.deviation_peak()),
        (h.deviation_mean(), h.deviation_peak())
    );
    assert_eq!(s.max_acceleration, h.max_acceleration);
    let stored = |o: &RunOutput| {
        let r = &o.record;
        r.time.len()
            + r.links
                .iter()
                .map(|l| l.frame.len() * 4 + l.displacements.len() + l.midspan.len())
                .sum::<usize>()
            + r.sliders
                .iter()
                .map(|s| s.position.len() + s.velocity.len() + s.acceleration.len())
                .sum::<usize>()
            + r.joints
                .iter()
                .map(|j| j.penetration.len() + j.force.len())
                .sum::<usize>()
    };
    assert_eq!(stored(&lean), 0);
    assert_eq!(stored(&run(1e-3, None)), stored(&run(4e-3, None)));
    // an ideal joint deviates by exactly 0 from the ideal run
    let same = crank_run(
        false,
        4e-3,
        RecordSpec {
            slider_reference: Some(reference.clone()),
            ..bare.clone()
        },
    );
    assert_eq!(same.record.sliders[0].deviation_peak(), [0.0; 3]);
    // a reference on another grid is refused, naming the parameter
    let mech = FlexibleSliderCrank::default().build().unwrap();
    for (t_end, every) in [(5e-3, every), (4e-3, 2)] {
        let mut settings = Settings::new(t_end, 1e-5);
        settings.record = RecordSpec {
            every,
            slider_reference: Some(reference.clone()),
            ..bare.clone()
        };
        let e = simulate_mechanism(&mech, &settings, &mut |_| true).err().unwrap().error;
        assert!(e.to_string().contains("record.slider_reference"), "{e}");
    }
}

// ------------------------------------------------------------------------------------------------
// Link peaks (issue 14 item 3): running maxima over every step, O(1) memory per link
// ------------------------------------------------------------------------------------------------

/// Largest magnitude in `v`.
fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

#[test]
fn link_peaks_are_the_maxima_of_the_channels_over_every_step_and_leave_the_run_unchanged() {
    // The crank-pin slider-crank over its impact phase (5 ms: 3 impacts): with the midspan and
    // axial-force channels kept at every step, the tracked peaks are exactly their largest
    // magnitudes (the same operations on the same states); with a stride of 7 the channels skip
    // steps and their maxima can only be smaller. Tracking reads the state and changes nothing:
    // the joint extremes and the final state are bitwise those of a run without it.
    let channels = |peaks: bool| LinkChannels {
        displacements: false,
        axial_force: true,
        midspan: true,
        energy: false,
        peaks,
    };
    let run = |peaks: bool, every: usize| {
        crank_run(
            true,
            5e-3,
            RecordSpec {
                every,
                links: channels(peaks),
                ..RecordSpec::default()
            },
        )
    };
    let (tracked, plain, strided) = (run(true, 1), run(false, 1), run(true, 7));
    assert_eq!(tracked.record.extremes, plain.record.extremes);
    assert_eq!(tracked.state, plain.state);
    for (li, (h, s)) in tracked.record.links.iter().zip(&strided.record.links).enumerate() {
        assert!(plain.record.links[li].peaks.is_none());
        let Some(p) = h.peaks else {
            // the crank and the slider are rigid
            assert!(
                h.axial_force.is_empty() || h.midspan.iter().all(|&m| m == 0.0),
                "link {li}"
            );
            continue;
        };
        println!(
            "link {li}: peak midspan {:.4e} m, peak axial force {:.1} N",
            p.midspan, p.axial_force
        );
        assert!(p.midspan > 0.0 && p.axial_force > 0.0);
        assert_eq!(p.midspan, max_abs(&h.midspan));
        assert_eq!(p.axial_force, max_abs(&h.axial_force));
        assert_eq!(s.peaks, Some(p), "the stride does not thin the peaks");
        assert!(max_abs(&s.midspan) <= p.midspan && max_abs(&s.axial_force) <= p.axial_force);
    }
    assert!(tracked.record.links.iter().any(|h| h.peaks.is_some()));
}

#[test]
fn link_peaks_of_a_beam_held_in_its_static_state_are_the_static_solution() {
    // A pinned-pinned steel beam (1 m, EI = 200 N m^2, EA = 2e7 N, 8 elements) started in the
    // static state of its load stays there (the start is an equilibrium of the discrete model to
    // rounding), so its peaks are the static ones:
    // - a central transverse load P = 10 N: the midspan deflection P L^3 / (48 EI) = 1.0417 mm.
    //   Hermite elements are exact at the nodes for nodal loads, so the analytic nodal state
    //   v = P x (3 L^2 - 4 x^2) / (48 EI), theta = v' (x <= L/2, mirrored) is the discrete one;
    // - an axial tip load P = 5 kN on the roller: every element carries F with
    //   F + F^2 / EA = P (the K3 term, see axially_loaded_pinned_beam_frequency_follows_the_load),
    //   u = F x / EA.
    // Tolerance 1e-9 relative: what moves the state is the residual of the analytic start in
    // floating point.
    let (l, n, ei, ea) = (1.0f64, 8usize, 2e11 * 1e-9, 2e11 * 1e-4);
    let run = |mech: Mechanism| {
        let mut s = Settings::new(0.01, 1e-4);
        s.record = RecordSpec {
            histories: false,
            links: LinkChannels {
                displacements: false,
                peaks: true,
                ..LinkChannels::NONE
            },
            ..RecordSpec::default()
        };
        let out = simulate_mechanism(&mech, &s, &mut |_| true).unwrap();
        assert!(out.record.time.is_empty(), "no output grid without histories");
        out.record.links[0].peaks.expect("a flexible link's peaks")
    };
    // transverse
    let p: f64 = 10.0;
    let mut bent = pinned_pinned(n, 0.0);
    bent.loads[0] = NodalLoad {
        link: 0,
        node: n / 2,
        force: [0.0, -p],
        moment: 0.0,
    };
    let mut y0 = vec![0.0; 3 * (n + 1)];
    for k in 0..=n {
        let x = l * k as f64 / n as f64;
        let (xs, sign) = if x <= 0.5 * l { (x, 1.0) } else { (l - x, -1.0) };
        y0[3 * k + 1] = -p * xs * (3.0 * l * l - 4.0 * xs * xs) / (48.0 * ei);
        y0[3 * k + 2] = -sign * p * (3.0 * l * l - 12.0 * xs * xs) / (48.0 * ei);
    }
    bent.links[0].initial_displacement = Some(y0);
    let peaks = run(bent);
    let delta = p * l.powi(3) / (48.0 * ei);
    println!("transverse: peak midspan {:.9e} m, static {delta:.9e} m", peaks.midspan);
    assert!((peaks.midspan - delta).abs() <= 1e-9 * delta);
    assert!(peaks.axial_force <= 1e-9 * p, "{}", peaks.axial_force);
    // axial
    let p: f64 = 5e3;
    let f = 0.5 * ea * ((1.0 + 4.0 * p / ea).sqrt() - 1.0);
    let mut pulled = pinned_pinned(n, p);
    let mut y0 = vec![0.0; 3 * (n + 1)];
    for k in 0..=n {
        y0[3 * k] = f * (l * k as f64 / n as f64) / ea;
    }
    pulled.links[0].initial_displacement = Some(y0);
    let peaks = run(pulled);
    println!("axial: peak axial force {:.9e} N, static {f:.9e} N", peaks.axial_force);
    assert!((peaks.axial_force - f).abs() <= 1e-9 * f);
    assert!(peaks.midspan <= 1e-12, "{}", peaks.midspan);
}
