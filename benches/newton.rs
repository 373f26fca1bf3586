//! Criterion benches of the kineto-elastodynamic (KED) integrator: the cost per step of a
//! rotating link with and without the terms its motion calls for (geometric stiffness K2/K3,
//! Coriolis, inertia coupling), a Kane spin-up run, one revolution of Simeon's flexible
//! slider-crank, and the cost per step as the element count grows from 10 to 10 000.
//!
//! "A scene that needs less must cost less": the `ked/step` group runs the same 10-element
//! cantilever (a) at rest in a fixed frame (M, K1 only: factorized once, one solve per step),
//! (b) spinning at constant speed with geometric stiffening off (Coriolis and M_IC only: the
//! Jacobian is constant, factorized once), (c) the same with Coriolis and M_IC also off, and
//! (d) with every term (K2, K3 updated with the axial force by iteration: refactorized every
//! step).

use std::hint::black_box;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use flexclear::contact::Coupling;
use flexclear::integrator::newton::{simulate_constant_rate, simulate_mechanism};
use flexclear::kinematics::{FrameKinematics, RotatingFrame, Rotation};
use flexclear::linalg::{BandLu, BandLuLanes};
use flexclear::model::mechanism::{Link, Mechanism, Support, Terms};
use flexclear::model::section::BeamSection;
use flexclear::model::Motion;
use flexclear::record::{LinkChannels, RecordSpec};
use flexclear::scenes::spinning_beam_in_a_bearing;
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin};
use flexclear::{Settings, SolverMode};

/// Kane, Ryan & Banerjee (1987) beam data on a hub with the given rotation and terms.
fn cantilever(elements: usize, rotation: Rotation, terms: Terms) -> Mechanism {
    let frame: Arc<dyn FrameKinematics> =
        Arc::new(RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, rotation).unwrap());
    Mechanism {
        links: vec![Link {
            name: "beam".into(),
            section: BeamSection {
                length: 8.0,
                elements,
                youngs_modulus: 6.8952e10,
                density: 2766.67,
                damping: 0.0,
                area: 7.2968e-5,
                inertia: 8.2189e-9,
            },
            frame,
            terms,
            rotary_inertia: false,
            initial_displacement: None,
            initial_velocity: None,
            rigid: None,
        }],
        supports: vec![Support {
            link: 0,
            node: 0,
            fixed: [true; 3],
        }],
        ..Default::default()
    }
}

/// Simeon's (1996) flexible slider-crank ([`FlexibleSliderCrank`]): rigid crank 0.15 m at
/// 150 rad/s, steel rod 0.30 m of 8 x 8 mm, slider 0.075552 kg.
fn slider_crank(elements: usize) -> Mechanism {
    FlexibleSliderCrank {
        elements,
        ..Default::default()
    }
    .build()
    .expect("slider-crank scene")
}

/// Settings that record nothing but the final state (the cost measured is the stepping).
fn quiet(t_end: f64, dt: f64) -> Settings {
    let mut s = Settings::new(t_end, dt);
    s.record = RecordSpec {
        every: usize::MAX / 2,
        links: LinkChannels::NONE,
        ..RecordSpec::default()
    };
    s
}

fn run(m: &Mechanism, s: &Settings) -> f64 {
    let out = simulate_mechanism(m, s, &mut |_| true).expect("bench run failed");
    out.time
}

/// 1000 steps of 1e-4 s; criterion's time / 1000 is the cost per step.
fn step_terms(c: &mut Criterion) {
    let spin = Rotation::Constant { angle0: 0.0, rate: 4.0 };
    let off = Terms {
        geometric: Some(false),
        ..Default::default()
    };
    let none = Terms {
        geometric: Some(false),
        coriolis: Some(false),
        inertia_coupling: Some(false),
        ..Default::default()
    };
    let cases = [
        (
            "(a) fixed frame: M, K1",
            cantilever(10, Rotation::Fixed { angle: 0.0 }, Terms::default()),
        ),
        (
            "(b) spinning, no K2/K3: + M_COR, M_IC, M_R a_R",
            cantilever(10, spin.clone(), off),
        ),
        (
            "(c) spinning, K2/K3/M_COR/M_IC off: M, K1, M_R a_R",
            cantilever(10, spin.clone(), none),
        ),
        (
            "(d) spinning, every term (K2, K3 iterated)",
            cantilever(10, spin, Terms::default()),
        ),
    ];
    let s = quiet(0.1, 1e-4);
    let mut g = c.benchmark_group("ked/step x1000, 10 elements");
    for (name, m) in &cases {
        g.bench_function(*name, |b| b.iter(|| run(black_box(m), &s)));
    }
    g.finish();
}

fn runs(c: &mut Criterion) {
    let mut g = c.benchmark_group("ked/run");
    g.sample_size(10);
    let spin = cantilever(
        10,
        Rotation::SpinUp {
            angle0: 0.0,
            final_rate: 4.0,
            ramp_time: 15.0,
        },
        Terms::default(),
    );
    let s = quiet(20.0, 1e-3);
    g.bench_function("spin-up Kane, 10 elements, 20 s at 1e-3 s", |b| {
        b.iter(|| run(black_box(&spin), &s))
    });
    let sc = slider_crank(8);
    let rev = 2.0 * std::f64::consts::PI / 150.0;
    let s = quiet(rev, 1e-5);
    g.bench_function("slider-crank Simeon, 8 elements, one revolution at 1e-5 s", |b| {
        b.iter(|| run(black_box(&sc), &s))
    });
    g.finish();
}

/// Cost per step against the element count (full terms, refactorized every step): 20 steps.
fn scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("ked/step x20 vs elements");
    g.sample_size(10);
    let s = quiet(20.0 * 1e-4, 1e-4);
    for n in [10usize, 100, 1000, 10_000] {
        let m = cantilever(n, Rotation::Constant { angle0: 0.0, rate: 4.0 }, Terms::default());
        g.bench_function(format!("{n} elements"), |b| b.iter(|| run(black_box(&m), &s)));
    }
    g.finish();
}

/// Contact terms on the contact-free factor (Woodbury) against refactorizing for them: 1000 steps
/// of 1e-5 s with implicit contact of (a) Simeon's slider-crank with a clearance at the crank pin
/// (the scene's defaults: 26 unknowns, geometric terms on, so one factorization per step either
/// way plus, refactorizing, one per contact change within the step) on the Newton stepper, and
/// (b) a cantilever spinning at 30 rad/s rattling in a bearing on its hub on the constant-rate
/// stepper (one factorization per run) and on Newton refactorizing.
fn contact(c: &mut Criterion) {
    let mut g = c.benchmark_group("ked/contact x1000 at 1e-5 s");
    g.sample_size(10);
    let mut s = quiet(0.01, 1e-5);
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    let mut refactor = s.clone();
    refactor.solver = SolverMode::Refactor;
    let crank = FlexibleSliderCrank {
        clearance_at: Some(SliderCrankPin::CrankPin),
        ..Default::default()
    }
    .build()
    .expect("slider-crank scene");
    g.bench_function("(a) slider-crank crank pin, Newton + Woodbury", |b| {
        b.iter(|| run(black_box(&crank), &s))
    });
    g.bench_function("(a) slider-crank crank pin, Newton refactorizing", |b| {
        b.iter(|| run(black_box(&crank), &refactor))
    });
    let spin = spinning_beam_in_a_bearing();
    g.bench_function("(b) spinning beam in a bearing, constant-rate", |b| {
        b.iter(|| simulate_constant_rate(black_box(&spin), &s, &mut |_| true).expect("bench run failed"))
    });
    g.bench_function("(b) spinning beam in a bearing, Newton refactorizing", |b| {
        b.iter(|| run(black_box(&spin), &refactor))
    });
    g.finish();
}

/// The lockstep lanes' band LU (issue 14, item 2): `L` nonsymmetric band matrices of the
/// slider-crank's size (26 unknowns, half-bandwidth 5) factorized and solved as `L` [`BandLu`]s
/// one after the other, and as one [`BandLuLanes`] (each lane bitwise the same), for 4 and 8
/// lanes.
fn band_lanes(c: &mut Criterion) {
    band_lanes_of::<4>(c);
    band_lanes_of::<8>(c);
}

fn band_lanes_of<const L: usize>(c: &mut Criterion) {
    let (n, b) = (26, 5);
    let mats: Vec<BandLu> = (0..L)
        .map(|q| {
            let mut m = BandLu::new(n, b);
            for i in 0..n {
                for j in i.saturating_sub(b)..(i + b + 1).min(n) {
                    let v = ((i * 7 + j * 13 + q * 5) % 11) as f64 / 11.0 - 0.5;
                    m.add(i, j, if i == j { 4.0 * b as f64 + v } else { v });
                }
            }
            m
        })
        .collect();
    let rhs: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
    let mut g = c.benchmark_group(format!("linalg/band LU n 26 b 5, {L} matrices"));
    // the matrices are copied outside the timed part (iter_batched)
    g.bench_function(format!("{L} x BandLu factorize + solve"), |bch| {
        bch.iter_batched(
            || (mats.clone(), vec![rhs.clone(); L]),
            |(mut work, mut xs)| {
                for (m, x) in work.iter_mut().zip(xs.iter_mut()) {
                    m.factorize("bench").expect("factorizes");
                    m.solve_in_place(black_box(x));
                }
                (work, xs)
            },
            BatchSize::SmallInput,
        )
    });
    let mut lanes = BandLuLanes::<L>::new(n, b);
    for (q, m) in mats.iter().enumerate() {
        lanes.set_lane(q, m);
    }
    let xl: Vec<[f64; L]> = rhs.iter().map(|&r| [r; L]).collect();
    g.bench_function(format!("BandLuLanes<{L}> factorize + solve"), |bch| {
        bch.iter_batched(
            || (lanes.clone(), xl.clone()),
            |(mut work, mut x)| {
                for r in work.factorize("bench") {
                    r.expect("factorizes");
                }
                work.solve_in_place(black_box(&mut x));
                (work, x)
            },
            BatchSize::SmallInput,
        )
    });
    // the solve alone on factors made once (a Newton step solves 1.2 times per factorization
    // kept for up to 20 steps): its latency-bound chains are what lanes side by side can hide
    let factored: Vec<BandLu> = (mats.iter().cloned())
        .map(|mut m| {
            m.factorize("bench").expect("factorizes");
            m
        })
        .collect();
    g.bench_function(format!("{L} x BandLu solve"), |bch| {
        bch.iter_batched(
            || vec![rhs.clone(); L],
            |mut xs| {
                for (m, x) in factored.iter().zip(xs.iter_mut()) {
                    m.solve_in_place(black_box(x));
                }
                xs
            },
            BatchSize::SmallInput,
        )
    });
    let mut lanes_factored = lanes.clone();
    for r in lanes_factored.factorize("bench") {
        r.expect("factorizes");
    }
    g.bench_function(format!("BandLuLanes<{L}> solve"), |bch| {
        bch.iter_batched(
            || xl.clone(),
            |mut x| {
                lanes_factored.solve_in_place(black_box(&mut x));
                x
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, step_terms, runs, scaling, contact, band_lanes);
criterion_main!(benches);
