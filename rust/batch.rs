//! Batches of independent runs (the samples of a Monte Carlo study) on a rayon thread pool.
//!
//! Every sample is a [`Mechanism`] and its settings, planned as [`crate::plan::simulate`] plans
//! it ([`Plan::compile`]). A sample the constant stepper runs is run on the translating model the
//! plan derives (its joint channels, state and statistics are those of `plan::simulate`, bitwise;
//! no link histories are made); any other sample (Newton, or one the plan refuses) runs alone, one
//! lane on one thread, through `plan::simulate` itself, so its outcome is that of a single run.
//! The samples run in parallel, each on one thread from start to end (a run is sequential), so
//! the results do not depend on the number of threads. The symbolic factorization is shared among samples whose models have the same
//! sparsity pattern ([`AnalysisCache`]); samples that change the element count get their own.
//! A sample that fails (invalid parameters, divergence, a Newton step that does not converge, a
//! matrix that is not positive definite) is an outcome like any other: the batch goes on. Memory is what each sample's
//! [`RecordSpec`](crate::record::RecordSpec) asks for, so a batch that records only running
//! extremes needs O(samples x outputs), whatever the run length.
//!
//! **Lockstep groups.** Consecutive samples (in input order) whose contact-free effective matrix
//! and step are the same ([`shares_factor`]: e.g. samples that differ only in clearance or
//! bearing law) and that record only extremes run as one [`Lockstep`] group of up to
//! [`BatchOptions::lanes`] lanes on one thread, sharing one factorization and one multi-lane
//! substitution per step. Each lane's result is bitwise that of its single run, and the groups
//! are formed from the input order alone, so results do not depend on the thread count, the
//! lane count or the chunking.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::integrator::constant::{Lockstep, RunResult};
use crate::linalg::AnalysisCache;
use crate::model::mechanism::Mechanism;
use crate::plan::assembly::shares_factor;
use crate::plan::assembly::System;
use crate::plan::translating::Model;
use crate::plan::{Plan, StepperKind};
use crate::run::{simulate_shared, RunFailure, RunOutput, Settings, SolverMode};

/// What to do when a sample diverges ([`Error::Diverged`]) or a Newton step does not converge
/// ([`Error::NotConverged`]): run it again from the start at a smaller step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retry {
    /// How many times to retry such a sample (0 = never), as long as the step stays at least
    /// [`RETRY_MIN_STEP_RATIO`] of the sample's own.
    pub attempts: u32,
    /// The step is multiplied by this at each retry (0 < factor < 1).
    pub factor: f64,
}

/// Retries stop once the next step would be shorter than this fraction of the sample's own
/// step: each retry runs the sample again from its start, at a cost that grows as the step
/// shrinks (a sample that diverges whatever the step would otherwise retry for ever).
pub const RETRY_MIN_STEP_RATIO: f64 = 1e-3;

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
    /// Largest lockstep group (samples sharing one factorization stepped together on one
    /// thread): 0 = the default ([`DEFAULT_LANES`]), 1 = every sample alone, at most
    /// [`MAX_LANES`]. Results are the same whatever the value.
    pub lanes: usize,
}

/// Lockstep lanes used when [`BatchOptions::lanes`] is 0: two 256-bit vectors per operation,
/// measured a few per cent faster per sample-step than 4 on the reference study.
pub const DEFAULT_LANES: usize = 8;
/// Largest accepted [`BatchOptions::lanes`].
pub const MAX_LANES: usize = 8;

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
    /// Wall-clock time of all attempts, s; a sample run in a lockstep group of k samples counts
    /// the group's time divided by k.
    pub wall_time: f64,
}

/// Counters of a batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BatchStats {
    /// Distinct sparsity patterns among the samples (symbolic analyses made).
    pub analyses: usize,
    /// Threads used.
    pub threads: usize,
    /// Lockstep groups of two or more samples.
    pub lockstep_groups: usize,
    /// Samples run in those groups.
    pub lockstep_samples: usize,
}

/// How the batch runs one sample.
enum Job {
    /// On the constant stepper: the translating model [`Plan::compile`] derives (validated as a
    /// mechanism first, as `plan::simulate` does).
    Constant(Model),
    /// Alone on the Newton or constant-rate stepper, on the plan made to group the samples
    /// ([`crate::plan::simulate_planned`]: not compiled, nor the mechanism validated, again).
    Planned(Plan),
    /// Alone, through [`crate::plan::simulate`]: a sample that fails before its first step (the
    /// failure is its outcome).
    Alone,
}

impl Job {
    fn of(mech: &Mechanism, settings: &Settings) -> Job {
        match Plan::compile(mech, settings) {
            Ok(plan) if plan.kind == StepperKind::Constant && mech.validate(settings.t_end).is_ok() => {
                mech.to_translating().map_or(Job::Alone, Job::Constant)
            }
            Ok(plan) if plan.kind != StepperKind::Constant => Job::Planned(plan),
            _ => Job::Alone,
        }
    }

    /// One run of `mech` (this job's sample) with `settings`: the sample's own, or with
    /// `retrying` a retry's (a smaller step, planned again).
    fn run(
        &self,
        mech: &Mechanism,
        settings: &Settings,
        cache: &AnalysisCache,
        control: &mut dyn FnMut(f64) -> bool,
        retrying: bool,
    ) -> RunResult {
        match self {
            Job::Constant(model) => simulate_shared(model, settings, Some(cache), control),
            Job::Planned(plan) if !retrying => crate::plan::simulate_planned(mech, settings, plan, control),
            Job::Planned(_) | Job::Alone => crate::plan::simulate(mech, settings, control),
        }
    }
}

/// Runs every `(mechanism, settings)` pair of `samples` on `options.threads` threads and returns
/// the outcomes in the input order.
///
/// `stop` is polled by every run (every few thousand steps) and before each sample (or lockstep
/// group) starts: once it is set, running samples end with [`Error::Interrupted`] and samples
/// not yet started are returned with `result: None`. `done` is incremented as each sample
/// finishes, so another thread can show progress. Fails only when the options are invalid or the
/// thread pool cannot be built.
pub fn run_batch(
    samples: &[(Mechanism, Settings)],
    options: &BatchOptions,
    stop: &AtomicBool,
    done: &AtomicUsize,
) -> Result<(Vec<SampleOutcome>, BatchStats)> {
    options.retry.validate()?;
    let lanes = match options.lanes {
        0 => DEFAULT_LANES,
        l if l <= MAX_LANES => l,
        l => {
            return Err(Error::param(
                "lanes",
                l,
                format!("an integer in 0 ..= {MAX_LANES} (0 = default)"),
            ))
        }
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .thread_name(|i| format!("flexclear-batch-{i}"))
        .build()
        .map_err(|e| Error::InvalidModel {
            message: format!("cannot start {} worker threads: {e}", options.threads),
        })?;
    let cache = AnalysisCache::new();
    let (outcomes, lockstep_groups, lockstep_samples) = pool.install(|| {
        // the plans, and the systems that decide grouping, made in parallel (None: runs alone)
        let jobs: Vec<Job> = samples.par_iter().map(|(m, s)| Job::of(m, s)).collect();
        let systems: Vec<Option<System>> = jobs
            .par_iter()
            .zip(samples.par_iter())
            .map(|(job, (_, s))| match job {
                Job::Constant(m) => {
                    let fits = lanes > 1
                        && !s.record.histories
                        && s.solver == SolverMode::Woodbury
                        && m.validate().is_ok()
                        && s.validate(m).is_ok();
                    fits.then(|| System::assemble(m))
                }
                Job::Planned(_) | Job::Alone => None,
            })
            .collect();
        let groups = lockstep_groups(samples, &systems, lanes);
        drop(systems);
        let multi = groups.iter().filter(|g| g.len() > 1);
        let counts = (multi.clone().count(), multi.map(|g| g.len()).sum::<usize>());
        let per_group: Vec<Vec<SampleOutcome>> = groups
            .par_iter()
            .with_max_len(1)
            .map(|g| {
                if g.len() == 1 {
                    let out = run_one(&samples[g.start], &jobs[g.start], options.retry, &cache, stop);
                    done.fetch_add(1, Ordering::Relaxed);
                    vec![out]
                } else {
                    run_group(&samples[g.clone()], &jobs[g.clone()], options.retry, &cache, stop, done)
                }
            })
            .collect();
        let outcomes: Vec<SampleOutcome> = per_group.into_iter().flatten().collect();
        (outcomes, counts.0, counts.1)
    });
    let stats = BatchStats {
        analyses: cache.len(),
        threads: pool.current_num_threads(),
        lockstep_groups,
        lockstep_samples,
    };
    Ok((outcomes, stats))
}

/// Splits `0 .. samples.len()` into consecutive groups: a new group starts at a sample that
/// cannot join the current one (it runs alone, the group is full, or [`shares_factor`] does not
/// hold with the group's first sample). Depends on the samples and `lanes` only.
fn lockstep_groups(
    samples: &[(Mechanism, Settings)],
    systems: &[Option<System>],
    lanes: usize,
) -> Vec<std::ops::Range<usize>> {
    let mut groups: Vec<std::ops::Range<usize>> = Vec::new();
    for i in 0..samples.len() {
        if let Some(g) = groups.last_mut() {
            let first = g.start;
            let joins = g.len() < lanes
                && match (&systems[first], &systems[i]) {
                    (Some(a), Some(b)) => shares_factor((a, &samples[first].1), (b, &samples[i].1)),
                    _ => false,
                };
            if joins {
                g.end = i + 1;
                continue;
            }
        }
        groups.push(i..i + 1);
    }
    groups
}

/// Runs 2 ..= 8 samples that share their factor (constant-stepper jobs) as one lockstep group; a
/// lane that diverges is retried alone (at smaller steps) as [`run_one`] would. Each sample's
/// wall time is the group's time divided by its size, plus its own retries.
fn run_group(
    group: &[(Mechanism, Settings)],
    jobs: &[Job],
    retry: Retry,
    cache: &AnalysisCache,
    stop: &AtomicBool,
    done: &AtomicUsize,
) -> Vec<SampleOutcome> {
    if stop.load(Ordering::Relaxed) {
        return group.iter().map(|(_, s)| not_run(s)).collect();
    }
    let start = Instant::now();
    let runs: Vec<(&Model, &Settings)> = jobs
        .iter()
        .zip(group)
        .filter_map(|(job, (_, s))| match job {
            Job::Constant(m) => Some((m, s)),
            Job::Planned(_) | Job::Alone => None,
        })
        .collect();
    debug_assert_eq!(
        runs.len(),
        group.len(),
        "a lockstep group holds constant-stepper jobs only"
    );
    let mut control = |_: f64| !stop.load(Ordering::Relaxed);
    // the narrowest lockstep that holds the group (a short group does not step idle lanes)
    let results = match group.len() {
        ..=2 => lockstep::<2>(&runs, cache, &mut control),
        3..=4 => lockstep::<4>(&runs, cache, &mut control),
        _ => lockstep::<8>(&runs, cache, &mut control),
    };
    let share = start.elapsed().as_secs_f64() / group.len() as f64;
    group
        .iter()
        .zip(jobs)
        .zip(results)
        .map(|((sample, job), result)| {
            let out = retry_failed(sample, job, result, retry, cache, stop, share);
            done.fetch_add(1, Ordering::Relaxed);
            out
        })
        .collect()
}

/// One lockstep run of `runs` (at most `L`); an error before the first step is every lane's.
fn lockstep<const L: usize>(
    runs: &[(&Model, &Settings)],
    cache: &AnalysisCache,
    control: &mut dyn FnMut(f64) -> bool,
) -> Vec<RunResult> {
    match Lockstep::<L>::with_analysis(runs, Some(cache)) {
        Ok(group) => group.run(control),
        Err(error) => runs
            .iter()
            .map(|_| Err(RunFailure::before_start(error.clone())))
            .collect(),
    }
}

/// The outcome of a sample the batch did not start.
fn not_run(settings: &Settings) -> SampleOutcome {
    SampleOutcome {
        result: None,
        dt: settings.dt,
        retries: 0,
        wall_time: 0.0,
    }
}

fn run_one(
    sample: &(Mechanism, Settings),
    job: &Job,
    retry: Retry,
    cache: &AnalysisCache,
    stop: &AtomicBool,
) -> SampleOutcome {
    if stop.load(Ordering::Relaxed) {
        return not_run(&sample.1);
    }
    let start = Instant::now();
    let mut control = |_: f64| !stop.load(Ordering::Relaxed);
    let result = job.run(&sample.0, &sample.1, cache, &mut control, false);
    let wall = start.elapsed().as_secs_f64();
    retry_failed(sample, job, result, retry, cache, stop, wall)
}

/// Retries a first attempt `result` (wall time `wall`, s) that diverged or did not converge at
/// smaller steps as `retry` allows, unless the batch is stopping.
fn retry_failed(
    (mech, settings): &(Mechanism, Settings),
    job: &Job,
    mut result: RunResult,
    retry: Retry,
    cache: &AnalysisCache,
    stop: &AtomicBool,
    mut wall: f64,
) -> SampleOutcome {
    let mut settings = settings.clone();
    let dt0 = settings.dt;
    let mut retries = 0;
    loop {
        let failed =
            matches!(&result, Err(f) if matches!(f.error, Error::Diverged { .. } | Error::NotConverged { .. }));
        let above_floor = settings.dt * retry.factor >= RETRY_MIN_STEP_RATIO * dt0;
        if failed && retries < retry.attempts && above_floor && !stop.load(Ordering::Relaxed) {
            retries += 1;
            settings.dt *= retry.factor;
            let start = Instant::now();
            let mut control = |_: f64| !stop.load(Ordering::Relaxed);
            result = job.run(mech, &settings, cache, &mut control, true);
            wall += start.elapsed().as_secs_f64();
            continue;
        }
        return SampleOutcome {
            result: Some(result),
            dt: settings.dt,
            retries,
            wall_time: wall,
        };
    }
}
