//! Platoons: one lead and N followers, each follower with its own pipeline (`docs/platoon.md`).
//!
//! A scenario without a `[platoon]` table has one follower. With one, `followers = N` vehicles
//! drive behind the lead; follower `k` (1 = right behind the lead) follows vehicle `k - 1`
//! (0 = the lead): its LiDAR sees whatever is in front of it (the predecessor occludes the
//! vehicles further ahead because the rays hit its collider), its V2V link comes from the
//! predecessor, the lead or both (`v2v_source`), and it runs its own detector, pure pursuit,
//! longitudinal controller and low-level speed controller.
//!
//! Every follower starts from the scenario's single-follower sections (`controller`,
//! `[follower]`, `[lidar]`, `[v2v]`, `[detector]`, `[flc]`, `[pid]`, `[pure_pursuit]`,
//! `[supervisor]` and the baselines' / robust FLC's), which therefore apply to the whole string; `[[platoon.overrides]]` patches
//! them for chosen followers, key by key:
//!
//! ```toml
//! [platoon]
//! followers = 7
//! v2v_source = "predecessor"
//!
//! [[platoon.overrides]]
//! followers = [3]
//! v2v = { loss_prob = 0.5 }        # only the link into follower 3
//! follower = { initial_gap = 12.0 }
//! ```
//!
//! The resolved per-follower settings are [`crate::FollowerConfig`]s ([`crate::Scenario::follower_configs`]).

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};

/// Largest number of followers.
pub const MAX_FOLLOWERS: u32 = 64;

/// Longest sine run of the frequency response, s (the limit of a scenario's `duration`).
const MAX_SINE_RUN: f64 = 36_000.0;

/// Most `[[platoon.overrides]]`.
pub const MAX_OVERRIDES: usize = 1000;

/// Where a follower's V2V messages come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum V2vSource {
    /// The vehicle in front broadcasts its own speed (predecessor following; the default).
    #[default]
    Predecessor,
    /// The lead broadcasts its speed to every follower (leader following).
    Lead,
    /// Both links: the PID gets `(1 - lead_weight) v_pred + lead_weight v_lead` whenever the
    /// predecessor's message arrives (the lead's last speed while it is fresh, else `v_pred`
    /// alone). Follower 1 has a single link (its predecessor is the lead).
    Both,
}

impl V2vSource {
    /// The name used in scenario files.
    pub fn as_str(self) -> &'static str {
        match self {
            V2vSource::Predecessor => "predecessor",
            V2vSource::Lead => "lead",
            V2vSource::Both => "both",
        }
    }
}

/// Settings of the string-stability measures (`crate::string_stability`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StringStabilitySpec {
    /// A ratio counts as string stable up to `1 + tolerance`.
    pub tolerance: f64,
    /// Start of the time-domain window, s. `None`: the lead's brake onset if it brakes, else 0.
    pub window_start: Option<f64>,
    /// Errors whose peak stays below these floors are noise, not amplification: a pair whose
    /// follower peak is below the floor counts as stable whatever the ratio (m and m/s).
    pub gap_floor: f64,
    /// See `gap_floor`, for the speed error, m/s.
    pub speed_floor: f64,
    /// Frequencies of the |Gamma(jw)| runs, Hz (empty: not measured).
    pub frequencies_hz: Vec<f64>,
    /// Amplitude of the lead's sinusoidal speed in the |Gamma(jw)| runs, m/s.
    pub sine_amplitude: f64,
    /// Time the string drives at constant speed before the sine starts, s.
    pub settle_time: f64,
    /// Sine periods before the fit window (transient), at least `min_warmup_time`.
    pub warmup_periods: u32,
    /// Sine periods the amplitude is fitted over, at least `min_fit_time`.
    pub fit_periods: u32,
    /// Shortest transient before the fit window, s (rounded up to whole periods).
    pub min_warmup_time: f64,
    /// Shortest fit window, s (rounded up to whole periods): averages out the noise at high
    /// frequencies.
    pub min_fit_time: f64,
    /// A follower whose fitted amplitude stays below this (m/s) does not count in the
    /// frequency-domain verdict: its ratio is one of noise, not of the drive.
    pub gamma_floor: f64,
}

impl Default for StringStabilitySpec {
    fn default() -> Self {
        Self {
            tolerance: 0.02,
            window_start: None,
            gap_floor: 0.1,
            speed_floor: 0.1,
            frequencies_hz: Vec::new(),
            sine_amplitude: 1.0,
            settle_time: 10.0,
            warmup_periods: 2,
            fit_periods: 3,
            min_warmup_time: 20.0,
            min_fit_time: 30.0,
            gamma_floor: 0.05,
        }
    }
}

impl StringStabilitySpec {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("tolerance", self.tolerance, 0.0, 1.0, "")?;
        if let Some(t) = self.window_start {
            check_range("window_start", t, 0.0, 1.0e5, "s")?;
        }
        check_range("gap_floor", self.gap_floor, 0.0, 100.0, "m")?;
        check_range("speed_floor", self.speed_floor, 0.0, 100.0, "m/s")?;
        if self.frequencies_hz.len() > 64 {
            return Err(ConfigError::new("frequencies_hz", "at most 64 frequencies"));
        }
        for (i, f) in self.frequencies_hz.iter().enumerate() {
            check_range(&format!("frequencies_hz[{i}]"), *f, 0.001, 5.0, "Hz")?;
        }
        check_range("sine_amplitude", self.sine_amplitude, 0.01, 20.0, "m/s")?;
        check_range("settle_time", self.settle_time, 0.0, 1000.0, "s")?;
        check_range("warmup_periods", f64::from(self.warmup_periods), 0.0, 100.0, "periods")?;
        check_range("fit_periods", f64::from(self.fit_periods), 1.0, 100.0, "periods")?;
        check_range("min_warmup_time", self.min_warmup_time, 0.0, 1000.0, "s")?;
        check_range("min_fit_time", self.min_fit_time, 0.0, 1000.0, "s")?;
        check_range("gamma_floor", self.gamma_floor, 0.0, 20.0, "m/s")?;
        // A run's `duration` is at most 36000 s: so is each sine run's (no step count explodes
        // at a low frequency with many periods).
        for (i, f) in self.frequencies_hz.iter().enumerate() {
            let (warmup, fit) = self.sine_periods(*f);
            let t = self.settle_time + f64::from(warmup + fit) / f;
            if t > MAX_SINE_RUN {
                return Err(ConfigError::new(
                    format!("frequencies_hz[{i}]"),
                    format!("gives a sine run of {t} s (settle_time + warmup and fit periods), more than {MAX_SINE_RUN} s"),
                ));
            }
        }
        Ok(())
    }

    /// `(warmup, fit)` periods of the sine run at `freq_hz`.
    pub fn sine_periods(&self, freq_hz: f64) -> (u32, u32) {
        let at_least = |n: u32, t: f64| n.max((t * freq_hz - 1e-9).ceil().max(0.0) as u32);
        (at_least(self.warmup_periods, self.min_warmup_time), at_least(self.fit_periods, self.min_fit_time))
    }
}

/// Settings patched into chosen followers (`[[platoon.overrides]]`): `followers` lists them
/// (1-based), every other key is a section of [`crate::FollowerConfig`] (`controller`, `follower`,
/// `lidar`, `v2v`, `detector`, `pure_pursuit` and the controllers' sections) whose given keys
/// replace the string's values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FollowerOverride {
    /// The followers patched, 1 = right behind the lead.
    pub followers: Vec<u32>,
    /// The patch, shaped like the scenario's sections.
    #[serde(flatten)]
    pub patch: toml::Table,
}

/// The `[platoon]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlatoonSpec {
    /// Number of followers N, [1, 64].
    pub followers: u32,
    /// Source of each follower's V2V messages.
    pub v2v_source: V2vSource,
    /// Weight of the lead's speed with `v2v_source = "both"`, [0, 1].
    pub lead_weight: f64,
    /// With `lead` / `both`: the lead's speed travels hop by hop (follower `k - 1` forwards each
    /// new lead message to follower `k` on its next broadcast slot), so a broken link cuts off
    /// every follower behind it. `false`: the lead reaches every follower directly.
    pub relay: bool,
    /// Start each follower at its controller's desired gap at its initial speed
    /// (its law's `formation_gap`) instead of `initial_gap`.
    pub equilibrium_start: bool,
    /// Per-follower patches, applied in order.
    pub overrides: Vec<FollowerOverride>,
    /// String-stability measures.
    pub string_stability: StringStabilitySpec,
}

impl Default for PlatoonSpec {
    fn default() -> Self {
        Self {
            followers: 1,
            v2v_source: V2vSource::Predecessor,
            lead_weight: 0.5,
            relay: false,
            equilibrium_start: false,
            overrides: Vec::new(),
            string_stability: StringStabilitySpec::default(),
        }
    }
}

impl PlatoonSpec {
    /// Checks the table's own values (the followers' settings: [`crate::Scenario::follower_configs`]).
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_range("followers", f64::from(self.followers), 1.0, f64::from(MAX_FOLLOWERS), "")?;
        check_range("lead_weight", self.lead_weight, 0.0, 1.0, "")?;
        if self.overrides.len() > MAX_OVERRIDES {
            return Err(ConfigError::new("overrides", format!("at most {MAX_OVERRIDES} overrides, got {}", self.overrides.len())));
        }
        for (i, o) in self.overrides.iter().enumerate() {
            let key = format!("overrides[{i}].followers");
            if o.followers.is_empty() {
                return Err(ConfigError::new(key, "list at least one follower (1-based)"));
            }
            if o.followers.len() > MAX_FOLLOWERS as usize {
                return Err(ConfigError::new(key, format!("at most {MAX_FOLLOWERS} followers, got {}", o.followers.len())));
            }
            for (j, &k) in o.followers.iter().enumerate() {
                if k < 1 || k > self.followers {
                    return Err(ConfigError::new(
                        format!("{key}[{j}]"),
                        format!("must be in [1, {}] (platoon.followers), got {k}", self.followers),
                    ));
                }
            }
        }
        self.string_stability.validate().map_err(|e| e.within("string_stability"))
    }
}
