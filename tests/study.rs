//! The batch runner: results in input order and equal to single runs whatever the thread count,
//! one symbolic analysis per sparsity pattern, failures kept as data, retries, and stopping.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use flexclear::contact::Coupling;
use flexclear::recorder::RecordSpec;
use flexclear::scenes::SliderYoke;
use flexclear::study::{run_batch, BatchOptions, Retry};
use flexclear::{simulate, Error, Settings};

fn settings(t_end: f64, dt: f64) -> Settings {
    let mut s = Settings::new(t_end, dt);
    s.record = RecordSpec {
        histories: false,
        ..Default::default()
    };
    s
}

fn clearance_samples(n: usize, elements: impl Fn(usize) -> usize) -> Vec<(flexclear::model::Model, Settings)> {
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
        let (stop, done) = (AtomicBool::new(false), AtomicUsize::new(0));
        let (outcomes, stats) = run_batch(&samples, &options, &stop, &done).unwrap();
        assert_eq!(done.load(Ordering::Relaxed), samples.len());
        assert_eq!(stats.threads, threads);
        // two element counts, two sparsity patterns: exactly two symbolic analyses
        assert_eq!(stats.analyses, 2);
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
    let (stop, done) = (AtomicBool::new(false), AtomicUsize::new(0));
    let (out, _) = run_batch(&samples, &BatchOptions::default(), &stop, &done).unwrap();
    let err = |i: usize| out[i].result.as_ref().unwrap().as_ref().err().map(|f| f.error.clone());
    assert!(matches!(err(0), Some(Error::Diverged { .. })), "{:?}", err(0));
    assert!(matches!(err(1), Some(Error::InvalidParameter { ref name, .. }) if name == "dt"));
    assert!(err(2).is_none());
    // a diverged sample keeps what it recorded until then
    let failed = out[0].result.as_ref().unwrap().as_ref().unwrap_err();
    assert!(failed.output.stats.steps > 0 && failed.output.time < 0.01);

    // retried at dt / 10 = 1e-6, where the force method is stable on the stiff bearing
    let options = BatchOptions {
        threads: 1,
        retry: Retry {
            attempts: 2,
            factor: 0.1,
        },
    };
    let (out, _) = run_batch(&samples[..1], &options, &stop, &done).unwrap();
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
    let options = BatchOptions {
        threads: 1,
        retry: Retry {
            attempts: 1,
            factor: 1.5,
        },
    };
    let (stop, done) = (AtomicBool::new(false), AtomicUsize::new(0));
    let e = run_batch(&[], &options, &stop, &done).unwrap_err();
    assert!(matches!(e, Error::InvalidParameter { ref name, .. } if name == "retry_factor"));
}
