//! The detector study of `docs/detector.md` (issue 23): measures the lead detector and LiDAR that
//! are in the tree and writes the figures and the tables.
//!
//! ```text
//! cargo run --release -p flc-sim --example detector_study -- --out docs/figures
//! python -m flc docs docs/detector.md
//! ```
//!
//! Writes `<out>/<prefix>-rate-vs-range.svg`, `<prefix>-error-vs-range.svg`,
//! `<prefix>-false-per-km.svg` and `<prefix>-study.md` (the tables, which `docs/detector.md`
//! includes as a generated block: `python -m flc docs`).

use std::path::PathBuf;

use clap::Parser;
use flc_sim::detection_study::{error_svg, false_svg, full_study, markdown, rate_svg, study_command};

#[derive(Parser)]
#[command(about = "Detector study: detection rate and distance error vs range, false detections per km")]
struct Args {
    /// Directory the figures and the tables go to.
    #[arg(long, default_value = "docs/figures")]
    out: PathBuf,
    /// File-name prefix of the outputs.
    #[arg(long, default_value = "detector")]
    prefix: String,
    /// What was measured, shown in the titles (e.g. the commit).
    #[arg(long, default_value = "the detector in the tree")]
    label: String,
    /// Frames per 10 m range bin and condition.
    #[arg(long, default_value_t = 200)]
    frames: usize,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let t0 = std::time::Instant::now();
    let (curves, clutter) = full_study(args.frames, |done| eprintln!("{done}: done ({:.0} s)", t0.elapsed().as_secs_f64()));
    let command = study_command(&args.out.display().to_string(), &args.prefix, &args.label, args.frames);
    std::fs::create_dir_all(&args.out)?;
    let p = &args.prefix;
    std::fs::write(args.out.join(format!("{p}-rate-vs-range.svg")), rate_svg(&curves, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-error-vs-range.svg")), error_svg(&curves, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-false-per-km.svg")), false_svg(&clutter, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-study.md")), markdown(&curves, &clutter, &args.label, p, &command))?;
    eprintln!("written into {} ({:.0} s)", args.out.display(), t0.elapsed().as_secs_f64());
    Ok(())
}
