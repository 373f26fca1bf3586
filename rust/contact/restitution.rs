//! The restitution a normal law actually achieves: one impact of a point mass against the law,
//! integrated to high accuracy.
//!
//! A mass `m` meets the surface at speed `v0` (m/s): `m d'' = -F(d, d', v0)`, `d(0) = 0`,
//! `d'(0) = v0`, until the mass leaves (`d` back to 0 with `d' < 0`). The effective restitution
//! is `-d'(exit) / v0`. The nominal `e` of a law and its effective value differ because the
//! laws' `chi(e)` come from approximate energy balances (`docs/contact.md`).
//!
//! The equation is integrated in the scaled variables `y = d / L`, `s = t v0 / L` with
//! `L = (m v0^2 / K)^(1 / (n + 1))` (the penetration scale of the impact) by the Dormand-Prince
//! 5(4) pair with a local error tolerance of 1e-12 on `y` and `y'`; the peak and the exit are
//! located within their step by a secant/bisection search on the step length (each trial an
//! exact Runge-Kutta step), so neither is interpolated. For the laws of the form
//! `K d^n (1 + chi dd / v0)` the scaled equation does not depend on `m`, `v0` or `K`: the
//! effective restitution depends on `chi` and `n` only.

use super::laws::NormalLaw;
use crate::error::{check_positive, Error, Result};

/// One impact against a normal law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Effective coefficient of restitution: exit speed over approach speed.
    pub restitution: f64,
    /// Duration of contact, s.
    pub contact_time: f64,
    /// Largest penetration, m.
    pub max_penetration: f64,
}

/// Local error tolerance per step in the scaled variables (order 1 over the impact).
const TOL: f64 = 1e-12;
/// Step cap: an impact takes a few hundred steps at this tolerance; a law that holds the mass
/// longer (a sticky law without clipping) ends with an error.
const MAX_STEPS: usize = 200_000;
/// Scaled-time cap: the undamped Hertz impact lasts 3.2 scaled units; 1e4 is "never separates".
const MAX_TIME: f64 = 1e4;

/// Integrates one impact of a mass `mass` (kg) arriving at `approach_speed` (m/s) against
/// `law`, whose `v0` is the approach speed. Errors: invalid law parameters, mass or speed not
/// finite and > 0 ([`Error::InvalidParameter`] naming `mass` or `approach_speed`); a mass that
/// does not leave the surface within 1e4 scaled time units or 200 000 steps
/// ([`Error::NotConverged`], `time` = the scaled time reached, `step` = steps done).
pub fn effective_restitution(law: &dyn NormalLaw, mass: f64, approach_speed: f64) -> Result<Impact> {
    law.validate("law")?;
    check_positive("mass", mass, "kg")?;
    check_positive("approach_speed", approach_speed, "m/s")?;
    let (k, n, v0) = (law.stiffness(), law.exponent(), approach_speed);
    let l = (mass * v0 * v0 / k).powf(1.0 / (n + 1.0));
    if !(l.is_finite() && l > 0.0) {
        return Err(Error::param(
            "mass, approach_speed",
            format!("{mass:e} kg, {v0:e} m/s"),
            format!("a penetration scale (m v0^2 / K)^(1/(n+1)) that is finite and > 0 for K = {k:e}"),
        ));
    }
    // scaled acceleration: y'' = -F(L y, v0 y', v0) L / (m v0^2)
    let scale = l / (mass * v0 * v0);
    let rhs = |x: [f64; 2]| -> [f64; 2] { [x[1], -scale * law.force(l * x[0], v0 * x[1], v0)] };
    let mut x = [0.0, 1.0];
    let mut s = 0.0;
    let mut h = 1e-3;
    let mut y_max = 0.0f64;
    let mut steps = 0usize;
    loop {
        if steps >= MAX_STEPS || s > MAX_TIME {
            return Err(Error::NotConverged {
                time: s,
                step: steps as u64,
                iterations: steps,
                residual: x[0],
                correction: x[1],
            });
        }
        steps += 1;
        let (x1, err) = dopri_step(&rhs, x, h);
        let err_norm = err[0].abs().max(err[1].abs());
        if !(err_norm.is_finite() && x1[0].is_finite() && x1[1].is_finite()) {
            h *= 0.1;
            continue;
        }
        if err_norm > TOL {
            h *= (0.9 * (TOL / err_norm).powf(0.2)).max(0.1);
            continue;
        }
        // peak: y' changes sign within the step
        if x[1] > 0.0 && x1[1] <= 0.0 {
            let hp = locate(&rhs, x, h, |z| z[1]);
            y_max = y_max.max(dopri_step(&rhs, x, hp).0[0]);
        }
        y_max = y_max.max(x1[0]);
        // exit: y crosses 0 downward
        if x1[0] <= 0.0 && x1[1] < 0.0 {
            let he = locate(&rhs, x, h, |z| z[0]);
            let xe = dopri_step(&rhs, x, he).0;
            let t = (s + he) * l / v0;
            return Ok(Impact {
                restitution: -xe[1],
                contact_time: t,
                max_penetration: y_max * l,
            });
        }
        x = x1;
        s += h;
        let grow = if err_norm > 0.0 {
            (0.9 * (TOL / err_norm).powf(0.2)).min(5.0)
        } else {
            5.0
        };
        h *= grow;
    }
}

/// The step length `hs` in (0, h] where `g(step(x, hs))` changes sign (`g(x) > 0`,
/// `g(step(x, h)) <= 0`): Illinois-modified regula falsi, bisection as a safeguard, to a
/// relative step accuracy of 1e-15.
fn locate<F, G>(rhs: &F, x: [f64; 2], h: f64, g: G) -> f64
where
    F: Fn([f64; 2]) -> [f64; 2],
    G: Fn([f64; 2]) -> f64,
{
    let (mut a, mut b) = (0.0, h);
    let (mut ga, mut gb) = (g(x), g(dopri_step(rhs, x, h).0));
    let mut side = 0i32;
    for _ in 0..200 {
        if (b - a) <= 1e-15 * h {
            break;
        }
        let mut m = if ga != gb {
            b - gb * (b - a) / (gb - ga)
        } else {
            0.5 * (a + b)
        };
        if !(m > a && m < b) {
            m = 0.5 * (a + b);
        }
        let gm = g(dopri_step(rhs, x, m).0);
        if gm == 0.0 {
            return m;
        }
        if (gm > 0.0) == (ga > 0.0) {
            a = m;
            ga = gm;
            if side == -1 {
                gb *= 0.5;
            }
            side = -1;
        } else {
            b = m;
            gb = gm;
            if side == 1 {
                ga *= 0.5;
            }
            side = 1;
        }
    }
    if ga.abs() < gb.abs() {
        a
    } else {
        b
    }
}

/// One Dormand-Prince 5(4) step: the fifth-order solution and the difference to the embedded
/// fourth-order one (the local error estimate).
fn dopri_step<F: Fn([f64; 2]) -> [f64; 2]>(f: &F, x: [f64; 2], h: f64) -> ([f64; 2], [f64; 2]) {
    const A: [[f64; 6]; 6] = [
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
            0.0,
            0.0,
        ],
        [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
            0.0,
        ],
        [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    const B5: [f64; 7] = [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ];
    const B4: [f64; 7] = [
        5179.0 / 57600.0,
        0.0,
        7571.0 / 16695.0,
        393.0 / 640.0,
        -92097.0 / 339200.0,
        187.0 / 2100.0,
        1.0 / 40.0,
    ];
    let mut k = [[0.0; 2]; 7];
    k[0] = f(x);
    for i in 0..6 {
        let mut xi = x;
        for j in 0..=i {
            xi[0] += h * A[i][j] * k[j][0];
            xi[1] += h * A[i][j] * k[j][1];
        }
        k[i + 1] = f(xi);
    }
    let mut x5 = x;
    let mut e = [0.0; 2];
    for i in 0..7 {
        for c in 0..2 {
            x5[c] += h * B5[i] * k[i][c];
            e[c] += h * (B5[i] - B4[i]) * k[i][c];
        }
    }
    (x5, e)
}

#[cfg(test)]
mod tests {
    use super::super::laws::{
        CarvalhoMartins, Flores, Gonthier, Hertz, HuntCrossley, KelvinVoigt, LankaraniNikravesh, NormalLaw,
    };
    use super::*;

    #[test]
    fn undamped_hertz_matches_the_closed_forms() {
        // Hertz impact (Johnson 1985, ch. 11; Goldsmith 1960): peak (5 m v0^2 / (4 K))^(2/5),
        // duration 3.2181 (m/K)^(2/5) v0^(-1/5); the constant 3.2181 is given to 5 digits, so the
        // duration is checked to 2e-5 relative, the peak and e = 1 to 1e-9 (integration error)
        for (m, k, v0) in [
            (1.0, 1e10, 1.0),
            (0.14, 6.61e10, 0.3),
            (1e-3, 1e3, 20.0),
            (50.0, 1e13, 1e-3),
        ] {
            let imp = effective_restitution(&Hertz::new(k), m, v0).unwrap();
            let peak = (5.0 * m * v0 * v0 / (4.0 * k)).powf(0.4);
            let time = 3.2181 * (m / k).powf(0.4) * v0.powf(-0.2);
            assert!((imp.restitution - 1.0).abs() < 1e-9, "{imp:?}");
            assert!((imp.max_penetration / peak - 1.0).abs() < 1e-9, "{imp:?} {peak}");
            assert!((imp.contact_time / time - 1.0).abs() < 2e-5, "{imp:?} {time}");
            // = 2.9433 delta_max / v0 (4 digits given)
            assert!((imp.contact_time / (2.9433 * peak / v0) - 1.0).abs() < 5e-5);
        }
    }

    #[test]
    fn linear_spring_dashpot_matches_the_closed_form() {
        // unclipped spring-dashpot leaving at d = 0: e = exp(-zeta pi / sqrt(1 - zeta^2)), contact
        // time pi / omega_d (exact); 1e-9 covers the integration error
        for zeta in [0.0, 0.05, 0.3, 0.7] {
            let (m, k) = (2.0f64, 5e7f64);
            let c = 2.0 * zeta * (k * m).sqrt();
            let imp = effective_restitution(&KelvinVoigt::new(k, c), m, 0.7).unwrap();
            let e = (-zeta * std::f64::consts::PI / (1.0f64 - zeta * zeta).sqrt()).exp();
            let wd = (k / m).sqrt() * (1.0f64 - zeta * zeta).sqrt();
            assert!((imp.restitution - e).abs() < 1e-9, "zeta {zeta}: {imp:?} vs {e}");
            assert!(
                (imp.contact_time * wd / std::f64::consts::PI - 1.0).abs() < 1e-9,
                "{imp:?}"
            );
        }
    }

    #[test]
    fn effective_restitution_is_independent_of_mass_speed_and_stiffness() {
        // the scaled impact equation contains only chi and n: equal to integration accuracy
        for law in [
            Box::new(LankaraniNikravesh::new(1e9, 0.5)) as Box<dyn NormalLaw>,
            Box::new(Flores::new(1e9, 0.5)),
        ] {
            let e0 = effective_restitution(law.as_ref(), 1.0, 1.0).unwrap().restitution;
            for (m, v0) in [(1e-3, 1e-2), (100.0, 30.0), (0.14, 0.5)] {
                let e = effective_restitution(law.as_ref(), m, v0).unwrap().restitution;
                assert!((e - e0).abs() < 1e-9, "{} {m} {v0}: {e} vs {e0}", law.name());
            }
        }
    }

    #[test]
    fn table_of_contact_md() {
        // ../shared/CONTACT.md section 1 (computed independently there, 3 digits): +-6e-4
        let cases: [(&dyn NormalLaw, f64); 6] = [
            (&LankaraniNikravesh::new(1e9, 0.9), 0.913),
            (&HuntCrossley::new(1e9, 0.9), 0.909),
            (&Flores::new(1e9, 0.9), 0.894),
            (&LankaraniNikravesh::new(1e9, 0.5), 0.725),
            (&HuntCrossley::new(1e9, 0.5), 0.663),
            (&Flores::new(1e9, 0.5), 0.470),
        ];
        for (law, expect) in cases {
            let e = effective_restitution(law, 1.0, 1.0).unwrap().restitution;
            assert!((e - expect).abs() <= 6e-4, "{law:?}: {e} vs {expect}");
        }
    }

    #[test]
    fn carvalho_martins_achieves_its_nominal_restitution() {
        // their chi(e) approximates the exact restitution of the Hunt-Crossley form; measured
        // here within 2e-4 for e >= 0.5 (4e-3 at e = 0.3, diverging below: Gonthier there)
        for e in [0.5, 0.7, 0.9, 0.95, 0.99, 1.0] {
            let got = effective_restitution(&CarvalhoMartins::new(1e9, e), 1.0, 1.0)
                .unwrap()
                .restitution;
            assert!((got - e).abs() <= 5e-4, "{e}: {got}");
        }
    }

    #[test]
    fn extremes_give_finite_values() {
        for k in [1e3, 1e13] {
            for e in [0.01, 0.5, 1.0] {
                let laws: [Box<dyn NormalLaw>; 4] = [
                    Box::new(Gonthier::new(k, e)),
                    Box::new(Flores::new(k, e)),
                    Box::new(CarvalhoMartins::new(k, e)),
                    Box::new(LankaraniNikravesh::new(k, e)),
                ];
                for law in laws {
                    let imp = effective_restitution(law.as_ref(), 0.1, 0.5).unwrap();
                    assert!(
                        imp.restitution.is_finite() && (0.0..=1.0 + 1e-9).contains(&imp.restitution),
                        "{law:?} {imp:?}"
                    );
                    assert!(imp.contact_time.is_finite() && imp.max_penetration.is_finite());
                }
            }
        }
        assert!(matches!(
            effective_restitution(&Hertz::new(1e9), 0.0, 1.0),
            Err(Error::InvalidParameter { ref name, .. }) if name == "mass"
        ));
    }
}
