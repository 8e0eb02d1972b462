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

pub mod error;
mod options;
pub mod road;
pub mod xml;

pub use error::ImportError;

// ---- TEMPORARY stub until the importer branch lands (replaced at merge) ----

/// Which road an import uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RoadChoice {
    /// The file's OpenDRIVE road.
    #[default]
    File,
    /// A straight road.
    Straight,
}

/// Options of [`import`].
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// `--param NAME=VALUE`.
    pub params: Vec<(String, String)>,
    /// `--ego NAME`.
    pub ego: Option<String>,
    /// `--ego-mode`.
    pub ego_mode: crate::story::EgoMode,
    /// `--controllers`.
    pub controller: Option<crate::ControllerKind>,
    /// `--road`.
    pub road: RoadChoice,
    /// `--traffic-dynamics`.
    pub dynamics: crate::story::Dynamics,
}

/// One imported entity.
#[derive(Debug, Clone)]
pub struct EntityInfo {
    /// Its name in the file.
    pub osc_name: String,
    /// Its name in the scenario.
    pub flc_name: String,
    /// Bounding box centre in the entity's frame, m.
    pub ref_offset: [f64; 2],
    /// Length, m.
    pub length: f64,
    /// Width, m.
    pub width: f64,
}

/// One run of an import.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The scenario.
    pub scenario: crate::Scenario,
    /// Its parameter values (distributions).
    pub params: Vec<(String, String)>,
    /// The entities.
    pub entities: Vec<EntityInfo>,
}

/// What an import gives.
#[derive(Debug, Clone)]
pub struct Import {
    /// The runs.
    pub runs: Vec<Imported>,
    /// Warnings.
    pub warnings: Vec<String>,
}

/// Imports `path`.
pub fn import(path: &std::path::Path, _opts: &ImportOptions) -> Result<Import, ImportError> {
    Err(ImportError::file(&path.display().to_string(), "the importer is not built yet"))
}
