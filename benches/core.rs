//! Criterion benches of the hot paths: element matrices, assembly, one Newmark step (contact
//! open and closed), the linear solves, and a full slider-yoke run (the target case).
//! The scene builds a mechanism; these benches run the constant stepper on the translating model
//! its plan derives (`Mechanism::to_translating`), as `plan::simulate` does, without the plan's
//! per-run work. One bench runs the Newton stepper on moving frames (Simeon's slider-crank with a
//! clearance at the crank pin), gated like the slider-yoke's.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use flexclear::contact::Coupling;
use flexclear::integrator::constant::Lockstep;
use flexclear::integrator::newton::simulate_mechanism;
use flexclear::linalg::Cholesky;
use flexclear::plan::assembly::System;
use flexclear::run::simulate;
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin, SliderYoke};
use flexclear::Settings;

fn elements(c: &mut Criterion) {
    let e = SliderYoke::default().build().unwrap().to_translating().unwrap().links[0].element();
    c.bench_function("element/mass+stiffness", |b| {
        b.iter(|| (black_box(&e).mass(), black_box(&e).stiffness()))
    });
    c.bench_function("element/geometric K2", |b| {
        b.iter(|| black_box(&e).geometric_stiffness(black_box(100.0)))
    });
}

fn assembly(c: &mut Criterion) {
    for n in [12, 120, 1200] {
        let model = SliderYoke {
            elements: n,
            ..Default::default()
        }
        .build()
        .unwrap()
        .to_translating()
        .unwrap();
        c.bench_function(&format!("assembly/slider {n} elements"), |b| {
            b.iter(|| System::assemble(black_box(&model)))
        });
    }
}

fn linsolve(c: &mut Criterion) {
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let sys = System::assemble(&model);
    let a: Vec<f64> = (0..sys.pattern.nnz())
        .map(|p| sys.mass[p] + 2.5e-13 * sys.stiffness[p])
        .collect();
    let mut ch = Cholesky::analyze(&sys.pattern).unwrap();
    ch.factorize(&a, "bench").unwrap();
    let b0: Vec<f64> = (0..sys.n()).map(|i| (i as f64).sin()).collect();
    let mut x = b0.clone();
    c.bench_function("linsolve/solve 39 dofs (banded substitution on faer's LDLt)", |b| {
        b.iter(|| {
            x.copy_from_slice(&b0);
            ch.solve_in_place(black_box(&mut x));
        })
    });
    c.bench_function("linsolve/solve 39 dofs (faer LDLt solve_in_place_with_conj)", |b| {
        b.iter(|| {
            x.copy_from_slice(&b0);
            ch.solve_in_place_faer(black_box(&mut x));
        })
    });
    c.bench_function("linsolve/numeric refactorization 39 dofs", |b| {
        b.iter(|| ch.factorize(black_box(&a), "bench").unwrap())
    });
}

/// Cost of one step = (run of N + 1000 steps - run of 1000 steps) / N, so setup is excluded.
fn steps(c: &mut Criterion) {
    for (label, clearance, kb) in [("contact open", 1.0, None), ("contact closed", 0.0, Some(1e9))] {
        let model = SliderYoke {
            clearance,
            bearing_stiffness: kb,
            ..Default::default()
        }
        .build()
        .unwrap()
        .to_translating()
        .unwrap();
        for (mname, coupling) in [("modified", Coupling::default()), ("force", Coupling::Force)] {
            let mut s = Settings::new(1e-2, 1e-6);
            s.coupling = coupling;
            s.record.histories = false;
            c.bench_function(&format!("newmark/10k steps, {label}, {mname}"), |b| {
                b.iter(|| simulate(black_box(&model), &s, &mut |_| true).unwrap())
            });
        }
    }
}

fn full_run(c: &mut Criterion) {
    let mut g = c.benchmark_group("slider-yoke");
    g.sample_size(20);
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
    g.bench_function(
        "target: 12 el, dt 1e-6, 0.1 s (1e5 steps), modified, extremes only",
        |b| {
            b.iter_batched(
                || model.clone(),
                |m| simulate(&m, &s, &mut |_| true).unwrap(),
                BatchSize::SmallInput,
            )
        },
    );
    let mut s2 = s.clone();
    s2.record.histories = true;
    g.bench_function("12 el, dt 1e-6, 0.1 s, modified, full history", |b| {
        b.iter(|| simulate(&model, &s2, &mut |_| true).unwrap())
    });
    g.finish();
}

/// Lockstep: 8 samples of the reference study (Table 1 slider-yoke, clearances spread over
/// [0, 1e-3] m, modified method, dt 1e-5 s, 2000 steps, extremes only) run one by one and as
/// lockstep groups of 2, 4 and 8 lanes on one factorization. Throughput is in sample-steps, so
/// the per-step cost of one sample is the inverse of the reported rate.
fn lockstep(c: &mut Criterion) {
    const SAMPLES: usize = 8;
    let samples: Vec<_> = (0..SAMPLES)
        .map(|i| {
            let model = SliderYoke {
                clearance: 1e-3 * (i as f64 + 0.5) / SAMPLES as f64,
                ..Default::default()
            }
            .build()
            .unwrap()
            .to_translating()
            .unwrap();
            let mut s = Settings::new(0.02, 1e-5);
            s.record.histories = false;
            (model, s)
        })
        .collect();
    let mut g = c.benchmark_group("lockstep");
    g.sample_size(20);
    g.throughput(Throughput::Elements((SAMPLES as u64) * samples[0].1.steps()));
    g.bench_function("8 samples x 2000 steps, one by one", |b| {
        b.iter(|| {
            for (m, s) in &samples {
                black_box(simulate(m, s, &mut |_| true).unwrap());
            }
        })
    });
    fn groups<const L: usize>(samples: &[(flexclear::plan::translating::Model, Settings)]) {
        for chunk in samples.chunks(L) {
            let runs: Vec<_> = chunk.iter().map(|(m, s)| (m, s)).collect();
            let out = Lockstep::<L>::with_analysis(&runs, None).unwrap().run(&mut |_| true);
            black_box(out);
        }
    }
    g.bench_function("8 samples x 2000 steps, 2 lanes", |b| b.iter(|| groups::<2>(&samples)));
    g.bench_function("8 samples x 2000 steps, 4 lanes", |b| b.iter(|| groups::<4>(&samples)));
    g.bench_function("8 samples x 2000 steps, 8 lanes", |b| b.iter(|| groups::<8>(&samples)));
    g.finish();
}

/// The Newton stepper on moving frames: Simeon's slider-crank with a 0.5 mm clearance at the
/// crank pin (8 elements, 26 unknowns, geometric terms, implicit contact iterated to 1e-10),
/// 1000 steps of 1e-5 s from rest (the opening impacts) and the whole 0.1 s, extremes only (as
/// `examples/profile_newton crank-pin`).
fn newton(c: &mut Criterion) {
    let mut g = c.benchmark_group("newton");
    g.sample_size(20);
    let mech = FlexibleSliderCrank {
        clearance_at: Some(SliderCrankPin::CrankPin),
        ..Default::default()
    }
    .build()
    .unwrap();
    let mut s = Settings::new(0.01, 1e-5);
    s.record.histories = false;
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    g.bench_function("slider-crank crank pin, 1000 steps, implicit contact", |b| {
        b.iter(|| simulate_mechanism(black_box(&mech), &s, &mut |_| true).unwrap())
    });
    // issue 14's target run (0.1 s at 1e-5 s): mostly steps past the opening impacts, where the
    // extrapolated first iterate and the kept factor set the cost
    let mut s = s.clone();
    s.t_end = 0.1;
    g.bench_function("slider-crank crank pin, 0.1 s (10000 steps), implicit contact", |b| {
        b.iter(|| simulate_mechanism(black_box(&mech), &s, &mut |_| true).unwrap())
    });
    g.finish();
}

criterion_group!(benches, elements, assembly, linsolve, steps, full_run, lockstep, newton);
criterion_main!(benches);
