//! [`ImportOptions`] from the words the interfaces use (`scenario --ego-mode scripted`,
//! `flc.Scenario.load(..., ego_mode="scripted")`): one parser for the CLI and Python.

use super::{ImportOptions, RoadChoice};
use crate::error::ConfigError;
use crate::story::{Dynamics, EgoMode};

impl ImportOptions {
    /// Options from their interface names: `params` as `NAME=VALUE` or pairs, `ego_mode`
    /// `controller` | `scripted`, `road` `file` | `straight`, `dynamics` `kinematic` |
    /// `vehicle`, `controller` a controller name. Errors name the option (`ego_mode`, ...).
    pub fn from_words(
        params: Vec<(String, String)>,
        ego: Option<String>,
        ego_mode: &str,
        road: &str,
        dynamics: &str,
        controller: Option<&str>,
    ) -> Result<Self, ConfigError> {
        let ego_mode = match ego_mode {
            "controller" => EgoMode::Controller,
            "scripted" => EgoMode::Scripted,
            other => return Err(ConfigError::new("ego_mode", format!("must be controller or scripted, got `{other}`"))),
        };
        let road = match road {
            "file" => RoadChoice::File,
            "straight" => RoadChoice::Straight,
            other => return Err(ConfigError::new("road", format!("must be file or straight, got `{other}`"))),
        };
        let dynamics = match dynamics {
            "kinematic" => Dynamics::Kinematic,
            "vehicle" => Dynamics::Vehicle,
            other => return Err(ConfigError::new("traffic_dynamics", format!("must be kinematic or vehicle, got `{other}`"))),
        };
        let controller = controller.map(crate::ControllerKind::parse).transpose()?;
        for (name, _) in &params {
            if name.trim().is_empty() {
                return Err(ConfigError::new("params", "a parameter name is empty"));
            }
        }
        Ok(Self { params, ego, ego_mode, controller, road, dynamics, strict: false })
    }

    /// `NAME=VALUE` (`--param`) as a pair; the error names `param`.
    pub fn param_pair(text: &str) -> Result<(String, String), ConfigError> {
        let (name, value) = text.split_once('=').ok_or_else(|| ConfigError::new("param", format!("expected NAME=VALUE, got `{text}`")))?;
        if name.trim().is_empty() {
            return Err(ConfigError::new("param", format!("empty parameter name in `{text}`")));
        }
        Ok((name.trim().to_string(), value.to_string()))
    }
}
