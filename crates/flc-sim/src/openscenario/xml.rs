//! Safe reading of XML files: bounded size, no DTD (so no external or expanding entities),
//! bounded node count and nesting depth. Every other importer module reads XML through here.

use std::path::Path;

use super::error::ImportError;

/// Largest file read, bytes.
pub const MAX_BYTES: u64 = 32 * 1024 * 1024;
/// Largest number of XML nodes in one file.
pub const MAX_NODES: u32 = 2_000_000;
/// Deepest element nesting in one file.
pub const MAX_DEPTH: usize = 64;

/// Reads `path` as UTF-8 text of at most [`MAX_BYTES`]; `origin` names it in errors.
pub fn read(path: &Path) -> Result<String, ImportError> {
    let origin = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| ImportError::file(&origin, e.to_string()))?;
    if !meta.is_file() {
        return Err(ImportError::file(&origin, "not a regular file"));
    }
    if meta.len() > MAX_BYTES {
        return Err(ImportError::file(&origin, format!("file is {} bytes, more than the limit of {MAX_BYTES}", meta.len())));
    }
    let bytes = std::fs::read(path).map_err(|e| ImportError::file(&origin, e.to_string()))?;
    String::from_utf8(bytes).map_err(|_| ImportError::file(&origin, "not UTF-8 text"))
}

/// Parses `text` (from `origin`): DTDs are refused, at most [`MAX_NODES`] nodes and
/// [`MAX_DEPTH`] levels of elements.
pub fn parse<'a>(text: &'a str, origin: &str) -> Result<roxmltree::Document<'a>, ImportError> {
    if text.len() as u64 > MAX_BYTES {
        return Err(ImportError::file(origin, format!("text is {} bytes, more than the limit of {MAX_BYTES}", text.len())));
    }
    let opts = roxmltree::ParsingOptions { allow_dtd: false, nodes_limit: MAX_NODES, ..roxmltree::ParsingOptions::default() };
    let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
        let pos = e.pos();
        let message = match e {
            roxmltree::Error::DtdDetected => {
                "a DTD (<!DOCTYPE ...>) is not accepted: no entity declarations, no external entities".to_string()
            }
            roxmltree::Error::NodesLimitReached => format!("more than {MAX_NODES} XML nodes"),
            other => format!("not well-formed XML: {other}"),
        };
        ImportError { file: origin.to_string(), line: pos.row, element: "xml".into(), message }
    })?;
    // Nesting depth, iteratively (no recursion on hostile input).
    let mut stack = vec![(doc.root(), 0usize)];
    while let Some((n, d)) = stack.pop() {
        if d > MAX_DEPTH {
            return Err(ImportError::at(origin, n, format!("elements nested deeper than {MAX_DEPTH} levels")));
        }
        stack.extend(n.children().filter(|c| c.is_element()).map(|c| (c, d + 1)));
    }
    Ok(doc)
}

pub use super::error::line;

/// The element children of `node` named `name`.
pub fn children<'a, 'input>(node: roxmltree::Node<'a, 'input>, name: &'a str) -> impl Iterator<Item = roxmltree::Node<'a, 'input>> + 'a {
    node.children().filter(move |c| c.is_element() && c.tag_name().name() == name)
}

/// The first element child of `node` named `name`.
pub fn child<'a, 'input>(node: roxmltree::Node<'a, 'input>, name: &str) -> Option<roxmltree::Node<'a, 'input>> {
    node.children().find(|c| c.is_element() && c.tag_name().name() == name)
}

/// The element children of `node`.
pub fn elements<'a, 'input>(node: roxmltree::Node<'a, 'input>) -> impl Iterator<Item = roxmltree::Node<'a, 'input>> + 'a {
    node.children().filter(|c| c.is_element())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_dtd_and_deep_nesting() {
        let e = parse("<?xml version=\"1.0\"?>\n<!DOCTYPE a [<!ENTITY x \"y\">]>\n<a>&x;</a>", "f.xosc").expect_err("dtd");
        assert!(e.to_string().contains("DTD"), "{e}");
        let deep = "<a>".repeat(MAX_DEPTH + 2) + &"</a>".repeat(MAX_DEPTH + 2);
        let e = parse(&deep, "f.xosc").expect_err("deep");
        assert!(e.to_string().contains("nested"), "{e}");
        let e = parse("<a>\n<b></a>", "f.xosc").expect_err("broken");
        assert!(e.to_string().starts_with("f.xosc:2:"), "{e}");
        let doc = parse("<a>\n <b x=\"1\"/>\n</a>", "f.xosc").expect("ok");
        let b = child(doc.root_element(), "b").expect("b");
        assert_eq!(line(b), 2);
    }
}
