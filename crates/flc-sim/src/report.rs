//! Output of runs: the JSON record per run, the results table laid out like the paper's, and the
//! per-step time series as CSV.

use crate::HitObject;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::metrics::{CollisionInfo, ContactRecord, Metrics, Series};
use crate::paper::{CellVerdict, paper_result};
use crate::scenario::Scenario;
use crate::sim::RunResult;
use crate::string_stability::StringStability;

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
    /// The metrics (of follower 1 in a platoon).
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Follower 1's first contact with anything (what `collision` says): time, speeds, the
    /// object hit (`{kind, name | index}`), contact point and normal; absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collision_info: Option<CollisionInfo>,
    /// `"ideal"` when the follower saw ground truth instead of the LiDAR (validation only,
    /// `follower.perception`); `"truth"` for a controller that always sees the ground truth
    /// (the R157 careful driver, `ControllerKind::perceives_truth`); absent with the LiDAR.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub perception: Option<String>,
    /// The scenario file's variant (`[[variants]]`), absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<String>,
    /// Platoon results, absent without `[platoon]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platoon: Option<PlatoonRecord>,
    /// The run against the paper's cell (the paper experiment's FLC and PID at the paper's
    /// speeds: outcome class, clearance within a tolerance); absent elsewhere.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_verdict: Option<CellVerdict>,
    /// First contacts of the pairs without a follower (the lead touching a road-side object);
    /// absent if none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub other_contacts: Vec<ContactRecord>,
}

/// One follower of a platoon in the JSON record.
#[derive(Debug, Clone, Serialize)]
pub struct FollowerRecord {
    /// 1 = right behind the lead.
    pub follower: u32,
    /// Its controller.
    pub controller: String,
    /// Its metrics against the vehicle in front (same fields as the run's).
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Its first contact with anything, absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collision_info: Option<CollisionInfo>,
}

/// The `platoon` object of the JSON record.
#[derive(Debug, Clone, Serialize)]
pub struct PlatoonRecord {
    /// Number of followers.
    pub followers: u32,
    /// `predecessor`, `lead` or `both`.
    pub v2v_source: String,
    /// Lead information relayed hop by hop.
    pub relay: bool,
    /// Some follower touched something (a vehicle, a parked car, a guard rail, a post).
    pub any_collision: bool,
    /// Smallest gap in the string, m.
    pub min_gap: f64,
    /// Per follower, 1..N.
    pub per_follower: Vec<FollowerRecord>,
    /// The string-stability measures and verdict.
    pub string_stability: StringStability,
}

impl PlatoonRecord {
    /// The record of a platoon run (`None` without `[platoon]`).
    pub fn of(run: &RunResult) -> Option<Self> {
        let p = run.platoon.as_ref()?;
        let spec = run.scenario.platoon.clone().unwrap_or_default();
        let configs = run.scenario.follower_configs().ok();
        let per_follower: Vec<FollowerRecord> = p
            .followers
            .iter()
            .enumerate()
            .map(|(i, f)| FollowerRecord {
                follower: i as u32 + 1,
                controller: configs.as_ref().and_then(|c| c.get(i)).map_or(run.scenario.controller, |c| c.controller).as_str().to_string(),
                metrics: f.metrics.clone(),
                collision_info: f.collision.clone(),
            })
            .collect();
        Some(Self {
            followers: p.followers.len() as u32,
            v2v_source: spec.v2v_source.as_str().to_string(),
            relay: spec.relay,
            any_collision: p.followers.iter().any(|f| f.collision.is_some()),
            min_gap: p.followers.iter().map(|f| f.metrics.min_gap).fold(f64::INFINITY, f64::min),
            per_follower,
            string_stability: p.string_stability.clone(),
        })
    }
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
            collision_info: None,
            variant: scenario.variant.clone(),
            perception: if scenario.controller.perceives_truth() {
                Some("truth".to_string())
            } else {
                (scenario.follower.perception != crate::follower::Perception::Lidar)
                    .then(|| scenario.follower.perception.as_str().to_string())
            },
            platoon: None,
            other_contacts: Vec::new(),
            // Only the built-in experiment is the paper's (a file may carry a speed too).
            paper_verdict: preset.and(scenario.speed_kmh).and_then(|v| CellVerdict::of(scenario.controller.as_str(), v, metrics)),
        }
    }

    /// The record of a run, with its platoon results if any.
    pub fn from_run(preset: Option<&str>, run: &RunResult) -> Self {
        Self {
            platoon: PlatoonRecord::of(run),
            collision_info: run.collision.clone(),
            other_contacts: run.other_contacts.clone(),
            ..Self::new(&run.scenario, preset, &run.metrics)
        }
    }

    /// The scenario name with its variant (`name/variant`).
    pub fn label(&self) -> String {
        let name = match &self.variant {
            Some(v) => format!("{}/{v}", self.scenario),
            None => self.scenario.clone(),
        };
        match &self.perception {
            Some(p) => format!("{name} [{p}]"),
            None => name,
        }
    }

    /// How follower 1's run ended, as the results table's outcome column says it
    /// (`stop,  4.66 m`, `collision  5.20 m/s, guard_rail #1`, `no stop, min  3.00 m`).
    pub fn outcome(&self) -> String {
        outcome(&self.metrics, self.collision_info.as_ref(), 1)
    }

    /// Some vehicle collided (follower 1, or any follower of a platoon).
    pub fn any_collision(&self) -> bool {
        self.metrics.collision || self.platoon.as_ref().is_some_and(|p| p.any_collision)
    }
}

/// The outcome column: `collision 5.20 m/s` (with what was hit unless it was the vehicle in
/// front: `collision 5.20 m/s, parked_car #3`), `stop, 1.20 m` or `no stop, min 3.00 m`.
fn outcome(m: &Metrics, hit: Option<&CollisionInfo>, follower: usize) -> String {
    if m.collision {
        match hit.map(|c| c.object.clone()) {
            Some(o) if o.name != HitObject::vehicle(follower.saturating_sub(1)).name => {
                format!("collision {:5.2} m/s, {}", m.impact_speed, o.label())
            }
            _ => format!("collision {:5.2} m/s", m.impact_speed),
        }
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
    // The scenario column fits the longest label (34 characters at least).
    let w = records.iter().map(|r| r.label().chars().count()).max().unwrap_or(0).max(34);
    let mut last_preset: Option<Option<String>> = None;
    for r in records {
        if last_preset.as_ref() != Some(&r.preset) {
            let title = match &r.preset {
                Some(p) => format!("paper experiment, {p} preset (lead brakes at -6 m/s² after ~650 m)"),
                None => "scenario files".to_string(),
            };
            out.push_str(&format!("\n{title}\n"));
            out.push_str(&format!(
                "{:<w$} {:<14} {:>6}  {:<24} {:<15} {:<16} {:>8} {:>9} {:>9} {:>10}\n",
                "scenario", "ctrl", "km/h", "outcome (clearance)", "paper", "verdict", "min gap", "min TTC", "max dec", "max jerk"
            ));
            last_preset = Some(r.preset.clone());
        }
        let m = &r.metrics;
        let paper = match r.speed_kmh.and_then(|s| paper_result(&r.controller, s)) {
            Some(Some(c)) => format!("stop, {c:.1} m"),
            Some(None) => "collision".to_string(),
            None => "-".to_string(),
        };
        let ttc = m.min_ttc.map_or("-".to_string(), |t| format!("{t:.2} s"));
        let verdict = r.paper_verdict.as_ref().map_or("-".to_string(), CellVerdict::short);
        out.push_str(&format!(
            "{:<w$} {:<14} {:>6} {:<24} {:<15} {:<16} {:>6.2} m {:>9} {:>5.2} m/s² {:>6.1} m/s³\n",
            r.label(),
            r.controller,
            r.speed_kmh.map_or("-".to_string(), |s| format!("{s:.0}")),
            format!(" {}", outcome(m, r.collision_info.as_ref(), 1)),
            paper,
            verdict,
            m.min_gap,
            ttc,
            m.max_decel,
            m.max_jerk
        ));
        out.push_str(&other_contacts_line(&r.other_contacts));
    }
    out
}

/// `  other contacts: lead - guard_rail #0 at 12.30 s, ...` (one line), empty without any.
fn other_contacts_line(contacts: &[ContactRecord]) -> String {
    if contacts.is_empty() {
        return String::new();
    }
    let list: Vec<String> = contacts.iter().map(|c| format!("{} - {} at {:.2} s", c.a.label(), c.b.label(), c.time)).collect();
    format!("  other contacts: {}\n", list.join(", "))
}

/// Writes the run's time series as `<dir>/<stem>.csv` (header = column names with units); for a
/// platoon also followers 2..N as `<dir>/<stem>-follower<k>.csv` (their `lead_*` columns are the
/// vehicle in front). Returns the first file.
pub fn write_series_csv(dir: &Path, run: &RunResult) -> std::io::Result<PathBuf> {
    let stem = run.scenario.run_file_stem();
    let path = dir.join(format!("{stem}.csv"));
    write_csv(&path, &run.series)?;
    if let Some(p) = &run.platoon {
        for (i, f) in p.followers.iter().enumerate().skip(1) {
            write_csv(&dir.join(format!("{stem}-follower{}.csv", i + 1)), &f.series)?;
        }
    }
    Ok(path)
}

fn write_csv(path: &Path, series: &Series) -> std::io::Result<()> {
    let tmp = path.with_extension("csv.part");
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        let cols = series.columns();
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
    std::fs::rename(&tmp, path)
}

fn fmt_ratios(peak: &[f64], l2: &[f64], i: usize) -> String {
    match (peak.get(i), l2.get(i)) {
        (Some(p), Some(q)) => format!("{p:5.2} / {q:5.2}"),
        _ => "     -       ".to_string(),
    }
}

/// The platoon section of the table: per follower its outcome, errors and ratios to the follower
/// in front, then |Gamma(jw)| and the verdict.
pub fn platoon_table(r: &RunRecord) -> String {
    let Some(p) = &r.platoon else { return String::new() };
    let ss = &p.string_stability;
    let mut out = format!(
        "\n{} ({}): lead + {} followers, V2V from {}{}, window {:.2}-{:.2} s\n",
        r.label(),
        r.controller,
        p.followers,
        p.v2v_source,
        if p.relay { " (relayed)" } else { "" },
        ss.window_start,
        ss.window_end
    );
    out.push_str(&format!(
        "  {:>3} {:<14} {:<24} {:>8} {:>10} {:>9} {:>10} {:>14} {:>14} {:>9}\n",
        "k", "ctrl", "outcome (clearance)", "min gap", "max dec", "gap err", "speed err", "gap ratio", "speed ratio", "peak |a|"
    ));
    out.push_str(&format!(
        "  {:>3} {:<14} {:<24} {:>8} {:>10} {:>9} {:>10} {:>14} {:>14} {:>5.2} m/s²\n",
        0,
        "lead",
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        ss.accel_peak.first().copied().unwrap_or(f64::NAN)
    ));
    for (i, f) in p.per_follower.iter().enumerate() {
        let m = &f.metrics;
        let pair = i.wrapping_sub(1);
        out.push_str(&format!(
            "  {:>3} {:<14} {:<24} {:>6.2} m {:>5.2} m/s² {:>7.2} m {:>6.2} m/s {:>14} {:>14} {:>5.2} m/s²\n",
            f.follower,
            f.controller,
            outcome(m, f.collision_info.as_ref(), f.follower as usize),
            m.min_gap,
            m.max_decel,
            ss.gap_error_peak.get(i).copied().unwrap_or(f64::NAN),
            ss.speed_error_peak.get(i).copied().unwrap_or(f64::NAN),
            fmt_ratios(&ss.gap_ratio_peak, &ss.gap_ratio_l2, pair),
            fmt_ratios(&ss.speed_ratio_peak, &ss.speed_ratio_l2, pair),
            ss.accel_peak.get(i + 1).copied().unwrap_or(f64::NAN),
        ));
    }
    out.push_str("  (ratios: follower / follower in front, peak / L2; |Gamma| in parentheses: amplitude below the floor, not counted)\n");
    for g in &ss.frequency_response {
        let gammas: Vec<String> =
            g.gamma.iter().zip(&g.counted).map(|(x, c)| if *c { format!("{x:.3}") } else { format!("({x:.3})") }).collect();
        out.push_str(&format!(
            "  |Gamma| at {:5.3} Hz: max {}{}  [{}]\n",
            g.freq_hz,
            if g.max_gamma.is_finite() { format!("{:.3}", g.max_gamma) } else { "- (none above the floor)".to_string() },
            if g.collision { " (collision)" } else { "" },
            gammas.join(" ")
        ));
    }
    let verdict = if ss.string_stable { "string stable" } else { "NOT string stable" };
    let mut why = Vec::new();
    if !ss.collisions.is_empty() {
        why.push(format!("collision of follower(s) {:?}", ss.collisions));
    }
    if let Some(m) = ss.max_ratio {
        why.push(format!("max error ratio {m:.3}"));
    }
    if let Some(g) = ss.max_gamma {
        why.push(format!("max |Gamma| {g:.3}"));
    }
    out.push_str(&format!("  verdict: {verdict} (tolerance 1 + {}; {})\n", ss.tolerance, why.join(", ")));
    out
}
