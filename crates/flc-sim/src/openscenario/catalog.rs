//! Catalogs: the directories of `CatalogLocations`, their `*.xosc` catalog files (read lazily,
//! the first time a `CatalogReference` needs a catalog of that kind, and found by the root
//! `Catalog@name`), and the `ParameterAssignments` of a `CatalogReference`.
//!
//! Only the files directly in a named directory are read (no recursion, no file whose canonical
//! path lies elsewhere, e.g. through a symbolic link), at most [`MAX_CATALOG_FILES`] files and
//! [`MAX_CATALOG_BYTES`] bytes in all. Reference cycles and nesting deeper than [`MAX_DEPTH`] are
//! caught by the importer's reference stack (`Ctx::catalog_entry` in the parent module).

use std::cell::{Cell, OnceCell};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::error::ImportError;
use super::params::Params;
use super::xml;

/// Most catalog files listed over all catalog directories.
pub const MAX_CATALOG_FILES: usize = 256;
/// Most bytes read from catalog files in all.
pub const MAX_CATALOG_BYTES: u64 = 64 * 1024 * 1024;
/// Deepest nesting of catalog references (an entry referring to another entry, ...).
pub const MAX_DEPTH: usize = 8;
/// Most directory entries looked at per catalog directory.
const MAX_DIR_ENTRIES: usize = 10_000;

/// The children of `CatalogLocations` (OpenSCENARIO 1.0-1.3).
pub const KINDS: [&str; 8] = [
    "VehicleCatalog",
    "ControllerCatalog",
    "PedestrianCatalog",
    "MiscObjectCatalog",
    "EnvironmentCatalog",
    "ManeuverCatalog",
    "TrajectoryCatalog",
    "RouteCatalog",
];

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// One listed catalog file (its text read on first use).
#[derive(Debug)]
struct CatalogFile {
    path: PathBuf,
    /// The location kinds whose directory holds it.
    kinds: Vec<&'static str>,
    text: OnceCell<String>,
}

/// The catalog files named by a scenario's `CatalogLocations`, listed (not read).
#[derive(Debug, Default)]
pub struct CatalogFiles {
    files: Vec<CatalogFile>,
    /// `(kind, directory as written, found)` of every location, for error messages.
    dirs: Vec<(&'static str, String, bool)>,
}

impl CatalogFiles {
    /// No catalogs.
    pub fn empty() -> Self {
        Self::default()
    }

    /// Lists the `*.xosc` files of every `Directory` of `locations` (a `CatalogLocations`
    /// element of `file`), relative to `base` (the scenario's folder). A directory that does not
    /// exist is remembered (and named when a reference cannot be found); an element that is not
    /// a catalog location is an error.
    pub fn list(locations: Node<'_, '_>, base: &Path, params: &Params, file: &str) -> Result<Self, ImportError> {
        let mut out = Self::default();
        let mut by_path: BTreeMap<PathBuf, usize> = BTreeMap::new();
        for loc in xml::elements(locations) {
            let name = loc.tag_name().name();
            let Some(&kind) = KINDS.iter().find(|k| **k == name) else {
                return Err(ImportError::unsupported(file, loc));
            };
            for dir in xml::elements(loc) {
                if dir.tag_name().name() != "Directory" {
                    return Err(ImportError::unsupported(file, dir));
                }
                let raw = params.req_str(dir, "path", file)?;
                let joined = base.join(raw.trim());
                let Ok(canon) = joined.canonicalize() else {
                    out.dirs.push((kind, raw, false));
                    continue;
                };
                if !canon.is_dir() {
                    return Err(ImportError::at(file, dir, format!("catalog directory `{raw}` is not a directory")));
                }
                out.dirs.push((kind, raw.clone(), true));
                let entries =
                    std::fs::read_dir(&canon).map_err(|e| ImportError::at(file, dir, format!("catalog directory `{raw}`: {e}")))?;
                let mut paths = Vec::new();
                for (n, entry) in entries.enumerate() {
                    if n >= MAX_DIR_ENTRIES {
                        return Err(ImportError::at(
                            file,
                            dir,
                            format!("catalog directory `{raw}` has more than {MAX_DIR_ENTRIES} entries"),
                        ));
                    }
                    let Ok(entry) = entry else { continue };
                    let p = entry.path();
                    if p.extension().and_then(|e| e.to_str()) != Some("xosc") {
                        continue;
                    }
                    // Only regular files that really are in this directory.
                    match p.canonicalize() {
                        Ok(c) if c.is_file() && c.parent() == Some(canon.as_path()) => paths.push(c),
                        _ => {}
                    }
                }
                paths.sort();
                for p in paths {
                    match by_path.get(&p) {
                        Some(&i) => {
                            if let Some(f) = out.files.get_mut(i) {
                                if !f.kinds.contains(&kind) {
                                    f.kinds.push(kind);
                                }
                            }
                        }
                        None => {
                            if out.files.len() >= MAX_CATALOG_FILES {
                                return Err(ImportError::at(file, dir, format!("more than {MAX_CATALOG_FILES} catalog files")));
                            }
                            by_path.insert(p.clone(), out.files.len());
                            out.files.push(CatalogFile { path: p, kinds: vec![kind], text: OnceCell::new() });
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    /// Number of listed files.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.files.len()
    }
}

/// The parsed catalog files (parsed on first use).
pub struct Catalogs<'t> {
    files: &'t CatalogFiles,
    docs: Vec<OnceCell<roxmltree::Document<'t>>>,
    bytes: Cell<u64>,
}

impl<'t> Catalogs<'t> {
    /// The documents of `files`, none parsed yet.
    pub fn new(files: &'t CatalogFiles) -> Self {
        Self { files, docs: files.files.iter().map(|_| OnceCell::new()).collect(), bytes: Cell::new(0) }
    }

    /// Document `i`, read and parsed on first use (within [`MAX_CATALOG_BYTES`] in all).
    fn doc(&self, i: usize) -> Result<Option<&roxmltree::Document<'t>>, ImportError> {
        let (Some(cell), Some(f)) = (self.docs.get(i), self.files.files.get(i)) else { return Ok(None) };
        if let Some(d) = cell.get() {
            return Ok(Some(d));
        }
        let origin = f.path.display().to_string();
        let text: &'t String = match f.text.get() {
            Some(t) => t,
            None => {
                let len = std::fs::metadata(&f.path).map(|m| m.len()).unwrap_or(0);
                let total = self.bytes.get().saturating_add(len);
                if total > MAX_CATALOG_BYTES {
                    return Err(ImportError::file(&origin, format!("catalog files larger than {MAX_CATALOG_BYTES} bytes in all")));
                }
                let t = xml::read(&f.path)?;
                self.bytes.set(self.bytes.get().saturating_add(t.len() as u64));
                let _ = f.text.set(t);
                match f.text.get() {
                    Some(t) => t,
                    None => return Ok(None),
                }
            }
        };
        let doc = xml::parse(text, &origin)?;
        let _ = cell.set(doc);
        Ok(cell.get())
    }

    /// The entry `entry` of the catalog named `catalog`: the file and the element. Files of the
    /// location kinds `kinds` are searched first, then the others (a catalog is found by its
    /// name, whatever directory holds it). `Ok(None)`: not found.
    pub fn find(&self, kinds: &[&str], catalog: &str, entry: &str) -> Result<Option<(String, Node<'_, 't>)>, ImportError> {
        let preferred = |f: &CatalogFile| f.kinds.iter().any(|k| kinds.contains(k));
        let order: Vec<usize> = (0..self.files.files.len())
            .filter(|&i| self.files.files.get(i).is_some_and(preferred))
            .chain((0..self.files.files.len()).filter(|&i| !self.files.files.get(i).is_some_and(preferred)))
            .collect();
        for i in order {
            let Some(doc) = self.doc(i)? else { continue };
            let root = doc.root_element();
            let Some(cat) = xml::children(root, "Catalog").find(|c| c.attribute("name") == Some(catalog)) else { continue };
            if let Some(e) = xml::elements(cat).find(|e| e.attribute("name") == Some(entry)) {
                let path = self.files.files.get(i).map(|f| f.path.display().to_string()).unwrap_or_default();
                return Ok(Some((path, e)));
            }
        }
        Ok(None)
    }

    /// Why an entry could not be found (the directories searched).
    pub fn not_found(&self, catalog: &str, entry: &str) -> String {
        let dirs: Vec<String> = self
            .files
            .dirs
            .iter()
            .map(|(k, d, found)| if *found { format!("{k} `{d}`") } else { format!("{k} `{d}` (does not exist)") })
            .collect();
        if dirs.is_empty() {
            format!("no entry `{entry}` in catalog `{catalog}`: the scenario has no CatalogLocations")
        } else {
            format!("no entry `{entry}` in catalog `{catalog}` (searched {})", dirs.join(", "))
        }
    }
}

/// The `ParameterAssignments` of the `CatalogReference` `reference` of `file`: parameter name
/// (written with or without `$`) -> value text, each value resolved in the scope of the
/// reference (`params`). A name assigned twice is an error.
pub fn assignments(params: &Params, reference: Node<'_, '_>, file: &str) -> Result<BTreeMap<String, String>, ImportError> {
    let mut out = BTreeMap::new();
    for c in xml::elements(reference) {
        if c.tag_name().name() != "ParameterAssignments" {
            return Err(ImportError::unsupported(file, c));
        }
        for a in xml::elements(c) {
            if a.tag_name().name() != "ParameterAssignment" {
                return Err(ImportError::unsupported(file, a));
            }
            let name = params.req_str(a, "parameterRef", file)?;
            let name = name.trim().trim_start_matches('$').to_string();
            let value = params.req_str(a, "value", file)?;
            if out.insert(name.clone(), value).is_some() {
                return Err(ImportError::at(file, a, format!("parameter `{name}` assigned twice")));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("flc-osc-catalog-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("cats")).expect("mkdir");
        d
    }

    #[test]
    fn lists_lazily_and_finds_entries_by_catalog_name() {
        let d = tmpdir("find");
        std::fs::write(
            d.join("cats/v.xosc"),
            "<OpenSCENARIO><Catalog name=\"Cars\"><Vehicle name=\"a\"/><Vehicle name=\"b\"/></Catalog></OpenSCENARIO>",
        )
        .expect("write");
        std::fs::write(d.join("cats/broken.xosc"), "<OpenSCENARIO>").expect("write");
        std::fs::write(d.join("cats/readme.txt"), "not a catalog").expect("write");
        let loc = "<CatalogLocations><VehicleCatalog><Directory path=\"cats\"/></VehicleCatalog>\
                   <ManeuverCatalog><Directory path=\"missing\"/></ManeuverCatalog></CatalogLocations>";
        let doc = xml::parse(loc, "s.xosc").expect("xml");
        let files = CatalogFiles::list(doc.root_element(), &d, &Params::new(), "s.xosc").expect("list");
        assert_eq!(files.len(), 2);
        let cats = Catalogs::new(&files);
        // broken.xosc sorts first and is parsed first: its error is reported.
        let e = cats.find(&["VehicleCatalog"], "Cars", "b").expect_err("broken file");
        assert!(e.to_string().contains("broken.xosc"), "{e}");
        std::fs::remove_file(d.join("cats/broken.xosc")).expect("rm");
        let files = CatalogFiles::list(doc.root_element(), &d, &Params::new(), "s.xosc").expect("list");
        let cats = Catalogs::new(&files);
        let (path, node) = cats.find(&["VehicleCatalog"], "Cars", "b").expect("find").expect("found");
        assert!(path.ends_with("v.xosc"));
        assert_eq!(node.attribute("name"), Some("b"));
        assert!(cats.find(&[], "Cars", "zz").expect("find").is_none());
        let msg = cats.not_found("Cars", "zz");
        assert!(msg.contains("`missing` (does not exist)"), "{msg}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn assignments_resolve_in_the_outer_scope() {
        let doc = xml::parse(
            "<R><ParameterDeclarations><ParameterDeclaration name=\"L\" parameterType=\"double\" value=\"5\"/></ParameterDeclarations>\
             <CatalogReference catalogName=\"c\" entryName=\"e\"><ParameterAssignments>\
             <ParameterAssignment parameterRef=\"Length\" value=\"${$L + 1}\"/></ParameterAssignments></CatalogReference></R>",
            "s.xosc",
        )
        .expect("xml");
        let root = doc.root_element();
        let mut p = Params::new();
        p.declare_in(root, "s.xosc", &BTreeMap::new()).expect("declare");
        let r = xml::child(root, "CatalogReference").expect("ref");
        let a = assignments(&p, r, "s.xosc").expect("assign");
        assert_eq!(a.get("Length").map(String::as_str), Some("6"));
    }
}
