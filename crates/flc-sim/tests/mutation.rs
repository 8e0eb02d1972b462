//! Whole runs fuzzed (issue 29): every shipped `scenarios/*.toml`, its numbers replaced by
//! extreme values and its keys renamed or deleted (a fixed-seed RNG), each mutant run for a few
//! simulated seconds through the library (`Scenario::from_toml_str`, the variants, `run`).
//!
//! A failure is a panic, a mutant past its wall-time limit, an error that is not one line
//! naming a key, or a finished run with non-finite metrics. The number of mutants is bounded
//! (`FLC_MUTANTS` per file, default 300); the outcomes are printed by category. The first
//! `FLC_CLI_MUTANTS` mutants of each file (default 20) also go through the `scenario` binary: its
//! exit status must be 0, 1 or 2, within the wall-time limit, and an exit 2 must print one
//! `error:` line naming a key; the exit statuses are counted.
//!
//! Release only (tests/run_all.sh runs it with --release): the runs are slow in debug.

use std::collections::BTreeMap;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use flc_sim::Scenario;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::Value;

/// Seed of the mutations.
const SEED: u64 = 29;
/// Simulated time of a mutant, s (a longer `duration` is cut to it).
const MAX_DURATION: f64 = 3.0;
/// Wall time of one mutant (parse, validate, every variant's run): at least this, and at least
/// four times what the file itself takes (some shipped files do more than one run per variant:
/// `platoon-brakedemo.toml`'s string-stability sine runs take about 8 s of CPU on their own).
const WALL_LIMIT: Duration = Duration::from_secs(10);

/// One step of a path into a TOML document.
#[derive(Debug, Clone)]
enum Step {
    Key(String),
    Index(usize),
}

fn path_text(path: &[Step]) -> String {
    let mut s = String::new();
    for p in path {
        match p {
            Step::Key(k) if s.is_empty() => s.push_str(k),
            Step::Key(k) => {
                s.push('.');
                s.push_str(k);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// Paths of every number and of every key (table entries).
fn collect(v: &Value, path: &mut Vec<Step>, numbers: &mut Vec<Vec<Step>>, keys: &mut Vec<Vec<Step>>) {
    match v {
        Value::Integer(_) | Value::Float(_) => numbers.push(path.clone()),
        Value::Table(t) => {
            for (k, x) in t {
                path.push(Step::Key(k.clone()));
                keys.push(path.clone());
                collect(x, path, numbers, keys);
                path.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(Step::Index(i));
                collect(x, path, numbers, keys);
                path.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    let mut cur = v;
    for p in path {
        cur = match (p, cur) {
            (Step::Key(k), Value::Table(t)) => t.get_mut(k)?,
            (Step::Index(i), Value::Array(a)) => a.get_mut(*i)?,
            _ => return None,
        };
    }
    Some(cur)
}

/// The replacements of a number.
fn replacement(rng: &mut ChaCha8Rng, old: &Value) -> Value {
    match rng.random_range(0..11) {
        0 => Value::Integer(0),
        1 => Value::Float(0.0),
        2 => match old {
            Value::Integer(i) => Value::Integer(-(i.saturating_abs().max(1))),
            Value::Float(f) => Value::Float(-(f.abs().max(1.0))),
            _ => Value::Integer(-1),
        },
        3 => Value::Float(1e-6),
        4 => Value::Float(1e12),
        5 => Value::Float(f64::NAN),
        6 => Value::Float(f64::INFINITY),
        7 => Value::Float(f64::NEG_INFINITY),
        8 => Value::Integer(i64::MAX),
        9 => Value::Integer(i64::MIN),
        _ => Value::Integer(7_000_000),
    }
}

#[derive(Debug)]
enum Outcome {
    /// Rejected with one line naming a key (`true`: the mutated key itself), the message.
    Rejected(bool, String),
    /// Every run finished with finite metrics.
    Ran(usize),
    /// A failure, described.
    Failed(String),
}

/// Debug text of a value holds a non-finite float.
fn non_finite(debug: &str) -> bool {
    // `min_gap: NaN` is the documented "no vehicle was ever in path" (JSON `null`; a mutated
    // track can put every vehicle off the ego's path); any other NaN or infinity is a failure.
    let debug = debug.replace("min_gap: NaN", "min_gap: none");
    debug.contains("NaN") || debug.contains(": inf") || debug.contains(": -inf") || debug.contains("(inf)") || debug.contains("(-inf)")
}

fn run_mutant(text: String, origin: String, key: String, leaf: String) -> Outcome {
    let scenario = match Scenario::from_toml_str(&text, &origin) {
        Ok(s) => s,
        Err(e) => return judge_error(&e.to_string(), &key, &leaf),
    };
    let runs = match scenario.expand_variants() {
        Ok(r) => r,
        Err(e) => return judge_error(&e.to_string(), &key, &leaf),
    };
    let mut n = 0;
    for mut s in runs {
        s.duration = s.duration.min(MAX_DURATION);
        match flc_sim::run(&s) {
            Ok(r) => {
                let m = format!("{:?}", r.metrics);
                if non_finite(&m) {
                    return Outcome::Failed(format!("non-finite metrics: {m}"));
                }
                n += 1;
            }
            Err(e) => return judge_error(&e.to_string(), &key, &leaf),
        }
    }
    Outcome::Ran(n)
}

/// The `scenario` binary on a mutant file: `Ok(exit status)` or a failure, described.
fn run_cli(text: &str, dir: &std::path::Path, n: usize, limit: Duration) -> Result<i32, String> {
    let file = dir.join(format!("mutant-{n}.toml"));
    std::fs::write(&file, text).map_err(|e| e.to_string())?;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_scenario"))
        .arg("--config")
        .arg(&file)
        .arg("--threads")
        .arg("1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let start = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().map_err(|e| e.to_string())? {
            break st;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("CLI past the wall-time limit of {limit:?}"));
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let mut stderr = String::new();
    if let Some(mut e) = child.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut stderr);
    }
    let code = status.code().ok_or_else(|| format!("CLI killed by a signal: {status}"))?;
    match code {
        0 | 1 => Ok(code),
        2 => {
            let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
            match lines.as_slice() {
                [l] if l.starts_with("error:") && l.contains('`') => Ok(2),
                _ => Err(format!("CLI exit 2 without one `error:` line naming a key: {stderr:?}")),
            }
        }
        c => Err(format!("CLI exit status {c}: {stderr:?}")),
    }
}

fn judge_error(msg: &str, key: &str, leaf: &str) -> Outcome {
    if msg.lines().count() != 1 {
        return Outcome::Failed(format!("error of {} lines: {msg}", msg.lines().count()));
    }
    if !msg.contains('`') {
        return Outcome::Failed(format!("error naming no key: {msg}"));
    }
    // A renamed key (`kind_x`) is named either way: as unknown, or as the missing original.
    let original = leaf.strip_suffix("_x").map(|k| format!("missing field `{k}`"));
    let named = msg.contains(key)
        || msg.contains(&format!("`{leaf}`"))
        || msg.contains(&format!(".{leaf}`"))
        || original.is_some_and(|o| msg.contains(&o));
    Outcome::Rejected(named, msg.to_string())
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn mutated_scenarios_fail_cleanly_or_run() {
    let per_file: usize = std::env::var("FLC_MUTANTS").ok().and_then(|v| v.parse().ok()).unwrap_or(300);
    let cli_per_file: usize = std::env::var("FLC_CLI_MUTANTS").ok().and_then(|v| v.parse().ok()).unwrap_or(20);
    let tmp = std::env::temp_dir().join(format!("flc-mutation-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let mut cli_n = 0;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("scenarios/")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut others = Vec::new();
    let t0 = Instant::now();
    for f in &files {
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let text = std::fs::read_to_string(f).expect("read");
        let doc: Value = toml::from_str(&text).expect("shipped file parses");
        let (mut numbers, mut keys) = (Vec::new(), Vec::new());
        collect(&doc, &mut Vec::new(), &mut numbers, &mut keys);
        // The file's own cost, with the mutants' duration cap: the limit scales with it (and with
        // the machine's load), so that a hang is caught but a file's legitimate work is not.
        let mut capped = doc.clone();
        if let Value::Table(t) = &mut capped {
            let d = t.get("duration").and_then(Value::as_float).unwrap_or(MAX_DURATION).min(MAX_DURATION);
            t.insert("duration".into(), Value::Float(d));
        }
        let start = Instant::now();
        let own = run_cli(&toml::to_string(&capped).expect("serialisable"), &tmp, 0, Duration::from_secs(600));
        assert!(matches!(own, Ok(0 | 1)), "{name} as shipped: {own:?}");
        let limit = WALL_LIMIT.max(start.elapsed() * 4);
        for m in 0..per_file {
            let mut mutant = doc.clone();
            // Two thirds numbers, one third keys (renamed or deleted).
            let (path, what) = if m % 3 != 2 && !numbers.is_empty() {
                let path = numbers[rng.random_range(0..numbers.len())].clone();
                let slot = get_mut(&mut mutant, &path).expect("number path");
                let new = replacement(&mut rng, slot);
                let what = format!("= {new}");
                *slot = new;
                (path, what)
            } else {
                let path = keys[rng.random_range(0..keys.len())].clone();
                let (parent, last) = path.split_at(path.len() - 1);
                let Some(Value::Table(t)) = get_mut(&mut mutant, parent) else { panic!("key path") };
                let Step::Key(k) = &last[0] else { panic!("key step") };
                let old = t.remove(k).expect("key");
                if rng.random_bool(0.5) {
                    t.insert(format!("{k}_x"), old);
                    (path, "renamed".to_string())
                } else {
                    (path, "deleted".to_string())
                }
            };
            let key = path_text(&path);
            let leaf = match path.iter().rev().find_map(|s| if let Step::Key(k) = s { Some(k.clone()) } else { None }) {
                Some(k) if what == "renamed" => format!("{k}_x"),
                Some(k) => k,
                None => key.clone(),
            };
            if key != "duration" {
                if let Some(Value::Table(t)) = Some(&mut mutant) {
                    let d = t.get("duration").and_then(Value::as_float).unwrap_or(MAX_DURATION).min(MAX_DURATION);
                    t.insert("duration".into(), Value::Float(d));
                }
            }
            let label = format!("{name}: {key} {what}");
            let Ok(mutant_text) = toml::to_string(&mutant) else {
                *counts.entry("not serialisable (skipped)").or_default() += 1;
                continue;
            };
            if m < cli_per_file {
                cli_n += 1;
                match run_cli(&mutant_text, &tmp, cli_n, limit) {
                    Ok(0) => *counts.entry("CLI exit 0").or_default() += 1,
                    Ok(1) => *counts.entry("CLI exit 1").or_default() += 1,
                    Ok(_) => *counts.entry("CLI exit 2, one error line naming a key").or_default() += 1,
                    Err(why) => {
                        *counts.entry("FAILED").or_default() += 1;
                        failures.push(format!("{label}: {why}"));
                    }
                }
            }
            let (tx, rx) = mpsc::channel();
            let (origin, k2, l2) = (name.clone(), key.clone(), leaf.clone());
            let start = Instant::now();
            std::thread::spawn(move || {
                let r = std::panic::catch_unwind(|| run_mutant(mutant_text, origin, k2, l2));
                let _ = tx.send(r);
            });
            let outcome = match rx.recv_timeout(limit) {
                Ok(Ok(o)) => o,
                Ok(Err(p)) => {
                    let msg = p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()));
                    Outcome::Failed(format!("panic: {}", msg.unwrap_or_default()))
                }
                Err(_) => Outcome::Failed(format!("past the wall-time limit of {limit:?}")),
            };
            let took = start.elapsed();
            match outcome {
                Outcome::Rejected(true, _) => *counts.entry("rejected, naming the mutated key").or_default() += 1,
                Outcome::Rejected(false, msg) => {
                    *counts.entry("rejected, naming another key").or_default() += 1;
                    if others.len() < 20 {
                        others.push(format!("{label}: {msg}"));
                    }
                }
                Outcome::Ran(n) => {
                    *counts.entry("ran, finite metrics").or_default() += 1;
                    *counts.entry("(runs, variants counted)").or_default() += n;
                }
                Outcome::Failed(why) => {
                    *counts.entry("FAILED").or_default() += 1;
                    failures.push(format!("{label} ({took:?}): {why}"));
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let total: usize = counts.iter().filter(|(k, _)| !k.starts_with('(') && !k.starts_with("CLI")).map(|(_, n)| n).sum();
    println!("{total} mutants of {} files in {:?} (seed {SEED}):", files.len(), t0.elapsed());
    for (k, n) in &counts {
        println!("  {k}: {n}");
    }
    println!("some rejections naming another key than the mutated one (a dependent check):");
    for o in &others {
        println!("  {o}");
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}
