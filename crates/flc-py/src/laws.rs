//! One binding for every longitudinal law ([`flc_core::LongitudinalController`]): built from its
//! parameters as JSON, stepped through the trait, its terms returned as the JSON of
//! [`flc_core::Terms`] (the law's own names, in its order). The pyclasses of `FallbackController`,
//! `RobustFallbackController`, `RobustFallbackController2` and `PidController` are thin shells around [`Held`].

use flc_core::{Frame, LongitudinalController, ParamError, Terms};
use pyo3::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde::ser::SerializeMap;

use crate::{from_json, param_err, to_json};

/// What the bindings need of a law beyond [`LongitudinalController`].
pub(crate) trait Law: LongitudinalController + Sized {
    /// Its parameter struct (serde: the names and defaults of the keyword arguments).
    type Params: Serialize + DeserializeOwned;
    /// The Python class name (prefixes errors).
    const WHAT: &'static str;
    /// Terms that are flags (0 / 1 in [`Terms`]): returned as booleans.
    const FLAGS: &'static [&'static str] = &[];
    fn build(p: Self::Params) -> Result<Self, ParamError>;
    fn law_params(&self) -> &Self::Params;
    /// The terms of the last step (every name, zero before the first step).
    fn law_terms(&self) -> Terms;
}

macro_rules! impl_law {
    ($law:ty, $params:ty, $what:literal, flags [$($flag:literal),*]) => {
        impl Law for $law {
            type Params = $params;
            const WHAT: &'static str = $what;
            const FLAGS: &'static [&'static str] = &[$($flag),*];
            fn build(p: Self::Params) -> Result<Self, ParamError> {
                <$law>::new(p)
            }
            fn law_params(&self) -> &Self::Params {
                self.params()
            }
            fn law_terms(&self) -> Terms {
                self.terms().to_terms()
            }
        }
    };
}

impl_law!(flc_core::FallbackController, flc_core::FlcParams, "FallbackController", flags ["braking_branch", "overridden"]);
impl_law!(flc_core::RobustFallbackController, flc_core::RobustFlcParams, "RobustFallbackController", flags ["revealed", "latched"]);
impl_law!(flc_core::RobustFallbackController2, flc_core::RobustFlc2Params, "RobustFallbackController2", flags ["held", "pending", "revealed", "latched", "comfort"]);
impl_law!(flc_core::PidController, flc_core::PidParams, "PidController", flags []);

/// The terms as serde writes [`Terms`] (name -> value, the law's order), flags as booleans.
struct TermsJson<'a> {
    terms: &'a Terms,
    flags: &'a [&'a str],
}

impl Serialize for TermsJson<'_> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.terms.len()))?;
        for (name, value) in self.terms.iter() {
            if self.flags.contains(&name) {
                map.serialize_entry(name, &(value != 0.0))?;
            } else {
                map.serialize_entry(name, &value)?;
            }
        }
        map.end()
    }
}

/// A law held by a pyclass.
pub(crate) struct Held<L: Law> {
    law: L,
}

/// `(speed_command, accel, status)`.
pub(crate) type CommandTuple = (f64, f64, &'static str);

impl<L: Law> Held<L> {
    pub(crate) fn new(params_json: &str) -> PyResult<Self> {
        let p: L::Params = from_json(params_json, L::WHAT)?;
        Ok(Self { law: L::build(p).map_err(|e| param_err(L::WHAT, e))? })
    }

    pub(crate) fn step(&mut self, frame: &Frame) -> CommandTuple {
        let c = LongitudinalController::step(&mut self.law, frame).command;
        (c.speed, c.accel, c.status.as_str())
    }

    pub(crate) fn reset(&mut self) {
        LongitudinalController::reset(&mut self.law);
    }

    pub(crate) fn terms_json(&self) -> PyResult<String> {
        to_json(&TermsJson { terms: &self.law.law_terms(), flags: L::FLAGS })
    }

    pub(crate) fn params_json(&self) -> PyResult<String> {
        to_json(self.law.law_params())
    }
}

/// A pyclass around [`Held`]: `new(params_json)`, `reset()`, `terms_json()`, `params_json()`,
/// plus the law's own `step` signature (the block).
macro_rules! law_class {
    ($(#[$doc:meta])* $name:ident($law:ty) { $($step:tt)* }) => {
        $(#[$doc])*
        #[pyclass(module = "flc._flc")]
        pub(crate) struct $name {
            held: $crate::laws::Held<$law>,
        }

        #[pymethods]
        impl $name {
            #[new]
            fn new(params_json: &str) -> PyResult<Self> {
                Ok(Self { held: $crate::laws::Held::new(params_json)? })
            }

            $($step)*

            /// Back to the initial state.
            fn reset(&mut self) {
                self.held.reset();
            }

            /// The terms of the last step as JSON (`flc_core::Terms`: name -> value).
            fn terms_json(&self) -> PyResult<String> {
                self.held.terms_json()
            }

            /// The parameters in use as JSON.
            fn params_json(&self) -> PyResult<String> {
                self.held.params_json()
            }
        }
    };
}

law_class! {
    /// The FLC of Eqs. (2)-(5).
    FallbackController(flc_core::FallbackController) {
        /// `(speed_command, accel, status)`; no dt (the law never reads it).
        fn step(&mut self, distance: Option<f64>, own_speed: f64) -> CommandTuple {
            self.held.step(&Frame::new(distance, own_speed, 0.0))
        }
    }
}

law_class! {
    /// The robust FLC (beyond the paper, `docs/robust-flc.md`).
    RobustFallbackController(flc_core::RobustFallbackController) {
        /// `(speed_command, accel, status)`; no dt (the law never reads it).
        fn step(&mut self, distance: Option<f64>, own_speed: f64) -> CommandTuple {
            self.held.step(&Frame::new(distance, own_speed, 0.0))
        }
    }
}

law_class! {
    /// The robust FLC v2 (beyond the paper, `docs/robust-flc.md`, "v2").
    RobustFallbackController2(flc_core::RobustFallbackController2) {
        /// `(speed_command, accel, status)`; no dt (the law never reads it).
        fn step(&mut self, distance: Option<f64>, own_speed: f64) -> CommandTuple {
            self.held.step(&Frame::new(distance, own_speed, 0.0))
        }
    }
}

law_class! {
    /// The PID gap controller.
    PidController(flc_core::PidController) {
        /// `(speed_command, u, status)`: the lead speed arrives with every step (a V2V message).
        fn step(&mut self, lead_speed: f64, own_speed: f64, distance: Option<f64>, dt: f64) -> CommandTuple {
            let v2v = Some(flc_core::V2vMessage::speed_only(lead_speed, 0));
            self.held.step(&Frame { distance, own_speed, v2v, dt, lead_speed: None, own_fix: None, travelled: None, intruder: None, path_clear: false })
        }
    }
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<FallbackController>()?;
    m.add_class::<RobustFallbackController>()?;
    m.add_class::<RobustFallbackController2>()?;
    m.add_class::<PidController>()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flags_are_terms<L: Law>(law: &L) {
        let t = law.law_terms();
        for f in L::FLAGS {
            assert!(t.names().contains(f), "{}: flag `{f}` is not a term ({:?})", L::WHAT, t.names());
        }
    }

    #[test]
    fn flags_name_terms_and_terms_are_the_laws() {
        let mut flc = flc_core::FallbackController::new(flc_core::FlcParams::paper()).expect("flc");
        flags_are_terms(&flc);
        flags_are_terms(&flc_core::RobustFallbackController::new(flc_core::RobustFlcParams::documented()).expect("robust"));
        flags_are_terms(&flc_core::RobustFallbackController2::new(flc_core::RobustFlc2Params::documented()).expect("robust v2"));
        flags_are_terms(&flc_core::PidController::new(flc_core::PidParams::paper()).expect("pid"));
        let out = LongitudinalController::step(&mut flc, &Frame::new(Some(25.0), 10.0, 0.05));
        assert_eq!(out.terms, flc.law_terms());
        let json = to_json(&TermsJson { terms: &flc.law_terms(), flags: <flc_core::FallbackController as Law>::FLAGS }).expect("json");
        assert!(json.starts_with("{\"tau_d\":") && json.contains("\"dist_s\":5.0") && json.contains("\"braking_branch\":false"), "{json}");
    }
}
