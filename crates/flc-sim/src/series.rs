//! The per-step time series of a run: the columns are declared **once**, in the table of
//! [`series_columns!`]; [`StepRecord`], [`Series`] (push, get, len, columns), [`Series::COLUMNS`]
//! (names and units: CSV headers, Python, the MCAP state schema) are all generated from it.
//!
//! Add a column: one line in the table (name, type `f64` or `u8` code, unit, doc), then fill it in
//! the closed loop where the [`StepRecord`] is built.

use serde::{Deserialize, Serialize};

/// Generates [`StepRecord`] and [`Series`] from the column table below.
macro_rules! series_columns {
    ($( $(#[doc = $doc:literal])* $name:ident : $ty:ident, $unit:literal; )*) => {
        /// One physics step as recorded by the closed loop (state *after* the step). SI units.
        #[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
        pub struct StepRecord {
            $( $(#[doc = $doc])* pub $name: $ty, )*
        }

        /// The per-step time series of a run, one column per [`StepRecord`] field.
        ///
        /// [`Series::push`] keeps the columns equally long; if columns are edited by hand, the
        /// metrics use the shortest one's length.
        #[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
        pub struct Series {
            $( $(#[doc = $doc])* pub $name: Vec<$ty>, )*
        }

        impl Series {
            /// Column names (as in [`Series::columns`], CSV headers and Python) with their units.
            pub const COLUMNS: &'static [(&'static str, &'static str)] = &[$( (stringify!($name), $unit), )*];

            /// The Rust type of each column, in [`Series::COLUMNS`] order: `"f64"`, or `"u8"` for codes.
            pub const COLUMN_TYPES: &'static [&'static str] = &[$( stringify!($ty), )*];

            /// An empty series with room for `n` steps.
            pub fn with_capacity(n: usize) -> Self {
                Self { $( $name: Vec::with_capacity(n), )* }
            }

            /// Appends one step.
            pub fn push(&mut self, r: StepRecord) {
                $( self.$name.push(r.$name); )*
            }

            /// Number of complete steps (the shortest column's length).
            pub fn len(&self) -> usize {
                [$( self.$name.len(), )*].into_iter().min().unwrap_or(0)
            }

            /// Step `i`, if recorded.
            pub fn get(&self, i: usize) -> Option<StepRecord> {
                Some(StepRecord { $( $name: *self.$name.get(i)?, )* })
            }

            /// A series from named columns, the inverse of [`Series::columns`] (for series recorded
            /// elsewhere, e.g. by another simulator). Every given column must have a known name,
            /// appear once and have the same length; a column not given is NaN throughout (`f64`)
            /// or [`MISSING_CODE`] (codes: no controller, so neither `time_pid` nor `time_flc`
            /// counts it). Codes must be integers in `0..=255`. Errors name the column.
            pub fn from_columns(cols: &[(&str, &[f64])]) -> Result<Self, String> {
                let mut n: Option<(&str, usize)> = None;
                for (k, (name, c)) in cols.iter().enumerate() {
                    if !Self::COLUMNS.iter().any(|(known, _)| known == name) {
                        let known: Vec<&str> = Self::COLUMNS.iter().map(|(c, _)| *c).collect();
                        return Err(format!("unknown column `{name}` (known: {})", known.join(", ")));
                    }
                    if cols[..k].iter().any(|(other, _)| other == name) {
                        return Err(format!("column `{name}` given twice"));
                    }
                    match n {
                        Some((first, m)) if m != c.len() => return Err(format!("column `{name}` has {} samples, `{first}` {m}", c.len())),
                        Some(_) => {}
                        None => n = Some((name, c.len())),
                    }
                }
                let n = n.map_or(0, |(_, m)| m);
                let find = |name: &str| cols.iter().find(|(k, _)| *k == name).map(|(_, c)| *c);
                Ok(Self { $( $name: match find(stringify!($name)) {
                    None => vec![<$ty as ColumnValue>::MISSING; n],
                    Some(c) => c
                        .iter()
                        .map(|&x| <$ty as ColumnValue>::from_f64(x).ok_or_else(|| format!("column `{}`: {x} is not a code (an integer in 0..=255)", stringify!($name))))
                        .collect::<Result<Vec<$ty>, String>>()?,
                }, )* })
            }

            /// Every column as `f64` (codes converted), in [`Series::COLUMNS`] order, truncated to
            /// [`Series::len`].
            pub fn columns(&self) -> Vec<(&'static str, Vec<f64>)> {
                let n = self.len();
                vec![$( (stringify!($name), self.$name[..n].iter().map(|&x| f64::from(x)).collect()), )*]
            }
        }
    };
}

series_columns! {
    /// Simulation time, s.
    t: f64, "s";
    /// Lead position x, m (world frame).
    lead_x: f64, "m";
    /// Lead position y, m.
    lead_y: f64, "m";
    /// Lead speed, m/s.
    lead_speed: f64, "m/s";
    /// Lead longitudinal acceleration, m/s².
    lead_accel: f64, "m/s^2";
    /// Follower position x, m.
    follower_x: f64, "m";
    /// Follower position y, m.
    follower_y: f64, "m";
    /// Follower yaw, rad.
    follower_yaw: f64, "rad";
    /// Follower speed, m/s.
    follower_speed: f64, "m/s";
    /// Follower longitudinal acceleration, m/s².
    follower_accel: f64, "m/s^2";
    /// Bumper-to-bumper distance to the vehicle in the follower's path (ground truth, the
    /// nearest whose body reaches into its swept path plus margin, `sim/path.rs`), m; NaN when
    /// nothing is in its path, negative only in a contact.
    gap: f64, "m";
    /// Desired gap of the law that drives at this step, m (for `gap_error_rms`; NaN if not defined).
    desired_gap: f64, "m";
    /// Distance reported by the detector, m (NaN if nothing detected).
    detected_distance: f64, "m";
    /// Speed command of the longitudinal controller, m/s.
    speed_command: f64, "m/s";
    /// Acceleration command of the low-level speed controller, m/s².
    accel_command: f64, "m/s^2";
    /// Steering command, rad.
    steer_command: f64, "rad";
    /// Active longitudinal controller: [`ACTIVE_FLC`] (0) or [`ACTIVE_PID`] (1).
    active: u8, "code";
    /// Supervisor switch reason, `flc_core::SwitchReason as u8`.
    reason: u8, "code";
    /// Control ticks since the last accepted V2V message (NaN if none yet).
    v2v_age: f64, "ticks";
    /// Signed lateral offset of the follower from the lane centreline, m (+ left).
    lateral_offset: f64, "m";
    /// Follower heading minus centreline heading, wrapped to (-pi, pi], rad.
    heading_error: f64, "rad";
    /// Bumper-to-bumper distance to the vehicle the follower follows in the string (the lead,
    /// the sender of its V2V, for the first follower; its predecessor for the others), wherever
    /// that is (ground truth), m; negative once it is passed in another lane.
    lead_gap: f64, "m";
}

/// The value of a code column that [`Series::from_columns`] was not given (no controller, no
/// switch reason).
pub const MISSING_CODE: u8 = u8::MAX;

/// The two column types: what a missing column holds and how an `f64` converts.
trait ColumnValue: Sized + Copy {
    const MISSING: Self;
    fn from_f64(x: f64) -> Option<Self>;
}

impl ColumnValue for f64 {
    const MISSING: f64 = f64::NAN;
    fn from_f64(x: f64) -> Option<f64> {
        Some(x)
    }
}

impl ColumnValue for u8 {
    const MISSING: u8 = MISSING_CODE;
    fn from_f64(x: f64) -> Option<u8> {
        // Exact integers in range only; the cast is then lossless.
        (x.fract() == 0.0 && (0.0..=255.0).contains(&x)).then_some(x as u8)
    }
}

/// Code of the FLC in the `active` column (`flc_core::ActiveController::Flc as u8` = 0).
pub const ACTIVE_FLC: u8 = flc_core::ActiveController::Flc as u8;
/// Code of the PID in the `active` column (`flc_core::ActiveController::Pid as u8` = 1).
pub const ACTIVE_PID: u8 = flc_core::ActiveController::Pid as u8;

impl Series {
    /// `true` if no step was recorded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_get_columns_agree() {
        let mut s = Series::with_capacity(2);
        let r = StepRecord { t: 0.5, gap: 3.0, active: ACTIVE_PID, reason: 4, v2v_age: f64::NAN, ..StepRecord::default() };
        s.push(r);
        s.push(StepRecord { t: 1.0, ..r });
        assert_eq!(s.len(), 2);
        assert_eq!(s.get(1).map(|x| x.t), Some(1.0));
        assert!(s.get(2).is_none());
        let cols = s.columns();
        assert_eq!(cols.len(), Series::COLUMNS.len());
        assert_eq!(cols.iter().map(|(n, _)| *n).collect::<Vec<_>>(), Series::COLUMNS.iter().map(|(n, _)| *n).collect::<Vec<_>>());
        assert_eq!(cols.iter().find(|(n, _)| *n == "active").map(|(_, c)| c.clone()), Some(vec![1.0, 1.0]));
        // A column shortened by hand: len is the shortest.
        s.gap.pop();
        assert_eq!(s.len(), 1);
        assert!(s.get(1).is_none());
        assert_eq!(s.columns()[0].1, vec![0.5]);
    }

    #[test]
    fn from_columns_inverts_columns_and_names_bad_columns() {
        let mut s = Series::default();
        for i in 0..3 {
            let x = f64::from(i);
            s.push(StepRecord {
                t: 0.1 * x,
                gap: 10.0 - x,
                lead_speed: 5.0,
                active: ACTIVE_PID,
                reason: 2,
                v2v_age: f64::NAN,
                ..StepRecord::default()
            });
        }
        let cols = s.columns();
        let slices: Vec<(&str, &[f64])> = cols.iter().map(|(n, c)| (*n, c.as_slice())).collect();
        let back = Series::from_columns(&slices).expect("round trip");
        // NaN != NaN: compare the columns' bits.
        let bits =
            |s: &Series| s.columns().into_iter().map(|(n, c)| (n, c.iter().map(|x| x.to_bits()).collect::<Vec<_>>())).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&s));
        // Only some columns: the others are NaN, codes MISSING_CODE.
        let t = [0.0, 0.1];
        let part = Series::from_columns(&[("t", &t), ("gap", &[3.0, 2.0])]).expect("partial");
        assert_eq!((part.len(), part.gap.clone(), part.active.clone()), (2, vec![3.0, 2.0], vec![MISSING_CODE; 2]));
        assert!(part.lead_speed.iter().all(|x| x.is_nan()));
        assert_eq!(Series::from_columns(&[]).map(|s| s.len()), Ok(0));
        let err = |cols: &[(&str, &[f64])]| Series::from_columns(cols).err().unwrap_or_default();
        assert!(err(&[("t", &t), ("gpa", &t)]).starts_with("unknown column `gpa` (known: t, lead_x,"));
        assert_eq!(err(&[("t", &t), ("gap", &[1.0])]), "column `gap` has 1 samples, `t` 2");
        assert_eq!(err(&[("t", &t), ("t", &t)]), "column `t` given twice");
        assert_eq!(err(&[("active", &[0.0, 1.5])]), "column `active`: 1.5 is not a code (an integer in 0..=255)");
        assert_eq!(err(&[("reason", &[256.0])]), "column `reason`: 256 is not a code (an integer in 0..=255)");
        assert!(err(&[("active", &[f64::NAN])]).contains("NaN is not a code"));
    }
}
