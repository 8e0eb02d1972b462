//! The lateral controller of Sec. III-A.2: a modified pure pursuit towards the lead, Eq. (1).
//!
//! ```text
//! D_ahead = base_lookahead + lookahead_gain * S_F
//! (1)  theta = 2 * delta_y / (D_ahead^2 + delta_x^2)            (PursuitLaw::Paper)
//!      delta = atan(wheelbase * theta)
//!      delta = atan(2 * wheelbase * sin(alpha) / D_ahead)        (PursuitLaw::Standard)
//! ```
//! with `(delta_x, delta_y)` the lead's position relative to the follower (x forward, y left) and
//! `alpha = atan2(delta_y, delta_x)` the relative angle (quadrant-correct arc tangent, as the paper
//! requires). Positive steering turns left. Time-independent: no `dt`.

use crate::command::{Status, clamp};
use crate::params::{ParamError, check_positive, check_range};
use nalgebra::Point2;

/// Which pure-pursuit law to use.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PursuitLaw {
    /// The paper's Eq. (1), `theta = 2 dy / (D_ahead^2 + dx^2)`. `theta` has the unit 1/m: it is
    /// the curvature of the pursuit arc (for `D_ahead = 0` exactly pure pursuit's `2 y / l^2`), so
    /// it is turned into a road-wheel angle with the bicycle model, `delta = atan(L theta)`
    /// (`docs/paper-notes.md`).
    Paper,
    /// Standard pure pursuit (Coulter 1992), `delta = atan(2 L sin(alpha) / D_ahead)`.
    Standard,
}

/// Parameters of the lateral controller.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PurePursuitParams {
    /// Base (minimum) lookahead distance, m. Paper: not given; default 4.0.
    pub base_lookahead: f64,
    /// Speed scaling of the lookahead, s (`D_ahead = base + k * S_F`). Paper: not given; default 0.5.
    pub lookahead_gain: f64,
    /// The law. Default [`PursuitLaw::Paper`].
    pub law: PursuitLaw,
    /// Wheelbase `L`, m. Default 2.9.
    pub wheelbase: f64,
    /// Steering saturation, rad. Default 0.6 (about 34 degrees).
    pub max_steer: f64,
}

impl Default for PurePursuitParams {
    fn default() -> Self {
        Self { base_lookahead: 4.0, lookahead_gain: 0.5, law: PursuitLaw::Paper, wheelbase: 2.9, max_steer: 0.6 }
    }
}

impl PurePursuitParams {
    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("base_lookahead", self.base_lookahead, 1000.0, "must be finite and in (0, 1000] m")?;
        check_range("lookahead_gain", self.lookahead_gain, 0.0, 100.0, "must be finite and in [0, 100] s")?;
        check_positive("wheelbase", self.wheelbase, 100.0, "must be finite and in (0, 100] m")?;
        check_positive("max_steer", self.max_steer, core::f64::consts::FRAC_PI_2, "must be finite and in (0, pi/2] rad")
    }
}

/// Output of the lateral controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteeringCommand {
    /// Road-wheel steering angle, rad, left positive, within `+-max_steer`; 0 when there is no lead.
    pub steer: f64,
    /// `D_ahead`, m.
    pub lookahead: f64,
    /// `alpha`, the relative angle to the lead, rad (0 without a lead).
    pub alpha: f64,
    /// The pursuit point: `D_ahead` along the ray towards the lead, follower frame, m.
    pub lookahead_point: Point2<f64>,
    /// [`Status::Ok`], or why the command is "straight ahead".
    pub status: Status,
}

/// The pure-pursuit lateral controller.
#[derive(Debug, Clone)]
pub struct PurePursuit {
    params: PurePursuitParams,
}

impl PurePursuit {
    /// Validates `params` and builds the controller.
    pub fn new(params: PurePursuitParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PurePursuitParams {
        &self.params
    }

    /// `D_ahead = base + k * max(0, S_F)`, m.
    pub fn lookahead(&self, own_speed: f64) -> f64 {
        self.params.base_lookahead + self.params.lookahead_gain * own_speed.max(0.0)
    }

    /// Steering towards the lead at `lead` (follower frame, m). `None` or invalid input steers
    /// straight (0 rad) and says why in `status`.
    pub fn step(&self, lead: Option<Point2<f64>>, own_speed: f64) -> SteeringCommand {
        let p = &self.params;
        let speed = if own_speed.is_finite() { own_speed } else { 0.0 };
        let lookahead = self.lookahead(speed);
        let straight = |status| SteeringCommand { steer: 0.0, lookahead, alpha: 0.0, lookahead_point: Point2::new(lookahead, 0.0), status };
        if !own_speed.is_finite() {
            return straight(Status::InvalidSpeed);
        }
        let Some(lead) = lead else { return straight(Status::NoLead) };
        let (dx, dy) = (lead.x, lead.y);
        if !(dx.is_finite() && dy.is_finite()) || (dx == 0.0 && dy == 0.0) {
            return straight(Status::InvalidDistance);
        }
        let alpha = libm::atan2(dy, dx);
        let raw = match p.law {
            PursuitLaw::Paper => libm::atan(p.wheelbase * 2.0 * dy / (lookahead * lookahead + dx * dx)),
            PursuitLaw::Standard => libm::atan(2.0 * p.wheelbase * libm::sin(alpha) / lookahead),
        };
        let steer = if raw.is_finite() { clamp(raw, -p.max_steer, p.max_steer) } else { 0.0 };
        let lookahead_point = Point2::new(lookahead * libm::cos(alpha), lookahead * libm::sin(alpha));
        SteeringCommand { steer, lookahead, alpha, lookahead_point, status: Status::Ok }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq1_by_hand() {
        let pp = PurePursuit::new(PurePursuitParams::default()).unwrap();
        // S_F = 10: D_ahead = 4 + 0.5 * 10 = 9. Lead at (20, 2): theta = 2 * 2 / (81 + 400) = 4 / 481
        // = 0.0083160 1/m; delta = atan(2.9 * 0.0083160) = atan(0.0241164) = 0.0241117 rad.
        let out = pp.step(Some(Point2::new(20.0, 2.0)), 10.0);
        assert_eq!(out.lookahead, 9.0);
        assert!((out.steer - libm::atan(2.9 * 4.0 / 481.0)).abs() < 1e-12);
        assert!((out.steer - 0.024_111_7).abs() < 1e-6);
        // Lead on the right steers right.
        assert!(pp.step(Some(Point2::new(20.0, -2.0)), 10.0).steer < 0.0);
    }

    #[test]
    fn standard_law_by_hand() {
        let p = PurePursuitParams { law: PursuitLaw::Standard, ..Default::default() };
        let pp = PurePursuit::new(p).unwrap();
        // alpha = atan2(2, 20); sin(alpha) = 2 / sqrt(404) = 0.09950371902099892;
        // delta = atan(2 * 2.9 * 0.0995037... / 9) = atan(0.06412462003575486) = 0.06403700...
        let out = pp.step(Some(Point2::new(20.0, 2.0)), 10.0);
        assert!((out.steer - libm::atan(2.0 * 2.9 * 0.09950371902099892 / 9.0)).abs() < 1e-12);
        assert!((out.steer - 0.064037).abs() < 1e-6);
    }

    #[test]
    fn saturation_and_bad_input() {
        let pp = PurePursuit::new(PurePursuitParams::default()).unwrap();
        assert_eq!(pp.step(Some(Point2::new(0.1, 50.0)), 0.0).steer, 0.6);
        assert_eq!(pp.step(None, 10.0).status, Status::NoLead);
        assert_eq!(pp.step(Some(Point2::new(f64::NAN, 1.0)), 10.0).steer, 0.0);
        assert_eq!(pp.step(Some(Point2::new(10.0, 1.0)), f64::NAN).status, Status::InvalidSpeed);
        let e = PurePursuit::new(PurePursuitParams { max_steer: 0.0, ..Default::default() }).unwrap_err();
        assert_eq!(e.field, "max_steer");
    }
}
