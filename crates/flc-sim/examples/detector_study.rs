//! The detector study of `docs/detector.md` (issue 23): measures the lead detector and LiDAR that
//! are in the tree and writes the figures and the tables.
//!
//! ```text
//! cargo run --release -p flc-sim --example detector_study -- --out docs/figures --doc docs/detector.md
//! ```
//!
//! Writes `<out>/<prefix>-rate-vs-range.svg`, `<prefix>-error-vs-range.svg`,
//! `<prefix>-false-per-km.svg` and `<prefix>-study.md` (the tables); with `--doc`, also replaces
//! the block between `<!-- <prefix>-study -->` and `<!-- /<prefix>-study -->` of that file by the
//! tables (figure links relative to the doc).

use std::path::{Path, PathBuf};

use clap::Parser;
use flc_sim::detection_study::{
    CAR, ClutterRun, MOTORCYCLE, RangeStudy, TRUCK, TrackKind, error_svg, false_svg, markdown, rate_svg, replace_block, run_clutter,
    run_range_study,
};

#[derive(Parser)]
#[command(about = "Detector study: detection rate and distance error vs range, false detections per km")]
struct Args {
    /// Directory the figures and the tables go to.
    #[arg(long, default_value = "docs/figures")]
    out: PathBuf,
    /// File-name prefix of the outputs (and the name of the doc block, `<prefix>-study`).
    #[arg(long, default_value = "detector")]
    prefix: String,
    /// What was measured, shown in the titles (e.g. the commit).
    #[arg(long, default_value = "the detector in the tree")]
    label: String,
    /// Frames per 10 m range bin and condition.
    #[arg(long, default_value_t = 200)]
    frames: usize,
    /// Markdown file whose `<!-- <prefix>-study -->` block receives the tables.
    #[arg(long)]
    doc: Option<PathBuf>,
}

/// `to` relative to the directory of `from` (both relative to the working directory).
fn relative(from_dir: &Path, to: &Path) -> String {
    let (a, b): (Vec<_>, Vec<_>) = (from_dir.components().collect(), to.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(b[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    parts.join("/")
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let t0 = std::time::Instant::now();
    let mut curves = Vec::new();
    for track in TrackKind::ALL {
        for target in [CAR, TRUCK, MOTORCYCLE] {
            let study = RangeStudy { frames_per_bin: args.frames, ..RangeStudy::new(track, target) };
            curves.extend(run_range_study(&study));
            eprintln!("{} / {}: done ({:.0} s)", track.name(), target.name, t0.elapsed().as_secs_f64());
        }
    }
    let clutter = run_clutter(&ClutterRun::default());
    eprintln!("clutter run: done ({:.0} s)", t0.elapsed().as_secs_f64());
    let command = format!(
        "cargo run --release -p flc-sim --example detector_study -- --out {} --prefix {} --label \"{}\" --frames {}{}",
        args.out.display(),
        args.prefix,
        args.label,
        args.frames,
        args.doc.as_ref().map_or(String::new(), |d| format!(" --doc {}", d.display()))
    );
    std::fs::create_dir_all(&args.out)?;
    let p = &args.prefix;
    std::fs::write(args.out.join(format!("{p}-rate-vs-range.svg")), rate_svg(&curves, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-error-vs-range.svg")), error_svg(&curves, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-false-per-km.svg")), false_svg(&clutter, &args.label))?;
    std::fs::write(args.out.join(format!("{p}-study.md")), markdown(&curves, &clutter, &args.label, p, &command))?;
    if let Some(doc) = &args.doc {
        let dir = doc.parent().unwrap_or(Path::new(""));
        let figures = relative(dir, &args.out.join(p));
        let body = markdown(&curves, &clutter, &args.label, &figures, &command);
        let text = std::fs::read_to_string(doc)?;
        let name = format!("{p}-study");
        let new = replace_block(&text, &name, &body)
            .ok_or_else(|| format!("{}: no <!-- {name} --> ... <!-- /{name} --> block", doc.display()))?;
        std::fs::write(doc, new)?;
    }
    eprintln!("written into {} ({:.0} s)", args.out.display(), t0.elapsed().as_secs_f64());
    Ok(())
}
