//! The suite report: Markdown (summary, outcome matrix, metrics), and one SVG overview figure
//! per suite (the outcome matrix in colour).

use std::fmt::Write;

use super::{Band, CaseResult, Outcome, REFERENCE, SuiteReport};
use crate::metrics::Metrics;
use crate::svg::{close, esc, open};

/// The metric columns of the report, by their `Metrics` field names (`docs/v2v-and-metrics.md`),
/// with headers.
const COLUMNS: &[(&str, &str)] = &[
    ("impact_speed", "impact m/s"),
    ("min_gap", "min gap m"),
    ("min_ttc", "min TTC s"),
    ("tet", "TET s"),
    ("tit", "TIT s²"),
    ("max_drac", "max DRAC m/s²"),
    ("max_decel", "max decel m/s²"),
    ("max_jerk", "max jerk m/s³"),
];

/// The report's metric columns of one run (`-` when a metric is `null`).
fn metric_cells(m: &Metrics) -> Vec<String> {
    let json = serde_json::to_value(m).unwrap_or_default();
    COLUMNS.iter().map(|(k, _)| num(json.get(*k).and_then(serde_json::Value::as_f64))).collect()
}

fn num(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.2}"),
        _ => "-".into(),
    }
}

/// The run label without the distribution index: `TestSpeed_kmh=10`.
fn short_run(run: &str) -> &str {
    match run.split_once(' ') {
        Some((p, rest)) if p.starts_with('p') && p[1..].chars().all(|c| c.is_ascii_digit()) => rest,
        _ => run,
    }
}

/// The controller compared with the reference cell by cell in a banded (2026) report.
pub const COMPARED: &str = "flc-robust";

/// The 2026 band of a run, if it has one.
fn band_of(r: &CaseResult) -> Option<Band> {
    r.ncap.as_ref().and_then(|n| n.band)
}

/// One cell of the outcome matrix.
fn cell(r: &CaseResult) -> String {
    let mark = if r.below_reference { " !" } else { "" };
    if let (Some(b), Some(n)) = (band_of(r), r.ncap.as_ref()) {
        return match b {
            Band::Green => format!("green{mark}"),
            _ => format!("{} {:.2}{mark}", b.name().to_lowercase(), n.impact_speed_kmh),
        };
    }
    match r.outcome {
        Outcome::Pass => format!("✓{mark}"),
        Outcome::Uncomfortable => format!("~ {:.1}{mark}", r.metrics.max_decel),
        Outcome::Collision => format!("✗ {:.1}{mark}", r.metrics.impact_speed),
    }
}

/// The summary table (one line per controller), as Markdown.
pub fn summary_table(reports: &[SuiteReport]) -> String {
    let mut out =
        String::from("| suite | controller | passed | collisions | below the careful driver | NCAP score |\n|---|---|---|---|---|---|\n");
    for rep in reports {
        for s in &rep.summary {
            let score = s.ncap_score.map_or("-".to_string(), |x| format!("{:.1} %", 100.0 * x));
            let below = if s.controller == REFERENCE { "(reference)".to_string() } else { s.below_reference.to_string() };
            let _ =
                writeln!(out, "| {} | {} | {} / {} | {} | {} | {} |", rep.name, s.controller, s.passed, s.runs, s.collisions, below, score);
        }
    }
    out
}

/// One line for all suites: each controller's passed runs over all runs, the reference first
/// (`careful-driver 51/51 · flc 48/51 · ...`).
pub fn summary_line(reports: &[SuiteReport]) -> String {
    let Some(first) = reports.first() else { return String::new() };
    let parts: Vec<String> = first
        .controllers
        .iter()
        .map(|c| {
            let (mut passed, mut runs) = (0, 0);
            for s in reports.iter().flat_map(|r| &r.summary).filter(|s| &s.controller == c) {
                passed += s.passed;
                runs += s.runs;
            }
            format!("{c} {passed}/{runs}")
        })
        .collect();
    parts.join(" · ")
}

/// The report of one suite as Markdown; `command` is the command line that made it.
pub fn markdown(rep: &SuiteReport, command: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# {} (`{}`)\n", rep.title, rep.name);
    let _ = writeln!(
        out,
        "Source: {}. Written by `{command}`; the cases are this project's own files (`scenarios/suites/{}/`).\n",
        rep.source, rep.name
    );
    let _ = writeln!(out, "## Summary\n\n{}", summary_table(std::slice::from_ref(rep)));
    let _ = writeln!(
        out,
        "A run passes without a collision (and, where the case sets one, without braking beyond its comfort limit). \
         *Below the careful driver*: runs the reference `{REFERENCE}` passes and the controller does not. \
         NCAP score: the mean over the NCAP runs of 1 (avoided) or `1 - impact speed / test speed`.\n"
    );
    let banded = rep.results.iter().any(|r| band_of(r).is_some());
    if banded {
        out.push_str(
            "This suite's runs are scored by Euro NCAP's 2026 rating calculator, not by the suite (its NCAP score column \
             stays empty): `scenario suite ncap-ccr-2026 --controllers NAME --ncap-workbook FILE.xlsx` fills the \
             calculator's workbook and, with `flc[ncap]`, prints its points (docs/standard-suites.md).\n\n",
        );
    }
    let _ = writeln!(out, "![{}]({}.svg)\n", rep.title, rep.name);
    out.push_str("## Cases\n\n| case | protocol section | criterion | comfort limit |\n|---|---|---|---|\n");
    for c in &rep.cases {
        let crit = match c.criterion {
            super::Criterion::Ncap => "avoid (NCAP partial credit by speed reduction)",
            super::Criterion::Ncap2026 => "2026 colour band by relative impact speed (scored by Euro NCAP's calculator)",
            super::Criterion::NoCollision => "no collision",
        };
        let _ = writeln!(
            out,
            "| {} | {} | {crit} | {} |",
            c.id,
            c.section,
            c.max_decel.map_or("-".to_string(), |m| format!("max decel {m} m/s²"))
        );
    }
    if banded {
        out.push_str(
            "\n## Outcomes\n\nThe 2026 colour band of each run and its relative impact speed, km/h (rounded half up to 0.01 km/h, as the \
             calculator does): green 0 km/h; from a VUT speed of 50 km/h yellow below 10, orange below 20, brown below 30, red \
             above; at 40 km/h orange / brown / red, at 30 km/h brown / red, at 10 and 20 km/h red (each band half-open, \
             `[lower, upper)`). ! below the careful driver (it avoids, the controller does not).\n\n",
        );
    } else {
        out.push_str("\n## Outcomes\n\n✓ pass, ✗ collision (relative impact speed, m/s), ~ beyond the comfort limit (max decel, m/s²), ! below the careful driver.\n\n");
    }
    let _ = writeln!(out, "| case | run | {} |", rep.controllers.join(" | "));
    let _ = writeln!(out, "|---|---|{}", "---|".repeat(rep.controllers.len()));
    for chunk in rep.results.chunks(rep.controllers.len().max(1)) {
        let Some(first) = chunk.first() else { continue };
        let cells: Vec<String> = chunk.iter().map(cell).collect();
        let _ = writeln!(out, "| {} | {} | {} |", first.case, short_run(&first.run), cells.join(" | "));
    }
    if banded {
        out.push_str(&compared(rep));
    }
    out.push_str("\n## Metrics\n\n");
    let heads: Vec<&str> = COLUMNS.iter().map(|(_, h)| *h).collect();
    let _ = writeln!(out, "| case | run | controller | outcome | {} |", heads.join(" | "));
    let _ = writeln!(out, "|---|---|---|---|{}", "---|".repeat(COLUMNS.len()));
    for r in &rep.results {
        let vals = metric_cells(&r.metrics);
        let outcome = match r.outcome {
            Outcome::Pass => "pass",
            Outcome::Uncomfortable => "uncomfortable",
            Outcome::Collision => "collision",
        };
        let _ = writeln!(out, "| {} | {} | {} | {outcome} | {} |", r.case, short_run(&r.run), r.controller, vals.join(" | "));
    }
    out
}

/// The section comparing [`COMPARED`] with the reference cell by cell: the cells where its band
/// is worse than the reference's (and, on equal bands, where it hits faster), by name.
fn compared(rep: &SuiteReport) -> String {
    let mut out = format!("\n## `{COMPARED}` against the careful driver, cell by cell\n\n");
    let (Some(ci), Some(ri)) = (rep.controllers.iter().position(|c| c == COMPARED), rep.controllers.iter().position(|c| c == REFERENCE))
    else {
        out.push_str("Not run: the comparison needs both controllers in the report.\n");
        return out;
    };
    let (mut better, mut equal, mut worse) = (0, 0, Vec::new());
    for chunk in rep.results.chunks(rep.controllers.len().max(1)) {
        let (Some(c), Some(r)) = (chunk.get(ci), chunk.get(ri)) else { continue };
        let (Some(bc), Some(br)) = (band_of(c), band_of(r)) else { continue };
        let (vc, vr) = (c.ncap.as_ref().map_or(0.0, |n| n.impact_speed_kmh), r.ncap.as_ref().map_or(0.0, |n| n.impact_speed_kmh));
        if bc > br || (bc == br && vc > vr) {
            worse.push((c, bc, vc, br, vr));
        } else if bc == br && vc == vr {
            equal += 1;
        } else {
            better += 1;
        }
    }
    let _ = writeln!(
        out,
        "Of {} cells, `{COMPARED}` is better than `{REFERENCE}` in {better}, the same in {equal} and below it in {}.\n",
        better + equal + worse.len(),
        worse.len()
    );
    if !worse.is_empty() {
        let _ = writeln!(out, "| case | run | `{COMPARED}` | `{REFERENCE}` |\n|---|---|---|---|");
        for (c, bc, vc, br, vr) in worse {
            let _ = writeln!(out, "| {} | {} | {} {vc:.2} km/h | {} {vr:.2} km/h |", c.case, short_run(&c.run), bc.name(), br.name());
        }
    }
    out
}

/// The overview figure of one suite: runs down, controllers across; green pass, amber beyond the
/// comfort limit, red collision (darker the faster the impact, its speed written in the cell);
/// a black frame marks a run the careful driver passes and the controller does not.
pub fn svg(rep: &SuiteReport) -> String {
    let cols = rep.controllers.len().max(1);
    let rows = rep.results.len() / cols;
    let label = |r: &CaseResult| format!("{} {}", r.case, short_run(&r.run));
    // About 6.8 px per character of the 11 px sans-serif font.
    let longest = rep.results.iter().map(|r| label(r).chars().count()).max().unwrap_or(0);
    let (label_w, cell_w, cell_h, head_h) = (16.0 + 6.8 * longest as f64, 92.0, 18.0, 50.0);
    let (w, h) = ((label_w + cell_w * cols as f64 + 10.0).max(560.0), head_h + cell_h * rows as f64 + 52.0);
    let mut out = String::new();
    open(&mut out, w, h);
    let _ = writeln!(out, r#"<text x="8" y="18" font-size="14" font-weight="bold">{}</text>"#, esc(&rep.title));
    for (j, c) in rep.controllers.iter().enumerate() {
        let x = label_w + cell_w * (j as f64 + 0.5);
        let _ = writeln!(out, r#"<text x="{x}" y="{}" text-anchor="middle">{}</text>"#, head_h - 8.0, esc(c));
    }
    for (i, chunk) in rep.results.chunks(cols).enumerate() {
        let y = head_h + cell_h * i as f64;
        if let Some(first) = chunk.first() {
            let _ = writeln!(out, r#"<text x="8" y="{}">{}</text>"#, y + 13.0, esc(&label(first)));
        }
        for (j, r) in chunk.iter().enumerate() {
            let x = label_w + cell_w * j as f64;
            let banded = band_of(r).map(|b| {
                let fill = match b {
                    Band::Green => "#4caf50",
                    Band::Yellow => "#fdd835",
                    Band::Orange => "#fb8c00",
                    Band::Brown => "#795548",
                    Band::Red => "#d32f2f",
                };
                let v = r.ncap.as_ref().map_or(0.0, |n| n.impact_speed_kmh);
                (fill.to_string(), if b == Band::Green { String::new() } else { format!("{v:.1}") })
            });
            let (fill, text) = if let Some(ft) = banded {
                ft
            } else {
                match r.outcome {
                    Outcome::Pass => ("#4caf50".to_string(), String::new()),
                    Outcome::Uncomfortable => ("#ffb300".to_string(), format!("{:.1}", r.metrics.max_decel)),
                    Outcome::Collision => {
                        let f = (r.metrics.impact_speed / 15.0).clamp(0.0, 1.0);
                        let g = (120.0 * (1.0 - f)) as u8;
                        (format!("rgb(220,{g},{g})"), format!("{:.1}", r.metrics.impact_speed))
                    }
                }
            };
            let stroke = if r.below_reference { r#" stroke="black" stroke-width="2""# } else { r#" stroke="white""# };
            let _ = writeln!(out, r#"<rect x="{x}" y="{y}" width="{cell_w}" height="{cell_h}" fill="{fill}"{stroke}/>"#);
            if !text.is_empty() {
                let _ = writeln!(out, r#"<text x="{}" y="{}" text-anchor="middle" fill="white">{text}</text>"#, x + cell_w / 2.0, y + 13.0);
            }
        }
    }
    let legend = if rep.results.iter().any(|r| band_of(r).is_some()) {
        "the 2026 colour band: green avoided · yellow · orange · brown · red (relative impact speed, km/h)"
    } else {
        "green: pass · amber: beyond the comfort limit (max decel, m/s²) · red: collision (impact speed, m/s)"
    };
    let _ = writeln!(out, r#"<text x="8" y="{}">{legend}</text>"#, h - 28.0);
    let _ = writeln!(out, r#"<text x="8" y="{}">black frame: the careful driver passes, the controller does not</text>"#, h - 12.0);
    close(&mut out);
    out
}
