//! Built-in scenarios besides the paper's experiment ([`crate::paper`]).

use crate::lead::Phase;
use crate::platoon::{PlatoonSpec, StringStabilitySpec, V2vSource};
use crate::scenario::{ControllerKind, Scenario, TrackSpec, Variant};
use crate::units::KMH;
use crate::v2v::V2vParams;

/// The platoon brake demo (`scenarios/platoon-brakedemo.toml`, after Plexe's braking example): 8
/// vehicles (the lead and 7 followers) in formation at 120 km/h on the straight track, V2V from
/// the predecessor; after 20 s the lead brakes at -6 m/s² to a stop. Three `[[variants]]`:
/// `pid-v2v` (the pipeline with working V2V: the PID drives), `flc` (FLC only, no V2V) and
/// `pipeline-outage` (every link lost at the brake onset). `|Gamma(jw)|` at 0.05-0.5 Hz.
pub fn brakedemo() -> Scenario {
    let v = 120.0 * KMH;
    let mut s = Scenario {
        name: "platoon-brakedemo".into(),
        controller: ControllerKind::Pipeline,
        duration: 90.0,
        track: TrackSpec::Straight { length: 2500.0 },
        speed_kmh: None,
        ..Scenario::default()
    };
    s.lead.initial_speed = v;
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: None, duration: Some(20.0) }.into(),
        Phase::Brake { decel: 6.0, speed: None, speed_kmh: None }.into(),
    ];
    s.follower.initial_speed = v;
    s.v2v = V2vParams::default();
    s.platoon = Some(PlatoonSpec {
        followers: 7,
        v2v_source: V2vSource::Predecessor,
        equilibrium_start: true,
        string_stability: StringStabilitySpec {
            frequencies_hz: vec![0.05, 0.1, 0.2, 0.3, 0.5],
            sine_amplitude: 1.0,
            ..StringStabilitySpec::default()
        },
        ..PlatoonSpec::default()
    });
    let table = |text: &str| text.parse::<toml::Table>().unwrap_or_default();
    s.variants = vec![
        Variant { name: "pid-v2v".into(), patch: toml::Table::new() },
        Variant { name: "flc".into(), patch: table("controller = \"flc\"\nv2v = { enabled = false }") },
        Variant { name: "pipeline-outage".into(), patch: table("v2v = { outage_on_brake = true }") },
    ];
    s
}
