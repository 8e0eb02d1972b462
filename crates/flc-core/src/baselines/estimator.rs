//! Range and range-rate estimation from the LiDAR distance alone: an alpha-beta filter.
//!
//! The baselines that need the lead's speed get it as `own speed + range rate`, with the range
//! rate estimated from successive distances. The filter is the classic alpha-beta (g-h) tracker
//! (Kalata, *IEEE Trans. AES* 20(2), 1984; Brookner, *Tracking and Kalman Filtering Made Easy*,
//! 1998, ch. 1) with the actual frame interval `dt` of every step:
//!
//! ```text
//! predict   d_p = d + dt * r            r_p = r
//! residual  e   = z - d_p
//! update    d   = d_p + alpha * e       r   = r_p + (beta / dt) * e
//! ```
//!
//! Initialisation: the first measurement after a reset gives `d = z`, `r = 0` (nothing is known
//! about the lead's speed; the baselines then assume it equals the own speed); the second gives
//! the two-point difference `r = (z2 - z1) / dt`, `d = z2`; the filter runs from the third on. For
//! a lead closing at a constant rate the estimate is therefore exact from the second frame on
//! (the residual of a noise-free straight line is zero).
//!
//! Defaults `alpha = 0.6`, `beta = 0.25`: close to critical damping (`beta = alpha^2 / (2 - alpha)
//! = 0.257`). At the simulator's 20 Hz and 2 cm range noise this gives a range-rate noise of
//! about `0.29 * 0.02 / 0.05 = 0.11 m/s` (variance ratio `2 beta^2 / (alpha (4 - 2 alpha - beta))`)
//! and a steady lag of `a dt (alpha - beta/2) / beta = 0.76 m/s` behind a lead braking 8 m/s²
//! harder than the follower. Stability needs `0 < alpha <= 1`, `0 < beta < 2` (and
//! `4 - 2 alpha - beta > 0`, implied). The estimate is clamped to `+-max_range_rate`.

use crate::command::clamp;
use crate::params::{ParamError, check_positive};

/// Parameters of the alpha-beta range-rate filter.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorParams {
    /// Position gain `alpha`, in `(0, 1]`. Default 0.6.
    pub alpha: f64,
    /// Rate gain `beta`, in `(0, 2)`. Default 0.25 (near critical damping for `alpha = 0.6`).
    pub beta: f64,
    /// Limit of the range-rate estimate, m/s. Default 100.
    pub max_range_rate: f64,
}

impl Default for EstimatorParams {
    fn default() -> Self {
        Self { alpha: 0.6, beta: 0.25, max_range_rate: 100.0 }
    }
}

impl EstimatorParams {
    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.validate_named(["alpha", "beta", "max_range_rate"])
    }

    /// As [`EstimatorParams::validate`], with the field names given (e.g. `"estimator.alpha"` when
    /// nested in a controller's parameters).
    pub(crate) fn validate_named(&self, names: [&'static str; 3]) -> Result<(), ParamError> {
        let [alpha, beta, max_rate] = names;
        check_positive(alpha, self.alpha, 1.0, "must be finite and in (0, 1]")?;
        if !(self.beta.is_finite() && self.beta > 0.0 && self.beta < 2.0) {
            return Err(ParamError { field: beta, problem: "must be finite and in (0, 2)" });
        }
        check_positive(max_rate, self.max_range_rate, 1000.0, "must be finite and in (0, 1000] m/s")
    }
}

/// The filter's output for one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RangeEstimate {
    /// Filtered distance, m.
    pub distance: f64,
    /// Range rate `d(distance)/dt`, m/s (negative while closing). 0 on the first frame.
    pub range_rate: f64,
    /// Measurements since the last reset, including this one (saturates).
    pub samples: u32,
}

/// Alpha-beta filter on the LiDAR distance. Feed one valid distance per frame with
/// [`RangeRateEstimator::update`]; call [`RangeRateEstimator::reset`] whenever the lead is lost.
#[derive(Debug, Clone)]
pub struct RangeRateEstimator {
    params: EstimatorParams,
    state: Option<RangeEstimate>,
}

impl RangeRateEstimator {
    /// Validates `params` and builds the filter.
    pub fn new(params: EstimatorParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params, state: None })
    }

    /// Builds the filter from parameters already validated by the caller.
    pub(crate) const fn new_unchecked(params: EstimatorParams) -> Self {
        Self { params, state: None }
    }

    /// The parameters in use.
    pub fn params(&self) -> &EstimatorParams {
        &self.params
    }

    /// Forgets the track; the next measurement starts a new one.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// The last estimate, `None` after a reset.
    pub fn estimate(&self) -> Option<RangeEstimate> {
        self.state
    }

    /// One measurement `z` (m) taken `dt` (s) after the previous one. Non-finite `z` or `dt`, or
    /// `dt <= 0`, reset the filter and return a zero-rate estimate at `z` (or 0).
    pub fn update(&mut self, z: f64, dt: f64) -> RangeEstimate {
        if !(z.is_finite() && dt.is_finite() && dt > 0.0) {
            self.state = None;
            return RangeEstimate { distance: if z.is_finite() { z } else { 0.0 }, range_rate: 0.0, samples: 0 };
        }
        let p = &self.params;
        let lim = p.max_range_rate;
        let next = match self.state {
            None => RangeEstimate { distance: z, range_rate: 0.0, samples: 1 },
            Some(s) if s.samples <= 1 => RangeEstimate { distance: z, range_rate: clamp((z - s.distance) / dt, -lim, lim), samples: 2 },
            Some(s) => {
                let predicted = s.distance + dt * s.range_rate;
                let residual = z - predicted;
                RangeEstimate {
                    distance: predicted + p.alpha * residual,
                    range_rate: clamp(s.range_rate + p.beta / dt * residual, -lim, lim),
                    samples: s.samples.saturating_add(1),
                }
            }
        };
        // Every term is finite for finite inputs except in overflow corner cases (dt ~ 1e-300):
        // restart the track rather than carry a non-finite state.
        if !(next.distance.is_finite() && next.range_rate.is_finite()) {
            self.state = None;
            return RangeEstimate { distance: z, range_rate: 0.0, samples: 0 };
        }
        self.state = Some(next);
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn est() -> RangeRateEstimator {
        RangeRateEstimator::new(EstimatorParams::default()).unwrap()
    }

    #[test]
    fn first_and_second_frame_by_hand() {
        let mut e = est();
        // First frame: nothing known about the rate.
        let a = e.update(40.0, 0.05);
        assert_eq!((a.distance, a.range_rate, a.samples), (40.0, 0.0, 1));
        // Second frame: two-point difference (39.8 - 40) / 0.05 = -4 m/s.
        let b = e.update(39.8, 0.05);
        assert!((b.range_rate + 4.0).abs() < 1e-9);
        assert_eq!((b.distance, b.samples), (39.8, 2));
    }

    #[test]
    fn one_filter_step_by_hand() {
        let mut e = est();
        e.update(40.0, 0.1);
        e.update(39.0, 0.1); // r = -10 m/s
        // Predict 39 + 0.1 * (-10) = 38; measure 38.5 -> residual 0.5.
        // d = 38 + 0.6 * 0.5 = 38.3; r = -10 + (0.25 / 0.1) * 0.5 = -8.75.
        let c = e.update(38.5, 0.1);
        assert!((c.distance - 38.3).abs() < 1e-9);
        assert!((c.range_rate + 8.75).abs() < 1e-9);
        assert_eq!(c.samples, 3);
    }

    #[test]
    fn constant_closing_rate_is_tracked_exactly() {
        // Lead closing at 3 m/s, frames every 50 ms with a jittered interval.
        let mut e = est();
        let (mut t, mut last) = (0.0, RangeEstimate::default());
        for k in 0..200 {
            let dt = if k % 3 == 0 { 0.06 } else { 0.045 };
            t += dt;
            last = e.update(80.0 - 3.0 * t, dt);
            if k >= 1 {
                assert!((last.range_rate + 3.0).abs() < 1e-6, "frame {k}: {}", last.range_rate);
            }
        }
        assert!((last.distance - (80.0 - 3.0 * t)).abs() < 1e-6);
    }

    #[test]
    fn converges_after_a_rate_step() {
        // Start with the wrong rate (first two frames say -10 m/s), then a constant 2 m/s opening.
        let mut e = est();
        e.update(50.0, 0.05);
        e.update(49.5, 0.05);
        let mut d = 49.5;
        let mut r = 0.0;
        for _ in 0..100 {
            d += 2.0 * 0.05;
            r = e.update(d, 0.05).range_rate;
        }
        assert!((r - 2.0).abs() < 1e-3, "{r}");
    }

    #[test]
    fn noisy_constant_rate_converges() {
        // Deterministic pseudo-noise of +-2 cm on a 5 m/s closing track at 20 Hz.
        let mut e = est();
        let mut sum = 0.0;
        let n = 400;
        for k in 0..n {
            let noise = 0.02 * (((k * 7919) % 13) as f64 / 6.0 - 1.0);
            let r = e.update(100.0 - 5.0 * 0.05 * k as f64 + noise, 0.05).range_rate;
            if k >= 100 {
                sum += r;
            }
        }
        let mean = sum / (n - 100) as f64;
        assert!((mean + 5.0).abs() < 0.05, "{mean}");
    }

    #[test]
    fn reset_and_bad_input_restart_the_track() {
        let mut e = est();
        e.update(40.0, 0.05);
        e.update(39.0, 0.05);
        e.reset();
        assert_eq!(e.estimate(), None);
        assert_eq!(e.update(30.0, 0.05).range_rate, 0.0);
        assert_eq!(e.update(f64::NAN, 0.05).samples, 0);
        assert_eq!(e.estimate(), None);
        assert_eq!(e.update(30.0, 0.0).samples, 0);
        // Rate limited.
        e.update(0.0, 0.05);
        assert_eq!(e.update(400.0, 0.05).range_rate, 100.0);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: EstimatorParams| RangeRateEstimator::new(p).unwrap_err().field;
        assert_eq!(bad(EstimatorParams { alpha: 0.0, ..Default::default() }), "alpha");
        assert_eq!(bad(EstimatorParams { alpha: 1.5, ..Default::default() }), "alpha");
        assert_eq!(bad(EstimatorParams { beta: 2.0, ..Default::default() }), "beta");
        assert_eq!(bad(EstimatorParams { beta: f64::NAN, ..Default::default() }), "beta");
        assert_eq!(bad(EstimatorParams { max_range_rate: 0.0, ..Default::default() }), "max_range_rate");
    }

    proptest! {
        #[test]
        fn state_stays_finite_and_bounded(seq in proptest::collection::vec((proptest::num::f64::ANY, proptest::num::f64::ANY), 1..60)) {
            let mut e = est();
            for (z, dt) in seq {
                let out = e.update(z, dt);
                prop_assert!(out.distance.is_finite() && out.range_rate.is_finite());
                prop_assert!(out.range_rate.abs() <= 100.0);
            }
        }
    }
}
