//! A lead seen leaving the path (issue 46): after it, nothing in path is a clear road, not a
//! lost lead.
//!
//! The gap laws brake when the detector reports nothing (the paper FLC's lost lead, the robust
//! FLC's hold-and-brake): a lead that vanishes may still be there (dropouts, a sensor fault).
//! But a lead that *walks or drives out of the path* is still seen, beside it: a pedestrian who
//! crossed the lane (UN R157 4.2.3), a car that cut out. A driver that held the brake then would
//! stand on an open road. [`LeadDeparture`] tells the two apart on positions alone (no
//! timestamp, no speed): it remembers where the lead was ([`ClusterInfo::selected`]) and, while
//! nothing is selected, follows the cluster nearest that place from scan to scan, whatever the
//! detector judged it (a pedestrian seen side-on is `TooNarrow` before it leaves); once that
//! cluster's whole body lies farther than `clear_half_width` from the path, the lead has **left**
//! and the path is **clear** until the detector selects a lead again. A lead that vanishes
//! without a cluster near its last place is lost, not gone: after `max_misses` scans the watch
//! forgets it and never reports clear.
//!
//! ```text
//! associated  <=>  |x_min - x_last| <= gate_x  and  the lateral extents [d_min, d_max] are
//!                  within gate_d of each other (nearest by |dx| / gate_x + |dd| / gate_d)
//! left        <=>  d_min > clear_half_width  or  d_max < -clear_half_width
//! ```
//!
//! Fixed size, no allocation, no panic; the work per scan is one pass over the clusters.

use crate::detector::{ClusterInfo, RejectReason};
use crate::params::{ParamError, check_positive, check_range};

/// Parameters of the watch; `Default` holds the documented choices.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepartureParams {
    /// Offset from the path beyond which a body is out of it, m: the in-path rule's half width
    /// (the simulator sets the detector's corridor: `swept_half_width` / `body_half_width`). Default
    /// 0: off (the path is never reported clear).
    pub clear_half_width: f64,
    /// Association gate along the path: the largest change of the rear-face x between two scans,
    /// m. Default 4.0 (40 m/s of closing speed at 10 Hz: a standing object seen from a moving ego).
    pub gate_x: f64,
    /// Association gate across the path: the largest gap between the lateral extents of two
    /// scans, m. Default 0.5 (a pedestrian walks 0.07 m per 20 Hz scan; a car in the next lane is
    /// 1.6 m from a lead's body).
    pub gate_d: f64,
    /// Scans without an associated cluster before the watch forgets the lead (lost, not gone).
    /// Default 3.
    pub max_misses: u8,
}

impl Default for DepartureParams {
    fn default() -> Self {
        Self::defaults()
    }
}

impl DepartureParams {
    /// The documented defaults (identical to `Default`).
    pub const fn defaults() -> Self {
        Self { clear_half_width: 0.0, gate_x: 4.0, gate_d: 0.5, max_misses: 3 }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("clear_half_width", self.clear_half_width, 0.0, 50.0, "must be finite and in [0, 50] m (0 = off)")?;
        check_positive("gate_x", self.gate_x, 100.0, "must be finite and in (0, 100] m")?;
        check_positive("gate_d", self.gate_d, 10.0, "must be finite and in (0, 10] m")?;
        if self.max_misses > 100 {
            return Err(ParamError { field: "max_misses", problem: "must be in [0, 100] scans" });
        }
        Ok(())
    }
}

/// Where the watched object was: rear-face x and lateral extent from the path, m.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Place {
    x: f64,
    d_min: f64,
    d_max: f64,
}

impl Place {
    fn of(c: &ClusterInfo) -> Self {
        Self { x: c.x_min, d_min: c.d_min, d_max: c.d_max }
    }
}

/// The watch (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeadDeparture {
    params: DepartureParams,
    last: Option<Place>,
    misses: u8,
    clear: bool,
}

impl LeadDeparture {
    /// A watch with `params` (validated).
    pub fn new(params: DepartureParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params, last: None, misses: 0, clear: false })
    }

    /// The parameters.
    pub fn params(&self) -> &DepartureParams {
        &self.params
    }

    /// Forgets the lead.
    pub fn reset(&mut self) {
        *self = Self { params: self.params, last: None, misses: 0, clear: false };
    }

    /// Whether the path is clear (the last lead left it and nothing was selected since).
    pub fn clear(&self) -> bool {
        self.clear
    }

    /// Reads the clusters of the detector's last scan ([`crate::LeadDetector::clusters`]);
    /// returns [`Self::clear`].
    pub fn update(&mut self, clusters: &[ClusterInfo]) -> bool {
        let p = self.params;
        if let Some(lead) = clusters.iter().find(|c| c.selected) {
            *self = Self { params: p, last: Some(Place::of(lead)), misses: 0, clear: false };
            return false;
        }
        let Some(last) = self.last.filter(|_| !self.clear && p.clear_half_width > 0.0) else { return self.clear };
        let mut best: Option<(&ClusterInfo, f64)> = None;
        for c in clusters {
            // A joined fragment's points are in the cluster it joined.
            if c.points == 0 || c.rejection == Some(RejectReason::Joined) {
                continue;
            }
            let dx = libm::fabs(c.x_min - last.x);
            let dd = f64::max(0.0, f64::max(c.d_min - last.d_max, last.d_min - c.d_max));
            // Also false for NaN.
            if !(dx <= p.gate_x && dd <= p.gate_d) {
                continue;
            }
            let centre = libm::fabs(0.5 * (c.d_min + c.d_max - last.d_min - last.d_max));
            let cost = dx / p.gate_x + centre / p.gate_d;
            if best.is_none_or(|(_, b)| cost < b) {
                best = Some((c, cost));
            }
        }
        match best {
            Some((c, _)) => {
                self.last = Some(Place::of(c));
                self.misses = 0;
                self.clear = c.d_min > p.clear_half_width || c.d_max < -p.clear_half_width;
            }
            None if self.misses >= p.max_misses => self.last = None,
            None => self.misses += 1,
        }
        self.clear
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cluster(x: f64, d_min: f64, d_max: f64, rejection: Option<RejectReason>, selected: bool) -> ClusterInfo {
        ClusterInfo {
            x_min: x,
            x_max: x + 0.3,
            y_min: d_min,
            y_max: d_max,
            d_min,
            d_max,
            points: 12,
            cells: 4,
            rejection,
            selected,
            ..ClusterInfo::EMPTY
        }
    }

    fn watch() -> LeadDeparture {
        LeadDeparture::new(DepartureParams { clear_half_width: 1.75, ..DepartureParams::default() }).unwrap()
    }

    #[test]
    fn a_pedestrian_walking_out_of_the_path_clears_it() {
        let mut w = watch();
        // Followed in the path, then too narrow (seen side-on) while still in it, then beside it.
        assert!(!w.update(&[cluster(6.0, 0.1, 0.5, None, true)]));
        let mut d = 0.1;
        let mut cleared_at = None;
        for k in 0..40 {
            d += 0.07;
            let rejection = if d < 1.4 { RejectReason::TooNarrow } else { RejectReason::OffPath };
            let clear = w.update(&[cluster(5.0, d, d + 0.3, Some(rejection), false)]);
            if clear && cleared_at.is_none() {
                cleared_at = Some((k, d));
            }
            // Clear only once the whole body is beyond the half width.
            assert_eq!(clear, d > 1.75, "{k}: {d}");
        }
        assert!(cleared_at.is_some());
        // It stays clear with nothing near, and until a lead is selected again.
        assert!(w.update(&[]));
        assert!(!w.update(&[cluster(30.0, -0.9, 0.9, None, true)]));
    }

    #[test]
    fn a_lead_that_vanishes_is_lost_not_gone() {
        let mut w = watch();
        w.update(&[cluster(20.0, -0.9, 0.9, None, true)]);
        // Nothing where it was (a dropout): never clear, forgotten after max_misses.
        for _ in 0..5 {
            assert!(!w.update(&[]));
        }
        // Something beside the path where it was, later: not it any more.
        assert!(!w.update(&[cluster(20.0, 2.0, 2.4, Some(RejectReason::OffPath), false)]));
        // A car in the next lane at the lead's x is not associated (1.6 m from its body).
        let mut w = watch();
        w.update(&[cluster(20.0, -0.95, 0.95, None, true)]);
        assert!(!w.update(&[cluster(20.5, 2.55, 4.45, Some(RejectReason::OffPath), false)]));
        // A jump across the path in one scan is not a walk.
        assert!(!w.update(&[cluster(20.0, 1.9, 2.3, Some(RejectReason::OffPath), false)]));
    }

    #[test]
    fn off_by_default_and_bad_parameters_name_their_field() {
        let mut w = LeadDeparture::new(DepartureParams::default()).unwrap();
        w.update(&[cluster(6.0, 0.1, 0.5, None, true)]);
        assert!(!w.update(&[cluster(6.0, 2.0, 2.3, Some(RejectReason::OffPath), false)]));
        let bad = |p: DepartureParams| LeadDeparture::new(p).unwrap_err().field;
        let d = DepartureParams::default;
        assert_eq!(bad(DepartureParams { clear_half_width: f64::NAN, ..d() }), "clear_half_width");
        assert_eq!(bad(DepartureParams { gate_x: 0.0, ..d() }), "gate_x");
        assert_eq!(bad(DepartureParams { gate_d: -1.0, ..d() }), "gate_d");
        assert_eq!(bad(DepartureParams { max_misses: 101, ..d() }), "max_misses");
        // NaN positions are never associated.
        let mut w = watch();
        w.update(&[cluster(6.0, 0.1, 0.5, None, true)]);
        assert!(!w.update(&[cluster(f64::NAN, 2.0, 2.3, Some(RejectReason::OffPath), false)]));
        w.reset();
        assert!(!w.clear());
    }
}
