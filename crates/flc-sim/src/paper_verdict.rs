//! The main job's verdict against the paper (Sec. IV): each run of the paper experiment against
//! the paper's cell ([`crate::paper::CellVerdict`], carried by each JSON record), a summary over the runs that ran ([`PaperSummary`]), the tracking
//! errors of the curved route against Sec. IV's ([`TrackingVerdict`]) and the 90 km/h impact
//! order ([`ImpactVerdict`]). Everything here is computed from the runs; only the region figure
//! ([`MatchingRegion`]) comes from the committed reproduction map.

use serde::Serialize;

use crate::paper::{
    CLEARANCE_TOLERANCE_M, PAPER_ACTUATOR_RESPONSE, PAPER_MATCHING_REGION, PAPER_MAX_DECEL, PAPER_SPEEDS_KMH, PAPER_TRACKING,
};
use crate::report::RunRecord;
use crate::sim::RunResult;

/// A tracking error within this factor of the paper's (either way) counts as reproduced: the
/// paper does not define how it averages them (`docs/paper-reproduction.md`), so only the order
/// of magnitude is compared.
pub const TRACKING_FACTOR: f64 = 2.0;

/// The summary of one preset over the runs that ran.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetSummary {
    /// `realistic` or `paper`.
    pub preset: String,
    /// Runs with a paper cell (at most 8: FLC and PID at the paper's four speeds).
    pub cells: usize,
    /// Of those, runs with the paper's outcome class.
    pub outcome_matches: usize,
    /// Runs where both the paper and the run stop (the clearances compared).
    pub clearances: usize,
    /// Of those, clearances within the tolerance.
    pub clearances_within: usize,
    /// The largest |clearance error| of those, m (`None` without any).
    pub max_clearance_error: Option<f64>,
    /// [`CLEARANCE_TOLERANCE_M`].
    pub clearance_tolerance: f64,
    /// The paper's 90 km/h impact order, when the FLC and the PID both ran at 90 km/h and both
    /// collided.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub impact_90: Option<ImpactVerdict>,
}

/// The paper: "both controllers failed to prevent a collision at 90 km/h; however, the proposed
/// FLC was able to decelerate the following vehicle more than the PID, resulting in a less severe
/// crash".
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImpactVerdict {
    /// The FLC's impact speed at 90 km/h, m/s.
    pub flc_impact_speed: f64,
    /// The PID's, m/s.
    pub pid_impact_speed: f64,
    /// The FLC's crash is the less severe one, as in the paper.
    pub holds: bool,
}

/// The tracking errors of one curved-route run (`Scenario::paper_tracking`) against the paper's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackingVerdict {
    /// `flc` or `pid`.
    pub controller: String,
    /// Mean |heading error|, deg (`None` without samples).
    pub rot_error_deg: Option<f64>,
    /// Mean |lateral offset|, m.
    pub trans_error_m: Option<f64>,
    /// The paper's, deg.
    pub paper_rot_error_deg: f64,
    /// The paper's, m.
    pub paper_trans_error_m: f64,
    /// `rot_error_deg / paper_rot_error_deg`.
    pub rot_ratio: Option<f64>,
    /// `trans_error_m / paper_trans_error_m`.
    pub trans_ratio: Option<f64>,
    /// `rot_error_deg` over the paper's figure read as radians (the paper does not define its
    /// measure; `docs/paper-reproduction.md`).
    pub rot_ratio_if_radians: Option<f64>,
    /// `rot_ratio` within [`TRACKING_FACTOR`] either way.
    pub rot_within: bool,
    /// `trans_ratio` within [`TRACKING_FACTOR`] either way.
    pub trans_within: bool,
    /// [`TRACKING_FACTOR`].
    pub factor: f64,
    /// How the run ended (the errors are averages up to there), as the table says it.
    pub outcome: String,
    /// Simulated time of the run, s.
    pub duration: f64,
}

impl TrackingVerdict {
    /// The verdict of a curved-route run; `None` for a controller the paper gives no errors for.
    pub fn of(run: &RunResult) -> Option<Self> {
        let controller = run.scenario.controller.as_str();
        let &(_, paper_rot, paper_trans) = PAPER_TRACKING.iter().find(|(c, _, _)| *c == controller)?;
        let m = &run.metrics;
        let ratio = |x: Option<f64>, p: f64| x.map(|v| v / p);
        let within = |r: Option<f64>| r.is_some_and(|r| (1.0 / TRACKING_FACTOR..=TRACKING_FACTOR).contains(&r));
        let (rot_ratio, trans_ratio) = (ratio(m.rot_error_deg, paper_rot), ratio(m.trans_error_m, paper_trans));
        Some(Self {
            controller: controller.to_string(),
            rot_error_deg: m.rot_error_deg,
            trans_error_m: m.trans_error_m,
            paper_rot_error_deg: paper_rot,
            paper_trans_error_m: paper_trans,
            rot_ratio,
            trans_ratio,
            rot_ratio_if_radians: m.rot_error_deg.map(|v| v / paper_rot.to_degrees()),
            rot_within: within(rot_ratio),
            trans_within: within(trans_ratio),
            factor: TRACKING_FACTOR,
            outcome: RunRecord::from_run(None, run).outcome().split_whitespace().collect::<Vec<_>>().join(" "),
            duration: m.duration,
        })
    }
}

/// The paper's claim that the FLC tracks better than the PID (0.0176 < 0.0199 deg, 0.2258 <
/// 0.2876 m), checked on the runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackingOrder {
    /// The FLC's rotational error is below the PID's.
    pub rot_holds: bool,
    /// The FLC's translational error is below the PID's.
    pub trans_holds: bool,
}

/// How large the region is where the paper preset's constants reproduce all 8 outcome classes:
/// from the committed map data, not from this run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MatchingRegion {
    /// Share of the brake authority x actuator response map, %.
    pub map_percent: f64,
    /// Share of the random sample over 7 constants, %.
    pub random_percent: f64,
    /// Where the figures come from.
    pub source: String,
}

impl MatchingRegion {
    /// [`PAPER_MATCHING_REGION`] with its source.
    pub fn committed() -> Self {
        let (map_percent, random_percent) = PAPER_MATCHING_REGION;
        Self {
            map_percent,
            random_percent,
            source: "committed map data sweeps/paper-reproduction-{map,random}.csv (python -m flc reproduction), not this run".into(),
        }
    }
}

/// The `paper_summary` line of `scenario --json` and the lines under the table: computed from
/// the runs that ran.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PaperSummary {
    /// Per preset, in the order they ran.
    pub presets: Vec<PresetSummary>,
    /// The curved-route runs (paper preset; the FLC and the PID among the controllers run).
    pub tracking: Vec<TrackingVerdict>,
    /// With both tracking runs: whether the paper's order holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking_order: Option<TrackingOrder>,
    /// With the paper preset: the region figure from the committed map.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub matching_region: Option<MatchingRegion>,
    /// `--set KEY=VALUE` overrides the runs were made with (empty: the presets as they are).
    pub overrides: Vec<String>,
}

impl PaperSummary {
    /// The summary of `records` (runs of the paper experiment, `preset` set) and `tracking`.
    pub fn new(records: &[RunRecord], tracking: Vec<TrackingVerdict>, overrides: Vec<String>) -> Self {
        let mut presets: Vec<PresetSummary> = Vec::new();
        for r in records {
            let Some(preset) = &r.preset else { continue };
            let i = match presets.iter().position(|p| &p.preset == preset) {
                Some(i) => i,
                None => {
                    presets.push(PresetSummary {
                        preset: preset.clone(),
                        cells: 0,
                        outcome_matches: 0,
                        clearances: 0,
                        clearances_within: 0,
                        max_clearance_error: None,
                        clearance_tolerance: CLEARANCE_TOLERANCE_M,
                        impact_90: None,
                    });
                    presets.len() - 1
                }
            };
            let Some(v) = &r.paper_verdict else { continue };
            let p = &mut presets[i];
            p.cells += 1;
            p.outcome_matches += usize::from(v.outcome_match);
            if let Some(e) = v.clearance_error {
                p.clearances += 1;
                p.clearances_within += usize::from(v.clearance_within == Some(true));
                p.max_clearance_error = Some(p.max_clearance_error.map_or(e.abs(), |m: f64| m.max(e.abs())));
            }
        }
        let at_90 = PAPER_SPEEDS_KMH[3];
        for p in &mut presets {
            let impact = |c: &str| {
                records
                    .iter()
                    .find(|r| r.preset.as_deref() == Some(p.preset.as_str()) && r.controller == c && r.speed_kmh == Some(at_90))
                    .filter(|r| r.metrics.collision)
                    .map(|r| r.metrics.impact_speed)
            };
            if let (Some(f), Some(q)) = (impact("flc"), impact("pid")) {
                p.impact_90 = Some(ImpactVerdict { flc_impact_speed: f, pid_impact_speed: q, holds: f < q });
            }
        }
        let get = |c: &str| tracking.iter().find(|t| t.controller == c);
        let tracking_order = match (get("flc"), get("pid")) {
            (Some(f), Some(p)) => Some(TrackingOrder {
                rot_holds: matches!((f.rot_error_deg, p.rot_error_deg), (Some(a), Some(b)) if a < b),
                trans_holds: matches!((f.trans_error_m, p.trans_error_m), (Some(a), Some(b)) if a < b),
            }),
            _ => None,
        };
        let matching_region = presets.iter().any(|p| p.preset == "paper").then(MatchingRegion::committed);
        Self { presets, tracking, tracking_order, matching_region, overrides }
    }

    /// The lines printed under the table: the summary line, the region figure (labelled as the
    /// committed map's), the tracking errors and the 90 km/h impacts, each with its verdict.
    pub fn text(&self) -> String {
        let mut out = String::new();
        let with = if self.overrides.is_empty() { String::new() } else { format!(" (with --set {})", self.overrides.join(" ")) };
        let parts: Vec<String> = self
            .presets
            .iter()
            .map(|p| {
                if p.cells == 0 {
                    return format!("{} preset: no run has a paper figure", p.preset);
                }
                let off = p.max_clearance_error.map_or(String::new(), |e| format!(", off by up to {e:.2} m"));
                format!(
                    "{} preset: {}/{} outcome classes, {}/{} clearances within ±{} m{off}",
                    p.preset, p.outcome_matches, p.cells, p.clearances_within, p.clearances, p.clearance_tolerance
                )
            })
            .collect();
        if !parts.is_empty() {
            out.push_str(&format!("verdict vs the paper{with}: {}\n", parts.join("; ")));
        }
        if let Some(r) = &self.matching_region {
            out.push_str(&format!(
                "reproduction map (committed sweeps/paper-reproduction-{{map,random}}.csv, not this run): the paper preset's constants (brake authority {PAPER_MAX_DECEL} m/s², actuator response {PAPER_ACTUATOR_RESPONSE} s) reproduce all 8 outcome classes on {:.1} % of the brake x response map and {:.1} % of a random sample over 7 constants, a narrow ridge (docs/paper-reproduction.md)\n",
                r.map_percent, r.random_percent
            ));
        }
        if self.tracking.is_empty() && self.presets.iter().all(|p| p.impact_90.is_none()) {
            return out;
        }
        out.push_str("the paper's other numbers:\n");
        let f = |x: Option<f64>, d: usize| x.map_or("-".to_string(), |v| format!("{v:.d$}"));
        let judge = |r: Option<f64>, within: bool, factor: f64| match r {
            None => "not measured".to_string(),
            Some(r) if within => format!("{}x the paper's, within {factor}x", ratio(r)),
            Some(r) => format!("{}x the paper's, NOT within {factor}x", ratio(r)),
        };
        for t in &self.tracking {
            out.push_str(&format!(
                "  tracking on the curved route, {}: rotational {} deg, translational {} m (paper {} deg, {} m): rotational {}, translational {}; the run ends after {:.2} s: {}\n",
                t.controller,
                f(t.rot_error_deg, 4),
                f(t.trans_error_m, 4),
                t.paper_rot_error_deg,
                t.paper_trans_error_m,
                judge(t.rot_ratio, t.rot_within, t.factor),
                judge(t.trans_ratio, t.trans_within, t.factor),
                t.duration,
                t.outcome
            ));
        }
        let off: Vec<&TrackingVerdict> = self.tracking.iter().filter(|t| !t.rot_within).collect();
        if !off.is_empty() {
            let rad: Vec<String> =
                off.iter().map(|t| format!("{} {}x", t.controller, t.rot_ratio_if_radians.map_or("-".into(), ratio))).collect();
            out.push_str(&format!(
                "  rotational errors not reproduced; the paper does not define the measure (read as radians its figures give {}; docs/paper-reproduction.md)\n",
                rad.join(", ")
            ));
        }
        if let Some(o) = &self.tracking_order {
            let says = |h: bool| if h { "holds" } else { "does not hold" };
            out.push_str(&format!(
                "  the FLC tracks better than the PID (paper): rotational {}, translational {}\n",
                says(o.rot_holds),
                says(o.trans_holds)
            ));
        }
        for p in &self.presets {
            if let Some(i) = &p.impact_90 {
                out.push_str(&format!(
                    "  at 90 km/h the FLC's crash is less severe than the PID's (paper), {} preset: impact {:.2} vs {:.2} m/s, {}\n",
                    p.preset,
                    i.flc_impact_speed,
                    i.pid_impact_speed,
                    if i.holds { "holds" } else { "does not hold" }
                ));
            }
        }
        out
    }
}

/// A ratio for the text: `33.3`, `0.95`.
fn ratio(r: f64) -> String {
    if r.abs() >= 10.0 { format!("{r:.1}") } else { format!("{r:.2}") }
}
