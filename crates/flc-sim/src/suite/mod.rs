//! The standard test suites (`scenario suite`): Euro NCAP AEB Car-to-Car Rear and the UN R157
//! longitudinal scenarios, every case run for every controller next to the R157 careful driver.
//!
//! A suite is a folder with a `suite.toml` (written by `tools/suite_cases.py`,
//! `docs/standard-suites.md`):
//!
//! ```toml
//! name = "ncap-ccr"
//! title = "Euro NCAP AEB Car-to-Car Rear"
//! source = "Euro NCAP Test Protocol - AEB Car-to-Car systems, version 4.3"
//! [patch]                          # scenario keys set in every run (the one key-patch mechanism)
//! "follower.lane_keeping" = true
//! [[cases]]
//! id = "CCRs"
//! file = "ccrs-runs.xosc"          # OpenSCENARIO: a scenario or a ParameterValueDistribution
//! ego = "VUT"
//! section = "Test scenarios: CCRs ..."
//! criterion = "ncap"               # or "ncap_2026", "no_collision"
//! max_decel = 3.5                  # optional comfort limit, m/s²
//! ```
//!
//! Each case's runs are the file's (one per distribution combination), imported once per
//! controller; `twins/` holds their TOML twins (`scenario convert`), which give the same results
//! bit for bit. Runs are deterministic and independent of the thread count (each run is seeded
//! by its scenario; the batch keeps input order).

mod ncap;
mod report;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::metrics::Metrics;
use crate::openscenario::{self, ImportOptions};
use crate::patch::Patch;
use crate::runner::RunOptions;
use crate::scenario::{ControllerKind, Scenario};

pub use ncap::{Band, NcapRun, band, round_half_up};
pub use report::{markdown, summary_line, summary_table, svg};

/// The reference every controller is compared with: UN R157's careful and competent human driver.
pub const REFERENCE: &str = "careful-driver";

/// How a case is passed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Euro NCAP: avoided is a pass; a collision scores the speed reduction
    /// `1 - impact speed / test speed` (partial credit).
    Ncap,
    /// Euro NCAP 2026: each run gets its colour band (green avoided, then by the relative impact
    /// speed, [`band`]); the points are Euro NCAP's rating calculator's (`flc.ncap`), not the
    /// suite's.
    #[serde(rename = "ncap_2026")]
    Ncap2026,
    /// UN R157: no collision (and the comfort limit where the case gives one).
    NoCollision,
}

/// One case of `suite.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    /// Short name (`CCRs`, `4.3_2`).
    pub id: String,
    /// The OpenSCENARIO file, relative to the suite's folder.
    pub file: String,
    /// The entity under test (default: the importer's, `Ego`).
    #[serde(default)]
    pub ego: Option<String>,
    /// Where the protocol defines the case.
    pub section: String,
    /// How the case is passed.
    pub criterion: Criterion,
    /// Comfort limit: the strongest braking allowed, m/s² (a pass needs `max_decel <=` it).
    #[serde(default)]
    pub max_decel: Option<f64>,
}

/// A `suite.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteSpec {
    /// The name (`ncap-ccr`, `r157`): `scenario suite NAME`.
    pub name: String,
    /// Title for the report.
    pub title: String,
    /// The protocol and its version.
    pub source: String,
    /// Scenario keys set in every run, e.g. `"follower.lane_keeping" = true`.
    #[serde(default)]
    pub patch: toml::Table,
    /// The cases, in report order.
    pub cases: Vec<CaseSpec>,
}

/// A suite: its file and folder.
#[derive(Debug, Clone, PartialEq)]
pub struct Suite {
    /// The parsed `suite.toml`.
    pub spec: SuiteSpec,
    /// Its folder (case files are relative to it).
    pub dir: PathBuf,
}

/// One run of a case (one distribution combination) for one controller.
#[derive(Debug, Clone)]
pub struct CaseRun {
    /// Index into [`SuiteSpec::cases`].
    pub case: usize,
    /// The run's label: the distribution's `p<i> NAME=VALUE ...`, or the case id.
    pub run: String,
    /// The scenario, ready to run (controller set, suite patch applied).
    pub scenario: Scenario,
}

/// The outcome of one run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// No collision (and within the comfort limit).
    Pass,
    /// No collision, but braking beyond the case's comfort limit.
    Uncomfortable,
    /// A collision (NCAP: with partial credit by the speed reduction).
    Collision,
}

/// One row of the report: a run of a case by a controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// The case id.
    pub case: String,
    /// The run label.
    pub run: String,
    /// The controller.
    pub controller: String,
    /// Pass, uncomfortable or collision.
    pub outcome: Outcome,
    /// NCAP score of the run, 0..1 (`1` avoided, else `1 - impact speed / test speed`); `null`
    /// for R157 cases.
    pub score: Option<f64>,
    /// The reference passed this run but this controller did not.
    pub below_reference: bool,
    /// The ego's speed at the start, m/s (the NCAP test speed).
    pub test_speed: f64,
    /// NCAP runs: VUT and target speeds, impact location, overlap, side, relative impact speed
    /// and (2026) the colour band; absent for R157 runs.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub ncap: Option<NcapRun>,
    /// The run's metrics (`docs/v2v-and-metrics.md`).
    pub metrics: Metrics,
}

/// One controller's line of the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControllerSummary {
    /// The controller.
    pub controller: String,
    /// Runs passed.
    pub passed: usize,
    /// Runs.
    pub runs: usize,
    /// Runs with a collision.
    pub collisions: usize,
    /// Runs the reference passed and this controller did not.
    pub below_reference: usize,
    /// Mean NCAP score over the 2023 NCAP runs, 0..1 (`null` without them; the 2026 suite is
    /// scored by Euro NCAP's calculator, `flc.ncap`).
    pub ncap_score: Option<f64>,
}

/// The result of a suite run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuiteReport {
    /// The suite's name.
    pub name: String,
    /// Its title.
    pub title: String,
    /// The protocol and its version.
    pub source: String,
    /// The cases.
    pub cases: Vec<CaseSpec>,
    /// The controllers, in column order (the reference first when it ran).
    pub controllers: Vec<String>,
    /// Per controller, in column order.
    pub summary: Vec<ControllerSummary>,
    /// Every run: case by case, run by run, controller by controller.
    pub results: Vec<CaseResult>,
}

fn file_err(path: &Path, message: impl Into<String>) -> SimError {
    SimError::File { path: path.display().to_string(), message: message.into() }
}

/// The folder the named suites live in, the same from any working directory: `scenarios/suites`
/// of the source tree holding the running executable (`target/<profile>/scenario`, the tests'
/// `target/<profile>/deps/...`), else of the source tree this crate was built from. An error
/// (one line: where it looked, how to name the folder) when neither exists, e.g. a copied
/// binary whose source tree is gone. (The Python package ships the suites: `flc.run_suite`.)
pub fn default_root() -> Result<PathBuf, SimError> {
    const SUITES: &str = "scenarios/suites";
    let exe = std::env::current_exe().ok();
    let near_exe = exe.as_deref().and_then(|e| e.ancestors().skip(1).map(|d| d.join(SUITES)).find(|d| d.is_dir()));
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(SUITES);
    near_exe.or_else(|| built.is_dir().then_some(built.clone())).ok_or_else(|| {
        SimError::Input(format!(
            "no suites folder found (no {SUITES} above the executable {} nor in the source tree it was built from, {}): give the folder, `--root DIR` or a suite's own folder",
            exe.as_deref().map_or_else(|| "?".into(), |e| e.display().to_string()),
            built.display()
        ))
    })
}

impl Suite {
    /// Reads `dir/suite.toml`.
    pub fn load(dir: &Path) -> Result<Suite, SimError> {
        let path = dir.join("suite.toml");
        let text = std::fs::read_to_string(&path).map_err(|e| file_err(&path, e.to_string()))?;
        let de = toml::Deserializer::parse(&text).map_err(|e| file_err(&path, e.to_string().replace('\n', " ")))?;
        let spec: SuiteSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e.path().to_string();
            file_err(&path, format!("`{key}`: {}", e.into_inner().to_string().replace('\n', " ")))
        })?;
        for (i, c) in spec.cases.iter().enumerate() {
            if let Some(m) = c.max_decel {
                crate::check_range(&format!("cases[{i}].max_decel"), m, 0.0, 50.0, "m/s²").map_err(|e| file_err(&path, e.to_string()))?;
            }
        }
        Ok(Suite { spec, dir: dir.to_path_buf() })
    }

    /// The suites `name` means under `root`: `all` (every folder with a `suite.toml`, by name),
    /// a suite's name, or a folder holding a `suite.toml`.
    pub fn find(root: &Path, name: &str) -> Result<Vec<Suite>, SimError> {
        // The folders under `root` holding a `suite.toml`, by name.
        let suite_dirs = || -> Vec<PathBuf> {
            let mut dirs: Vec<PathBuf> = std::fs::read_dir(root)
                .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.join("suite.toml").is_file()).collect())
                .unwrap_or_default();
            dirs.sort();
            dirs
        };
        if name == "all" {
            let dirs = suite_dirs();
            if dirs.is_empty() {
                return Err(SimError::Input(format!("no suite (a folder with a suite.toml) in {}", root.display())));
            }
            return dirs.iter().map(|d| Suite::load(d)).collect();
        }
        let dir = if Path::new(name).join("suite.toml").is_file() { PathBuf::from(name) } else { root.join(name) };
        if !dir.join("suite.toml").is_file() {
            let known: Vec<String> = suite_dirs().iter().filter_map(|d| d.file_name().map(|n| n.to_string_lossy().into_owned())).collect();
            return Err(SimError::Input(format!("suite `{name}`: not found in {} (known: all, {})", root.display(), known.join(", "))));
        }
        Ok(vec![Suite::load(&dir)?])
    }

    /// The suite's patch.
    fn patch(&self) -> Patch {
        Patch::from_table(&self.spec.patch)
    }

    /// Every run of every case for each controller, in report order (case, run, controller).
    /// Each file is imported once; a controller is then set as the importer sets it
    /// ([`Scenario::set_controller`]), so a run equals the import with that controller.
    pub fn runs(&self, controllers: &[ControllerKind]) -> Result<Vec<CaseRun>, SimError> {
        let mut out = Vec::new();
        for (ci, case) in self.spec.cases.iter().enumerate() {
            let path = self.dir.join(&case.file);
            let opts = ImportOptions { ego: case.ego.clone(), ..ImportOptions::default() };
            let import = openscenario::import(&path, &opts).map_err(|e| SimError::Input(e.to_string()))?;
            for imp in &import.runs {
                let run = imp.scenario.variant.clone().unwrap_or_else(|| case.id.clone());
                for &k in controllers {
                    out.push(CaseRun { case: ci, run: run.clone(), scenario: self.twin_scenario(&imp.scenario, k)? });
                }
            }
        }
        Ok(out)
    }

    /// A run as the suite runs it (an imported run or its TOML twin): the controller set to
    /// `kind`, the suite's patch applied.
    pub fn twin_scenario(&self, twin: &Scenario, kind: ControllerKind) -> Result<Scenario, SimError> {
        let mut s = twin.clone();
        s.set_controller(kind);
        s.patched(&self.patch()).map_err(|e| file_err(&self.dir.join("suite.toml"), format!("`patch`: {e}")))
    }

    /// Runs every case for every controller (the reference added first if missing and known)
    /// and scores them.
    pub fn run(&self, controllers: &[ControllerKind]) -> Result<SuiteReport, SimError> {
        let mut kinds: Vec<ControllerKind> = Vec::with_capacity(controllers.len() + 1);
        if let Ok(r) = ControllerKind::parse(REFERENCE) {
            kinds.push(r);
        }
        for &k in controllers {
            if !kinds.contains(&k) {
                kinds.push(k);
            }
        }
        let runs = self.runs(&kinds)?;
        let scenarios: Vec<Scenario> = runs.iter().map(|r| r.scenario.clone()).collect();
        let results = RunOptions::default().run_batch(&scenarios);
        let mut rows = Vec::with_capacity(runs.len());
        for (r, res) in runs.iter().zip(results) {
            let res = res?;
            rows.push(score(&self.spec.cases[r.case], r, res.metrics));
        }
        mark_reference(&mut rows);
        let names: Vec<String> = kinds.iter().map(|k| k.as_str().to_string()).collect();
        let summary = names.iter().map(|n| summarise(n, &rows)).collect();
        Ok(SuiteReport {
            name: self.spec.name.clone(),
            title: self.spec.title.clone(),
            source: self.spec.source.clone(),
            cases: self.spec.cases.clone(),
            controllers: names,
            summary,
            results: rows,
        })
    }
}

/// A run's outcome under its case's criterion.
fn score(case: &CaseSpec, r: &CaseRun, metrics: Metrics) -> CaseResult {
    let test_speed = r.scenario.follower.initial_speed;
    let outcome = if metrics.collision {
        Outcome::Collision
    } else if case.max_decel.is_some_and(|m| metrics.max_decel > m) {
        Outcome::Uncomfortable
    } else {
        Outcome::Pass
    };
    let ncap = matches!(case.criterion, Criterion::Ncap | Criterion::Ncap2026)
        .then(|| NcapRun::of(&r.scenario, &metrics, case.criterion == Criterion::Ncap2026));
    let score = (case.criterion == Criterion::Ncap).then(|| match outcome {
        Outcome::Collision if test_speed > 0.0 => (1.0 - metrics.impact_speed / test_speed).clamp(0.0, 1.0),
        Outcome::Collision => 0.0,
        _ => 1.0,
    });
    CaseResult {
        case: case.id.clone(),
        run: r.run.clone(),
        controller: r.scenario.controller.as_str().to_string(),
        outcome,
        score,
        below_reference: false,
        test_speed,
        ncap,
        metrics,
    }
}

/// Marks the rows whose run the reference passed and they did not.
fn mark_reference(rows: &mut [CaseResult]) {
    let passed: std::collections::HashSet<(String, String)> =
        rows.iter().filter(|r| r.controller == REFERENCE && r.outcome == Outcome::Pass).map(|r| (r.case.clone(), r.run.clone())).collect();
    for r in rows.iter_mut() {
        r.below_reference = r.controller != REFERENCE && r.outcome != Outcome::Pass && passed.contains(&(r.case.clone(), r.run.clone()));
    }
}

fn summarise(controller: &str, rows: &[CaseResult]) -> ControllerSummary {
    let mine: Vec<&CaseResult> = rows.iter().filter(|r| r.controller == controller).collect();
    let scores: Vec<f64> = mine.iter().filter_map(|r| r.score).collect();
    ControllerSummary {
        controller: controller.to_string(),
        passed: mine.iter().filter(|r| r.outcome == Outcome::Pass).count(),
        runs: mine.len(),
        collisions: mine.iter().filter(|r| r.outcome == Outcome::Collision).count(),
        below_reference: mine.iter().filter(|r| r.below_reference).count(),
        ncap_score: (!scores.is_empty()).then(|| scores.iter().sum::<f64>() / scores.len() as f64),
    }
}

impl SuiteReport {
    /// The report as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}
