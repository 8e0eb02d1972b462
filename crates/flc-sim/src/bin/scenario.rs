//! `scenario`: run the paper's experiment (no arguments) or scenario files, print a results table
//! or JSON, write time series. See `scenario --help` and `docs/scenarios.md`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use flc_sim::openscenario::{self, ImportOptions, Imported};
use flc_sim::paper::{Calibration, PAPER_SPEEDS_KMH};
use flc_sim::report::{self, RunRecord};
use flc_sim::{ControllerKind, Scenario};
use flc_sim::{RunOptions, SimError};

/// Closed-loop simulation of the flc vehicle-following pipeline.
///
/// Without --config, runs the paper's experiment: lead and follower at standstill 7 m apart, the lead
/// accelerates to each speed of --speeds, covers about 650 m and brakes at -6 m/s² to a stop; the
/// follower is driven by the FLC only, the PID only (perfect V2V) and the switching pipeline (V2V
/// lost at brake onset); once with the realistic vehicle and once with the paper-calibrated preset.
/// Prints a table next to the paper's numbers.
///
/// Exit status: 0 success, 1 a run collided and --fail-on-collision was given, 2 bad input,
/// 130 interrupted by Ctrl-C while recording (--record).
/// Set by the Ctrl-C handler (installed with --record only).
static STOP: AtomicBool = AtomicBool::new(false);

#[derive(Debug, Parser)]
#[command(name = "scenario", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Scenario file(s): TOML (schema in docs/scenarios.md) or ASAM OpenSCENARIO `.xosc`
    /// (docs/openscenario.md; a `ParameterValueDistribution` file runs every combination).
    /// Repeat or list several.
    #[arg(long = "config", value_name = "FILE", num_args = 1..)]
    config: Vec<PathBuf>,
    /// `.xosc`: set a parameter, NAME=VALUE (repeatable; as esmini's --param).
    #[arg(long = "param", value_name = "NAME=VALUE", global = true)]
    param: Vec<String>,
    /// `.xosc`: the entity flc's controller drives (default: `Ego` / `ego`, else the first).
    #[arg(long, value_name = "NAME", global = true)]
    ego: Option<String>,
    /// `.xosc`: `controller` (flc's controller drives the ego) or `scripted` (the ego follows its
    /// storyboard, as esmini's default controller does: for comparing whole files with esmini).
    #[arg(long, value_name = "MODE", default_value = "controller", global = true)]
    ego_mode: String,
    /// `.xosc`: the road: `file` (the referenced OpenDRIVE file) or `straight` (4 lanes of 3.5 m
    /// along +x, for files whose road is missing).
    #[arg(long, value_name = "ROAD", default_value = "file", global = true)]
    road: String,
    /// `.xosc`: how the scripted entities move: `kinematic` (exactly as their actions
    /// prescribe, as in esmini) or `vehicle` (a driver tracks them through each entity's vehicle
    /// model: actuator lag, dead time, limits).
    #[arg(long, value_name = "MODEL", default_value = "kinematic", global = true)]
    traffic_dynamics: String,
    /// Print one JSON record per run on stdout (fields documented in docs/scenarios.md) instead of the table.
    #[arg(long)]
    json: bool,
    /// Write each run's per-step time series as CSV into DIR (one file per run).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Record each run as an MCAP file in DIR for Foxglove (`<scenario>-<controller>[-<speed>kmh].mcap`,
    /// docs/foxglove.md). Ctrl-C stops the runs and finishes the files (exit status 130).
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Maximum speeds of the paper experiment, km/h, comma separated (ignored with --config).
    #[arg(long, value_name = "KMH", value_delimiter = ',', default_values_t = PAPER_SPEEDS_KMH)]
    speeds: Vec<f64>,
    /// Controllers, comma separated, by their scenario-file names (flc, pid, pipeline, the
    /// baselines, ...; a wrong name lists them all): of the paper experiment (default
    /// flc,pid,pipeline), or driving the ego of `.xosc` files (default: the file's
    /// controller, else flc). Ignored for TOML files.
    #[arg(long, value_name = "NAME", value_delimiter = ',', global = true)]
    controllers: Option<Vec<String>>,
    /// Which presets of the paper experiment to run: realistic, paper or both (ignored with --config).
    #[arg(long, value_name = "PRESET", default_value = "both")]
    preset: String,
    /// Override the seed of every run.
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// Exit with status 1 when any run collided.
    #[arg(long)]
    fail_on_collision: bool,
    /// `.xosc` distribution: run only permutation I (0-based, as esmini's --param_permutation).
    #[arg(long, value_name = "I")]
    permutation: Option<usize>,
    /// `.xosc`: print the number of runs (permutations) of each file and exit.
    #[arg(long)]
    permutations: bool,
    /// `.xosc`: the guard on a run's length, s (default 3600): a run whose StopTrigger has not
    /// fired by then is cut, with a line on stderr and `"end": "duration"` in its JSON.
    #[arg(long, value_name = "SECONDS")]
    max_duration: Option<f64>,
}

#[derive(Debug, clap::Subcommand)]
enum Command {
    /// Print the TOML twin of an OpenSCENARIO file (running it gives bit-identical results);
    /// with --out, write one `<name>.toml` per run (a distribution has several) into DIR.
    Convert {
        /// The `.xosc` file.
        file: PathBuf,
        /// Write the TOML file(s) into DIR instead of printing.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
    /// Run a sweep file (grid or random sample over scenario fields; docs/safety-envelope.md) in
    /// parallel, streaming one CSV row per finished run; re-running skips finished rows.
    Sweep {
        /// The sweep file (TOML).
        file: PathBuf,
        /// Output CSV (default: the sweep file's name with `.csv`). Parquet output and Dask
        /// clusters: `python -m flc sweep FILE` (docs/distributed.md), same rows.
        #[arg(long, value_name = "CSV")]
        out: Option<PathBuf>,
    },
    /// Run a standard test suite (docs/standard-suites.md): `ncap-ccr` (Euro NCAP AEB
    /// Car-to-Car Rear), `r157` (UN R157 ALKS), `all`, or a folder with a `suite.toml`. Every
    /// case runs for every controller (default: all; `--controllers` picks) next to the R157
    /// careful driver; prints the summary.
    Suite {
        /// The suite.
        name: String,
        /// Write `<suite>.md`, `<suite>.json` and `<suite>.svg` (the overview figure) into DIR.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
}

/// The import options the command line gives.
fn import_options(cli: &Cli) -> Result<ImportOptions, String> {
    let flag = |e: flc_sim::ConfigError| format!("`--{}`: {}", e.key.replace('_', "-"), e.problem);
    let params = cli.param.iter().map(|p| ImportOptions::param_pair(p)).collect::<Result<Vec<_>, _>>().map_err(flag)?;
    ImportOptions::from_words(params, cli.ego.clone(), &cli.ego_mode, &cli.road, &cli.traffic_dynamics, None)
        .and_then(|o| o.with_max_duration(cli.max_duration))
        .map_err(flag)
}

/// `--config` with `.xosc` files only: every run imported on demand and streamed (JSON lines
/// or table rows in run order as runs finish), in bounded memory (`flc_sim::stream`).
fn run_xosc_stream(cli: &Cli) -> ExitCode {
    use flc_sim::stream::{StreamOptions, run_sources};
    let opts = match import_options(cli) {
        Ok(o) => o,
        Err(e) => return bad_input(e),
    };
    let controllers = match &cli.controllers {
        None => vec![None],
        Some(list) => match list.iter().map(|c| ControllerKind::parse(c).map(Some)).collect::<Result<Vec<_>, _>>() {
            Ok(c) => c,
            Err(e) => return bad_input(format!("`--controllers`: {e}")),
        },
    };
    let mut sources = Vec::new();
    for path in &cli.config {
        for c in &controllers {
            match openscenario::Source::open(path, &ImportOptions { controller: *c, ..opts.clone() }) {
                Ok(s) => sources.push(s),
                Err(e) => return bad_input(e),
            }
        }
    }
    if cli.permutations {
        for (path, src) in cli.config.iter().zip(sources.iter().step_by(controllers.len())) {
            if cli.config.len() == 1 {
                println!("{}", src.len());
            } else {
                println!("{}\t{}", src.len(), path.display());
            }
        }
        return ExitCode::SUCCESS;
    }
    if let Some(i) = cli.permutation {
        for (path, src) in cli.config.iter().zip(sources.iter().step_by(controllers.len())) {
            if i >= src.len() {
                return bad_input(format!(
                    "`--permutation`: {}: permutation {i} does not exist: the file has {} run(s), permutations 0-{}",
                    path.display(),
                    src.len(),
                    src.len() - 1
                ));
            }
        }
    }
    // The jobs: (source, permutation), file by file, controller by controller.
    let counts: Vec<usize> = sources.iter().map(|s| if cli.permutation.is_some() { 1 } else { s.len() }).collect();
    let total: usize = counts.iter().sum();
    let job = |mut k: usize| {
        for (s, &n) in counts.iter().enumerate() {
            if k < n {
                return (s, cli.permutation.unwrap_or(k));
            }
            k -= n;
        }
        (usize::MAX, 0)
    };
    for dir in [&cli.out, &cli.record].into_iter().flatten() {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return bad_input(format!("`--out` {}: {e}", dir.display()));
        }
    }
    let stop = &STOP;
    if let Err(e) = ctrlc::set_handler(move || {
        if stop.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    }) {
        eprintln!("warning: cannot handle Ctrl-C ({e})");
    }
    let sopts = StreamOptions { out: cli.out.as_deref(), record: cli.record.as_deref(), stop: Some(stop) };
    let bar = (total > 1).then(|| {
        let b = indicatif::ProgressBar::new(total as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed_precise} {msg}") {
            b.set_style(style);
        }
        b
    });
    let say = |line: String| match &bar {
        Some(b) => b.suspend(|| eprintln!("{line}")),
        None => eprintln!("{line}"),
    };
    let mut seen = std::collections::HashSet::new();
    let mut table = flc_sim::report::TableWriter::new(0);
    let (mut collided, mut failed, mut cut, mut n_coll) = (false, 0usize, 0usize, 0usize);
    let mut stdout = std::io::stdout();
    let result = run_sources(&sources, total, job, &sopts, |item| {
        use std::io::Write;
        for w in item.warnings {
            if seen.insert(w.clone()) {
                say(format!("warning: {w}"));
            }
        }
        let rec = match item.record {
            Ok(r) => r,
            Err(e) => {
                failed += 1;
                say(format!("error: permutation {}: {e}", item.permutation));
                return Ok(());
            }
        };
        if item.end == Some(flc_sim::RunEnd::Duration) {
            cut += 1;
            say(format!(
                "warning: {}: cut at --max-duration {} s: its StopTrigger had not fired",
                rec.label(),
                cli.max_duration.unwrap_or(openscenario::DEFAULT_MAX_DURATION)
            ));
        }
        if rec.any_collision() {
            collided = true;
            n_coll += 1;
        }
        let text = if cli.json {
            serde_json::to_string(&rec).map(|l| l + "\n").map_err(|e| SimError::Input(e.to_string()))?
        } else {
            table.row(&rec)
        };
        match &bar {
            Some(b) => b.suspend(|| write!(stdout, "{text}").and_then(|()| stdout.flush())),
            None => write!(stdout, "{text}").and_then(|()| stdout.flush()),
        }?;
        if let Some(b) = &bar {
            b.inc(1);
        }
        Ok(())
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let done = match result {
        Ok(n) => n,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if total > 1 {
        eprintln!("{done} of {total} runs: {n_coll} with a collision, {cut} cut by --max-duration, {failed} failed");
    }
    if STOP.load(Ordering::SeqCst) {
        eprintln!("interrupted: {done} of {total} runs finished and written; the outputs hold only finished runs");
        return ExitCode::from(130);
    }
    if failed > 0 {
        return ExitCode::from(2);
    }
    if cli.fail_on_collision && collided {
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}

/// `true` for an OpenSCENARIO file name.
fn is_xosc(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xosc"))
}

/// The runs of a `.xosc` file (one per distribution combination, times each controller of
/// `--controllers`); warnings go to stderr.
fn import_xosc(path: &std::path::Path, cli: &Cli) -> Result<Vec<Imported>, String> {
    let opts = import_options(cli)?;
    let controllers = match &cli.controllers {
        None => vec![None],
        Some(list) => list
            .iter()
            .map(|c| ControllerKind::parse(c).map(Some))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("`--controllers`: {e}"))?,
    };
    let mut out = Vec::new();
    for (k, c) in controllers.into_iter().enumerate() {
        // One import per controller (the importer owns what a controller implies: V2V, set
        // speeds); its warnings are the same every time: printed once.
        let import = openscenario::import(path, &ImportOptions { controller: c, ..opts.clone() }).map_err(|e| e.to_string())?;
        if k == 0 {
            for w in &import.warnings {
                eprintln!("warning: {w}");
            }
        }
        out.extend(import.runs);
    }
    Ok(out)
}

fn convert(cli: &Cli, file: &std::path::Path, out: Option<&std::path::Path>) -> ExitCode {
    let runs = match import_xosc(file, cli) {
        Ok(r) => r,
        Err(e) => return bad_input(e),
    };
    match out {
        None if runs.len() == 1 => match runs[0].scenario.to_toml() {
            Ok(t) => {
                print!("{t}");
                ExitCode::SUCCESS
            }
            Err(e) => bad_input(e),
        },
        None => {
            bad_input(format!("{}: {} runs (a distribution): give `--out DIR` to write one TOML file per run", file.display(), runs.len()))
        }
        Some(dir) => {
            if let Err(e) = std::fs::create_dir_all(dir) {
                return bad_input(format!("`--out` {}: {e}", dir.display()));
            }
            for r in &runs {
                let stem = r.scenario.run_file_stem();
                let path = dir.join(format!("{stem}.toml"));
                let text = match r.scenario.to_toml() {
                    Ok(t) => t,
                    Err(e) => return bad_input(e),
                };
                if let Err(e) = std::fs::write(&path, text) {
                    eprintln!("error: writing {}: {e}", path.display());
                    return ExitCode::FAILURE;
                }
                eprintln!("{}", path.display());
            }
            ExitCode::SUCCESS
        }
    }
}

/// `scenario sweep FILE.xosc`: a distribution's runs through the sweep engine, one CSV row per
/// combination with its parameter values, each run imported when its turn comes (bounded
/// memory, `openscenario::Source`).
fn sweep_xosc(cli: &Cli, file: &std::path::Path, out: Option<&std::path::Path>) -> ExitCode {
    use flc_sim::sweep::{SweepPoint, run_points_with};
    let opts = match import_options(cli) {
        Ok(o) => o,
        Err(e) => return bad_input(e),
    };
    let controllers = match &cli.controllers {
        None => vec![None],
        Some(list) => match list.iter().map(|c| ControllerKind::parse(c).map(Some)).collect::<Result<Vec<_>, _>>() {
            Ok(c) => c,
            Err(e) => return bad_input(format!("`--controllers`: {e}")),
        },
    };
    let mut sources = Vec::new();
    for c in &controllers {
        match openscenario::Source::open(file, &ImportOptions { controller: *c, ..opts.clone() }) {
            Ok(s) => sources.push(s),
            Err(e) => return bad_input(e),
        }
    }
    let first = match sources.first().map(|s| s.run(0)) {
        Some(Ok((imp, warnings))) => {
            for w in warnings {
                eprintln!("warning: {w}");
            }
            imp
        }
        Some(Err(e)) => return bad_input(e),
        None => return bad_input("no run"),
    };
    let keys: Vec<String> = first.params.iter().map(|(k, _)| k.clone()).collect();
    let per = sources.first().map_or(0, openscenario::Source::len);
    let total = per * sources.len();
    let point = |id: usize| {
        let src = sources.get(id / per.max(1)).ok_or_else(|| format!("no run {id}"))?;
        let (r, _) = src.run(id % per.max(1)).map_err(|e| e.to_string())?;
        let values = r.params.into_iter().map(|(k, v)| (k, serde_json::Value::String(v))).collect();
        Ok(SweepPoint { id, values, scenario: r.scenario })
    };
    let out = out.map_or_else(|| file.with_extension("csv"), std::path::Path::to_path_buf);
    match run_points_with(&keys, total, point, &out, true) {
        Ok(n) => {
            eprintln!("{n} runs done ({total} in the distribution), rows in {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn sweep(file: &std::path::Path, out: Option<&std::path::Path>) -> ExitCode {
    use flc_sim::sweep::{SweepSpec, run_sweep};
    let (spec, dir) = match SweepSpec::from_file(file) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let points = match spec.points(dir.as_deref()) {
        Ok(p) => p,
        Err(e) => return bad_input(format!("{}: {e}", file.display())),
    };
    let out = out.map_or_else(|| file.with_extension("csv"), std::path::Path::to_path_buf);
    match run_sweep(&spec, &points, &out, true) {
        Ok(n) => {
            eprintln!("{n} runs done ({} in the sweep), rows in {}", points.len(), out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `scenario suite NAME`: the suite's runs for the controllers, the summary on stdout, the
/// reports into `--out`.
fn suite(cli: &Cli, name: &str, out: Option<&std::path::Path>) -> ExitCode {
    use flc_sim::suite::{Suite, default_root, markdown, summary_line, summary_table, svg};
    // The cases fix their own parameters, ego and road: the per-file options do not apply.
    for (given, flag) in
        [(cli.record.is_some(), "--record"), (!cli.param.is_empty(), "--param"), (cli.ego.is_some(), "--ego"), (cli.json, "--json")]
    {
        if given {
            return bad_input(format!("`{flag}` does not apply to `suite` (its cases fix their own; --out writes the reports)"));
        }
    }
    let controllers = match &cli.controllers {
        None => ControllerKind::ALL.to_vec(),
        Some(list) => match list.iter().map(|c| ControllerKind::parse(c)).collect::<Result<Vec<_>, _>>() {
            Ok(k) => k,
            Err(e) => return bad_input(format!("`--controllers`: {e}")),
        },
    };
    let suites = match Suite::find(&default_root(), name) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    if let Some(dir) = out {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return bad_input(format!("`--out` {}: {e}", dir.display()));
        }
    }
    let mut reports = Vec::with_capacity(suites.len());
    for s in &suites {
        match s.run(&controllers) {
            Ok(r) => reports.push(r),
            Err(SimError::Input(e)) => return bad_input(e),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    print!("{}", summary_table(&reports));
    if let Some(dir) = out {
        let command = |n: &str| {
            let picked = cli.controllers.as_ref().map_or(String::new(), |c| format!(" --controllers {}", c.join(",")));
            format!("cargo run --release --bin scenario -- suite {n}{picked} --out DIR")
        };
        let mut files: Vec<(String, String)> = Vec::new();
        for r in &reports {
            files.push((format!("{}.md", r.name), markdown(r, &command(&r.name))));
            files.push((format!("{}.json", r.name), r.to_json() + "\n"));
            files.push((format!("{}.svg", r.name), svg(r)));
        }
        // The summaries the README and docs/standard-suites.md include (`python -m flc docs`).
        files.push(("summary.md".into(), summary_table(&reports)));
        files.push(("summary-line.md".into(), format!("Standard suites, runs passed: {}\n", summary_line(&reports))));
        for (name, text) in files {
            let path = dir.join(name);
            if let Err(e) = std::fs::write(&path, text) {
                eprintln!("error: writing {}: {e}", path.display());
                return ExitCode::FAILURE;
            }
            eprintln!("{}", path.display());
        }
    }
    ExitCode::SUCCESS
}

fn bad_input(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {msg}");
    ExitCode::from(2)
}

fn scenarios(cli: &Cli) -> Result<Vec<(Scenario, Option<Calibration>)>, SimError> {
    let mut out = Vec::new();
    if !cli.config.is_empty() {
        for path in &cli.config {
            if is_xosc(path) {
                let runs = import_xosc(path, cli).map_err(SimError::Input)?;
                out.extend(runs.into_iter().map(|r| (r.scenario, None)));
                continue;
            }
            let s = Scenario::from_file(path)?;
            // A file with `[[variants]]` runs each variant.
            let variants = s.expand_variants().map_err(|e| SimError::File { path: path.display().to_string(), message: e.to_string() })?;
            out.extend(variants.into_iter().map(|v| (v, None)));
        }
    } else {
        let presets = match cli.preset.as_str() {
            "both" => vec![Calibration::Realistic, Calibration::Paper],
            "realistic" => vec![Calibration::Realistic],
            "paper" => vec![Calibration::Paper],
            other => {
                return Err(flc_sim::ConfigError::new("--preset", format!("must be realistic, paper or both, got `{other}`")).into());
            }
        };
        let default = ["flc", "pid", "pipeline"].map(String::from).to_vec();
        let controllers =
            cli.controllers.as_ref().unwrap_or(&default).iter().map(|c| ControllerKind::parse(c)).collect::<Result<Vec<_>, _>>()?;
        for &speed in &cli.speeds {
            flc_sim::check_range("--speeds", speed, 1.0, 250.0, "km/h")?;
        }
        for &preset in &presets {
            for &speed in &cli.speeds {
                for &c in &controllers {
                    out.push((Scenario::paper_experiment(speed, c, preset), Some(preset)));
                }
            }
        }
    }
    if let Some(seed) = cli.seed {
        for (s, _) in &mut out {
            s.seed = seed;
        }
    }
    for (s, _) in &out {
        s.validate().map_err(|e| SimError::File { path: s.name.clone(), message: e.to_string() })?;
    }
    Ok(out)
}

/// The paper's tracking errors (two curved-route runs, paper preset) and its 90 km/h comparison
/// (from the paper-preset records), as text.
fn paper_numbers(records: &[RunRecord]) -> Result<String, SimError> {
    let kinds = [ControllerKind::Flc, ControllerKind::Pid];
    let runs: Vec<Scenario> = kinds.iter().map(|&k| Scenario::paper_tracking(k, Calibration::Paper)).collect();
    let results = RunOptions::default().run_batch(&runs);
    let mut tracking = Vec::new();
    for (k, r) in kinds.iter().zip(results) {
        let r = r?;
        let record = RunRecord::from_run(None, &r);
        tracking.push(flc_sim::paper::TrackingRun {
            controller: k.as_str(),
            rot_error_deg: r.metrics.rot_error_deg,
            trans_error_m: r.metrics.trans_error_m,
            outcome: record.outcome(),
            duration: r.metrics.duration,
        });
    }
    let impacts: Vec<(&str, f64)> = records
        .iter()
        .filter(|r| r.preset.as_deref() == Some("paper") && r.speed_kmh == Some(90.0) && r.metrics.collision)
        .map(|r| (r.controller.as_str(), r.metrics.impact_speed))
        .collect();
    Ok(flc_sim::paper::other_numbers(&tracking, &impacts))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            return bad_input("`--threads`: must be >= 1");
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
            return bad_input(format!("`--threads`: {e}"));
        }
    }
    match &cli.command {
        Some(Command::Sweep { file, out }) => {
            if cli.record.is_some() {
                return bad_input("`--record` does not apply to `sweep`");
            }
            if let Some(o) = out.as_deref().filter(|o| o.extension().is_some_and(|e| e.eq_ignore_ascii_case("parquet"))) {
                return bad_input(format!(
                    "`--out` {}: `scenario sweep` writes CSV; Parquet (and Dask) is `python -m flc sweep FILE --out X.parquet` (docs/distributed.md)",
                    o.display()
                ));
            }
            if is_xosc(file) {
                return sweep_xosc(&cli, file, out.as_deref());
            }
            return sweep(file, out.as_deref());
        }
        Some(Command::Convert { file, out }) => return convert(&cli, file, out.as_deref()),
        Some(Command::Suite { name, out }) => return suite(&cli, name, out.as_deref()),
        None => {}
    }
    if !cli.config.is_empty() && cli.config.iter().all(|p| is_xosc(p)) {
        return run_xosc_stream(&cli);
    }
    if cli.permutation.is_some() || cli.permutations {
        return bad_input("`--permutation` / `--permutations`: only for `--config` with `.xosc` files");
    }
    let list = match scenarios(&cli) {
        Ok(l) => l,
        Err(e) => return bad_input(e),
    };
    if let Some(dir) = &cli.out {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return bad_input(format!("`--out` {}: {e}", dir.display()));
        }
    }
    let scenarios: Vec<Scenario> = list.iter().map(|(s, _)| s.clone()).collect();
    let progress = list.len() > 1;
    let results = match &cli.record {
        None => RunOptions { progress, ..RunOptions::default() }.run_batch(&scenarios),
        Some(dir) => {
            if let Err(e) = std::fs::create_dir_all(dir) {
                return bad_input(format!("`--record` {}: {e}", dir.display()));
            }
            let stop = &STOP;
            // First Ctrl-C: stop the runs at their next step and finish the recordings; second: exit.
            if let Err(e) = ctrlc::set_handler(move || {
                if stop.swap(true, Ordering::SeqCst) {
                    std::process::exit(130);
                }
            }) {
                eprintln!("warning: cannot handle Ctrl-C ({e}); an interrupted recording may be incomplete");
            }
            let results = RunOptions { record: Some(dir), stop: Some(stop), progress, ..RunOptions::default() }.run_batch(&scenarios);
            if stop.load(Ordering::SeqCst) {
                eprintln!("interrupted: the recordings in {} are finished up to the interrupt", dir.display());
                return ExitCode::from(130);
            }
            results
        }
    };
    let mut records = Vec::new();
    for ((scenario, preset), result) in list.iter().zip(results) {
        let run = match result {
            Ok(r) => r,
            Err(e) => return bad_input(format!("{}: {e}", scenario.name)),
        };
        if let Some(dir) = &cli.out {
            if let Err(e) = report::write_series_csv(dir, &run) {
                eprintln!("error: writing time series for {}: {e}", scenario.name);
                return ExitCode::FAILURE;
            }
        }
        records.push(RunRecord::from_run(preset.map(Calibration::as_str), &run));
    }
    // Platoons with `string_stability.frequencies_hz`: |Gamma(jw)|, one sine run per frequency.
    if cli.record.is_none() {
        if let Err(e) = flc_sim::frequency_response::add_to_records(&scenarios, &mut records, true) {
            return bad_input(e);
        }
    }
    if cli.json {
        for r in &records {
            match serde_json::to_string(r) {
                Ok(line) => println!("{line}"),
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
    } else {
        print!("{}", report::table(&records));
        if cli.config.is_empty() && cli.preset != "realistic" {
            print!("\n{}", flc_sim::paper::matching_region_line());
            match paper_numbers(&records) {
                Ok(text) => print!("{text}"),
                Err(e) => return bad_input(e),
            }
        }
        for r in &records {
            print!("{}", report::platoon_table(r));
        }
    }
    if cli.fail_on_collision && records.iter().any(RunRecord::any_collision) {
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}
