//! Whole runs from arbitrary scenario text (issue 29): `Scenario::from_toml_str`, the variants,
//! and `flc_sim::run` with the duration cut to 2 simulated seconds. Seeded with `scenarios/*.toml`
//! by `fuzz/run.sh`. A failure is a panic, a run past libFuzzer's `-timeout`, memory past its
//! `-rss_limit_mb`, an error message of more than one line, or a finished run with non-finite
//! metrics. The same checks as `crates/flc-sim/tests/mutation.rs`, on coverage-guided inputs.
#![no_main]

use flc_sim::Scenario;
use libfuzzer_sys::fuzz_target;

/// Simulated time of one run, s.
const MAX_DURATION: f64 = 2.0;
/// Runs per input (the variants beyond are not run).
const MAX_RUNS: usize = 4;

fn one_line(e: &dyn std::fmt::Display) {
    let msg = e.to_string();
    assert!(!msg.trim().is_empty() && !msg.contains('\n'), "error message not one line: {msg:?}");
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let scenario = match Scenario::from_toml_str(text, "fuzz") {
        Ok(s) => s,
        Err(e) => return one_line(&e),
    };
    let runs = match scenario.expand_variants() {
        Ok(r) => r,
        Err(e) => return one_line(&e),
    };
    for mut s in runs.into_iter().take(MAX_RUNS) {
        s.duration = s.duration.min(MAX_DURATION);
        match flc_sim::run(&s) {
            Ok(r) => {
                let m = format!("{:?}", r.metrics);
                assert!(
                    !(m.contains("NaN") || m.contains(": inf") || m.contains(": -inf") || m.contains("(inf)") || m.contains("(-inf)")),
                    "non-finite metrics: {m}"
                );
            }
            Err(e) => one_line(&e),
        }
    }
});
