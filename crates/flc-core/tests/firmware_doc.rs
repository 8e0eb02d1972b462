//! The static-memory table of `docs/firmware.md` ("Static memory and stack") against the code:
//! every Rust type's and every C storage struct's size as `size_of` gives it on this host. (The
//! stack columns are measured by `tests/c_api.rs` and dated in the document.)
#![cfg(feature = "capi")]

use core::mem::size_of;

use flc_core::capi::{FlcDetector, FlcFallback, FlcNeighbours, FlcPid, FlcPursuit, FlcRobust, FlcRobust2, FlcSupervisor};
use flc_core::{
    FallbackController, LeadDetector, NeighbourTracker, PidController, PurePursuit, RobustFallbackController, RobustFallbackController2,
    Supervisor,
};

/// `(Rust type, its size, C storage struct, its size)`, as the table names them.
fn sizes() -> Vec<(&'static str, usize, &'static str, usize)> {
    vec![
        ("FallbackController", size_of::<FallbackController>(), "FlcFallback", size_of::<FlcFallback>()),
        ("RobustFallbackController", size_of::<RobustFallbackController>(), "FlcRobust", size_of::<FlcRobust>()),
        ("RobustFallbackController2", size_of::<RobustFallbackController2>(), "FlcRobust2", size_of::<FlcRobust2>()),
        ("PidController", size_of::<PidController>(), "FlcPid", size_of::<FlcPid>()),
        ("Supervisor", size_of::<Supervisor>(), "FlcSupervisor", size_of::<FlcSupervisor>()),
        ("PurePursuit", size_of::<PurePursuit>(), "FlcPursuit", size_of::<FlcPursuit>()),
        ("LeadDetector", size_of::<LeadDetector>(), "FlcDetector", size_of::<FlcDetector>()),
        ("NeighbourTracker", size_of::<NeighbourTracker>(), "FlcNeighbours", size_of::<FlcNeighbours>()),
    ]
}

/// A number as the document prints it: `51 600 (50.4 KiB)` is 51 600.
fn number(cell: &str) -> usize {
    let digits: String = cell.split('(').next().unwrap_or("").chars().filter(|c| c.is_ascii_digit()).collect();
    digits.parse().unwrap_or_else(|e| panic!("docs/firmware.md: `{cell}` is not a byte count: {e}"))
}

#[test]
fn the_static_memory_table_is_what_size_of_gives() {
    let doc = include_str!("../../../docs/firmware.md");
    let mut wrong = Vec::new();
    let mut checked = 0;
    for (rust, bytes, c, c_bytes) in sizes() {
        let row = doc
            .lines()
            .find(|l| l.starts_with("| ") && l.contains(&format!("| `{rust}` |")))
            .unwrap_or_else(|| panic!("docs/firmware.md: no row for `{rust}`"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        // | controller | Rust type | bytes | C storage | ...
        assert!(cells[4].starts_with(&format!("`{c}` ")), "docs/firmware.md: `{rust}`'s C storage is `{c}`: {row}");
        if number(cells[3]) != bytes || number(&cells[4][c.len() + 2..]) != c_bytes {
            wrong.push(format!("`{rust}` {bytes} bytes (table: {}), `{c}` {c_bytes} (table: {})", cells[3], &cells[4][c.len() + 2..]));
        }
        checked += 1;
    }
    assert!(wrong.is_empty(), "docs/firmware.md's static memory table differs from size_of:\n{}", wrong.join("\n"));
    assert_eq!(checked, 8);
    let kib = size_of::<LeadDetector>() as f64 / 1024.0;
    assert!(doc.contains(&format!("detector {kib:.1} KiB <= 64 KiB")), "docs/firmware.md's claims table: the detector is {kib:.1} KiB");
}
