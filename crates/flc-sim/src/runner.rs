//! The runner: one way to run scenarios, with options (MCAP recording, a stop flag, a progress
//! bar), one at a time or many in parallel (rayon; results in input order and independent of
//! the number of threads).

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::SimError;
use crate::record::Recorder;
use crate::scenario::Scenario;
use crate::sim::{Observer, RunResult, Simulation};
use crate::trajectory::TrajectoryWriter;

/// How to run: `RunOptions::default()` runs to the end, records nothing, shows no progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions<'a> {
    /// Write an MCAP recording of each run into this directory (`crate::record`).
    pub record: Option<&'a std::path::Path>,
    /// Checked before every physics step: once set, the run ends there (recordings are finished
    /// without `flc.metrics`, the partial result is returned) and runs of a batch that have not
    /// started are not started (an error each). Callers tell an interrupted run by the flag.
    pub stop: Option<&'a AtomicBool>,
    /// Show a progress bar on stderr ([`RunOptions::run_batch`] only).
    pub progress: bool,
    /// Write each run's per-entity trajectory (`crate::trajectory`) into this directory as
    /// `<run file stem>-trajectory.csv`, for these entities.
    pub trajectory: Option<(&'a std::path::Path, &'a [crate::trajectory::TrajectoryEntity])>,
}

impl RunOptions<'_> {
    fn stopped(&self) -> bool {
        self.stop.is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// Runs one scenario (validated first).
    pub fn run(&self, scenario: &Scenario) -> Result<RunResult, SimError> {
        scenario.validate()?;
        let sim = Simulation::new(scenario)?;
        let traj = match self.trajectory {
            None => None,
            Some((dir, entities)) => {
                let path = dir.join(format!("{}-trajectory.csv", scenario.run_file_stem()));
                Some(TrajectoryWriter::create(&path, entities)?)
            }
        };
        match self.record {
            None => self.drive(sim, traj),
            Some(dir) => {
                let rec = Recorder::for_simulation(dir, &sim)?;
                self.drive(sim.with_observer(rec), traj)
            }
        }
    }

    fn drive<O: Observer>(&self, mut sim: Simulation<O>, mut traj: Option<TrajectoryWriter>) -> Result<RunResult, SimError> {
        if let Some(w) = &mut traj {
            w.write_step(&sim)?;
        }
        let completed = loop {
            if self.stopped() {
                break false;
            }
            let more = sim.step()?;
            if let Some(w) = &mut traj {
                w.write_step(&sim)?;
            }
            if !more {
                break true;
            }
        };
        sim.finish_observer(completed)?;
        if let Some(w) = traj {
            w.finish()?;
        }
        let mut r = sim.finish();
        if !completed {
            r.end = crate::sim::RunEnd::Interrupted;
        }
        Ok(r)
    }

    /// Runs many scenarios in parallel; results in input order.
    pub fn run_batch(&self, scenarios: &[Scenario]) -> Vec<Result<RunResult, SimError>> {
        use rayon::prelude::*;
        let bar = self.progress.then(|| progress_bar(scenarios.len(), "runs"));
        let out = scenarios
            .par_iter()
            .map(|s| {
                if self.stopped() {
                    return Err(SimError::File { path: s.name.clone(), message: "interrupted before it started".into() });
                }
                let r = self.run(s);
                if let Some(b) = &bar {
                    b.inc(1);
                }
                r
            })
            .collect();
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        out
    }
}

/// The progress bar of every batch (runs, sweep points): `{bar} pos/len <what> elapsed`.
pub(crate) fn progress_bar(len: usize, what: &str) -> indicatif::ProgressBar {
    let b = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(&format!("{{bar:40}} {{pos}}/{{len}} {what} {{elapsed_precise}} {{msg}}")) {
        b.set_style(style);
    }
    b
}

/// Runs a scenario to its end with no sink: `RunOptions::default().run(scenario)`.
pub fn run(scenario: &Scenario) -> Result<RunResult, SimError> {
    RunOptions::default().run(scenario)
}
