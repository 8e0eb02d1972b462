//! Why the detector's grid looks as it does (issue 23): four representations measured on the same
//! synthetic scans, printed as the Markdown tables of `docs/detector.md` ("Choosing the grid").
//!
//! ```sh
//! cargo run --release -p flc-core --example detector_design            # print the tables
//! cargo run --release -p flc-core --example detector_design -- --write  # rewrite docs/figures/detector-design.md (included by docs/detector.md)
//! ```
//!
//! Scans: the rear face of a car (1.8 m) or a motorcycle (0.8 m) on the path at range r, seen by
//! beams every 0.1 deg (the default LiDAR), each beam dropped with probability p, 5 cm Gaussian
//! range noise (Box-Muller on the tests' exact LCG), plus guard rails at +-5 m. Detection rate over
//! 400 scans per cell (seeded: the tables are reproducible bit for bit); timing: the
//! median of 15 rounds of 200 scans of a car at 60 m with rails to 200 m (about 1800 points).
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::Lcg;
use flc_core::{DetectorParams, LeadDetector};
use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

const RES: f64 = 0.1 * std::f64::consts::PI / 180.0;
const SCANS: usize = 400;

fn normal(rng: &mut Lcg) -> f64 {
    let u1 = rng.uniform().max(1e-300);
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// One scan: a rear face `width` m wide at range `d` on the path, rails at +-5 m to 200 m.
fn scan(rng: &mut Lcg, d: f64, width: f64, dropout: f64, rails: bool) -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    let mut push = |rng: &mut Lcg, x: f64, y: f64| {
        if rng.uniform() >= dropout {
            let r = x.hypot(y) + 0.05 * normal(rng);
            let a = y.atan2(x);
            pts.push([r * a.cos(), r * a.sin()]);
        }
    };
    let a0 = (-0.5 * width).atan2(d);
    let a1 = (0.5 * width).atan2(d);
    let mut k = (a0 / RES).ceil() as i64;
    while k as f64 * RES <= a1 {
        let y = d * (k as f64 * RES).tan();
        push(rng, d, y);
        k += 1;
    }
    if rails {
        // The beams that hit a rail at y = +-5 m in front of the car (those beyond it are hidden).
        let mut k = 1;
        loop {
            let a = k as f64 * RES;
            let x = 5.0 / a.tan();
            if x < 1.0 || a > 1.0 {
                break;
            }
            if x < d.min(200.0) || a > a1 {
                push(rng, x, 5.0);
                push(rng, x, -5.0);
            }
            k += 1;
        }
    }
    pts
}

/// Runs a detector on one scan and returns the detected distance.
type DetectFn = Box<dyn FnMut(&[[f64; 2]]) -> Option<f64>>;

/// A representation: its name, memory and a detect function.
struct Repr {
    name: &'static str,
    bytes: usize,
    reach: f64,
    detect: DetectFn,
}

fn repr<const NX: usize>(name: &'static str, params: DetectorParams) -> Repr {
    let mut det = Box::new(LeadDetector::<NX, 60>::new(params).expect("valid parameters"));
    let reach = det.x_range().1;
    Repr {
        name,
        bytes: std::mem::size_of::<LeadDetector<NX, 60>>(),
        reach,
        detect: Box::new(move |pts| det.detect(pts, 0.0).detection.map(|d| d.distance)),
    }
}

fn representations() -> Vec<Repr> {
    let new = DetectorParams::defaults();
    // The first design of the detector: 350 x 0.2 m columns to 70.5 m, min_width 0.8 m, a fixed 3 x 3
    // dilation and a fixed 3-point threshold (a tiny beam spacing keeps min_points_at at 3).
    let old = DetectorParams { far_start: 70.5, min_width: 0.8, max_dilation_radius: 1, beam_spacing_deg: 1e-6, ..new };
    vec![
        repr::<350>("first design: 350 x 0.2 m to 70.5 m, fixed dilation and threshold", old),
        repr::<1000>("uniform: 1000 x 0.2 m to 200.5 m", DetectorParams { far_start: 200.5, ..new }),
        repr::<520>("no joining: the default without step 7b", DetectorParams { join_gap: 0.0, ..new }),
        repr::<520>("no joining, fixed 3 x 3 dilation", DetectorParams { join_gap: 0.0, max_dilation_radius: 1, ..new }),
        repr::<520>("**default**: 200 x 0.2 m + 320 x 0.5 m, by range, joining", new),
    ]
}

fn tables() -> String {
    let mut out = String::new();
    let ranges = [20.0, 40.0, 60.0, 80.0, 100.0, 120.0, 150.0, 180.0];
    let cases: [(&str, f64, f64); 4] = [
        ("car, clean", 1.8, 0.0),
        ("car, 50 % dropout", 1.8, 0.5),
        ("motorcycle (0.8 m), clean", 0.8, 0.0),
        ("motorcycle, 25 % dropout", 0.8, 0.25),
    ];
    let mut reprs = representations();
    for (case, width, dropout) in cases {
        let _ = writeln!(out, "Detection rate, {case} (5 cm noise, guard rails at ±5 m, {SCANS} scans per cell):\n");
        let _ = write!(out, "| grid |");
        for r in ranges {
            let _ = write!(out, " {r:.0} m |");
        }
        let _ = write!(out, "\n|---|");
        for _ in ranges {
            let _ = write!(out, "---:|");
        }
        out.push('\n');
        for rep in reprs.iter_mut() {
            let _ = write!(out, "| {} |", rep.name);
            for (i, &r) in ranges.iter().enumerate() {
                let mut rng = Lcg(1000 + i as u64 + (width * 10.0) as u64 * 100 + (dropout * 100.0) as u64 * 10_000);
                let mut hits = 0;
                for _ in 0..SCANS {
                    let pts = scan(&mut rng, r, width, dropout, true);
                    if (rep.detect)(&pts).is_some_and(|d| (d - r).abs() < 0.3) {
                        hits += 1;
                    }
                }
                let _ = write!(out, " {:.1} |", 100.0 * f64::from(hits) / SCANS as f64);
            }
            out.push('\n');
        }
        out.push('\n');
    }
    out
}

/// Time per scan (µs, median of rounds) and static memory.
fn costs() -> String {
    let mut rng = Lcg(99);
    let scans: Vec<_> = (0..200).map(|_| scan(&mut rng, 60.0, 1.8, 0.0, true)).collect();
    let points = scans.iter().map(Vec::len).sum::<usize>() / scans.len();
    let mut out = String::new();
    let _ = writeln!(out, "Cost per scan ({points} points on average: a car at 60 m and rails; measured, not checked):\n");
    let _ = writeln!(out, "| grid | reach | static memory | time per scan |");
    let _ = writeln!(out, "|---|---:|---:|---:|");
    for mut rep in representations() {
        let mut rounds: Vec<f64> = (0..15)
            .map(|_| {
                let t = Instant::now();
                for s in &scans {
                    black_box((rep.detect)(black_box(s)));
                }
                t.elapsed().as_secs_f64() * 1e6 / scans.len() as f64
            })
            .collect();
        rounds.sort_by(f64::total_cmp);
        let _ = writeln!(out, "| {} | {:.1} m | {:.1} KiB | {:.1} µs |", rep.name, rep.reach, rep.bytes as f64 / 1024.0, rounds[7]);
    }
    out
}

fn main() {
    let write = std::env::args().any(|a| a == "--write");
    let block = format!("{}\n{}", tables(), costs());
    if !write {
        print!("{block}");
        return;
    }
    // The committed data file that `docs/detector.md` includes (`python -m flc docs`).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/figures/detector-design.md");
    if let Err(e) = std::fs::write(path, block) {
        eprintln!("error: writing docs/figures/detector-design.md: {e}");
        std::process::exit(2);
    }
}
