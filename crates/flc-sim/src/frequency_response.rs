//! The string-stability frequency response `|Gamma(jw)|` (an experiment on top of the runner):
//! one sine run of the lead per frequency, each follower's speed amplitude fitted over whole
//! periods ([`crate::string_stability`] has the measures, `docs/platoon.md` the method).

use crate::error::{ConfigError, SimError};
use crate::lead::Phase;
use crate::report::RunRecord;
use crate::runner::RunOptions;
use crate::scenario::Scenario;
use crate::sim::RunResult;
use crate::string_stability::{GammaPoint, gamma_from_speeds};
use crate::v2v::Outage;

/// The scenario of the `|Gamma|` run at `freq_hz`: `base` with the string starting in
/// equilibrium at the lead's initial speed, which holds it for `settle_time`, then drives
/// `warmup_periods + fit_periods` periods of `v + sine_amplitude sin(w t)`. A link with
/// `outage_on_brake` (of `[v2v]`) is down from the start (the regime after the outage).
pub fn sine_scenario(base: &Scenario, freq_hz: f64) -> Result<Scenario, ConfigError> {
    let p = base.platoon.clone().unwrap_or_default();
    let ss = &p.string_stability;
    let v = base.lead.initial_speed;
    if v <= ss.sine_amplitude {
        return Err(ConfigError::new(
            "platoon.string_stability.sine_amplitude",
            format!("the frequency response needs lead.initial_speed ({v} m/s) > sine_amplitude ({} m/s)", ss.sine_amplitude),
        ));
    }
    let mut s = Scenario { variants: Vec::new(), ..base.clone() };
    let (warmup, fit) = ss.sine_periods(freq_hz);
    let sine = f64::from(warmup + fit) / freq_hz;
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: None, duration: Some(ss.settle_time) }.into(),
        Phase::Sine { amplitude: ss.sine_amplitude, freq_hz, duration: sine }.into(),
    ];
    s.duration = ss.settle_time + sine + 2.0 * s.physics_dt;
    s.follower.initial_speed = v;
    if s.v2v.outage_on_brake {
        s.v2v.outages.push(Outage { start: 0.0, end: f64::INFINITY });
    }
    s.platoon = Some(crate::platoon::PlatoonSpec { equilibrium_start: true, ..p });
    s.name = format!("{}-sine-{freq_hz}hz", base.name);
    Ok(s)
}

/// `|Gamma|` from one run of [`sine_scenario`]: the fit covers its last fit periods
/// ([`crate::StringStabilitySpec::sine_periods`]).
pub fn gamma_from_run(scenario: &Scenario, run: &RunResult, freq_hz: f64) -> GammaPoint {
    let spec = scenario.platoon.as_ref().map(|p| p.string_stability.clone()).unwrap_or_default();
    let fit = f64::from(spec.sine_periods(freq_hz).1) / freq_hz;
    let first = &run.series;
    let t1 = first.t.last().copied().unwrap_or(0.0);
    let mut speeds: Vec<&[f64]> = vec![&first.lead_speed];
    let mut collision = run.metrics.collision;
    match &run.platoon {
        Some(p) => {
            for f in &p.followers {
                speeds.push(&f.series.follower_speed);
                collision |= f.collision.is_some();
            }
        }
        None => speeds.push(&first.follower_speed),
    }
    let mut g = gamma_from_speeds(&first.t, &speeds, freq_hz, t1 - fit, t1, spec.gamma_floor);
    g.collision = collision;
    g
}

/// `|Gamma(jw)|` of `base` at each of its `platoon.string_stability.frequencies_hz`: one run of
/// [`sine_scenario`] per frequency (in parallel).
pub fn frequency_response(base: &Scenario) -> Result<Vec<GammaPoint>, SimError> {
    let freqs = base.platoon.as_ref().map(|p| p.string_stability.frequencies_hz.clone()).unwrap_or_default();
    frequency_response_at(base, &freqs)
}

/// [`frequency_response`] at the given frequencies, Hz.
pub fn frequency_response_at(base: &Scenario, freqs_hz: &[f64]) -> Result<Vec<GammaPoint>, SimError> {
    let mut sines = Vec::with_capacity(freqs_hz.len());
    for &f in freqs_hz {
        crate::error::check_range("frequencies_hz", f, 0.001, 5.0, "Hz")?;
        sines.push(sine_scenario(base, f)?);
    }
    let runs = RunOptions::default().run_batch(&sines);
    sines.iter().zip(freqs_hz).zip(runs).map(|((s, &f), r)| Ok(gamma_from_run(s, &r?, f))).collect()
}

/// Runs the `|Gamma(jw)|` sine runs of every platoon scenario in `scenarios` with
/// `string_stability.frequencies_hz` (all in parallel) and adds them to `records` (one per
/// scenario, same order).
pub fn add_to_records(scenarios: &[Scenario], records: &mut [RunRecord], progress: bool) -> Result<(), SimError> {
    let mut jobs = Vec::new();
    for (i, s) in scenarios.iter().enumerate() {
        let freqs = s.platoon.as_ref().map(|p| p.string_stability.frequencies_hz.clone()).unwrap_or_default();
        for f in freqs {
            jobs.push((i, f, sine_scenario(s, f).map_err(|e| SimError::File { path: s.name.clone(), message: e.to_string() })?));
        }
    }
    if jobs.is_empty() {
        return Ok(());
    }
    let sines: Vec<Scenario> = jobs.iter().map(|(_, _, s)| s.clone()).collect();
    let results = RunOptions { progress, ..RunOptions::default() }.run_batch(&sines);
    let mut points: Vec<Vec<GammaPoint>> = vec![Vec::new(); scenarios.len()];
    for ((i, f, s), r) in jobs.iter().zip(results) {
        points[*i].push(gamma_from_run(s, &r?, *f));
    }
    for (rec, pts) in records.iter_mut().zip(points) {
        if let Some(p) = rec.platoon.as_mut() {
            p.string_stability.set_frequency_response(pts);
        }
    }
    Ok(())
}
