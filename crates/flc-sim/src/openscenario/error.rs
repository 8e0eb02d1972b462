//! The importer's one error type: file, line, element and reason. It depends on no other
//! importer module (`xml` reads files into documents and reports through it, not the reverse).

use thiserror::Error;

/// An OpenSCENARIO / OpenDRIVE file (or one it references) was rejected. Printed as one line:
/// `FILE:LINE: <Element>: reason` (line 0: the file as a whole).
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{file}:{line}: <{element}>: {message}")]
pub struct ImportError {
    /// The file, as given or as resolved from the referencing file.
    pub file: String,
    /// 1-based line of the element (0: the file as a whole).
    pub line: u32,
    /// The element's tag name (or attribute path such as `SpeedAction@rate`).
    pub element: String,
    /// What is wrong.
    pub message: String,
}

impl ImportError {
    /// An error about the file as a whole (unreadable, too large, not XML).
    pub fn file(file: &str, message: impl Into<String>) -> Self {
        Self { file: file.to_string(), line: 0, element: "file".into(), message: message.into() }
    }

    /// An error at `node` of a document parsed from `file`.
    pub fn at(file: &str, node: roxmltree::Node<'_, '_>, message: impl Into<String>) -> Self {
        Self { file: file.to_string(), line: line(node), element: node.tag_name().name().to_string(), message: message.into() }
    }

    /// The standard "not supported" error of an element that would change motion.
    pub fn unsupported(file: &str, node: roxmltree::Node<'_, '_>) -> Self {
        Self::at(file, node, "unsupported element (it would change motion or sensing; docs/openscenario.md lists what is supported)")
    }
}

/// 1-based line of `node` in its document.
pub fn line(node: roxmltree::Node<'_, '_>) -> u32 {
    node.document().text_pos_at(node.range().start).row
}
