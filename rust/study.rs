//! Batches of independent runs (the samples of a Monte Carlo study) on a rayon thread pool.
//!
//! Every sample is a model and its settings. The samples run in parallel, each on one thread
//! from start to end (a run is sequential), so the results do not depend on the number of
//! threads. The symbolic factorization is shared among samples whose models have the same
//! sparsity pattern ([`AnalysisCache`]); samples that change the element count get their own.
//! A sample that fails (invalid parameters, divergence, a matrix that is not positive definite)
//! is an outcome like any other: the batch goes on. Memory is what each sample's
//! [`RecordSpec`](crate::recorder::RecordSpec) asks for, so a batch that records only running
//! extremes needs O(samples x outputs), whatever the run length.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::linsolve::AnalysisCache;
use crate::model::Model;
use crate::simulation::{simulate_shared, RunFailure, RunOutput, Settings};

/// What to do when a sample diverges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retry {
    /// How many times to retry a diverged sample (0 = never).
    pub attempts: u32,
    /// The step is multiplied by this at each retry (0 < factor < 1).
    pub factor: f64,
}

impl Default for Retry {
    fn default() -> Self {
        Retry {
            attempts: 0,
            factor: 0.5,
        }
    }
}

impl Retry {
    /// Checks the policy.
    pub fn validate(&self) -> Result<()> {
        if !(self.factor > 0.0 && self.factor < 1.0) {
            return Err(Error::param("retry_factor", self.factor, "0 < retry_factor < 1"));
        }
        Ok(())
    }
}

/// Options of a batch.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BatchOptions {
    /// Worker threads; 0 = one per core.
    pub threads: usize,
    /// Retry policy for diverged samples.
    pub retry: Retry,
}

/// One sample's outcome.
#[derive(Debug, Clone)]
pub struct SampleOutcome {
    /// The run's output, or why it failed (with what it recorded until then). `None` when the
    /// batch was stopped before this sample started.
    pub result: Option<std::result::Result<RunOutput, Box<RunFailure>>>,
    /// The step of the last attempt, s.
    pub dt: f64,
    /// Retries made (0 when the first attempt stood).
    pub retries: u32,
    /// Wall-clock time of all attempts, s.
    pub wall_time: f64,
}

/// Counters of a batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BatchStats {
    /// Distinct sparsity patterns among the samples (symbolic analyses made).
    pub analyses: usize,
    /// Threads used.
    pub threads: usize,
}

/// Runs every `(model, settings)` pair of `samples` on `options.threads` threads and returns the
/// outcomes in the input order.
///
/// `stop` is polled by every run (every few thousand steps) and before each sample starts: once
/// it is set, running samples end with [`Error::Interrupted`] and samples not yet started are
/// returned with `result: None`. `done` is incremented as each sample finishes, so another
/// thread can show progress. Fails only when the options are invalid or the thread pool cannot
/// be built.
pub fn run_batch(
    samples: &[(Model, Settings)],
    options: &BatchOptions,
    stop: &AtomicBool,
    done: &AtomicUsize,
) -> Result<(Vec<SampleOutcome>, BatchStats)> {
    options.retry.validate()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .thread_name(|i| format!("flexclear-batch-{i}"))
        .build()
        .map_err(|e| Error::InvalidModel {
            message: format!("cannot start {} worker threads: {e}", options.threads),
        })?;
    let cache = AnalysisCache::new();
    let outcomes = pool.install(|| {
        samples
            .par_iter()
            .with_max_len(1)
            .map(|(model, settings)| {
                let out = run_one(model, settings, options.retry, &cache, stop);
                done.fetch_add(1, Ordering::Relaxed);
                out
            })
            .collect()
    });
    let stats = BatchStats {
        analyses: cache.len(),
        threads: pool.current_num_threads(),
    };
    Ok((outcomes, stats))
}

fn run_one(
    model: &Model,
    settings: &Settings,
    retry: Retry,
    cache: &AnalysisCache,
    stop: &AtomicBool,
) -> SampleOutcome {
    let start = Instant::now();
    let mut settings = settings.clone();
    let mut retries = 0;
    if stop.load(Ordering::Relaxed) {
        return SampleOutcome {
            result: None,
            dt: settings.dt,
            retries,
            wall_time: 0.0,
        };
    }
    loop {
        let mut control = |_: f64| !stop.load(Ordering::Relaxed);
        let result = simulate_shared(model, &settings, Some(cache), &mut control);
        let diverged = matches!(&result, Err(f) if matches!(f.error, Error::Diverged { .. }));
        if diverged && retries < retry.attempts && !stop.load(Ordering::Relaxed) {
            retries += 1;
            settings.dt *= retry.factor;
            continue;
        }
        return SampleOutcome {
            result: Some(result),
            dt: settings.dt,
            retries,
            wall_time: start.elapsed().as_secs_f64(),
        };
    }
}
