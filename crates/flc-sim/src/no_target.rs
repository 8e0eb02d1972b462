//! No target is not an emergency: what a controller without a free-road branch of its own does
//! while nothing has ever been in its path (the ACC convention, ISO 15622: with no target an ACC
//! holds its set speed).
//!
//! The paper's FLC (Eqs. (2)-(5)), the V2V PID, the pipeline of Fig. 1 and the robust FLCs are
//! gap laws: each is defined only with a lead, and each brakes on a frame without one (its
//! documented lost-lead behaviour; the robust FLC's hold-and-brake). Before the first detection
//! there is nothing to have lost, so [`NoTargetCruise`] drives such a law's vehicle at the set
//! speed: its speed command is the set speed (the low-level speed controller's limits bound the
//! acceleration, as for every command). From the first detection on the law drives alone, and a
//! target lost later is the law's business. A target seen *leaving* the path is not lost: once
//! the simulator's departure watch (`flc_core::LeadDeparture`, `Frame::path_clear`) sees its
//! whole body beside the path and nothing else in it, the road is clear again, and the wrapper
//! cruises until the next detection (a pedestrian who crossed the lane, a car that cut out). The
//! law is stepped on every frame all the same (its inputs and its V2V bookkeeping stay its own),
//! only its command is replaced while cruising.
//!
//! The baselines and the careful driver have a free-road branch of their own (the
//! `NoLeadPolicy::Cruise` of `flc_core::baselines`, towards their `desired_speed`) and are not
//! wrapped; the registry says which law is (`crate::ControllerKind::cruises`).
//! `docs/sim-model.md` ("No target") lists what every controller does.

use flc_core::{ControlOutput, Frame, LongitudinalCommand, LongitudinalController, Status};

use crate::controllers::BoxedLaw;

/// A gap law that cruises at `set_speed` until its first target (module docs).
pub struct NoTargetCruise {
    law: BoxedLaw,
    /// The set speed, m/s.
    set_speed: f64,
    /// Whether a target has been detected since the start (or the last reset).
    target_seen: bool,
}

impl NoTargetCruise {
    /// `law`, cruising at `set_speed` (m/s) until its first target.
    pub fn new(law: BoxedLaw, set_speed: f64) -> Self {
        Self { law, set_speed, target_seen: false }
    }

    /// Whether the law still cruises (no target yet).
    pub fn cruising(&self) -> bool {
        !self.target_seen
    }
}

impl LongitudinalController for NoTargetCruise {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        // A target seen drives the law; a path seen cleared (the lead left it, `Frame::path_clear`)
        // is as good as never having had one.
        if frame.distance.is_some() {
            self.target_seen = true;
        } else if frame.path_clear {
            self.target_seen = false;
        }
        let mut out = self.law.step(frame);
        if !self.target_seen {
            out.command = LongitudinalCommand { speed: self.set_speed, accel: 0.0, status: Status::Ok };
        }
        out
    }

    fn reset(&mut self) {
        self.target_seen = false;
        self.law.reset();
    }

    fn desired_gap(&self, v: f64) -> f64 {
        self.law.desired_gap(v)
    }

    fn formation_gap(&self, v: f64) -> f64 {
        self.law.formation_gap(v)
    }

    fn uses_dt(&self) -> bool {
        self.law.uses_dt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flc_core::{FallbackController, FlcParams};

    fn flc() -> NoTargetCruise {
        NoTargetCruise::new(Box::new(FallbackController::new(FlcParams::paper()).expect("paper FLC")), 20.0)
    }

    #[test]
    fn cruises_until_the_first_target_then_the_law_alone_drives() {
        let mut c = flc();
        let mut bare = FallbackController::new(FlcParams::paper()).expect("paper FLC");
        for v in [0.0, 12.0, 25.0] {
            let out = c.step(&Frame::new(None, v, 0.05));
            assert_eq!((out.command.speed, out.command.status), (20.0, Status::Ok), "{v}");
            assert!(c.cruising());
        }
        // The first target: the law's own command, bit for bit.
        let a = c.step(&Frame::new(Some(30.0), 20.0, 0.05)).command;
        bare.step(None, 25.0);
        let b = bare.step(Some(30.0), 20.0);
        assert_eq!((a.speed.to_bits(), a.accel.to_bits(), a.status), (b.speed.to_bits(), b.accel.to_bits(), b.status));
        // Lost after it: the law's own lost-lead behaviour (the paper FLC brakes), not the cruise.
        let lost = c.step(&Frame::new(None, 20.0, 0.05)).command;
        assert_eq!(lost.status, Status::NoLead);
        assert!(lost.speed < 20.0, "{lost:?}");
        // A reset starts over: no target yet.
        c.reset();
        assert_eq!(c.step(&Frame::new(None, 5.0, 0.05)).command.speed, 20.0);
    }
}
