//! `scenario`: run the paper's experiment (no arguments) or scenario files, print a results table
//! or JSON, write time series. See `scenario --help` and `docs/scenarios.md`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use flc_sim::openscenario::{self, ImportOptions, Imported};
use flc_sim::paper::{Calibration, PAPER_SPEEDS_KMH};
use flc_sim::paper_verdict::{PaperSummary, TrackingVerdict};
use flc_sim::report::{self, RunRecord};
use flc_sim::{ControllerKind, Scenario};
use flc_sim::{RunOptions, SimError};

/// Set by the Ctrl-C handler (installed with --record only).
static STOP: AtomicBool = AtomicBool::new(false);

/// The options of OpenSCENARIO imports: the runs of `--config FILE.xosc`, `convert` and
/// `sweep FILE.xosc`.
#[derive(Debug, Clone, clap::Args)]
struct XoscArgs {
    /// `.xosc`: set a parameter, NAME=VALUE (repeatable; as esmini's --param).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    param: Vec<String>,
    /// `.xosc`: the entity flc's controller drives (default: `Ego` / `ego`, else the first).
    #[arg(long, value_name = "NAME")]
    ego: Option<String>,
    /// `.xosc`: `controller` (flc's controller drives the ego) or `scripted` (the ego follows its
    /// storyboard, as esmini's default controller does: for comparing whole files with esmini).
    #[arg(long, value_name = "MODE", default_value = "controller")]
    ego_mode: String,
    /// `.xosc`: the road: `file` (the referenced OpenDRIVE file) or `straight` (4 lanes of 3.5 m
    /// along +x, for files whose road is missing).
    #[arg(long, value_name = "ROAD", default_value = "file")]
    road: String,
    /// `.xosc`: how the scripted entities move: `kinematic` (exactly as their actions
    /// prescribe, as in esmini) or `vehicle` (a driver tracks them through each entity's vehicle
    /// model: actuator lag, dead time, limits).
    #[arg(long, value_name = "MODEL", default_value = "kinematic")]
    traffic_dynamics: String,
    /// `.xosc`: refuse what esmini accepts but OpenSCENARIO does not (the expression extensions
    /// `pi`, `sin`, ...; a negative dynamics value; a value its declaration's constraints forbid)
    /// instead of warning.
    #[arg(long)]
    strict: bool,
    /// `.xosc`: the guard on a run's length, s (default 3600): a run whose StopTrigger has not
    /// fired by then is cut, with a line on stderr and `"end": "duration"` in its JSON.
    #[arg(long, value_name = "SECONDS")]
    max_duration: Option<f64>,
}

/// What an OpenSCENARIO import needs from the command line.
struct ImportFlags<'a> {
    xosc: &'a XoscArgs,
    controllers: Option<&'a [String]>,
    quiet: bool,
}

/// Closed-loop simulation of the flc vehicle-following pipeline.
///
/// Without --config, runs the paper's experiment: lead and follower at standstill 7 m apart, the lead
/// accelerates to each speed of --speeds, covers about 650 m and brakes at -6 m/s² to a stop; the
/// follower is driven by the FLC only, the PID only (perfect V2V) and the switching pipeline (V2V
/// lost at brake onset); once with the realistic vehicle and once with the paper-calibrated preset.
/// Prints a table next to the paper's numbers with each run's verdict (outcome class, clearance
/// within 0.5 m), a summary over the runs made, and the paper's other numbers (tracking errors,
/// 90 km/h impacts), each with its verdict.
///
/// Exit status: 0 success, 1 a run collided and --fail-on-collision was given, 2 bad input,
/// 130 interrupted by Ctrl-C while recording (--record).
#[derive(Debug, clap::Parser)]
#[command(name = "scenario", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Scenario file(s): TOML (schema in docs/scenarios.md) or ASAM OpenSCENARIO `.xosc`
    /// (docs/openscenario.md; a `ParameterValueDistribution` file runs every combination).
    /// Repeat or list several.
    #[arg(long = "config", value_name = "FILE", num_args = 1..)]
    config: Vec<PathBuf>,
    #[command(flatten)]
    xosc: XoscArgs,
    /// Override a scenario key of every run, KEY=VALUE (repeatable, applied in order after the
    /// file's `[[variants]]`): a dotted key (`lidar.rate_hz=10`, `lead.phases[2].decel=4`), a
    /// section name then `_` (`lidar_rate_hz=10`), `lead_decel` (every brake phase of the
    /// lead) or `seed`, as Python's keyword overrides; VALUE is a TOML value, else a string
    /// (`controller=pid`). Applies to TOML files, imported `.xosc` runs and the paper experiment.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Print one JSON record per run on stdout (fields documented in docs/scenarios.md) instead
    /// of the table; the paper experiment adds a last line, `{"paper_summary": ...}`.
    #[arg(long)]
    json: bool,
    /// Write each run's per-step time series as CSV into DIR (one file per run).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Record each run as an MCAP file in DIR for Foxglove (`<scenario>-<controller>[-<speed>kmh].mcap`,
    /// docs/foxglove.md). Ctrl-C stops the runs and finishes the files (exit status 130).
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Maximum speeds of the paper experiment, km/h, comma separated (not with --config).
    #[arg(long, value_name = "KMH", value_delimiter = ',', default_values_t = PAPER_SPEEDS_KMH)]
    speeds: Vec<f64>,
    /// Controllers, comma separated, by their scenario-file names (flc, pid, pipeline, the
    /// baselines, ...; a wrong name lists them all): of the paper experiment (default
    /// flc,pid,pipeline); with --config, each one runs every file (TOML: as `--set
    /// controller=NAME`, the file's [v2v] as written; `.xosc`: the importer sets what the
    /// controller implies; default: the file's controller).
    #[arg(long, value_name = "NAME", value_delimiter = ',')]
    controllers: Option<Vec<String>>,
    /// Which presets of the paper experiment to run: realistic, paper or both (not with --config).
    #[arg(long, value_name = "PRESET", default_value = "both")]
    preset: String,
    /// Override the seed of every run.
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
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
    /// No warnings (OpenSCENARIO import, flags that do not apply) and no progress bar on
    /// stderr; errors still print.
    #[arg(long, short)]
    quiet: bool,
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
        #[command(flatten)]
        xosc: XoscArgs,
        /// The controller(s) driving the ego, comma separated (default: the file's, else flc);
        /// several give one file per controller (with --out).
        #[arg(long, value_name = "NAME", value_delimiter = ',')]
        controllers: Option<Vec<String>>,
        /// A distribution: convert only permutation I (0-based, as esmini's
        /// --param_permutation), without importing the others.
        #[arg(long, value_name = "I")]
        permutation: Option<usize>,
        /// No import warnings and no list of the files written on stderr.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run a sweep file (grid or random sample over scenario fields; docs/safety-envelope.md) in
    /// parallel, streaming one CSV row per finished run; re-running the same sweep skips finished
    /// rows (an output of other inputs is refused: see --restart).
    Sweep {
        /// The sweep file (TOML), or an OpenSCENARIO `.xosc` distribution (one row per
        /// combination).
        file: PathBuf,
        /// Output CSV (default: the sweep file's name with `.csv`); the digest of its rows'
        /// inputs goes into `<CSV>.digest`. Parquet output and Dask clusters: `python -m flc
        /// sweep FILE` (docs/distributed.md), same rows.
        #[arg(long, value_name = "CSV")]
        out: Option<PathBuf>,
        /// Start the output over (its rows are dropped). Without it, an output whose rows ran
        /// other inputs (the sweep file, a base scenario, an option or the flc version changed)
        /// is refused, never resumed.
        #[arg(long)]
        restart: bool,
        #[command(flatten)]
        xosc: XoscArgs,
        /// `.xosc`: the controller(s) driving the ego, comma separated (a TOML sweep file sets
        /// its controllers with a `controller` axis).
        #[arg(long, value_name = "NAME", value_delimiter = ',')]
        controllers: Option<Vec<String>>,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// No import warnings and no progress bar on stderr.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run a standard test suite (docs/standard-suites.md): `ncap-ccr` (Euro NCAP AEB
    /// Car-to-Car Rear), `r157` (UN R157 ALKS), `all`, or a folder with a `suite.toml`. Every
    /// case runs for every controller (default: all; `--controllers` picks) next to the R157
    /// careful driver; prints the summary. The cases fix their own parameters, ego and road.
    Suite {
        /// The suite.
        name: String,
        /// Write `<suite>.md`, `<suite>.json` and `<suite>.svg` (the overview figure) into DIR.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// The folder of the named suites (default: `scenarios/suites` of the source tree
        /// holding this executable, else of the one it was built from).
        #[arg(long, value_name = "DIR")]
        root: Option<PathBuf>,
        /// Controllers, comma separated (default: all), each next to the careful driver.
        #[arg(long, value_name = "NAME", value_delimiter = ',')]
        controllers: Option<Vec<String>>,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// No list of the files written on stderr.
        #[arg(long, short)]
        quiet: bool,
        /// `ncap-ccr-2026` with one controller (`--controllers NAME`): fill Euro NCAP's 2026
        /// rating calculator's workbook with its runs and print the calculator's points
        /// (`python3 -m flc.ncap`, needs `pip install 'flc[ncap]'`; `FLC_PYTHON` names another
        /// interpreter).
        #[arg(long, value_name = "FILE.xlsx")]
        ncap_workbook: Option<PathBuf>,
    },
}

impl Command {
    fn name(&self) -> &'static str {
        match self {
            Command::Convert { .. } => "convert",
            Command::Sweep { .. } => "sweep",
            Command::Suite { .. } => "suite",
        }
    }

    /// The subcommand's own `--threads`.
    fn threads(&self) -> Option<usize> {
        match self {
            Command::Convert { .. } => None,
            Command::Sweep { threads, .. } | Command::Suite { threads, .. } => *threads,
        }
    }
}

/// The import options the command line gives.
fn import_options(x: &XoscArgs) -> Result<ImportOptions, String> {
    let flag = |e: flc_sim::ConfigError| format!("`--{}`: {}", e.key.replace('_', "-"), e.problem);
    let params = x.param.iter().map(|p| ImportOptions::param_pair(p)).collect::<Result<Vec<_>, _>>().map_err(flag)?;
    let opts = ImportOptions::from_words(params, x.ego.clone(), &x.ego_mode, &x.road, &x.traffic_dynamics, None)
        .and_then(|o| o.with_max_duration(x.max_duration))
        .map_err(flag)?;
    Ok(ImportOptions { strict: x.strict, ..opts })
}

/// `--config` with `.xosc` files only: every run imported on demand and streamed (JSON lines
/// or table rows in run order as runs finish), in bounded memory (`flc_sim::stream`).
fn run_xosc_stream(cli: &Cli) -> ExitCode {
    use flc_sim::stream::{StreamOptions, run_sources};
    let opts = match import_options(&cli.xosc) {
        Ok(o) => o,
        Err(e) => return bad_input(e),
    };
    let set = match overrides(cli) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    // `--set` and `--seed` on every run, as for TOML files.
    let adjust = |s: Scenario| -> Result<Scenario, String> {
        let origin = s.name.clone();
        let mut s = apply_set(s, &set, &origin).map_err(|e| e.to_string())?;
        if let Some(seed) = cli.seed {
            s.seed = seed;
        }
        s.validate().map_err(|e| format!("{origin}: {e}"))?;
        Ok(s)
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
    let sopts = StreamOptions { out: cli.out.as_deref(), record: cli.record.as_deref(), stop: Some(stop), adjust: Some(&adjust) };
    let bar = (total > 1 && !cli.quiet).then(|| {
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
            if !cli.quiet && seen.insert(w.clone()) {
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
        }
        if item.end == Some(flc_sim::RunEnd::Duration) && !cli.quiet {
            say(format!(
                "warning: {}: cut at --max-duration {} s: its StopTrigger had not fired",
                rec.label(),
                cli.xosc.max_duration.unwrap_or(openscenario::DEFAULT_MAX_DURATION)
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
/// `--controllers`); warnings go to stderr unless `--quiet`.
/// The runs of `path` (only run `permutation` of a distribution when given), one set per
/// controller of `--controllers`.
fn import_xosc(path: &std::path::Path, flags: &ImportFlags<'_>, permutation: Option<usize>) -> Result<Vec<Imported>, String> {
    let opts = import_options(flags.xosc)?;
    let controllers = match flags.controllers {
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
        let copts = ImportOptions { controller: c, ..opts.clone() };
        let (runs, warnings) = match permutation {
            Some(i) => {
                let source = openscenario::Source::open(path, &copts).map_err(|e| e.to_string())?;
                let (run, warnings) = source.run(i).map_err(|e| e.to_string())?;
                (vec![run], warnings)
            }
            None => {
                let import = openscenario::import(path, &copts).map_err(|e| e.to_string())?;
                (import.runs, import.warnings)
            }
        };
        if k == 0 && !flags.quiet {
            for w in &warnings {
                eprintln!("warning: {w}");
            }
        }
        out.extend(runs);
    }
    Ok(out)
}

fn convert(flags: &ImportFlags<'_>, file: &std::path::Path, permutation: Option<usize>, out: Option<&std::path::Path>) -> ExitCode {
    let runs = match import_xosc(file, flags, permutation) {
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
                if !flags.quiet {
                    eprintln!("{}", path.display());
                }
            }
            ExitCode::SUCCESS
        }
    }
}

/// `scenario sweep FILE.xosc`: a distribution's runs through the sweep engine, one CSV row per
/// combination with its parameter values, each run imported when its turn comes (bounded
/// memory, `openscenario::Source`).
fn sweep_xosc(flags: &ImportFlags<'_>, file: &std::path::Path, out: Option<&std::path::Path>, restart: bool) -> ExitCode {
    use flc_sim::sweep::{SweepPoint, run_points_with};
    let opts = match import_options(flags.xosc) {
        Ok(o) => o,
        Err(e) => return bad_input(e),
    };
    let controllers = match flags.controllers {
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
            if !flags.quiet {
                for w in warnings {
                    eprintln!("warning: {w}");
                }
            }
            imp
        }
        Some(Err(e)) => return bad_input(e),
        None => return bad_input("no run"),
    };
    let keys: Vec<String> = first.params.iter().map(|(k, _)| k.clone()).collect();
    drop(first);
    let per = sources.first().map_or(0, openscenario::Source::len);
    let total = per * sources.len();
    let point = |id: usize| {
        let src = sources.get(id / per.max(1)).ok_or_else(|| format!("no run {id}"))?;
        let (r, _) = src.run(id % per.max(1)).map_err(|e| e.to_string())?;
        let values = r.params.into_iter().map(|(k, v)| (k, serde_json::Value::String(v))).collect();
        Ok(SweepPoint { id, values, scenario: r.scenario })
    };
    let out = out.map_or_else(|| file.with_extension("csv"), std::path::Path::to_path_buf);
    match run_points_with(&keys, total, point, &out, !flags.quiet, restart) {
        Ok(n) => {
            eprintln!("{n} runs done ({total} in the distribution), rows in {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e @ SimError::StaleOutput { .. }) => stale(e),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn sweep(file: &std::path::Path, out: Option<&std::path::Path>, quiet: bool, restart: bool) -> ExitCode {
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
    match run_sweep(&spec, &points, &out, !quiet, restart) {
        Ok(n) => {
            eprintln!("{n} runs done ({} in the sweep), rows in {}", points.len(), out.display());
            ExitCode::SUCCESS
        }
        Err(e @ SimError::StaleOutput { .. }) => stale(e),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Fills Euro NCAP's 2026 calculator workbook for `controller` from `rep` and prints its
/// points: `python3 -m flc.ncap` (the Python package owns the calculator and its template).
fn ncap_workbook(rep: &flc_sim::suite::SuiteReport, controller: &str, workbook: &std::path::Path) -> ExitCode {
    let json = std::env::temp_dir().join(format!("flc-ncap-report-{}.json", std::process::id()));
    if let Err(e) = std::fs::write(&json, rep.to_json()) {
        eprintln!("error: writing {}: {e}", json.display());
        return ExitCode::FAILURE;
    }
    let python = std::env::var("FLC_PYTHON").unwrap_or_else(|_| "python3".into());
    let status = std::process::Command::new(&python)
        .args(["-m", "flc.ncap"])
        .arg(&json)
        .args(["--controller", controller, "--score", "--workbook"])
        .arg(workbook)
        .status();
    let _ = std::fs::remove_file(&json);
    match status {
        Ok(s) if s.success() => ExitCode::SUCCESS,
        Ok(s) if s.code() == Some(2) => ExitCode::from(2),
        Ok(s) => bad_input(format!(
            "`--ncap-workbook` {}: `{python} -m flc.ncap` failed ({s}); it needs the flc package with the calculator: pip install 'flc[ncap]'",
            workbook.display()
        )),
        Err(e) => bad_input(format!("`--ncap-workbook` {}: cannot run `{python}` ({e}); set FLC_PYTHON", workbook.display())),
    }
}

/// A sweep output that cannot be resumed (exit 2): what is wrong and how to start over.
fn stale(e: SimError) -> ExitCode {
    bad_input(format!("{e}; start over with `--restart` (or give another `--out`)"))
}

/// `scenario suite NAME`: the suite's runs for the controllers, the summary on stdout, the
/// reports into `--out`.
fn suite(
    picked: Option<&[String]>,
    name: &str,
    out: Option<&std::path::Path>,
    root: Option<&std::path::Path>,
    quiet: bool,
    workbook: Option<&std::path::Path>,
) -> ExitCode {
    use flc_sim::suite::{Suite, default_root, markdown, summary_line, summary_table, svg};
    let controllers = match picked {
        None => ControllerKind::ALL.to_vec(),
        Some(list) => match list.iter().map(|c| ControllerKind::parse(c)).collect::<Result<Vec<_>, _>>() {
            Ok(k) => k,
            Err(e) => return bad_input(format!("`--controllers`: {e}")),
        },
    };
    // A suite's own folder needs no root; a name needs the folder of the suites.
    let own_folder = std::path::Path::new(name).join("suite.toml").is_file();
    let root = match root {
        Some(r) => r.to_path_buf(),
        None if own_folder => std::path::PathBuf::new(),
        None => match default_root() {
            Ok(r) => r,
            Err(e) => return bad_input(format!("suite `{name}`: {e}")),
        },
    };
    let suites = match Suite::find(&root, name) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    // The workbook is one controller's, of the 2026 grid: check before running anything.
    let ncap_controller = match workbook {
        None => None,
        Some(_) => {
            let tested: Vec<&ControllerKind> = controllers.iter().filter(|k| k.as_str() != flc_sim::suite::REFERENCE).collect();
            let banded = suites.iter().any(|s| s.spec.cases.iter().any(|c| c.criterion == flc_sim::suite::Criterion::Ncap2026));
            if !banded {
                return bad_input(format!("`--ncap-workbook`: suite `{name}` has no 2026 NCAP cases (use ncap-ccr-2026)"));
            }
            match (picked, tested.as_slice()) {
                (Some(_), [one]) => Some(one.as_str()),
                _ => return bad_input("`--ncap-workbook`: the workbook is one controller's: give `--controllers NAME`"),
            }
        }
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
    if let (Some(wb), Some(c)) = (workbook, ncap_controller) {
        let Some(rep) = reports.iter().find(|r| r.results.iter().any(|x| x.ncap.as_ref().is_some_and(|n| n.band.is_some()))) else {
            return bad_input("`--ncap-workbook`: no 2026 NCAP runs");
        };
        let code = ncap_workbook(rep, c, wb);
        if code != ExitCode::SUCCESS {
            return code;
        }
    }
    if let Some(dir) = out {
        let command = |n: &str| {
            let picked = picked.map_or(String::new(), |c| format!(" --controllers {}", c.join(",")));
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
            if !quiet {
                eprintln!("{}", path.display());
            }
        }
    }
    ExitCode::SUCCESS
}

fn bad_input(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {msg}");
    ExitCode::from(2)
}

/// The `--set KEY=VALUE` pairs, parsed (keys and values as Python's keyword overrides).
fn overrides(cli: &Cli) -> Result<Vec<(String, serde_json::Value)>, SimError> {
    cli.set.iter().map(|a| Scenario::override_pair(a).map_err(|e| SimError::Input(e.to_string()))).collect()
}

/// `s` with the `--set` overrides applied (the one patch mechanism, `Scenario::with_overrides`);
/// an error names the flag, the run's `origin` (file or scenario), the key and the problem.
fn apply_set(s: Scenario, set: &[(String, serde_json::Value)], origin: &str) -> Result<Scenario, SimError> {
    if set.is_empty() {
        return Ok(s);
    }
    s.with_overrides(set).map_err(|e| SimError::Input(format!("`--set` ({origin}): {e}")))
}

fn scenarios(cli: &Cli) -> Result<Vec<(Scenario, Option<Calibration>)>, SimError> {
    let set = overrides(cli)?;
    let mut out = Vec::new();
    if !cli.config.is_empty() {
        let flags = ImportFlags { xosc: &cli.xosc, controllers: cli.controllers.as_deref(), quiet: cli.quiet };
        // `--controllers` on a TOML file: `controller` is a scenario key, patched like any other
        // (as Python's `Scenario.load(path, controller=...)`).
        let toml_controllers: Vec<Option<(String, serde_json::Value)>> = match &cli.controllers {
            None => vec![None],
            Some(list) => list
                .iter()
                .map(|c| ControllerKind::parse(c).map(|k| Some(("controller".to_string(), serde_json::Value::from(k.as_str())))))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| SimError::Input(format!("`--controllers`: {e}")))?,
        };
        for path in &cli.config {
            if is_xosc(path) {
                let runs = import_xosc(path, &flags, None).map_err(SimError::Input)?;
                for r in runs {
                    out.push((apply_set(r.scenario, &set, &path.display().to_string())?, None));
                }
                continue;
            }
            let s = Scenario::from_file(path)?;
            // A file with `[[variants]]` runs each variant.
            let variants = s.expand_variants().map_err(|e| SimError::File { path: path.display().to_string(), message: e.to_string() })?;
            for c in &toml_controllers {
                for v in &variants {
                    let v = match c {
                        None => v.clone(),
                        Some(pair) => v
                            .with_overrides(std::slice::from_ref(pair))
                            .map_err(|e| SimError::File { path: path.display().to_string(), message: format!("`--controllers`: {e}") })?,
                    };
                    out.push((apply_set(v, &set, &path.display().to_string())?, None));
                }
            }
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
        for &speed in &cli.speeds {
            flc_sim::paper::check_speed_kmh("--speeds", speed)?;
        }
        for &preset in &presets {
            for &speed in &cli.speeds {
                for &c in &paper_controllers(cli)? {
                    let s = Scenario::paper_experiment(speed, c, preset);
                    let origin = format!("{}, {}", s.name, c.as_str());
                    out.push((apply_set(s, &set, &origin)?, Some(preset)));
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

/// The controllers of the paper experiment (`--controllers`, default flc, pid, pipeline).
fn paper_controllers(cli: &Cli) -> Result<Vec<ControllerKind>, SimError> {
    let default = ["flc", "pid", "pipeline"].map(String::from).to_vec();
    Ok(cli.controllers.as_ref().unwrap_or(&default).iter().map(|c| ControllerKind::parse(c)).collect::<Result<Vec<_>, _>>()?)
}

/// The verdict of the paper experiment's runs: each record's is in the record; this runs the
/// curved-route tracking runs (paper preset, the FLC and the PID among `--controllers`, with
/// `--set` and `--seed` as the table's runs) and sums up.
fn paper_summary(cli: &Cli, records: &[RunRecord]) -> Result<PaperSummary, SimError> {
    let set = overrides(cli)?;
    let mut runs = Vec::new();
    if records.iter().any(|r| r.preset.as_deref() == Some(Calibration::Paper.as_str())) {
        for k in paper_controllers(cli)?.into_iter().filter(|k| matches!(k, ControllerKind::Flc | ControllerKind::Pid)) {
            let s = Scenario::paper_tracking(k, Calibration::Paper);
            let origin = format!("{}, {}", s.name, k.as_str());
            let mut s = apply_set(s, &set, &origin)?;
            if let Some(seed) = cli.seed {
                s.seed = seed;
            }
            runs.push(s);
        }
    }
    let mut tracking = Vec::new();
    for r in RunOptions::default().run_batch(&runs) {
        tracking.extend(TrackingVerdict::of(&r?));
    }
    Ok(PaperSummary::new(records, tracking, cli.set.clone()))
}

/// Top-level flags given before a subcommand: only `--threads` and `--quiet` apply there (kept
/// for `scenario --threads 1 sweep ...`); anything else is an error naming it.
fn check_flags_before(matches: &clap::ArgMatches, command: &Command) -> Result<(), String> {
    use clap::parser::ValueSource;
    for arg in <Cli as clap::CommandFactory>::command().get_arguments() {
        let id = arg.get_id().as_str();
        if matches!(id, "threads" | "quiet") || matches.value_source(id) != Some(ValueSource::CommandLine) {
            continue;
        }
        let flag = arg.get_long().map_or(id.to_string(), |l| format!("--{l}"));
        return Err(format!("`{flag}` does not apply to `{}` (`scenario {} --help` lists its flags)", command.name(), command.name()));
    }
    Ok(())
}

/// Flags of the paper experiment given with `--config` (where they do nothing): a warning each.
fn warn_ignored(matches: &clap::ArgMatches, cli: &Cli) {
    use clap::parser::ValueSource;
    if cli.quiet || cli.config.is_empty() {
        return;
    }
    for (id, flag) in [("speeds", "--speeds"), ("preset", "--preset")] {
        if matches.value_source(id) == Some(ValueSource::CommandLine) {
            eprintln!("warning: `{flag}` is ignored with --config (it picks the paper experiment's runs)");
        }
    }
}

fn main() -> ExitCode {
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let threads = cli.command.as_ref().and_then(Command::threads).or(cli.threads);
    if let Some(n) = threads {
        if n == 0 {
            return bad_input("`--threads`: must be >= 1");
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
            return bad_input(format!("`--threads`: {e}"));
        }
    }
    if let Some(command) = &cli.command {
        if let Err(e) = check_flags_before(&matches, command) {
            return bad_input(e);
        }
    }
    match &cli.command {
        Some(Command::Sweep { file, out, restart, xosc, controllers, quiet, .. }) => {
            let quiet = *quiet || cli.quiet;
            if let Some(o) = out.as_deref().filter(|o| o.extension().is_some_and(|e| e.eq_ignore_ascii_case("parquet"))) {
                return bad_input(format!(
                    "`--out` {}: `scenario sweep` writes CSV; Parquet (and Dask) is `python -m flc sweep FILE --out X.parquet` (docs/distributed.md)",
                    o.display()
                ));
            }
            if is_xosc(file) {
                let flags = ImportFlags { xosc, controllers: controllers.as_deref(), quiet };
                return sweep_xosc(&flags, file, out.as_deref(), *restart);
            }
            // The `.xosc` options do nothing for a sweep file: say so rather than ignore them.
            let sub = matches.subcommand_matches("sweep");
            for id in ["param", "ego", "ego_mode", "road", "traffic_dynamics", "controllers"] {
                if sub.and_then(|m| m.value_source(id)) == Some(clap::parser::ValueSource::CommandLine) {
                    return bad_input(format!(
                        "`--{}` applies to `.xosc` sweeps; {} is a sweep file (its axes set the scenario keys, a `controller` axis the controllers)",
                        id.replace('_', "-"),
                        file.display()
                    ));
                }
            }
            return sweep(file, out.as_deref(), quiet, *restart);
        }
        Some(Command::Convert { file, out, xosc, controllers, permutation, quiet }) => {
            let flags = ImportFlags { xosc, controllers: controllers.as_deref(), quiet: *quiet || cli.quiet };
            return convert(&flags, file, *permutation, out.as_deref());
        }
        Some(Command::Suite { name, out, root, controllers, quiet, ncap_workbook, .. }) => {
            return suite(controllers.as_deref(), name, out.as_deref(), root.as_deref(), *quiet || cli.quiet, ncap_workbook.as_deref());
        }
        None => {}
    }
    warn_ignored(&matches, &cli);
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
    let progress = list.len() > 1 && !cli.quiet;
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
        if let Err(e) = flc_sim::frequency_response::add_to_records(&scenarios, &mut records, !cli.quiet) {
            return bad_input(e);
        }
    }
    // The paper experiment's verdict, computed from the runs above (and the tracking runs).
    let summary = if cli.config.is_empty() {
        match paper_summary(&cli, &records) {
            Ok(s) => Some(s),
            Err(e) => return bad_input(e),
        }
    } else {
        None
    };
    if cli.json {
        /// The last line of the paper experiment's `--json`.
        #[derive(serde::Serialize)]
        struct SummaryLine<'a> {
            paper_summary: &'a PaperSummary,
        }
        let summary_line = summary.as_ref().map(|s| SummaryLine { paper_summary: s });
        for line in records.iter().map(serde_json::to_string).chain(summary_line.iter().map(serde_json::to_string)) {
            match line {
                Ok(line) => println!("{line}"),
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
    } else {
        print!("{}", report::table(&records));
        if let Some(s) = &summary {
            print!("\n{}", s.text());
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
