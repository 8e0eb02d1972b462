//! What the loop tells its sinks. The simulation never imports a sink: a recorder, a live
//! viewer or a test probe implements [`Observer`]; `()` is the no-op (as rapier's
//! `EventHandler for ()`), so a run without sinks pays nothing.

use flc_core::ClusterInfo;

use crate::error::SimError;
use crate::lidar::Scan;
use crate::metrics::{CollisionInfo, ContactRecord, Metrics};
use crate::series::StepRecord;
use crate::vehicle::VehicleState;

/// Receives follower 1's view of a run while it runs. Every method defaults to doing nothing.
pub trait Observer {
    /// A scan delivered to follower 1 at simulation time `t`, after its pipeline ran: the points,
    /// the detector's clusters (`selected` marks the accepted lead), the distance the controller
    /// got (m) and the pure-pursuit lookahead point `(x, y)` in the follower's frame (m).
    fn scan(
        &mut self,
        t: f64,
        scan: &Scan,
        clusters: &[ClusterInfo],
        detected: Option<f64>,
        lookahead: (f64, f64),
    ) -> Result<(), SimError> {
        let _ = (t, scan, clusters, detected, lookahead);
        Ok(())
    }

    /// One physics step: follower 1's record (state after the step) and both vehicles' states.
    fn step(&mut self, record: &StepRecord, lead: &VehicleState, follower: &VehicleState) -> Result<(), SimError> {
        let _ = (record, lead, follower);
        Ok(())
    }

    /// One physics step of scripted vehicle `index` (of `[[vehicles]]`, called `name`, a
    /// `length` x `width` box): its state after the step at time `t`. Called after
    /// [`Observer::step`], only in scenarios with traffic.
    fn traffic(&mut self, t: f64, index: usize, name: &str, state: &VehicleState, size: (f64, f64)) -> Result<(), SimError> {
        let _ = (t, index, name, state, size);
        Ok(())
    }

    /// Follower `follower`'s (1-based) first contact with anything, right after the step it
    /// happened in (before that step's [`Observer::step`]).
    fn collision(&mut self, follower: usize, info: &CollisionInfo) -> Result<(), SimError> {
        let _ = (follower, info);
        Ok(())
    }

    /// The first contact of a pair of bodies that involves no follower (the lead touching a
    /// road-side object).
    fn other_contact(&mut self, contact: &ContactRecord) -> Result<(), SimError> {
        let _ = contact;
        Ok(())
    }

    /// The run ended: `metrics` of follower 1 when it ran to its end, `None` when it was stopped.
    fn finish(&mut self, metrics: Option<&Metrics>) -> Result<(), SimError> {
        let _ = metrics;
        Ok(())
    }
}

/// No sink.
impl Observer for () {}

/// An optional sink (recording switched on at run time).
impl<O: Observer> Observer for Option<O> {
    fn scan(
        &mut self,
        t: f64,
        scan: &Scan,
        clusters: &[ClusterInfo],
        detected: Option<f64>,
        lookahead: (f64, f64),
    ) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.scan(t, scan, clusters, detected, lookahead))
    }
    fn step(&mut self, record: &StepRecord, lead: &VehicleState, follower: &VehicleState) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.step(record, lead, follower))
    }
    fn traffic(&mut self, t: f64, index: usize, name: &str, state: &VehicleState, size: (f64, f64)) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.traffic(t, index, name, state, size))
    }
    fn collision(&mut self, follower: usize, info: &CollisionInfo) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.collision(follower, info))
    }
    fn other_contact(&mut self, contact: &ContactRecord) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.other_contact(contact))
    }
    fn finish(&mut self, metrics: Option<&Metrics>) -> Result<(), SimError> {
        self.as_mut().map_or(Ok(()), |o| o.finish(metrics))
    }
}

/// A boxed sink.
impl<O: Observer + ?Sized> Observer for Box<O> {
    fn scan(
        &mut self,
        t: f64,
        scan: &Scan,
        clusters: &[ClusterInfo],
        detected: Option<f64>,
        lookahead: (f64, f64),
    ) -> Result<(), SimError> {
        (**self).scan(t, scan, clusters, detected, lookahead)
    }
    fn step(&mut self, record: &StepRecord, lead: &VehicleState, follower: &VehicleState) -> Result<(), SimError> {
        (**self).step(record, lead, follower)
    }
    fn traffic(&mut self, t: f64, index: usize, name: &str, state: &VehicleState, size: (f64, f64)) -> Result<(), SimError> {
        (**self).traffic(t, index, name, state, size)
    }
    fn collision(&mut self, follower: usize, info: &CollisionInfo) -> Result<(), SimError> {
        (**self).collision(follower, info)
    }
    fn other_contact(&mut self, contact: &ContactRecord) -> Result<(), SimError> {
        (**self).other_contact(contact)
    }
    fn finish(&mut self, metrics: Option<&Metrics>) -> Result<(), SimError> {
        (**self).finish(metrics)
    }
}
