//! Running OpenSCENARIO files of any size in bounded memory: each run is imported on demand
//! ([`crate::openscenario::Source`]), run, its files written (series, per-entity trajectory) and
//! reduced to its [`RunRecord`] on a worker thread; the records reach the caller in run order
//! ([`crate::sweep::stream_ordered`], a window of a few runs per thread). What `scenario
//! --config FILE.xosc` runs.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::error::SimError;
use crate::openscenario::{Imported, Source};
use crate::report::{self, RunRecord};
use crate::runner::RunOptions;
use crate::scenario::Scenario;
use crate::sim::RunEnd;
use crate::trajectory::TrajectoryEntity;

/// Where a run's outputs go.
#[derive(Clone, Copy, Default)]
pub struct StreamOptions<'a> {
    /// Series CSV and per-entity trajectory CSV of each run into this directory.
    pub out: Option<&'a Path>,
    /// MCAP recordings into this directory.
    pub record: Option<&'a Path>,
    /// Once set, running runs end at their next step and no further run starts.
    pub stop: Option<&'a AtomicBool>,
    /// Applied to each imported scenario before it runs (the CLI's `--set` and `--seed`); its
    /// error text fails that run.
    pub adjust: Option<&'a (dyn Fn(Scenario) -> Result<Scenario, String> + Sync)>,
}

/// One finished run, in order.
#[derive(Debug)]
pub struct StreamItem {
    /// The source (file) index.
    pub source: usize,
    /// The run's index in its source (the permutation).
    pub permutation: usize,
    /// Its record, or the one-line error that kept it from running.
    pub record: Result<RunRecord, String>,
    /// The import's warning lines.
    pub warnings: Vec<String>,
    /// Why it ended.
    pub end: Option<RunEnd>,
}

/// The trajectory entities of an imported run: the file's names, the reference points.
pub fn trajectory_entities(imp: &Imported) -> Vec<TrajectoryEntity> {
    imp.entities
        .iter()
        .map(|e| TrajectoryEntity { name: e.osc_name.clone(), sim_name: e.flc_name.clone(), reference: e.ref_offset })
        .collect()
}

/// Renames the vehicles of `rec`'s contacts and collision from the simulation's names (`follower
/// 1` = the ego, `lead`, ...) to the file's.
fn rename(rec: &mut RunRecord, imp: &Imported) {
    let map = |n: &mut Option<String>| {
        let Some(name) = n.as_mut() else { return };
        let sim = if name == "follower 1" { crate::scenario::EGO } else { name.as_str() };
        if let Some(e) = imp.entities.iter().find(|e| e.flc_name == sim) {
            *name = e.osc_name.clone();
        }
    };
    for c in &mut rec.contacts {
        map(&mut c.a.name);
        map(&mut c.b.name);
    }
    if let Some(c) = &mut rec.collision_info {
        map(&mut c.object.name);
    }
}

/// Runs one job: run `i` of `src`.
fn run_one(src: &Source, source: usize, i: usize, opts: &StreamOptions<'_>) -> StreamItem {
    let (mut imp, warnings) = match src.run(i) {
        Ok(x) => x,
        Err(e) => return StreamItem { source, permutation: i, record: Err(e.to_string()), warnings: Vec::new(), end: None },
    };
    if let Some(adjust) = opts.adjust {
        match adjust(imp.scenario) {
            Ok(s) => imp.scenario = s,
            Err(e) => return StreamItem { source, permutation: i, record: Err(e), warnings, end: None },
        }
    }
    let entities = trajectory_entities(&imp);
    let ro = RunOptions { record: opts.record, stop: opts.stop, progress: false, trajectory: opts.out.map(|d| (d, &entities[..])) };
    let run = match ro.run(&imp.scenario) {
        Ok(r) => r,
        Err(e) => return StreamItem { source, permutation: i, record: Err(e.to_string()), warnings, end: None },
    };
    if let Some(dir) = opts.out {
        if let Err(e) = report::write_series_csv(dir, &run) {
            return StreamItem { source, permutation: i, record: Err(format!("writing the series: {e}")), warnings, end: Some(run.end) };
        }
    }
    let mut rec = RunRecord::from_run(None, &run);
    rename(&mut rec, &imp);
    StreamItem { source, permutation: i, record: Ok(rec), warnings, end: Some(run.end) }
}

/// Runs `jobs` (`(source index, permutation)`, built on demand by `job(k)` for `k` in `0..n`)
/// of `sources` in parallel, calling `sink` with each finished run in order. Memory: a window
/// of runs per thread, whatever `n`. Returns the number of runs sunk.
pub fn run_sources(
    sources: &[Source],
    n: usize,
    job: impl Fn(usize) -> (usize, usize) + Sync,
    opts: &StreamOptions<'_>,
    sink: impl FnMut(StreamItem) -> Result<(), SimError>,
) -> Result<usize, SimError> {
    let mut sink = sink;
    crate::sweep::stream_ordered(
        n,
        |k| {
            let (s, i) = job(k);
            match sources.get(s) {
                Some(src) => run_one(src, s, i, opts),
                None => StreamItem { source: s, permutation: i, record: Err("no such source".into()), warnings: Vec::new(), end: None },
            }
        },
        |_, item| sink(item),
        opts.stop,
    )
}
