//! A LiDAR reduced to its distance, for followers driven by another simulator (`flc.sumo`,
//! [`crate::ExternalFollower`]): the host simulator knows the gap to the vehicle in front, this
//! sensor turns it into what the detector would report.
//!
//! It takes the LiDAR's own parameters ([`LidarParams`], the `[lidar]` section), so a scenario's
//! sensor settings mean the same in both worlds:
//!
//! * **schedule**: a measurement every `1 / rate_hz` s from the first call, with the scan-period
//!   jitter `jitter` (the [`crate::Lidar`]'s schedule);
//! * **range**: no distance beyond `max_range` (the detector's grid is shorter still:
//!   `detector.grid_max_x`, applied by the caller's configuration if wanted);
//! * **noise**: Gaussian, `range_noise_std` on the distance (the LiDAR adds it per ray and the
//!   detector averages many rays, so the same value is a pessimistic distance noise);
//! * **dropouts**: a measurement is lost with probability `scan_drop_prob` (a dropped scan) or
//!   `dropout_prob` (the lead's returns lost: the object is not seen, `None`);
//! * **latency**: delivered `latency_frames` scans late.
//!
//! Determinism: one ChaCha8 stream, seeded by the caller; each measurement draws the same number of
//! values (jitter, scan drop, dropout, noise) whatever the configuration.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::lidar::{LidarParams, ScanSchedule};

/// The distance sensor (see the module docs).
#[derive(Debug, Clone)]
pub struct GapSensor {
    params: LidarParams,
    rng: ChaCha8Rng,
    /// The LiDAR's schedule; a measurement is the distance seen (`None`: no object).
    schedule: ScanSchedule<Option<f64>>,
}

impl GapSensor {
    /// A sensor with the LiDAR's parameters (validated by the caller) and random stream `seed`.
    pub fn new(params: LidarParams, seed: u64) -> Self {
        Self { params, rng: ChaCha8Rng::seed_from_u64(seed), schedule: ScanSchedule::new() }
    }

    /// Its parameters.
    pub fn params(&self) -> &LidarParams {
        &self.params
    }

    /// Called every step at time `t` with the true gap to the vehicle in front (`None`: nothing
    /// in front). Returns `None` when no measurement is delivered now, `Some(d)` when one is,
    /// `d` being the distance seen (`None`: no object, or the scan was dropped).
    pub fn tick(&mut self, t: f64, true_gap: Option<f64>) -> Option<Option<f64>> {
        if !self.schedule.due(t) {
            return None;
        }
        let p = &self.params;
        let jitter = self.rng.random_range(-1.0..=1.0) * p.jitter;
        let scan_dropped = self.rng.random::<f64>() < p.scan_drop_prob;
        let object_lost = self.rng.random::<f64>() < p.dropout_prob;
        let noise = p.range_noise_std * self.rng.sample::<f64, _>(rand_distr::StandardNormal);
        let faulted = p.faults.iter().filter(|f| f.active(t)).fold(true_gap.unwrap_or(f64::INFINITY), |r, f| f.apply(r, 0.0));
        let seen = Some(faulted).filter(|g| g.is_finite() && *g <= p.max_range && !object_lost).map(|g| (g + noise).max(0.0));
        self.schedule.take(&self.params, jitter, (!scan_dropped).then_some(seen)).map(Option::flatten)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clean() -> LidarParams {
        LidarParams { range_noise_std: 0.0, dropout_prob: 0.0, scan_drop_prob: 0.0, latency_frames: 0, jitter: 0.0, ..Default::default() }
    }

    #[test]
    fn a_clean_sensor_reports_the_gap_at_its_rate() {
        let mut s = GapSensor::new(LidarParams { rate_hz: 20.0, ..clean() }, 1);
        let delivered: Vec<(usize, Option<f64>)> =
            (0..20).filter_map(|k| s.tick(k as f64 * 0.01, Some(10.0 + k as f64)).map(|d| (k, d))).collect();
        assert_eq!(delivered, [(0, Some(10.0)), (5, Some(15.0)), (10, Some(20.0)), (15, Some(25.0))]);
    }

    #[test]
    fn latency_delays_by_whole_scans_and_range_cuts_off() {
        let mut s = GapSensor::new(LidarParams { rate_hz: 10.0, latency_frames: 2, max_range: 30.0, ..clean() }, 1);
        let out: Vec<Option<Option<f64>>> = (0..5).map(|k| s.tick(k as f64 * 0.1, Some(25.0 + 5.0 * k as f64))).collect();
        // Scans at 0.0 (25 m), 0.1 (30 m), 0.2 (35 m: out of range), ... delivered two scans late.
        assert_eq!(out, [None, None, Some(Some(25.0)), Some(Some(30.0)), Some(None)]);
    }

    #[test]
    fn noise_and_drops_have_their_configured_statistics() {
        let p = LidarParams { range_noise_std: 0.1, scan_drop_prob: 0.2, ..clean() };
        let rate = p.rate_hz;
        let mut s = GapSensor::new(p.clone(), 7);
        let n = 20_000;
        let d: Vec<Option<f64>> = (0..n).filter_map(|k| s.tick(k as f64 / rate, Some(20.0))).collect();
        assert_eq!(d.len(), n);
        let seen: Vec<f64> = d.iter().flatten().copied().collect();
        let drop_rate = 1.0 - seen.len() as f64 / n as f64;
        assert!((drop_rate - 0.2).abs() < 0.01, "{drop_rate}");
        let mean = seen.iter().sum::<f64>() / seen.len() as f64;
        let sd = (seen.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / seen.len() as f64).sqrt();
        assert!((mean - 20.0).abs() < 0.005 && (sd - 0.1).abs() < 0.005, "{mean} {sd}");
        // Same seed, same measurements.
        let mut again = GapSensor::new(p, 7);
        let d2: Vec<Option<f64>> = (0..n).filter_map(|k| again.tick(k as f64 / rate, Some(20.0))).collect();
        assert_eq!(d, d2);
    }
}
