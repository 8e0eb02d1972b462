//! The module graph of every crate in the workspace has no cycle, and flc-sim's modules use only
//! the layers below them (`docs/architecture.md`). Reads the sources: every `crate::module` path
//! (in `use` lines and inline, `$crate::` in macros included; names re-exported at the crate
//! root are traced to their module), outside `#[cfg(test)]` code.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read src dir") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n != "bin") {
                rs_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file belongs to (`None`: the crate root).
fn top_module(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).expect("under src");
    let first = rel.components().next()?.as_os_str().to_string_lossy().into_owned();
    if first == "lib.rs" {
        return None;
    }
    Some(first.trim_end_matches(".rs").to_string())
}

/// The code of a file without comments and without its `#[cfg(test)]` part.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or_default();
    text.lines().map(|l| l.split("//").next().unwrap_or_default()).collect::<Vec<_>>().join("\n")
}

/// Identifiers following `crate::` in `code`.
fn crate_paths(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        if !name.is_empty() {
            out.push(name);
        }
        // `crate::{a, b}`: every name in the braces.
        if let Some(braced) = rest.strip_prefix('{') {
            let inner = braced.split('}').next().unwrap_or_default();
            out.extend(inner.split(',').map(|s| s.trim().split("::").next().unwrap_or_default().to_string()).filter(|s| !s.is_empty()));
        }
    }
    out
}

/// `pub use module::{A, B};` / `pub use module::A;` of the crate root: name -> module.
fn root_reexports(lib: &str) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    for stmt in code(lib).split(';') {
        let stmt = stmt.trim();
        let Some(path) = stmt.strip_prefix("pub use ") else { continue };
        let Some((module, names)) = path.split_once("::") else { continue };
        let names = names.trim_start_matches('{').trim_end_matches('}');
        for n in names.split(',') {
            let n = n.trim();
            let n = n.rsplit(" as ").next().unwrap_or(n).rsplit("::").next().unwrap_or(n);
            if !n.is_empty() {
                map.insert(n.to_string(), module.trim().to_string());
            }
        }
    }
    map
}

/// Edges `module -> module it uses` between the top-level modules of the crate at `src`.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rs_files(src, &mut files);
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("lib.rs");
    let reexports = root_reexports(&lib);
    let modules: BTreeSet<String> = files.iter().filter_map(|f| top_module(src, f)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for f in &files {
        let Some(from) = top_module(src, f) else { continue };
        let text = std::fs::read_to_string(f).expect("read");
        for name in crate_paths(&code(&text)) {
            let to = if modules.contains(&name) { Some(name) } else { reexports.get(&name).cloned() };
            if let Some(to) = to.filter(|t| *t != from) {
                g.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    g
}

/// A cycle of `g`, if any (as the list of modules on it).
fn find_cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = stack.iter().position(|s| s == m).unwrap_or(0);
                    let mut c = stack[start..].to_vec();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(m, g, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in g.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            let mut stack = Vec::new();
            if let Some(c) = visit(n, g, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

fn crate_src(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name).join("src")
}

/// Only the OpenSCENARIO importer knows XML exists: no other module of flc-sim names the XML
/// crate (the model, the loop and the sinks see `Scenario` only).
#[test]
fn only_the_importer_reads_xml() {
    let src = crate_src("flc-sim");
    let mut files = Vec::new();
    rs_files(&src, &mut files);
    for f in files {
        let rel = f.strip_prefix(&src).expect("under src");
        if rel.starts_with("openscenario") {
            continue;
        }
        let text = std::fs::read_to_string(&f).expect("read");
        assert!(!code(&text).contains("roxmltree"), "{} uses the XML reader: only `openscenario` may", rel.display());
    }
}

#[test]
fn no_crate_has_an_import_cycle() {
    for krate in ["flc-core", "flc-sim", "flc-py"] {
        let g = graph(&crate_src(krate));
        if let Some(c) = find_cycle(&g) {
            panic!("{krate}: import cycle {}", c.join(" -> "));
        }
    }
}

/// flc-sim's layers, lowest first (`docs/architecture.md`); a module may use its own layer and
/// the layers below.
const SIM_LAYERS: &[&[&str]] = &[
    &["error", "units", "noise"],
    &["track", "world", "vehicle", "lidar", "gap_sensor", "gnss", "v2v", "trigger", "lead", "story"],
    &["series", "metrics"],
    &["patch", "controllers", "no_target", "follower", "platoon", "scenario", "paper", "presets", "string_stability", "openscenario"],
    &["sim", "external"],
    &["record", "trajectory", "report", "paper_verdict", "svg"],
    &["runner", "gym"],
    &["sweep", "suite", "frequency_response", "detection_study", "cut_in_grid", "neighbour_traffic"],
    &["stream"],
];

#[test]
fn flc_sim_modules_use_only_lower_layers() {
    let layer_of = |m: &str| SIM_LAYERS.iter().position(|l| l.contains(&m));
    let g = graph(&crate_src("flc-sim"));
    for (from, tos) in &g {
        let lf = layer_of(from)
            .unwrap_or_else(|| panic!("module `{from}` is not in SIM_LAYERS (add it to its layer and to docs/architecture.md)"));
        for to in tos {
            let lt = layer_of(to).unwrap_or_else(|| panic!("module `{to}` is not in SIM_LAYERS"));
            assert!(lt <= lf, "`{from}` (layer {lf}) uses `{to}` (layer {lt}, above it)");
        }
    }
}

#[test]
fn the_checker_sees_cycles_and_reexports() {
    // A hand-made graph with a cycle, and the path parser on the shapes used in the crates.
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    g.entry("c".into()).or_default().insert("a".into());
    assert_eq!(find_cycle(&g).map(|c| c.len()), Some(4));
    g.get_mut("c").map(|s| s.remove("a"));
    assert!(find_cycle(&g).is_none());
    let paths = crate_paths("use crate::{a::X, b};\nlet y = crate::c::f(); $crate::d::g();");
    assert_eq!(paths, ["a", "b", "c", "d"]);
    let r = root_reexports("pub use sim::{Observer, Simulation};\npub use units::KMH;\nmod x;");
    assert_eq!(r.get("Observer").map(String::as_str), Some("sim"));
    assert_eq!(r.get("KMH").map(String::as_str), Some("units"));
}
