//! The scenario-file parser (`flc_sim::Scenario::from_toml_str`) on arbitrary text. Seeded with
//! `scenarios/*.toml` by `fuzz/run.sh`. A parsed scenario must also survive a TOML round trip.
#![no_main]

use flc_sim::Scenario;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(s) = Scenario::from_toml_str(text, "fuzz") {
        if let Ok(again) = s.to_toml() {
            assert!(Scenario::from_toml_str(&again, "fuzz-roundtrip").is_ok(), "round trip failed:\n{again}");
        }
    }
});
