//! The batch runner: results in input order and equal to single runs whatever the thread count,
//! one symbolic analysis per sparsity pattern, failures kept as data, retries, and stopping.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use flexclear::batch::{run_batch, BatchOptions, BatchStats, Retry, SampleOutcome};
use flexclear::contact::{Coupling, DampingLaw};
use flexclear::integrator::constant::Lockstep;
use flexclear::model::mechanism::Mechanism;
use flexclear::record::RecordSpec;
use flexclear::scenes::{FlexibleSliderCrank, SliderCrankPin, SliderYoke};
use flexclear::{Error, RunFailure, RunOutput, Settings};

/// A single run of a mechanism the constant stepper runs, on the translating model its plan
/// derives (what the batch runs for such a sample).
fn simulate(m: &Mechanism, s: &Settings, control: &mut dyn FnMut(f64) -> bool) -> Result<RunOutput, Box<RunFailure>> {
    flexclear::run::simulate(&m.to_translating().unwrap(), s, control)
}

/// [`run_batch`] with no stop asked: the outcomes, the statistics and the count of samples done.
fn run_all(
    samples: &[(Mechanism, Settings)],
    options: &BatchOptions,
) -> flexclear::Result<(Vec<SampleOutcome>, BatchStats, usize)> {
    let (stop, done) = (AtomicBool::new(false), AtomicUsize::new(0));
    let (out, stats) = run_batch(samples, options, &stop, &done)?;
    Ok((out, stats, done.load(Ordering::Relaxed)))
}

/// Batch options on `threads` threads that retry a failed sample up to `attempts` times, the
/// step multiplied by `factor` each time.
fn retrying(threads: usize, attempts: u32, factor: f64) -> BatchOptions {
    BatchOptions {
        threads,
        retry: Retry { attempts, factor },
        ..Default::default()
    }
}

fn settings(t_end: f64, dt: f64) -> Settings {
    let mut s = Settings::new(t_end, dt);
    s.record = RecordSpec {
        histories: false,
        ..Default::default()
    };
    s
}

fn clearance_samples(n: usize, elements: impl Fn(usize) -> usize) -> Vec<(Mechanism, Settings)> {
    (0..n)
        .map(|i| {
            let model = SliderYoke {
                clearance: 1e-4 * i as f64 / n as f64,
                elements: elements(i),
                ..Default::default()
            }
            .build()
            .unwrap();
            (model, settings(0.02, 1e-5))
        })
        .collect()
}

#[test]
fn batch_equals_single_runs_on_any_number_of_threads() {
    let samples = clearance_samples(8, |i| if i % 3 == 0 { 13 } else { 12 });
    let single: Vec<_> = samples
        .iter()
        .map(|(m, s)| simulate(m, s, &mut |_| true).unwrap().record.extremes)
        .collect();
    for threads in [1, 2, 3] {
        let options = BatchOptions {
            threads,
            ..Default::default()
        };
        let (outcomes, stats, done) = run_all(&samples, &options).unwrap();
        assert_eq!(done, samples.len());
        assert_eq!(stats.threads, threads);
        // two element counts, two sparsity patterns: exactly two symbolic analyses
        assert_eq!(stats.analyses, 2);
        // input order 13, 12, 12, 13, 12, 12, 13, 12 elements: lockstep groups (default 8 lanes)
        // of consecutive samples with one pattern: [1, 2], [4, 5], the rest alone
        assert_eq!((stats.lockstep_groups, stats.lockstep_samples), (2, 4));
        for (o, e) in outcomes.iter().zip(&single) {
            let out = o.result.as_ref().unwrap().as_ref().unwrap();
            // bitwise: a run is sequential on one thread, whatever the pool
            assert_eq!(&out.record.extremes, e);
            // extremes only: no history kept
            assert!(out.record.time.is_empty() && out.record.joints.is_empty());
            assert_eq!(o.retries, 0);
        }
    }
}

#[test]
fn failures_are_data_and_retries_are_recorded() {
    let stiff = SliderYoke {
        clearance: 1e-5,
        bearing_stiffness: Some(1e10),
        ..Default::default()
    };
    let mut force = settings(0.01, 1e-5);
    force.coupling = Coupling::Force;
    let mut bad = settings(0.01, 1e-5);
    bad.dt = -1.0;
    let samples = vec![
        (stiff.build().unwrap(), force.clone()), // force method, stiff bearing: diverges at 1e-5
        (SliderYoke::default().build().unwrap(), bad),
        (SliderYoke::default().build().unwrap(), force.clone()),
    ];
    let (out, _, _) = run_all(&samples, &BatchOptions::default()).unwrap();
    let err = |i: usize| out[i].result.as_ref().unwrap().as_ref().err().map(|f| f.error.clone());
    assert!(matches!(err(0), Some(Error::Diverged { .. })), "{:?}", err(0));
    assert!(matches!(err(1), Some(Error::InvalidParameter { ref name, .. }) if name == "dt"));
    assert!(err(2).is_none());
    // a diverged sample keeps what it recorded until then
    let failed = out[0].result.as_ref().unwrap().as_ref().unwrap_err();
    assert!(failed.output.stats.steps > 0 && failed.output.time < 0.01);

    // retried at dt / 10 = 1e-6, where the force method is stable on the stiff bearing
    let (out, _, _) = run_all(&samples[..1], &retrying(1, 2, 0.1)).unwrap();
    assert!(out[0].result.as_ref().unwrap().is_ok());
    assert_eq!(out[0].retries, 1);
    assert!((out[0].dt - 1e-6).abs() < 1e-18);
}

#[test]
fn a_stopped_batch_runs_nothing_more() {
    let samples = clearance_samples(4, |_| 12);
    let (stop, done) = (AtomicBool::new(true), AtomicUsize::new(0));
    let (out, _) = run_batch(&samples, &BatchOptions::default(), &stop, &done).unwrap();
    assert!(out.iter().all(|o| o.result.is_none()));
}

#[test]
fn bad_retry_factor_is_refused() {
    let e = run_all(&[], &retrying(1, 1, 1.5)).unwrap_err();
    assert!(matches!(e, Error::InvalidParameter { ref name, .. } if name == "retry_factor"));
}

/// Everything a run produced, for bitwise comparisons (`RunOutput: PartialEq` compares f64 with
/// `==`, which would also accept -0.0 for 0.0; the debug text does not).
fn text(r: &Result<flexclear::RunOutput, Box<flexclear::RunFailure>>) -> String {
    format!("{r:?}")
}

/// Samples that share one effective matrix: clearances, bearing laws, couplings and motions
/// differ, M, K, C and dt do not.
fn shared_factor_samples(n: usize) -> Vec<(Mechanism, Settings)> {
    (0..n)
        .map(|i| {
            let scene = SliderYoke {
                clearance: 1e-3 * (i as f64 + 0.5) / n as f64,
                bearing_stiffness: if i % 5 == 1 { Some(1e9) } else { None },
                damping_law: if i % 4 == 2 {
                    DampingLaw::Radial
                } else {
                    DampingLaw::Viscous
                },
                amplitude: if i % 6 == 3 {
                    0.2
                } else {
                    SliderYoke::default().amplitude
                },
                ..Default::default()
            };
            let mut s = settings(0.02, 1e-5);
            s.coupling = match i % 7 {
                3 => Coupling::Modified {
                    iterate: true,
                    tol: 1e-10,
                    max_iter: 50,
                },
                5 => Coupling::Force,
                6 => Coupling::Gap {
                    stiffness: None,
                    damping: 5.0,
                    max_iter: 20,
                },
                _ => Coupling::default(),
            };
            (scene.build().unwrap(), s)
        })
        .collect()
}

#[test]
fn lockstep_lanes_are_bitwise_single_runs() {
    let samples = shared_factor_samples(11);
    let single: Vec<String> = samples
        .iter()
        .map(|(m, s)| text(&simulate(m, s, &mut |_| true)))
        .collect();
    for (threads, lanes) in [(1, 1), (1, 2), (2, 4), (3, 8), (2, 3), (2, 5)] {
        let options = BatchOptions {
            threads,
            lanes,
            ..Default::default()
        };
        let (out, stats, done) = run_all(&samples, &options).unwrap();
        assert_eq!(done, samples.len());
        // groups of consecutive samples, `lanes` at most (a group of 3 runs 4 lanes, one idle)
        let n = samples.len();
        let expect = if lanes == 1 {
            0
        } else {
            n / lanes + usize::from(n % lanes > 1)
        };
        assert_eq!(stats.lockstep_groups, expect, "lanes {lanes}");
        for (i, (o, e)) in out.iter().zip(&single).enumerate() {
            assert_eq!(
                &text(o.result.as_ref().unwrap()),
                e,
                "sample {i}, {threads} threads, {lanes} lanes"
            );
        }
    }
}

#[test]
fn a_diverging_lane_fails_alone_and_the_others_finish() {
    // force method on the stiff bearing diverges at 1e-5 s steps (step 512); the others finish
    let mut samples = shared_factor_samples(4);
    let mut stiff = SliderYoke {
        clearance: 1e-5,
        bearing_stiffness: Some(1e10),
        ..Default::default()
    }
    .build()
    .unwrap();
    std::mem::swap(&mut samples[1].0, &mut stiff);
    samples[1].1.coupling = Coupling::Force;
    let single: Vec<_> = samples.iter().map(|(m, s)| simulate(m, s, &mut |_| true)).collect();
    // mid-run: after some steps and well before the end (2000 steps)
    assert!(
        matches!(&single[1], Err(f) if matches!(f.error, Error::Diverged { step, .. } if step > 100 && step < 1000))
    );
    assert!(single.iter().enumerate().all(|(i, r)| (i == 1) != r.is_ok()));
    let models: Vec<_> = samples.iter().map(|(m, _)| m.to_translating().unwrap()).collect();
    let runs: Vec<_> = models.iter().zip(&samples).map(|(m, (_, s))| (m, s)).collect();
    let group = Lockstep::<4>::with_analysis(&runs, None).unwrap();
    let out = group.run(&mut |_| true);
    for (i, (o, e)) in out.iter().zip(&single).enumerate() {
        // the failed lane keeps its own error, partial record and state
        assert_eq!(text(o), text(e), "lane {i}");
    }
    // in a batch, with a retry at dt / 10 where the force method is stable
    let (out, stats, _) = run_all(&samples, &retrying(2, 1, 0.1)).unwrap();
    assert_eq!(stats.lockstep_samples, 4);
    assert_eq!(out[1].retries, 1);
    let mut retried = samples[1].1.clone();
    retried.dt *= 0.1;
    let alone = simulate(&samples[1].0, &retried, &mut |_| true);
    assert!(alone.is_ok());
    assert_eq!(text(out[1].result.as_ref().unwrap()), text(&alone));
    for i in [0, 2, 3] {
        assert_eq!(out[i].retries, 0);
        assert_eq!(text(out[i].result.as_ref().unwrap()), text(&single[i]));
    }
}

#[test]
fn samples_that_cannot_share_run_alone() {
    // histories asked, another step, another Young's modulus: no lockstep with their neighbours
    let mut samples = shared_factor_samples(8);
    samples[1].1.record.histories = true;
    samples[3].1.dt = 2e-5;
    samples[5].0 = SliderYoke {
        first_frequency: 150.0,
        ..Default::default()
    }
    .build()
    .unwrap();
    let options = BatchOptions {
        threads: 2,
        lanes: 8,
        ..Default::default()
    };
    let (out, stats, _) = run_all(&samples, &options).unwrap();
    // groups: [0] [1] [2] [3] [4] [5] [6, 7]
    assert_eq!((stats.lockstep_groups, stats.lockstep_samples), (1, 2));
    for (o, (m, s)) in out.iter().zip(&samples) {
        assert_eq!(text(o.result.as_ref().unwrap()), text(&simulate(m, s, &mut |_| true)));
    }
    let e = run_all(
        &samples,
        &BatchOptions {
            lanes: 9,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, Error::InvalidParameter { ref name, .. } if name == "lanes"));
}

#[test]
fn lanes_that_do_not_share_the_factor_are_refused() {
    let a = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let b = SliderYoke {
        elements: 10,
        ..Default::default()
    }
    .build()
    .unwrap()
    .to_translating()
    .unwrap();
    let s = settings(0.001, 1e-5);
    assert!(Lockstep::<2>::with_analysis(&[(&a, &s), (&b, &s)], None).is_err());
    assert!(Lockstep::<2>::with_analysis(&[(&a, &s), (&a, &s), (&a, &s)], None).is_err());
}

#[test]
fn a_one_step_penetration_spike_stops_its_lane_at_that_step() {
    // lagged kappa at K_B = 1e13 N/m and dt = 1e-5 s chatters with a one-step spike of 4.67 m of
    // penetration at step 713 (between two strided state checks); the per-step joint check must
    // stop that lane there, and only that lane
    let build = |kb: f64| {
        SliderYoke {
            clearance: 1e-6,
            bearing_stiffness: Some(kb),
            ..Default::default()
        }
        .build()
        .unwrap()
    };
    let (spiky, calm) = (build(1e13), build(1e8));
    let mut s = settings(0.01, 1e-5);
    s.divergence_limit = Some(1.0);
    let alone = simulate(&spiky, &s, &mut |_| true);
    match &alone {
        Err(f) => match &f.error {
            Error::Diverged { step, dof, reason, .. } => {
                assert_eq!(*step, 713);
                assert!(
                    dof.contains("bearing") && reason.contains("penetration"),
                    "{dof}: {reason}"
                );
            }
            e => panic!("expected a divergence, got {e}"),
        },
        Ok(_) => panic!("the spike was not detected"),
    }
    let (calm_t, spiky_t) = (calm.to_translating().unwrap(), spiky.to_translating().unwrap());
    let out = Lockstep::<2>::with_analysis(&[(&calm_t, &s), (&spiky_t, &s)], None)
        .unwrap()
        .run(&mut |_| true);
    assert!(out[0].is_ok());
    assert_eq!(text(&out[0]), text(&simulate(&calm, &s, &mut |_| true)));
    assert_eq!(text(&out[1]), text(&alone));
}

#[test]
fn event_aware_runs_do_not_share_a_factor() {
    let model = SliderYoke::default().build().unwrap().to_translating().unwrap();
    let s = settings(0.001, 1e-5);
    let mut e = s.clone();
    e.events = true;
    assert!(Lockstep::<2>::with_analysis(&[(&model, &s), (&model, &s)], None).is_ok());
    assert!(Lockstep::<2>::with_analysis(&[(&model, &s), (&model, &e)], None).is_err());
    assert!(Lockstep::<2>::with_analysis(&[(&model, &e), (&model, &e)], None).is_err());
}

/// A slider-crank with a clearance joint at the crank pin (the Newton stepper's model) at
/// `clearance` (m).
fn slider_crank(clearance: f64) -> Mechanism {
    FlexibleSliderCrank {
        clearance_at: Some(SliderCrankPin::CrankPin),
        clearance,
        ..Default::default()
    }
    .build()
    .unwrap()
}

#[test]
fn samples_that_need_newton_run_in_the_batch_as_single_runs() {
    // slider-crank samples (Newton) between slider-yoke samples (constant, two lockstep pairs)
    let mut samples = clearance_samples(4, |_| 12);
    let mut s = settings(0.004, 1e-5);
    s.coupling = Coupling::Modified {
        iterate: true,
        tol: 1e-10,
        max_iter: 50,
    };
    samples.insert(2, (slider_crank(5e-4), s.clone()));
    samples.push((slider_crank(2e-4), s.clone()));
    // a Newton sample that fails before its first step is an outcome too
    let mut bad = s.clone();
    bad.dt = -1.0;
    samples.push((slider_crank(5e-4), bad));
    let single: Vec<String> = samples
        .iter()
        .map(|(m, s)| text(&flexclear::plan::simulate(m, s, &mut |_| true)))
        .collect();
    for threads in [1, 2] {
        let options = BatchOptions {
            threads,
            ..Default::default()
        };
        let (out, stats, done) = run_all(&samples, &options).unwrap();
        assert_eq!(done, samples.len());
        // [0, 1] and [3, 4] in lockstep; the slider-cranks alone
        assert_eq!((stats.lockstep_groups, stats.lockstep_samples), (2, 4));
        for i in [2, 5, 6] {
            // bitwise the single run, its stepper's statistics included
            assert_eq!(text(out[i].result.as_ref().unwrap()), single[i], "sample {i}");
        }
        let newton = out[2].result.as_ref().unwrap().as_ref().unwrap();
        assert_eq!(newton.stats.stepper, "newton");
        assert!(newton.record.extremes[0].max_force > 0.0);
        let failed = out[6].result.as_ref().unwrap().as_ref().unwrap_err();
        assert!(matches!(failed.error, Error::InvalidParameter { ref name, .. } if name == "dt"));
        for i in [0, 1, 3, 4] {
            let (a, b) = (out[i].result.as_ref().unwrap().as_ref().unwrap(), &samples[i]);
            let alone = flexclear::plan::simulate(&b.0, &b.1, &mut |_| true).unwrap();
            // the constant stepper's joint channels, state and counters as in a single run
            assert_eq!(
                (&a.record.extremes, &a.state, &a.stats),
                (&alone.record.extremes, &alone.state, &alone.stats)
            );
        }
    }
}

#[test]
fn a_newton_sample_that_fails_is_retried_on_a_new_plan() {
    // one Newton iteration a step to a tolerance it cannot reach: the run stops, not converged;
    // the retry at dt / 2 plans again (its own plan, not the first attempt's) and is the single
    // run at that step, outcome for outcome
    let mut s = settings(0.002, 1e-5);
    s.newton.max_iter = 1;
    s.newton.tol = 1e-15;
    let first = flexclear::plan::simulate(&slider_crank(5e-4), &s, &mut |_| true);
    assert!(
        matches!(&first, Err(f) if matches!(f.error, Error::NotConverged { .. })),
        "{}",
        text(&first)
    );
    let samples = vec![
        (slider_crank(5e-4), s.clone()),
        (slider_crank(2e-4), settings(0.002, 1e-5)),
    ];
    let (out, _, _) = run_all(&samples, &retrying(1, 1, 0.5)).unwrap();
    assert_eq!((out[0].retries, out[0].dt), (1, 5e-6));
    let mut retried = s.clone();
    retried.dt = 5e-6;
    let alone = flexclear::plan::simulate(&samples[0].0, &retried, &mut |_| true);
    assert_eq!(text(out[0].result.as_ref().unwrap()), text(&alone));
    assert_eq!(out[1].retries, 0);
    let single = flexclear::plan::simulate(&samples[1].0, &samples[1].1, &mut |_| true);
    assert_eq!(text(out[1].result.as_ref().unwrap()), text(&single));
}
