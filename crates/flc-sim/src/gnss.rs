//! GNSS position error of a vehicle: a 2-D first-order Gauss–Markov process (issue 25).
//!
//! Each axis' error `e` is stationary Gaussian with standard deviation `sigma_m` and correlation
//! time `tau_s`: sampled at times `t_k`, `e_{k+1} = phi e_k + sigma sqrt(1 - phi²) w_k`, `phi =
//! exp(-(t_{k+1} - t_k) / tau)`, `w_k ~ N(0, 1)`, `e_0 ~ N(0, sigma²)`. This is the usual model of
//! a standalone receiver's error, which is dominated by slowly varying terms (ionosphere,
//! troposphere, orbit and clock, multipath) rather than by white noise; see
//! `docs/v2v-and-metrics.md`. Each vehicle has its own, independent process (a conservative
//! choice: nearby receivers share much of their error, which would cancel in the gap).
//!
//! Determinism: its own ChaCha8 stream; every sample draws exactly two normals.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};

/// GNSS error model (TOML table `[v2v.gnss]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GnssParams {
    /// 1-sigma position error per axis, m, in [0, 100]. Default 1 (a standalone automotive
    /// receiver in open sky).
    pub sigma_m: f64,
    /// Correlation time of the error, s, in [0.01, 1e6]. Default 60.
    pub tau_s: f64,
}

impl Default for GnssParams {
    fn default() -> Self {
        Self { sigma_m: 1.0, tau_s: 60.0 }
    }
}

impl GnssParams {
    /// Checks every value; the error names the key (relative to the `gnss` table).
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_range("sigma_m", self.sigma_m, 0.0, 100.0, "m")?;
        check_range("tau_s", self.tau_s, 0.01, 1e6, "s")
    }
}

/// One vehicle's GNSS error process.
#[derive(Debug, Clone)]
pub struct GnssError {
    params: GnssParams,
    rng: ChaCha8Rng,
    t: Option<f64>,
    e: (f64, f64),
}

impl GnssError {
    /// Builds the process; deterministic per `seed`.
    pub fn new(params: GnssParams, seed: u64) -> Self {
        Self { params, rng: ChaCha8Rng::seed_from_u64(seed), t: None, e: (0.0, 0.0) }
    }

    /// The error (east, north) at time `t` (s, non-decreasing), m.
    pub fn sample(&mut self, t: f64) -> (f64, f64) {
        let w: (f64, f64) = (StandardNormal.sample(&mut self.rng), StandardNormal.sample(&mut self.rng));
        let s = self.params.sigma_m;
        self.e = match self.t {
            None => (s * w.0, s * w.1),
            Some(prev) => {
                let phi = (-(t - prev).max(0.0) / self.params.tau_s).exp();
                let k = s * (1.0 - phi * phi).max(0.0).sqrt();
                (phi * self.e.0 + k * w.0, phi * self.e.1 + k * w.1)
            }
        };
        self.t = Some(t);
        self.e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stationary_sigma_and_correlation_time() {
        let p = GnssParams { sigma_m: 2.0, tau_s: 10.0 };
        let mut g = GnssError::new(p, 3);
        let dt = 0.1;
        let xs: Vec<f64> = (0..2_000_000).map(|k| g.sample(k as f64 * dt).0).collect();
        let n = xs.len() as f64;
        let var = xs.iter().map(|x| x * x).sum::<f64>() / n;
        // 200 000 s / 10 s = 20 000 correlation times: the variance within a few percent.
        assert!((var.sqrt() - 2.0).abs() < 0.05, "{}", var.sqrt());
        // Autocorrelation at lag tau: exp(-1).
        let lag = 100;
        let c = xs.windows(lag + 1).map(|w| w[0] * w[lag]).sum::<f64>() / (n - lag as f64) / var;
        assert!((c - (-1.0f64).exp()).abs() < 0.03, "{c}");
    }

    #[test]
    fn zero_sigma_is_exact_and_bad_values_name_the_key() {
        let mut g = GnssError::new(GnssParams { sigma_m: 0.0, ..Default::default() }, 1);
        assert_eq!(g.sample(0.0), (0.0, 0.0));
        assert_eq!(g.sample(1.0), (0.0, 0.0));
        assert_eq!(GnssParams { tau_s: 0.0, ..Default::default() }.validate().unwrap_err().key, "tau_s");
    }
}
