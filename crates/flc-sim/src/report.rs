//! Output of runs: the JSON record per run, the results table laid out like the paper's, and the
//! per-step time series as CSV.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::metrics::Metrics;
use crate::scenario::Scenario;
use crate::sim::RunResult;

/// One line of `scenario --json`: identification plus every metric (flattened). Field names are a
/// contract (documented in `docs/scenarios.md`).
#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    /// Scenario name.
    pub scenario: String,
    /// `flc`, `pid`, `pipeline`, ...
    pub controller: String,
    /// Maximum speed of the paper experiment, km/h (`null` for other scenarios).
    pub speed_kmh: Option<f64>,
    /// `realistic` or `paper` for the built-in experiment, `null` for scenario files.
    pub preset: Option<String>,
    /// Seed of the run.
    pub seed: u64,
    /// The metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
}

impl RunRecord {
    /// Builds the record of one run.
    pub fn new(scenario: &Scenario, preset: Option<&str>, metrics: &Metrics) -> Self {
        Self {
            scenario: scenario.name.clone(),
            controller: scenario.controller.as_str().to_string(),
            speed_kmh: scenario.speed_kmh,
            preset: preset.map(str::to_string),
            seed: scenario.seed,
            metrics: metrics.clone(),
        }
    }
}

/// The paper's results (Sec. IV): clearance at standstill in m, or `None` for a collision.
pub fn paper_result(controller: &str, speed_kmh: f64) -> Option<Option<f64>> {
    let speeds = [30.0, 50.0, 70.0, 90.0];
    let i = speeds.iter().position(|s| (s - speed_kmh).abs() < 1e-9)?;
    let flc = [Some(3.8), Some(4.0), Some(2.3), None];
    let pid = [Some(7.9), Some(1.2), None, None];
    match controller {
        "flc" => flc.get(i).copied(),
        "pid" => pid.get(i).copied(),
        _ => None,
    }
}

fn outcome(m: &Metrics) -> String {
    if m.collision {
        format!("collision {:5.2} m/s", m.impact_speed)
    } else {
        match m.final_clearance {
            Some(c) => format!("stop, {c:5.2} m"),
            None => format!("no stop, min {:5.2} m", m.min_gap),
        }
    }
}

/// The results table: one row per run with the outcome next to the paper's.
pub fn table(records: &[RunRecord]) -> String {
    let mut out = String::new();
    let mut last_preset: Option<Option<String>> = None;
    for r in records {
        if last_preset.as_ref() != Some(&r.preset) {
            let title = match &r.preset {
                Some(p) => format!("paper experiment, {p} preset (lead brakes at -6 m/s² after ~650 m)"),
                None => "scenario files".to_string(),
            };
            out.push_str(&format!("\n{title}\n"));
            out.push_str(&format!(
                "{:<28} {:<14} {:>6}  {:<24} {:<18} {:>8} {:>9} {:>9} {:>10}\n",
                "scenario", "ctrl", "km/h", "outcome (clearance)", "paper", "min gap", "min TTC", "max dec", "max jerk"
            ));
            last_preset = Some(r.preset.clone());
        }
        let m = &r.metrics;
        let paper = match r.speed_kmh.and_then(|s| paper_result(&r.controller, s)) {
            Some(Some(c)) => format!("stop, {c} m"),
            Some(None) => "collision".to_string(),
            None => "-".to_string(),
        };
        let ttc = m.min_ttc.map_or("-".to_string(), |t| format!("{t:.2} s"));
        out.push_str(&format!(
            "{:<28} {:<14} {:>6} {:<24} {:<18} {:>6.2} m {:>9} {:>5.2} m/s² {:>6.1} m/s³\n",
            r.scenario,
            r.controller,
            r.speed_kmh.map_or("-".to_string(), |s| format!("{s:.0}")),
            format!(" {}", outcome(m)),
            paper,
            m.min_gap,
            ttc,
            m.max_decel,
            m.max_jerk
        ));
    }
    out
}

/// File name of a run's outputs: `<scenario>-<controller>` with anything but `[A-Za-z0-9._-]`
/// replaced by `_`.
pub fn run_file_stem(scenario: &Scenario) -> String {
    let raw = format!("{}-{}", scenario.name, scenario.controller.as_str());
    raw.chars().map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' }).collect()
}

/// Writes the run's time series as `<dir>/<stem>.csv` (header = column names with units).
pub fn write_series_csv(dir: &Path, run: &RunResult) -> std::io::Result<PathBuf> {
    let path = dir.join(format!("{}.csv", run_file_stem(&run.scenario)));
    let tmp = path.with_extension("csv.part");
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        let cols = run.series.columns();
        let header: Vec<&str> = cols.iter().map(|(name, _)| *name).collect();
        writeln!(w, "{}", header.join(","))?;
        let n = cols.first().map_or(0, |(_, c)| c.len());
        for i in 0..n {
            let mut line = String::new();
            for (j, (_, col)) in cols.iter().enumerate() {
                if j > 0 {
                    line.push(',');
                }
                if let Some(v) = col.get(i) {
                    line.push_str(&format!("{v}"));
                }
            }
            writeln!(w, "{line}")?;
        }
        w.flush()?;
    }
    std::fs::rename(&tmp, &path)?;
    Ok(path)
}
