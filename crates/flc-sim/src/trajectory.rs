//! Per-entity trajectories as a long CSV (`t,entity,x,y,heading,speed`, one row per entity per
//! step from t = 0), in the names an outside tool knows the entities by: what `scenario --out`
//! writes beside the series for an OpenSCENARIO run, comparable row by row with esmini's
//! `dat2csv` output.
//!
//! `x, y` are the entity's reference point (for an imported vehicle the OpenSCENARIO reference
//! point, the rear axle: `reference` behind and to the right of the box centre flc moves, as
//! `[story] references`), `heading` the world heading in (-pi, pi], `speed` m/s.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::sim::{Observer, Simulation};
use crate::vehicle::VehicleState;

/// One entity of a trajectory file.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryEntity {
    /// The name written in the `entity` column (an OpenSCENARIO file's entity name).
    pub name: String,
    /// Its name in the simulation: `ego` (follower 1), `lead` or a `[[vehicles]]` name.
    pub sim_name: String,
    /// Where the box centre lies from the reference point, m: `[ahead, left]` in the entity's
    /// frame (`[story] references`; an OpenSCENARIO `BoundingBox/Center` x, y).
    pub reference: [f64; 2],
}

/// The CSV header.
pub const HEADER: &str = "t,entity,x,y,heading,speed";

/// The reference point of a body whose box centre is at `st` and whose centre lies `reference`
/// (ahead, left) of that point: `(x, y)`, m.
pub fn reference_point(st: &VehicleState, reference: [f64; 2]) -> (f64, f64) {
    let (c, s) = (st.yaw.cos(), st.yaw.sin());
    (st.x - c * reference[0] + s * reference[1], st.y - s * reference[0] - c * reference[1])
}

/// `a` wrapped into (-pi, pi].
pub fn heading(a: f64) -> f64 {
    crate::track::wrap(a)
}

/// Writes one run's trajectory file (into `<path>.part`, renamed when finished, so a file with
/// the final name is always complete).
pub struct TrajectoryWriter {
    w: std::io::BufWriter<std::fs::File>,
    part: PathBuf,
    path: PathBuf,
    entities: Vec<TrajectoryEntity>,
}

impl TrajectoryWriter {
    /// Starts `path` with its header.
    pub fn create(path: &Path, entities: &[TrajectoryEntity]) -> std::io::Result<Self> {
        let part = path.with_extension("csv.part");
        let mut w = std::io::BufWriter::new(std::fs::File::create(&part)?);
        writeln!(w, "{HEADER}")?;
        Ok(Self { w, part, path: path.to_path_buf(), entities: entities.to_vec() })
    }

    /// The rows of the simulation's state now (every entity it knows; others are skipped).
    pub fn write_step<O: Observer>(&mut self, sim: &Simulation<O>) -> std::io::Result<()> {
        let t = sim.time();
        for e in &self.entities {
            let st = if e.sim_name == crate::scenario::EGO { sim.follower_state(0) } else { sim.scripted_state(&e.sim_name) };
            let Some(st) = st else { continue };
            let (x, y) = reference_point(st, e.reference);
            writeln!(self.w, "{t:.6},{},{x:.6},{y:.6},{:.6},{:.6}", csv_name(&e.name), heading(st.yaw), st.speed)?;
        }
        Ok(())
    }

    /// Finishes the file (flushed and renamed to its final name); returns the path.
    pub fn finish(mut self) -> std::io::Result<PathBuf> {
        self.w.flush()?;
        drop(self.w);
        std::fs::rename(&self.part, &self.path)?;
        Ok(self.path)
    }
}

/// An entity name as a CSV field (quoted if it holds a comma, a quote or a line break).
fn csv_name(n: &str) -> String {
    if n.contains([',', '"', '\n', '\r']) { format!("\"{}\"", n.replace('"', "\"\"")) } else { n.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_are_in_minus_pi_to_pi() {
        use std::f64::consts::PI;
        assert!((heading(PI) - PI).abs() < 1e-12);
        assert!((heading(-PI) - PI).abs() < 1e-12);
        assert!((heading(1.5 * PI) + 0.5 * PI).abs() < 1e-12);
        assert!((heading(0.25) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn reference_point_is_behind_the_centre() {
        let st = VehicleState { x: 10.0, y: 5.0, yaw: std::f64::consts::FRAC_PI_2, ..VehicleState::default() };
        let (x, y) = reference_point(&st, [1.4, 0.0]);
        assert!((x - 10.0).abs() < 1e-12 && (y - 3.6).abs() < 1e-12, "{x} {y}");
        assert_eq!(csv_name("a,b"), "\"a,b\"");
    }
}
