//! What several test crates share: the repository root and the one check of a committed output
//! (goldens, generated doc tables, reference comparisons) against what the code gives now.
//!
//! A difference fails naming the file, its first differing line and `regenerate`, the command
//! that rewrites it. With [`bless_or_compare`], `FLC_BLESS=1` rewrites the committed file; any
//! other value (`FLC_BLESS=0`, empty) or none compares.

// Each test crate that includes this module uses some of it.
#![allow(dead_code)]

pub mod robust;
pub mod two_lanes;

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `true` when `FLC_BLESS=1`: committed outputs are rewritten instead of compared.
pub fn blessing() -> bool {
    std::env::var("FLC_BLESS").is_ok_and(|v| v == "1")
}

/// Compares `actual` with the committed file `path` (relative to the repository root), or writes
/// it when [`blessing`].
pub fn bless_or_compare(path: &str, actual: &str, regenerate: &str) {
    if blessing() {
        let file = repo().join(path);
        if let Some(dir) = file.parent() {
            std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        }
        std::fs::write(&file, actual).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    } else {
        compare(path, actual, regenerate);
    }
}

/// Fails unless the committed file `path` (relative to the repository root) equals `actual`.
pub fn compare(path: &str, actual: &str, regenerate: &str) {
    let expected = std::fs::read_to_string(repo().join(path)).unwrap_or_else(|e| panic!("{path}: {e} (regenerate: {regenerate})"));
    if expected != actual {
        let (el, al): (Vec<&str>, Vec<&str>) = (expected.lines().collect(), actual.lines().collect());
        let first = el.iter().zip(&al).position(|(a, b)| a != b).unwrap_or(el.len().min(al.len()));
        panic!(
            "{path} is stale ({} committed lines, {} now); first difference at line {}:\n committed: {}\n now:       {}\nregenerate: {regenerate}",
            el.len(),
            al.len(),
            first + 1,
            el.get(first).unwrap_or(&"<end>"),
            al.get(first).unwrap_or(&"<end>")
        );
    }
}
