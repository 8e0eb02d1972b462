//! Euro NCAP Car-to-Car Rear runs: what each run records (VUT and target speeds, impact
//! location, overlap, side, relative impact speed) and, for the 2026 grid, its colour band as
//! Euro NCAP's 2026 rating calculator (`euroncap-rating-2026`) bands a measured relative impact
//! speed (docs/standard-suites.md).

use serde::{Deserialize, Serialize};

use crate::metrics::Metrics;
use crate::scenario::Scenario;

/// The colour band of a 2026 run, best to worst; the calculator's standard-range points per
/// cell are 1, 0.75, 0.5, 0.25 and 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Band {
    /// Avoided: relative impact speed 0 km/h.
    Green,
    /// 0 < v < 10 km/h (VUT >= 50 km/h).
    Yellow,
    /// 10 <= v < 20 km/h (VUT >= 50), 0 < v < 10 (VUT 40).
    Orange,
    /// 20 <= v < 30 km/h (VUT >= 50), 10 <= v < 20 (VUT 40), 0 < v < 10 (VUT 30).
    Brown,
    /// Every other impact (at VUT 10 and 20 km/h any impact).
    Red,
}

impl Band {
    /// The calculator's name (`Green`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Band::Green => "Green",
            Band::Yellow => "Yellow",
            Band::Orange => "Orange",
            Band::Brown => "Brown",
            Band::Red => "Red",
        }
    }
}

/// Rounds half up (away from zero) to `digits` (0..=9) decimals, as the calculator does (its
/// `round_half_up`: the value first taken to 9 decimals, so that a binary artefact such as
/// 9.994999999999999 rounds as 9.995 does, then rounded half up), in integers.
pub fn round_half_up(x: f64, digits: u32) -> f64 {
    let digits = digits.min(9);
    let n = (x.abs() * 1e9).round() as i128;
    let q = 10i128.pow(9 - digits);
    let y = ((n + q / 2) / q) as f64 / 10f64.powi(digits as i32);
    if x < 0.0 { -y } else { y }
}

/// The band of a relative impact speed `v_kmh` (already rounded to 0.01 km/h) at VUT speed
/// `vut_kmh`: the calculator's "mitigation or avoidance" table, its row for the VUT speed (the
/// 50 km/h row from 50 km/h up; below, the row of the 10 km/h step at or below the VUT speed).
/// Green is the single point 0; the other bands are half-open, `[lower, upper)`, the boundary
/// belonging to the worse band.
pub fn band(vut_kmh: f64, v_kmh: f64) -> Band {
    if v_kmh <= 0.0 {
        return Band::Green;
    }
    let row: &[(Band, f64)] = if vut_kmh >= 50.0 {
        &[(Band::Yellow, 10.0), (Band::Orange, 20.0), (Band::Brown, 30.0)]
    } else if vut_kmh >= 40.0 {
        &[(Band::Orange, 10.0), (Band::Brown, 20.0)]
    } else if vut_kmh >= 30.0 {
        &[(Band::Brown, 10.0)]
    } else {
        &[]
    };
    row.iter().find(|(_, upper)| v_kmh < *upper).map_or(Band::Red, |(b, _)| *b)
}

/// What an NCAP run records besides its metrics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcapRun {
    /// The VUT's test speed, km/h.
    pub vut_speed_kmh: f64,
    /// The target's speed at the start, km/h.
    pub target_speed_kmh: f64,
    /// Where the target's centreline meets the VUT's front, % of the VUT's width from its right
    /// edge (50: centred; docs/standard-suites.md).
    pub impact_location: f64,
    /// The share of the VUT's width the target covers, % (100: full overlap).
    pub overlap: f64,
    /// The side of the VUT the target is offset to: `left`, `right` or `centre`.
    pub side: String,
    /// Relative impact speed, km/h, rounded half up to 0.01 km/h (0: avoided).
    pub impact_speed_kmh: f64,
    /// The 2026 colour band (`null` for the 2023 cases, which the 2026 calculator does not band).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub band: Option<Band>,
}

fn round6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

impl NcapRun {
    /// The record of a run of `scenario` with `metrics`; `banded`: a 2026 case.
    pub fn of(scenario: &Scenario, metrics: &Metrics, banded: bool) -> NcapRun {
        let vut_speed_kmh = round6(scenario.follower.initial_speed * 3.6);
        let w_vut = scenario.follower.vehicle.width;
        let w_gvt = scenario.lead.vehicle.width;
        let dy = scenario.lead.offset - scenario.follower.start_offset;
        let lo = (dy - w_gvt / 2.0).max(-w_vut / 2.0);
        let hi = (dy + w_gvt / 2.0).min(w_vut / 2.0);
        let overlap = round6(100.0 * ((hi - lo) / w_vut).clamp(0.0, 1.0));
        let side = if dy.abs() < 1e-9 {
            "centre"
        } else if dy > 0.0 {
            "left"
        } else {
            "right"
        };
        let impact_speed_kmh = if metrics.collision { round_half_up(metrics.impact_speed * 3.6, 2) } else { 0.0 };
        NcapRun {
            vut_speed_kmh,
            target_speed_kmh: round6(scenario.lead.initial_speed * 3.6),
            impact_location: round6(100.0 * (0.5 + dy / w_vut)),
            overlap,
            side: side.to_string(),
            impact_speed_kmh,
            band: banded.then(|| band(vut_speed_kmh, impact_speed_kmh)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_are_half_open_with_green_the_single_point_zero() {
        assert_eq!(band(50.0, 0.0), Band::Green);
        assert_eq!(band(50.0, 0.01), Band::Yellow);
        assert_eq!(band(50.0, 9.99), Band::Yellow);
        assert_eq!(band(50.0, 10.0), Band::Orange);
        assert_eq!(band(130.0, 20.0), Band::Brown);
        assert_eq!(band(80.0, 29.99), Band::Brown);
        assert_eq!(band(80.0, 30.0), Band::Red);
        assert_eq!(band(40.0, 9.99), Band::Orange);
        assert_eq!(band(40.0, 10.0), Band::Brown);
        assert_eq!(band(40.0, 20.0), Band::Red);
        assert_eq!(band(30.0, 5.0), Band::Brown);
        assert_eq!(band(30.0, 10.0), Band::Red);
        assert_eq!(band(20.0, 0.01), Band::Red);
        assert_eq!(band(10.0, 0.0), Band::Green);
    }

    #[test]
    fn rounding_is_half_up_to_the_hundredth() {
        assert_eq!(round_half_up(9.995, 2), 10.0);
        // One ulp-ish below the midpoint, as a computed speed lands: still half up.
        assert_eq!(round_half_up(9.995 - 2e-15, 2), 10.0);
        assert_eq!(round_half_up(9.9949, 2), 9.99);
        assert_eq!(round_half_up(0.004, 2), 0.0);
        // So a 9.995 km/h impact at 60 km/h is orange, as the calculator bands it.
        assert_eq!(band(60.0, round_half_up(9.995, 2)), Band::Orange);
    }
}
