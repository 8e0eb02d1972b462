//! The SVG writer of the generated figures: the document frame, text escaping, and small-multiple
//! line charts (shared by the suite report, [`crate::suite`], and the detector study,
//! [`crate::detection_study`]). Plain text out, no dependency.

use std::fmt::Write;

/// Escapes `&`, `<` and `>` for SVG text.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Opens a `w x h` document (11 px sans-serif) on a white background.
pub(crate) fn open(out: &mut String, w: f64, h: f64) {
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(out, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
}

/// Closes a document opened with [`open`].
pub(crate) fn close(out: &mut String) {
    out.push_str("</svg>\n");
}

/// One line of a chart panel.
#[derive(Debug, Clone)]
pub(crate) struct Line {
    /// Legend label (the same label has the same colour in every panel).
    pub label: String,
    /// Stroke colour.
    pub color: &'static str,
    /// Dashed stroke.
    pub dashed: bool,
    /// `(x, y)` points; non-finite y breaks the line.
    pub points: Vec<(f64, f64)>,
}

/// One panel of a [`Chart`].
#[derive(Debug, Clone)]
pub(crate) struct Panel {
    /// Title above the panel.
    pub title: String,
    /// Its lines.
    pub lines: Vec<Line>,
}

/// A grid of panels sharing axes, with one legend.
#[derive(Debug, Clone)]
pub(crate) struct Chart {
    /// Figure title.
    pub title: String,
    /// A line of small text under the title.
    pub subtitle: String,
    /// Axis labels.
    pub x_label: String,
    /// Axis labels.
    pub y_label: String,
    /// Axis ranges `(min, max)`.
    pub x_range: (f64, f64),
    /// Axis ranges `(min, max)`.
    pub y_range: (f64, f64),
    /// Tick positions.
    pub x_ticks: Vec<f64>,
    /// Tick positions.
    pub y_ticks: Vec<f64>,
    /// Grey reference lines across every panel: `(y, label)`.
    pub h_refs: Vec<(f64, String)>,
    /// Grey reference lines across every panel: `(x, label)`.
    pub v_refs: Vec<(f64, String)>,
    /// Panels per row.
    pub columns: usize,
    /// The panels, row by row.
    pub panels: Vec<Panel>,
}

fn tick(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 { format!("{}", v.round()) } else { format!("{v:.2}") }
}

impl Chart {
    /// The chart as an SVG document.
    pub(crate) fn to_svg(&self) -> String {
        let cols = self.columns.max(1);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let (pw, ph) = (300.0, 190.0);
        let (ml, mr, mt, mb) = (52.0, 14.0, 26.0, 36.0);
        let (head, legend_h) = (50.0, 26.0);
        let cell_w = ml + pw + mr;
        let cell_h = mt + ph + mb;
        let w = 10.0 + cell_w * cols as f64;
        let h = head + cell_h * rows as f64 + legend_h + 10.0;
        let mut out = String::new();
        open(&mut out, w, h);
        let _ = writeln!(out, r#"<text x="10" y="20" font-size="14" font-weight="bold">{}</text>"#, esc(&self.title));
        let _ = writeln!(out, r##"<text x="10" y="38" fill="#555">{}</text>"##, esc(&self.subtitle));
        let (x0, x1) = self.x_range;
        let (y0, y1) = self.y_range;
        for (i, p) in self.panels.iter().enumerate() {
            let (r, c) = (i / cols, i % cols);
            let left = 10.0 + cell_w * c as f64 + ml;
            let top = head + cell_h * r as f64 + mt;
            let sx = |x: f64| left + (x - x0) / (x1 - x0) * pw;
            let sy = |y: f64| top + ph - (y.clamp(y0, y1) - y0) / (y1 - y0) * ph;
            let _ = writeln!(
                out,
                r#"<text x="{}" y="{}" text-anchor="middle" font-weight="bold">{}</text>"#,
                left + pw / 2.0,
                top - 8.0,
                esc(&p.title)
            );
            let _ = writeln!(out, r##"<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>"##);
            for &t in &self.x_ticks {
                let x = sx(t);
                let _ = writeln!(out, r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{}" stroke="#eee"/>"##, top + ph);
                let _ = writeln!(out, r#"<text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"#, top + ph + 13.0, tick(t));
            }
            for &t in &self.y_ticks {
                let y = sy(t);
                let _ = writeln!(out, r##"<line x1="{left}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#eee"/>"##, left + pw);
                let _ = writeln!(out, r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#, left - 4.0, y + 4.0, tick(t));
            }
            for (v, label) in &self.h_refs {
                let y = sy(*v);
                let _ = writeln!(
                    out,
                    r##"<line x1="{left}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#888" stroke-dasharray="2,3"/>"##,
                    left + pw
                );
                let _ = writeln!(
                    out,
                    r##"<text x="{}" y="{:.1}" text-anchor="end" fill="#666" font-size="9">{}</text>"##,
                    left + pw - 3.0,
                    y - 3.0,
                    esc(label)
                );
            }
            for (v, label) in &self.v_refs {
                let x = sx(*v);
                let _ =
                    writeln!(out, r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{}" stroke="#888" stroke-dasharray="2,3"/>"##, top + ph);
                let _ = writeln!(out, r##"<text x="{:.1}" y="{}" fill="#666" font-size="9">{}</text>"##, x + 3.0, top + 10.0, esc(label));
            }
            for l in &p.lines {
                let dash = if l.dashed { r#" stroke-dasharray="6,3""# } else { "" };
                // Runs of finite points, each one polyline with markers.
                let mut run: Vec<String> = Vec::new();
                let flush = |run: &mut Vec<String>, out: &mut String| {
                    if !run.is_empty() {
                        let _ = writeln!(
                            out,
                            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.6"{dash}/>"#,
                            run.join(" "),
                            l.color
                        );
                        run.clear();
                    }
                };
                for &(x, y) in &l.points {
                    if y.is_finite() && x.is_finite() {
                        run.push(format!("{:.1},{:.1}", sx(x), sy(y)));
                        let _ = writeln!(out, r#"<circle cx="{:.1}" cy="{:.1}" r="2" fill="{}"/>"#, sx(x), sy(y), l.color);
                    } else {
                        flush(&mut run, &mut out);
                    }
                }
                flush(&mut run, &mut out);
            }
            let _ = writeln!(
                out,
                r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
                left + pw / 2.0,
                top + ph + 28.0,
                esc(&self.x_label)
            );
            let (lx, ly) = (left - 38.0, top + ph / 2.0);
            let _ = writeln!(
                out,
                r#"<text x="{lx}" y="{ly}" text-anchor="middle" transform="rotate(-90 {lx} {ly})">{}</text>"#,
                esc(&self.y_label)
            );
        }
        // Legend: every distinct label once, in order of first appearance.
        let mut seen: Vec<(&str, &str, bool)> = Vec::new();
        for l in self.panels.iter().flat_map(|p| &p.lines) {
            if !seen.iter().any(|(s, _, _)| *s == l.label) {
                seen.push((&l.label, l.color, l.dashed));
            }
        }
        let ly = h - legend_h;
        let mut x = 14.0;
        for (label, color, dashed) in seen {
            let dash = if dashed { r#" stroke-dasharray="6,3""# } else { "" };
            let _ = writeln!(out, r#"<line x1="{x}" y1="{ly}" x2="{}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/>"#, x + 22.0);
            let _ = writeln!(out, r#"<text x="{}" y="{}">{}</text>"#, x + 27.0, ly + 4.0, esc(label));
            x += 40.0 + 6.8 * label.chars().count() as f64;
        }
        close(&mut out);
        out
    }
}

/// A horizontal bar chart: one bar per `(label, value)`, the value written beside it.
pub(crate) fn bars(title: &str, subtitle: &str, unit: &str, rows: &[(String, f64, &'static str)]) -> String {
    let longest = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0);
    let (label_w, bar_w, row_h, head) = (16.0 + 6.8 * longest as f64, 360.0, 22.0, 52.0);
    let w = (label_w + bar_w + 90.0).max(560.0);
    let h = head + row_h * rows.len() as f64 + 16.0;
    let max = rows.iter().map(|r| r.1).filter(|v| v.is_finite()).fold(0.0_f64, f64::max);
    let scale = if max > 0.0 { bar_w / max } else { 0.0 };
    let mut out = String::new();
    open(&mut out, w, h);
    let _ = writeln!(out, r#"<text x="8" y="20" font-size="14" font-weight="bold">{}</text>"#, esc(title));
    let _ = writeln!(out, r##"<text x="8" y="38" fill="#555">{}</text>"##, esc(subtitle));
    for (i, (label, v, color)) in rows.iter().enumerate() {
        let y = head + row_h * i as f64;
        let _ = writeln!(out, r#"<text x="8" y="{}">{}</text>"#, y + 14.0, esc(label));
        let bw = (v * scale).max(0.0);
        let _ = writeln!(out, r#"<rect x="{label_w}" y="{}" width="{bw:.1}" height="{}" fill="{color}"/>"#, y + 3.0, row_h - 6.0);
        let _ = writeln!(out, r#"<text x="{:.1}" y="{}">{v:.2} {}</text>"#, label_w + bw + 6.0, y + 14.0, esc(unit));
    }
    close(&mut out);
    out
}
