use super::*;
use crate::model::Table;

// Finite-difference checks. Central differences with step h have truncation error
// ~ h^2 |f'''| / 6 and round-off ~ eps |f| / h. The motions below have time scales of
// 0.05 s or more (rates <= ~20 rad/s, frequencies <= 2 Hz), so with h = 1e-5 s the truncation
// error is ~ (20 * 1e-5)^2 / 6 ~ 1e-8 relative and the round-off ~ 1e-16 / 1e-5 ~ 1e-11
// relative: a tolerance of 1e-6 relative to the quantity's magnitude (over the whole run, so
// that zero crossings do not demand absolute precision) leaves two orders of margin both ways.
const H: f64 = 1e-5;
const FD_TOL: f64 = 1e-6;

fn assert_close(label: &str, t: f64, got: f64, want: f64, scale: f64) {
    let tol = FD_TOL * want.abs().max(scale).max(1e-12);
    assert!(
        (got - want).abs() <= tol,
        "{label} at t = {t}: finite difference {got} vs exact {want} (tol {tol})"
    );
}

fn times(t0: f64, t1: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| t0 + (t1 - t0) * i as f64 / (n - 1) as f64).collect()
}

fn max_abs(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(0.0, |m, x| m.max(x.abs()))
}

/// Checks rate/accel of `(angle, rate, accel)` against central differences.
fn check_angles(label: &str, f: impl Fn(f64) -> (f64, f64, f64), ts: &[f64]) {
    let rs = max_abs(ts.iter().map(|&t| f(t).1));
    let as_ = max_abs(ts.iter().map(|&t| f(t).2));
    for &t in ts {
        let (p, m, x) = (f(t + H), f(t - H), f(t));
        assert_close(&format!("{label} rate"), t, (p.0 - m.0) / (2.0 * H), x.1, rs);
        assert_close(&format!("{label} accel"), t, (p.1 - m.1) / (2.0 * H), x.2, as_);
    }
}

/// Checks a point's velocity/acceleration against central differences.
fn check_point(label: &str, f: impl Fn(f64) -> Kinematics, ts: &[f64]) {
    let vs = max_abs(ts.iter().flat_map(|&t| f(t).vel));
    let acs = max_abs(ts.iter().flat_map(|&t| f(t).acc));
    for &t in ts {
        let (p, m, x) = (f(t + H), f(t - H), f(t));
        for k in 0..2 {
            assert_close(
                &format!("{label} vel[{k}]"),
                t,
                (p.pos[k] - m.pos[k]) / (2.0 * H),
                x.vel[k],
                vs,
            );
            assert_close(
                &format!("{label} acc[{k}]"),
                t,
                (p.vel[k] - m.vel[k]) / (2.0 * H),
                x.acc[k],
                acs,
            );
        }
    }
}

/// Checks a frame's origin and angle derivatives against central differences.
fn check_frame(label: &str, f: impl Fn(f64) -> FrameState, ts: &[f64]) {
    check_angles(
        label,
        |t| {
            let s = f(t);
            (s.angle, s.rate, s.accel)
        },
        ts,
    );
    check_point(
        &format!("{label} origin"),
        |t| {
            let s = f(t);
            Kinematics {
                pos: s.origin,
                vel: s.origin_vel,
                acc: s.origin_acc,
            }
        },
        ts,
    );
}

fn smooth_drivers() -> Vec<Rotation> {
    vec![
        Rotation::Constant { angle0: 0.3, rate: 7.0 },
        Rotation::Constant {
            angle0: -1.0,
            rate: -5.0,
        },
        Rotation::SpinUp {
            angle0: 0.2,
            final_rate: 15.0,
            ramp_time: 0.6,
        },
        Rotation::Harmonic {
            mean: 0.4,
            amplitude: 2.5,
            frequency: 1.5,
            phase: 0.3,
        },
    ]
}

fn err_name(e: Error) -> String {
    match e {
        Error::InvalidParameter { name, .. } => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

fn err_message(e: Error) -> String {
    match e {
        Error::InvalidModel { message } => message,
        other => panic!("expected InvalidModel, got {other:?}"),
    }
}

fn sub(a: Vec2, b: Vec2) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[test]
fn frame_state_point_matches_finite_differences() {
    let frame = RotatingFrame::new(
        Motion::Harmonic {
            offset: [0.1, -0.2],
            amplitude: [0.05, 0.03],
            frequency: 2.0,
            phase: 0.4,
        },
        Rotation::Harmonic {
            mean: 0.2,
            amplitude: 1.2,
            frequency: 1.3,
            phase: -0.5,
        },
    )
    .unwrap();
    let ts = times(0.0, 1.5, 61);
    check_frame("rotating", |t| frame.frame(t), &ts);
    check_point("point(0.7)", |t| frame.frame(t).point(0.7), &ts);
    check_point("local_point", |t| frame.frame(t).local_point([0.3, -0.2]), &ts);
    let f = frame.frame(0.37);
    let r = f.rotation();
    let p = f.point(0.7).pos;
    assert!(sub(p, [f.origin[0] + 0.7 * r[0][0], f.origin[1] + 0.7 * r[1][0]]) < 1e-15);
    assert!((r[0][0] - f.angle.cos()).abs() < 1e-15 && (r[1][0] - f.angle.sin()).abs() < 1e-15);
}

#[test]
fn drivers_match_finite_differences() {
    let ts = times(0.0, 2.0, 81);
    check_angles("fixed", |t| Rotation::Fixed { angle: 0.7 }.at(t), &ts);
    for d in smooth_drivers() {
        check_angles(&format!("{d:?}"), |t| d.at(t), &ts);
    }
    // Spin-up: during the ramp and after it (finite differences straddling t = T would mix the
    // two pieces of the definition).
    let spin = Rotation::SpinUp {
        angle0: 0.0,
        final_rate: 20.0,
        ramp_time: 0.5,
    };
    check_angles("spin-up ramp", |t| spin.at(t), &times(0.01, 0.49, 49));
    check_angles("spin-up after", |t| spin.at(t), &times(0.51, 1.5, 20));
    // Tabulated: within an interval the rate and acceleration are the derivatives of the
    // interpolated angle (one quintic; at a sample its third derivative jumps, so the differences
    // are taken inside the intervals).
    let tt = times(0.0, 1.0, 101);
    let angle: Vec<f64> = tt.iter().map(|t| (3.0 * t).sin()).collect();
    let table = Rotation::tabulated(tt.clone(), angle, None, None).unwrap();
    let inside: Vec<f64> = tt[2..99]
        .iter()
        .flat_map(|t| [t + 0.0025, t + 0.005, t + 0.0075])
        .collect();
    check_angles("tabulated", |t| table.at(t), &inside);
}

#[test]
fn spin_up_reaches_half_w_t_and_rate_is_continuous() {
    let (a0, w, tr) = (0.25, 12.0, 0.8);
    let d = Rotation::SpinUp {
        angle0: a0,
        final_rate: w,
        ramp_time: tr,
    };
    let (angle, rate, accel) = d.at(tr);
    assert!((angle - (a0 + w * tr / 2.0)).abs() < 1e-12);
    assert_eq!((rate, accel), (w, 0.0));
    let before = d.at(tr - 1e-9);
    assert!((before.0 - angle).abs() < 1e-7 && (before.1 - w).abs() < 1e-6 && before.2.abs() < 1e-6);
    assert_eq!(d.at(0.0), (a0, 0.0, 0.0));
    assert_eq!(d.at(-1.0), (a0, 0.0, 0.0));
    let (a, r, _) = d.at(tr + 1.0);
    assert!((a - (a0 + w * tr / 2.0 + w)).abs() < 1e-12 && r == w);
    // Smooth start: tiny but positive angle and rate just after 0.
    let (a, r, al) = d.at(1e-3);
    assert!(a > a0 && r > 0.0 && al > 0.0 && a - a0 < 1e-8);
}

#[test]
fn tabulated_rotation_validates_and_interpolates() {
    let e = |r: Result<Rotation>| err_name(r.unwrap_err());
    assert_eq!(e(Rotation::tabulated(vec![0.0], vec![0.0], None, None)), "time");
    assert_eq!(
        e(Rotation::tabulated(vec![0.0, 1.0, 1.0], vec![0.0; 3], None, None)),
        "time[2]"
    );
    assert_eq!(
        e(Rotation::tabulated(vec![f64::NAN, 1.0], vec![0.0; 2], None, None)),
        "time[0]"
    );
    assert_eq!(
        e(Rotation::tabulated(vec![0.0, f64::INFINITY], vec![0.0; 2], None, None)),
        "time[1]"
    );
    assert_eq!(
        e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0; 3], None, None)),
        "angle"
    );
    assert_eq!(
        e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0, f64::NAN], None, None)),
        "angle[1]"
    );
    assert_eq!(
        e(Rotation::tabulated(vec![0.0, 1.0], vec![0.0; 2], Some(vec![1.0]), None)),
        "rate"
    );
    assert_eq!(
        e(Rotation::tabulated(
            vec![0.0, 1.0],
            vec![0.0; 2],
            None,
            Some(vec![1.0, f64::NAN])
        )),
        "accel[1]"
    );
    let named = AngleTable::new("hub", vec![0.0, 0.0], vec![0.0; 2], None, None).unwrap_err();
    assert_eq!(err_name(named), "hub.time[1]");

    // angles alone (derived rates [2, 1.5, 1]): the cubic Hermite through angles and rates; at
    // the middle of [0, 1] its basis is (1/2, 1/8, 1/2, -1/8) in value, (-3/2, -1/4, 3/2, -1/4) in
    // slope and (0, -1, 0, 1) in curvature, of (0, 2, 2, 1.5)
    let d = Rotation::tabulated(vec![0.0, 1.0, 2.0], vec![0.0, 2.0, 3.0], None, None).unwrap();
    assert_eq!(d.at(1.0).0, 2.0);
    assert_eq!(d.at(1.0).1, 1.5);
    let (a, r, al) = d.at(0.5);
    assert!((a - 1.0625).abs() < 1e-15 && (r - 2.125).abs() < 1e-15 && (al + 0.5).abs() < 1e-15);
    // angles on an uneven grid stay near their samples: the cubic's largest angle here is the
    // largest sample, 1 rad, where a quintic through the accelerations derived from the derived
    // rates reaches 86 rad (over 2000 random uneven grids of 3 to 6 samples in [-1, 1]: 3e4
    // against the cubic's 1.25)
    let uneven = Rotation::tabulated(vec![0.0, 1e-3, 5.0, 10.0], vec![0.0, 1.0, 0.0, 0.0], None, None).unwrap();
    let swing = (0..=100_000)
        .map(|k| uneven.at(k as f64 * 1e-4).0.abs())
        .fold(0.0, f64::max);
    assert!(swing <= 1.0 + 1e-12, "{swing}");
    // held outside: the end angle and rate, the cubic's end curvature
    assert_eq!((d.at(-1.0).0, d.at(-1.0).1), (0.0, 2.0));
    assert_eq!((d.at(5.0).0, d.at(5.0).1), (3.0, 1.0));
    // a quintic is reproduced exactly from two samples of its value, rate and acceleration
    let q = |t: f64| {
        (
            1.0 + t - 2.0 * t.powi(3) + 0.5 * t.powi(5),
            1.0 - 6.0 * t * t + 2.5 * t.powi(4),
            -12.0 * t + 10.0 * t.powi(3),
        )
    };
    let (q0, q1) = (q(0.0), q(1.5));
    let given = Rotation::tabulated(
        vec![0.0, 1.5],
        vec![q0.0, q1.0],
        Some(vec![q0.1, q1.1]),
        Some(vec![q0.2, q1.2]),
    )
    .unwrap();
    for t in [0.1, 0.7, 1.2] {
        let (g, w) = (given.at(t), q(t));
        assert!(
            (g.0 - w.0).abs() < 1e-13 && (g.1 - w.1).abs() < 1e-13 && (g.2 - w.2).abs() < 1e-12,
            "{t}: {g:?} {w:?}"
        );
    }

    assert!(d.covers("rot", 2.0).is_ok());
    assert_eq!(err_name(d.covers("rot", 2.5).unwrap_err()), "rot.time");
    let late = Rotation::tabulated(vec![0.1, 1.0], vec![0.0, 1.0], None, None).unwrap();
    assert_eq!(err_name(late.covers("rot", 0.5).unwrap_err()), "rot.time");
    assert!(Rotation::Constant { angle0: 0.0, rate: 1.0 }.covers("rot", 1e9).is_ok());
}

#[test]
fn tabulated_motions_stay_finite_at_the_extremes_of_their_spacing() {
    // an angle of 1 rad held over 1e-200 s with its rates and accelerations zero: in range, and
    // the quintic's rate and acceleration are exactly zero
    let held = Rotation::tabulated(
        vec![0.0, 1e-200],
        vec![1.0, 1.0],
        Some(vec![0.0; 2]),
        Some(vec![0.0; 2]),
    )
    .unwrap();
    for t in [0.0, 1.6e-201, 5e-201, 1e-200] {
        assert_eq!(held.at(t), (1.0, 0.0, 0.0), "{t}");
    }
    // the same through the cubic (no accelerations given)
    let cubic = Rotation::tabulated(vec![0.0, 1e-200], vec![1.0, 1.0], Some(vec![0.0; 2]), None).unwrap();
    assert_eq!(cubic.at(5e-201), (1.0, 0.0, 0.0));
    // a crank at 1e20 rad/s tabulated 1e-300 s apart (fuzz case 79:60599, a linkage run over
    // 1e-300 s): accelerations of the order of 1e320 rad/s^2, refused naming the later sample
    let fast = |acc: Option<Vec<f64>>| {
        AngleTable::new("crank", vec![0.0, 1e-300], vec![0.0, 1e-280], Some(vec![1e20; 2]), acc).unwrap_err()
    };
    for e in [fast(Some(vec![0.0; 2])), fast(None)] {
        let msg = e.to_string();
        assert_eq!(err_name(e), "crank.time[1]");
        assert!(
            msg.contains("(at most 1e75)") && msg.contains("1e-300 s apart"),
            "{msg}"
        );
    }
    // the same rate 1e-3 s apart is in range, and its accelerations are finite
    let ok = Rotation::tabulated(
        vec![0.0, 1e-3],
        vec![0.0, 1e17],
        Some(vec![1e20; 2]),
        Some(vec![0.0; 2]),
    )
    .unwrap();
    assert!([0.2e-3, 0.5e-3, 0.9e-3].iter().all(|&t| {
        let (a, r, al) = ok.at(t);
        a.is_finite() && r.is_finite() && al.is_finite()
    }));
    // translations: a point held at 1 m over 1e-200 s, and one moving at 1e20 m/s 1e-300 s apart
    let point = Table::new(
        "slider",
        vec![0.0, 1e-200],
        vec![[1.0, -1.0]; 2],
        Some(vec![[0.0; 2]; 2]),
        Some(vec![[0.0; 2]; 2]),
    )
    .unwrap();
    let k = crate::model::Motion::Tabulated(point).at(5e-201);
    assert_eq!((k.pos, k.vel, k.acc), ([1.0, -1.0], [0.0; 2], [0.0; 2]));
    let e = Table::new(
        "slider",
        vec![0.0, 1e-300],
        vec![[0.0; 2], [1e-280, 0.0]],
        Some(vec![[1e20, 0.0]; 2]),
        None,
    )
    .unwrap_err();
    assert_eq!(err_name(e), "slider.time[1]");
}

#[test]
fn rotation_validate_names_the_field() {
    let v = |d: Rotation| err_name(d.validate("r").unwrap_err());
    assert_eq!(v(Rotation::Fixed { angle: f64::NAN }), "r.angle");
    assert_eq!(
        v(Rotation::Constant {
            angle0: 0.0,
            rate: f64::INFINITY
        }),
        "r.rate"
    );
    assert_eq!(
        v(Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 1.0,
            ramp_time: 0.0
        }),
        "r.ramp_time"
    );
    assert_eq!(
        v(Rotation::Harmonic {
            mean: 0.0,
            amplitude: 1.0,
            frequency: -1.0,
            phase: 0.0
        }),
        "r.frequency"
    );
    match (Rotation::SpinUp {
        angle0: 0.0,
        final_rate: 1.0,
        ramp_time: -2.0,
    })
    .validate("r")
    .unwrap_err()
    {
        Error::InvalidParameter { allowed, .. } => assert!(allowed.contains("> 0") && allowed.contains('s')),
        other => panic!("{other:?}"),
    }
    for d in smooth_drivers() {
        d.validate("r").unwrap();
    }
}

fn slider_cranks() -> Vec<SliderCrank> {
    let mut out = Vec::new();
    for d in smooth_drivers() {
        out.push(SliderCrank::new(0.15, 0.6, 0.0, d.clone()).unwrap());
        out.push(SliderCrank::new(0.15, 0.6, 0.08, d.clone()).unwrap());
        out.push(SliderCrank::new(0.2, 0.35, -0.1, d).unwrap());
    }
    out
}

#[test]
fn slider_crank_frames_match_finite_differences() {
    let ts = times(0.0, 2.0, 81);
    for sc in slider_cranks() {
        let label = format!("{sc:?}");
        check_frame(&format!("crank {label}"), |t| sc.crank_frame(t), &ts);
        check_frame(&format!("rod {label}"), |t| sc.rod_frame(t), &ts);
        check_frame(&format!("slider {label}"), |t| sc.slider_frame(t), &ts);
        check_point(&format!("B {label}"), |t| sc.slider(t), &ts);
        check_point(
            &format!("rod midpoint {label}"),
            |t| sc.rod_frame(t).point(0.5 * sc.rod()),
            &ts,
        );
    }
}

#[test]
fn slider_crank_loop_closes() {
    for sc in slider_cranks() {
        for t in times(0.0, 3.0, 1001) {
            let rod = sc.rod_frame(t);
            let end = rod.point(sc.rod());
            let b = sc.slider(t);
            assert!(
                sub(end.pos, b.pos) < 1e-12,
                "closure at t = {t}: {:?} vs {:?}",
                end.pos,
                b.pos
            );
            assert!((b.pos[1] - sc.offset()).abs() < 1e-15);
            // The rod's far end moves with the slider (exact identities up to round-off).
            let vs = 1.0 + b.vel[0].abs();
            let acs = 1.0 + b.acc[0].abs();
            assert!(sub(end.vel, b.vel) < 1e-9 * vs && sub(end.acc, b.acc) < 1e-9 * acs);
            // The rod starts at the crank pin.
            let pin = sc.crank_frame(t).point(sc.crank());
            assert!(sub(pin.pos, rod.origin) < 1e-15);
            assert!(rod.angle.cos() > 0.0);
        }
    }
}

#[test]
fn slider_crank_rod_rotation_is_the_closures_own() {
    // the rod's rotation matrix from the loop closure's (cos psi, sin psi): the frame of the
    // same instant, orthonormal, and the matrix of its angle to rounding; the crank's and the
    // slider's are their angles' (the default)
    for sc in slider_cranks() {
        let sc = Arc::new(sc);
        let frame = |link| SliderCrankFrame {
            mechanism: sc.clone(),
            link,
        };
        for t in times(0.0, 2.0, 401) {
            for link in [SliderCrankLink::Crank, SliderCrankLink::Rod, SliderCrankLink::Slider] {
                let f = frame(link);
                let (state, r) = f.frame_rotation(t);
                assert_eq!(state, f.frame(t));
                let by_angle = state.rotation();
                if link == SliderCrankLink::Rod {
                    let det = r[0][0] * r[1][1] - r[0][1] * r[1][0];
                    assert!((det - 1.0).abs() < 4.0 * f64::EPSILON, "{t}: det {det}");
                    assert!(r[0][0] == r[1][1] && r[0][1] == -r[1][0]);
                    for (a, b) in r.iter().flatten().zip(by_angle.iter().flatten()) {
                        assert!((a - b).abs() < 4.0 * f64::EPSILON, "{t}: {r:?} vs {by_angle:?}");
                    }
                } else {
                    assert_eq!(r, by_angle);
                }
            }
        }
    }
}

#[test]
fn slider_crank_dead_centres() {
    let (a, l) = (0.1, 0.45);
    let at = |th: f64| {
        SliderCrank::new(a, l, 0.0, Rotation::Fixed { angle: th })
            .unwrap()
            .slider(0.0)
    };
    let b0 = at(0.0);
    assert!(sub(b0.pos, [a + l, 0.0]) < 1e-15);
    let b1 = at(PI);
    assert!(sub(b1.pos, [l - a, 0.0]) < 1e-15);
    assert_eq!((b0.vel, b0.acc), ([0.0, 0.0], [0.0, 0.0]));
    // Constant rate w at theta = 0: the slider acceleration is -a w^2 (1 + a / l).
    let w = 10.0;
    let sc = SliderCrank::new(a, l, 0.0, Rotation::Constant { angle0: 0.0, rate: w }).unwrap();
    let b = sc.slider(0.0);
    assert!((b.acc[0] + a * w * w * (1.0 + a / l)).abs() < 1e-12);
    assert!(b.vel[0].abs() < 1e-15);
}

#[test]
fn slider_crank_rejects_bad_geometry() {
    let d = || Rotation::Constant { angle0: 0.0, rate: 1.0 };
    let e = |r: Result<SliderCrank>| err_name(r.unwrap_err());
    assert_eq!(e(SliderCrank::new(0.3, 0.2, 0.0, d())), "rod");
    assert_eq!(e(SliderCrank::new(0.3, 0.4, 0.1, d())), "rod"); // rod == crank + |offset|
    assert_eq!(e(SliderCrank::new(0.3, 0.45, -0.2, d())), "rod");
    assert_eq!(e(SliderCrank::new(0.0, 1.0, 0.0, d())), "crank");
    assert_eq!(e(SliderCrank::new(0.1, f64::NAN, 0.0, d())), "rod");
    assert_eq!(e(SliderCrank::new(0.1, 1.0, f64::NAN, d())), "offset");
    let bad = Rotation::SpinUp {
        angle0: 0.0,
        final_rate: 1.0,
        ramp_time: 0.0,
    };
    assert_eq!(e(SliderCrank::new(0.1, 1.0, 0.0, bad)), "driver.ramp_time");
    match SliderCrank::new(0.3, 0.2, 0.0, d()).unwrap_err() {
        Error::InvalidParameter { allowed, .. } => assert!(allowed.contains("crank + |offset| = 0.3 m")),
        other => panic!("{other:?}"),
    }
}

/// Crank-rocker (crank shortest, Grashof), both branches, and a drag link (ground shortest,
/// crank longer than ground).
fn four_bars(driver: &Rotation) -> Vec<FourBar> {
    vec![
        FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, driver.clone()).unwrap(),
        FourBar::new(0.4, 0.1, 0.35, 0.3, -1.0, driver.clone()).unwrap(),
        FourBar::new(0.1, 0.3, 0.35, 0.32, 1.0, driver.clone()).unwrap(),
        FourBar::new(0.1, 0.3, 0.35, 0.32, -1.0, driver.clone()).unwrap(),
    ]
}

#[test]
fn four_bar_rotations_are_their_angles_bitwise() {
    // the closure's own (cos, sin) of each link's angle: the frame of the same instant and
    // bitwise the matrix of its angle, for every link, both branches, crank-rocker and drag link
    for d in smooth_drivers() {
        for fb in four_bars(&d) {
            let fb = Arc::new(fb);
            for t in times(0.0, 2.0, 201) {
                for link in [FourBarLink::Crank, FourBarLink::Coupler, FourBarLink::Rocker] {
                    let f = FourBarFrame {
                        mechanism: fb.clone(),
                        link,
                    };
                    let (state, r) = f.frame_rotation(t);
                    assert_eq!(state, f.frame(t), "{t}: {link:?}");
                    let bits = |m: [[f64; 2]; 2]| m.map(|row| row.map(f64::to_bits));
                    assert_eq!(bits(r), bits(state.rotation()), "{t}: {link:?} {r:?}");
                }
            }
        }
    }
}

#[test]
fn four_bar_frames_match_finite_differences() {
    let ts = times(0.0, 2.0, 81);
    for d in smooth_drivers() {
        for fb in four_bars(&d) {
            fb.check("fb", 2.0 + H).unwrap();
            let label = format!("{fb:?}");
            check_frame(&format!("crank {label}"), |t| fb.crank_frame(t), &ts);
            check_frame(&format!("coupler {label}"), |t| fb.coupler_frame(t), &ts);
            check_frame(&format!("rocker {label}"), |t| fb.rocker_frame(t), &ts);
            check_point(&format!("B {label}"), |t| fb.rocker_frame(t).point(fb.rocker()), &ts);
        }
    }
}

#[test]
fn four_bar_loop_closes() {
    for d in smooth_drivers() {
        for fb in four_bars(&d) {
            for t in times(0.0, 3.0, 1001) {
                let (cr, co, ro) = (fb.crank_frame(t), fb.coupler_frame(t), fb.rocker_frame(t));
                let a = cr.point(fb.crank());
                let b3 = co.point(fb.coupler());
                let b4 = ro.point(fb.rocker());
                assert!(sub(a.pos, co.origin) < 1e-15);
                assert!(sub(b3.pos, b4.pos) < 1e-12, "closure at t = {t}: {:?}", fb);
                // B computed along the coupler and along the rocker moves the same way.
                let vs = 1.0 + max_abs(b4.vel.into_iter());
                let acs = 1.0 + max_abs(b4.acc.into_iter());
                assert!(sub(b3.vel, b4.vel) < 1e-9 * vs, "velocity at t = {t}");
                assert!(sub(b3.acc, b4.acc) < 1e-9 * acs, "acceleration at t = {t}");
                assert!(sub(a.vel, co.origin_vel) < 1e-12 && sub(a.acc, co.origin_acc) < 1e-9 * acs);
                assert_eq!(ro.origin, [fb.ground(), 0.0]);
            }
        }
    }
}

#[test]
fn four_bar_branch_convention() {
    // Norton's open (+) and crossed (-) solutions for theta4 of a crank-rocker.
    let (a, b, c, d) = (0.1, 0.35, 0.3, 0.4);
    let norton = |th2: f64, sign: f64| {
        let (k1, k2, k3) = (d / a, d / c, (a * a - b * b + c * c + d * d) / (2.0 * a * c));
        let aa = th2.cos() - k1 - k2 * th2.cos() + k3;
        let bb = -2.0 * th2.sin();
        let cc = k1 - (k2 + 1.0) * th2.cos() + k3;
        2.0 * ((-bb - sign * (bb * bb - 4.0 * aa * cc).sqrt()) / (2.0 * aa)).atan()
    };
    for branch in [1.0, -1.0] {
        for th2 in times(-3.0, 3.0, 25) {
            let fb = FourBar::new(d, a, b, c, branch, Rotation::Fixed { angle: th2 }).unwrap();
            let (th3, th4) = (fb.coupler_frame(0.0).angle, fb.rocker_frame(0.0).angle);
            let diff = (th4 - norton(th2, branch)).rem_euclid(TAU);
            assert!(diff < 1e-12 || TAU - diff < 1e-12, "branch {branch} th2 {th2}");
            assert!(branch * (th4 - th3).sin() > 0.0);
        }
    }
    // With the crank straight up, the open assembly has B above the ground line.
    let fb = FourBar::new(d, a, b, c, 1.0, Rotation::Fixed { angle: PI / 2.0 }).unwrap();
    assert!(fb.rocker_frame(0.0).point(c).pos[1] > 0.0);
}

#[test]
fn four_bar_angles_are_continuous() {
    // Two crank turns: crank-rocker angles oscillate, drag-link angles turn with the crank.
    let d = Rotation::Constant { angle0: 0.0, rate: TAU };
    for fb in four_bars(&d) {
        let ts = times(0.0, 2.0, 4001);
        for w in ts.windows(2) {
            for f in [FourBar::coupler_frame, FourBar::rocker_frame] {
                let jump = (f(&fb, w[1]).angle - f(&fb, w[0]).angle).abs();
                assert!(jump < 0.05, "jump {jump} at t = {} in {fb:?}", w[0]);
            }
        }
        let turns = (fb.coupler_frame(2.0).angle - fb.coupler_frame(0.0).angle) / TAU;
        let expected = if fb.crank() > fb.ground() { 2.0 } else { 0.0 };
        assert!((turns - expected).abs() < 1e-9, "coupler turns {turns} in {fb:?}");
    }
}

#[test]
fn four_bar_check_reports_failures() {
    let spin = Rotation::Constant { angle0: 0.0, rate: 3.0 };
    // Can never close.
    let fb = FourBar::new(10.0, 1.0, 1.0, 1.0, 1.0, spin.clone()).unwrap();
    let msg = err_message(fb.check("links[0].frame", 1.0).unwrap_err());
    assert!(msg.starts_with("links[0].frame: the four-bar does not close at crank angle 0 rad (t = 0 s)"));
    assert!(msg.contains("|coupler - rocker| <= |A - O4| <= coupler + rocker violated"));
    assert!(
        msg.contains("non-Grashof") && msg.contains("closes at no crank angle"),
        "{msg}"
    );
    // Non-Grashof (s + l = 5 > p + q = 4.7): closes for |theta2| <= acos(-0.7575) = 2.43 rad.
    let rock = |amplitude: f64| Rotation::Harmonic {
        mean: 0.0,
        amplitude,
        frequency: 1.0,
        phase: 0.0,
    };
    let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(1.0)).unwrap();
    fb.check("fb", 3.0).unwrap();
    let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(3.0)).unwrap();
    let msg = err_message(fb.check("fb", 3.0).unwrap_err());
    assert!(msg.contains("does not close") && msg.contains("non-Grashof"), "{msg}");
    assert!(msg.contains("[0, 2.43"), "{msg}");
    // ... but only once the driver gets there.
    FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, rock(3.0))
        .unwrap()
        .check("fb", 0.1)
        .unwrap();
    // Grashof, rocker shortest: the crank cannot turn fully.
    let fb = FourBar::new(0.4, 0.3, 0.35, 0.1, 1.0, spin.clone()).unwrap();
    let msg = err_message(fb.check("fb", 3.0).unwrap_err());
    assert!(msg.contains("coupler or rocker is the shortest"), "{msg}");
    // Parallelogram: dead centre at theta2 = pi (found between samples).
    let fb = FourBar::new(2.0, 1.0, 2.0, 1.0, 1.0, Rotation::Constant { angle0: 0.5, rate: 1.0 }).unwrap();
    fb.check("fb", 1.0).unwrap();
    let msg = err_message(fb.check("fb", 4.0).unwrap_err());
    assert!(msg.contains("dead-centre") && msg.contains("change-point"), "{msg}");
    assert!(msg.contains(&format!("crank angle {PI} rad")), "{msg}");
    // the memo of a passed check holds for its own t_end only: the longer window fails again
    fb.check("fb", 1.0).unwrap();
    assert!(err_message(fb.check("fb", 4.0).unwrap_err()).contains("dead-centre"));
    // A harmonic driver just past the limit (2.43027 rad) is caught at its peak, which is
    // among the sampled times.
    let peak = |amplitude: f64| Rotation::Harmonic {
        mean: 0.0,
        amplitude,
        frequency: 0.37,
        phase: 0.1,
    };
    let fb = FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, peak(2.4303)).unwrap();
    let t_peak = (0.5 * PI - 0.1) / (TAU * 0.37);
    assert!(fb.check_times(100.0).contains(&t_peak));
    assert!(fb.check("fb", 100.0).is_err());
    FourBar::new(2.0, 3.0, 2.5, 2.2, 1.0, peak(2.4302))
        .unwrap()
        .check("fb", 100.0)
        .unwrap();
    // Parameter errors.
    assert_eq!(err_name(fb.check("fb", -1.0).unwrap_err()), "t_end");
    assert_eq!(err_name(fb.check("fb", f64::NAN).unwrap_err()), "t_end");
    let table = Rotation::tabulated(vec![0.0, 1.0], vec![0.0, 0.1], None, None).unwrap();
    let fb = FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, table).unwrap();
    fb.check("fb", 1.0).unwrap();
    assert_eq!(err_name(fb.check("fb", 2.0).unwrap_err()), "fb.driver.time");
}

#[test]
fn four_bar_rejects_bad_parameters() {
    let d = || Rotation::Fixed { angle: 0.0 };
    let e = |r: Result<FourBar>| err_name(r.unwrap_err());
    assert_eq!(e(FourBar::new(-1.0, 1.0, 1.0, 1.0, 1.0, d())), "ground");
    assert_eq!(e(FourBar::new(1.0, 0.0, 1.0, 1.0, 1.0, d())), "crank");
    assert_eq!(e(FourBar::new(1.0, 1.0, f64::NAN, 1.0, 1.0, d())), "coupler");
    assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, f64::INFINITY, 1.0, d())), "rocker");
    assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, 1.0, 0.0, d())), "branch");
    assert_eq!(e(FourBar::new(1.0, 1.0, 1.0, 1.0, 0.5, d())), "branch");
    assert_eq!(
        e(FourBar::new(
            1.0,
            1.0,
            1.0,
            1.0,
            1.0,
            Rotation::Fixed { angle: f64::NAN }
        )),
        "driver.angle"
    );
}

#[test]
fn frame_kinematics_wrappers() {
    let driver = Rotation::SpinUp {
        angle0: 0.1,
        final_rate: 8.0,
        ramp_time: 0.5,
    };
    let sc = Arc::new(SliderCrank::new(0.1, 0.4, 0.02, driver.clone()).unwrap());
    let fb = Arc::new(FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, driver.clone()).unwrap());
    let mut frames: Vec<(Arc<dyn FrameKinematics>, FrameState)> = Vec::new();
    let t = 0.73;
    for (link, want) in [
        (SliderCrankLink::Crank, sc.crank_frame(t)),
        (SliderCrankLink::Rod, sc.rod_frame(t)),
        (SliderCrankLink::Slider, sc.slider_frame(t)),
    ] {
        let f: Arc<dyn FrameKinematics> = Arc::new(SliderCrankFrame {
            mechanism: sc.clone(),
            link,
        });
        frames.push((f, want));
    }
    for (link, want) in [
        (FourBarLink::Crank, fb.crank_frame(t)),
        (FourBarLink::Coupler, fb.coupler_frame(t)),
        (FourBarLink::Rocker, fb.rocker_frame(t)),
    ] {
        let f: Arc<dyn FrameKinematics> = Arc::new(FourBarFrame {
            mechanism: fb.clone(),
            link,
        });
        frames.push((f, want));
    }
    let rot = RotatingFrame::new(Motion::Fixed { position: [1.0, 2.0] }, driver).unwrap();
    let want = FrameState {
        origin: [1.0, 2.0],
        angle: sc.crank_frame(t).angle,
        rate: sc.crank_frame(t).rate,
        accel: sc.crank_frame(t).accel,
        ..FrameState::default()
    };
    let f: Arc<dyn FrameKinematics> = Arc::new(rot);
    frames.push((f, want));
    for (f, want) in &frames {
        assert_eq!(f.frame(t), *want, "{f:?}");
        f.check("f", 10.0).unwrap();
    }
    // rotates / translates: crank, rod, slider, crank, coupler, rocker, rotating frame.
    let flags: Vec<(bool, bool)> = frames.iter().map(|(f, _)| (f.rotates(), f.translates())).collect();
    let (y, n) = (true, false);
    assert_eq!(flags, [(y, n), (y, y), (n, y), (y, n), (y, y), (y, n), (y, n)]);
    let still = FourBarFrame {
        mechanism: Arc::new(FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, Rotation::Fixed { angle: 1.0 }).unwrap()),
        link: FourBarLink::Coupler,
    };
    assert!(!still.rotates() && !still.translates());
    let table_zero = Rotation::tabulated(vec![0.0, 1.0], vec![0.5, 0.5], None, None).unwrap();
    assert!(table_zero.is_fixed());
    // zero rates at the samples, but the angle moves between them (the cubic through them)
    let table_turning = Rotation::tabulated(vec![0.0, 1.0], vec![0.0, 1.0], Some(vec![0.0, 0.0]), None).unwrap();
    assert!(table_turning.at(0.5).1 > 0.0 && !table_turning.is_fixed());
    assert!(Rotation::Constant { angle0: 1.0, rate: 0.0 }.is_fixed());
    assert!(!smooth_drivers().iter().any(Rotation::is_fixed));
    assert_eq!(sc.slider_frame(t).origin, sc.slider(t).pos);
    let ((th, _, _), (psi, _, _)) = sc.angles(t);
    assert_eq!((th, psi), (sc.crank_frame(t).angle, sc.rod_frame(t).angle));

    // Checks through the trait: coverage of tables and parameter validation.
    let table = Rotation::tabulated(vec![0.0, 1.0], vec![0.0, 1.0], None, None).unwrap();
    let short = RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: table.clone(),
    };
    assert!(short.check("f", 1.0).is_ok());
    assert_eq!(err_name(short.check("f", 2.0).unwrap_err()), "f.rotation.time");
    let origin = Table::new("o", vec![0.0, 0.5], vec![[0.0, 0.0], [1.0, 0.0]], None, None).unwrap();
    let moving = RotatingFrame {
        origin: Motion::Tabulated(origin),
        rotation: table.clone(),
    };
    assert_eq!(err_name(moving.check("f", 1.0).unwrap_err()), "f.origin.time");
    let bad = RotatingFrame {
        origin: Motion::Fixed { position: [0.0, 0.0] },
        rotation: Rotation::Harmonic {
            mean: 0.0,
            amplitude: 1.0,
            frequency: f64::NAN,
            phase: 0.0,
        },
    };
    assert_eq!(err_name(bad.check("f", 1.0).unwrap_err()), "f.rotation.frequency");
    assert_eq!(
        err_name(
            RotatingFrame::new(
                Motion::Fixed {
                    position: [f64::NAN, 0.0]
                },
                table.clone()
            )
            .unwrap_err()
        ),
        "origin.position[0]"
    );
    let sct = SliderCrankFrame {
        mechanism: Arc::new(SliderCrank::new(0.1, 0.4, 0.0, table).unwrap()),
        link: SliderCrankLink::Rod,
    };
    assert!(sct.check("s", 1.0).is_ok());
    assert!(sct.rotates() && sct.translates());
    assert_eq!(err_name(sct.check("s", 1.5).unwrap_err()), "s.driver.time");
}

/// The pose memo ([`PoseMemo`]) returns what solving would: frames asked for in turn at
/// alternating and repeated instants are bitwise those of a fresh mechanism (a clone starts with
/// an empty memo) asked for each instant once.
#[test]
fn remembered_poses_are_the_solved_ones() {
    let driver = Rotation::SpinUp {
        angle0: 0.2,
        final_rate: 150.0,
        ramp_time: 0.01,
    };
    let sc = SliderCrank::new(0.15, 0.6, 0.08, driver.clone()).unwrap();
    let fb = FourBar::new(0.4, 0.1, 0.35, 0.3, 1.0, driver).unwrap();
    for t in [0.0, 1e-3, 1e-3, 0.0, 2.5e-3, 1e-3, 1e-3] {
        let (a, b) = (sc.clone(), fb.clone());
        assert_eq!(sc.rod_frame(t), a.rod_frame(t), "slider-crank rod at {t}");
        assert_eq!(
            sc.slider_frame(t),
            sc.clone().slider_frame(t),
            "slider-crank slider at {t}"
        );
        assert_eq!(sc.angles(t), a.angles(t), "slider-crank angles at {t}");
        assert_eq!(fb.coupler_frame(t), b.coupler_frame(t), "four-bar coupler at {t}");
        assert_eq!(fb.rocker_frame(t), fb.clone().rocker_frame(t), "four-bar rocker at {t}");
    }
}

#[test]
fn a_tabulated_motion_follows_its_samples_to_sixth_order_with_consistent_derivatives() {
    // x = sin(w t), y = cos(w t) / 2 sampled with their exact velocities and accelerations at
    // spacing h: the quintic Hermite interpolant's error between the samples is O(h^6), so
    // halving h divides it by about 64; its velocity and acceleration are O(h^5) and O(h^4)
    let w = 150.0;
    let exact = |t: f64| {
        let (s, c) = (w * t).sin_cos();
        ([s, 0.5 * c], [w * c, -0.5 * w * s], [-w * w * s, -0.5 * w * w * c])
    };
    let error = |h: f64| {
        let n = (0.05 / h).round() as usize + 1;
        let time: Vec<f64> = (0..n).map(|i| i as f64 * h).collect();
        let e: Vec<_> = time.iter().map(|&t| exact(t)).collect();
        let table = Table::new(
            "m",
            time.clone(),
            e.iter().map(|x| x.0).collect(),
            Some(e.iter().map(|x| x.1).collect()),
            Some(e.iter().map(|x| x.2).collect()),
        )
        .unwrap();
        let m = Motion::Tabulated(table);
        let mut worst = [0.0f64; 3];
        for k in 0..(n - 1) * 7 {
            let t = k as f64 * h / 7.0;
            let (got, want) = (m.at(t), exact(t));
            for (j, (g, x)) in [(got.pos, want.0), (got.vel, want.1), (got.acc, want.2)]
                .into_iter()
                .enumerate()
            {
                worst[j] = worst[j].max((g[0] - x[0]).abs().max((g[1] - x[1]).abs()));
            }
        }
        worst
    };
    let (coarse, fine) = (error(1e-3), error(5e-4));
    // the bound h^6 w^6 / 46080 (a unit amplitude): 2.5e-10 at 1e-3 s
    assert!(coarse[0] < 2.5e-10 && coarse[0] > 1e-12, "{coarse:?}");
    let order = |j: usize| (coarse[j] / fine[j]).log2();
    assert!((order(0) - 6.0).abs() < 0.3, "value order {}", order(0));
    assert!((order(1) - 5.0).abs() < 0.4, "velocity order {}", order(1));
    assert!((order(2) - 4.0).abs() < 0.4, "acceleration order {}", order(2));
    // a span of 1e200 s (h^2 overflows) with zero accelerations stays finite, as do derived rates
    for (vel, acc) in [(Some(vec![[0.0; 2]; 2]), Some(vec![[0.0; 2]; 2])), (None, None)] {
        let wide =
            Motion::Tabulated(Table::new("m", vec![0.0, 1e200], vec![[0.0, 0.0], [1.0, 1.0]], vel, acc).unwrap());
        let k = wide.at(3e199);
        assert!(k.pos.iter().chain(&k.vel).chain(&k.acc).all(|x| x.is_finite()), "{k:?}");
        assert!(k.pos[0] > 0.0 && k.pos[0] < 1.0);
    }
    // a sample is met exactly
    assert_eq!(
        Motion::Tabulated(Table::new("m", vec![0.0, 1.0], vec![[1.0, 2.0], [3.0, 4.0]], None, None).unwrap())
            .at(1.0)
            .pos,
        [3.0, 4.0]
    );
}
