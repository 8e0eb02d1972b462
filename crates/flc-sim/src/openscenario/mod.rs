//! Import of ASAM OpenSCENARIO XML 1.0-1.3 files (`.xosc`) and their OpenDRIVE roads (`.xodr`)
//! into the one [`crate::Scenario`] model (`docs/openscenario.md` lists the supported subset
//! element by element). Layer 3 (configuration): nothing below it knows XML exists.
//!
//! - [`xml`]: safe reading (size, node and depth limits, no DTD);
//! - [`error`]: [`ImportError`] (file, line, element, reason);
//! - `expr`, `params`: parameters, `$name` and `${expr}`;
//! - `road`: OpenDRIVE plan view and lanes -> [`crate::Track`];
//! - `distribution`: `ParameterValueDistribution` files;
//! - `catalog`, `entities`, `storyboard`: entities, init and storyboard -> [`crate::Scenario`].

pub mod distribution;
pub mod error;
pub mod expr;
pub mod params;
pub mod road;
pub mod xml;

pub use error::ImportError;
