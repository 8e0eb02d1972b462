//! The `/flc/state` channel: one JSON message per physics step with its JSON schema, derived
//! from the series columns.

use super::*;

pub(super) fn reason_name(code: u8) -> &'static str {
    const REASONS: [SwitchReason; 6] = [
        SwitchReason::V2vFresh,
        SwitchReason::NoV2v,
        SwitchReason::V2vStale,
        SwitchReason::Recovering,
        SwitchReason::InvalidV2v,
        SwitchReason::NotAssociated,
    ];
    REASONS.iter().find(|r| **r as u8 == code).map_or("unknown", |r| r.as_str())
}

pub(super) fn active_name(code: u8) -> &'static str {
    if code == ActiveController::Pid as u8 { ActiveController::Pid.as_str() } else { ActiveController::Flc.as_str() }
}

/// The JSON message of [`TOPIC_STATE`].
#[derive(Serialize)]
pub(super) struct StateMessage<'a> {
    #[serde(flatten)]
    pub(super) step: &'a StepRecord,
    pub(super) active_name: &'static str,
    pub(super) reason_name: &'static str,
}

/// The JSON schema of [`TOPIC_STATE`]: one property per [`Series::COLUMNS`] entry (units in the
/// descriptions; `null` stands for NaN) plus the two names.
pub fn state_json_schema() -> String {
    let mut props = serde_json::Map::new();
    for (&(name, unit), &rust_ty) in Series::COLUMNS.iter().zip(Series::COLUMN_TYPES) {
        let ty = if rust_ty == "u8" { serde_json::json!("integer") } else { serde_json::json!(["number", "null"]) };
        props.insert(name.to_string(), serde_json::json!({ "type": ty, "description": format!("{name}, {unit} (null = NaN)") }));
    }
    props
        .insert("active_name".into(), serde_json::json!({ "type": "string", "description": "active longitudinal controller: flc or pid" }));
    props.insert("reason_name".into(), serde_json::json!({ "type": "string", "description": "supervisor switch reason" }));
    serde_json::json!({
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": STATE_SCHEMA,
        "description": "One physics step of an flc-sim run (the run's StepRecord; docs/v2v-and-metrics.md)",
        "type": "object",
        "properties": props,
    })
    .to_string()
}
