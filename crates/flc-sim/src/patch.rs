//! The one key-patch mechanism: scenario variants (`[[variants]]`), platoon overrides
//! (`[[platoon.overrides]]`), sweep axes and Python keyword overrides all build a [`Patch`] and
//! apply it here.
//!
//! A patch is a list of dotted keys with values, applied in order to the serialised form of a
//! configuration (its TOML value): `lidar.rate_hz`, `lead.phases[2].decel`. Missing tables on the
//! way are created (so `platoon.followers = 3` adds a `[platoon]` table, and a key of an unset
//! optional value can be set); list items must exist. The result is deserialised again, so an
//! unknown key or a bad value is an error naming the dotted key, exactly as in a scenario file.
//! A table given as a value (`v2v = { loss_prob = 0.5 }`, as in a variant) patches key by key:
//! tables merge, every other value (lists included) is replaced.

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::ConfigError;

/// Dotted keys with values, applied in order (see [`Patch::apply`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Patch {
    entries: Vec<(String, toml::Value)>,
}

/// One segment of a dotted key: a table key with an optional list index (`phases[2]`).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Segment<'a> {
    name: &'a str,
    index: Option<usize>,
}

fn segments(key: &str) -> Result<Vec<Segment<'_>>, ConfigError> {
    if key.is_empty() {
        return Err(ConfigError::new(key, "empty key"));
    }
    key.split('.')
        .map(|part| {
            let (name, index) = match part.split_once('[') {
                Some((n, rest)) => {
                    let i = rest.strip_suffix(']').and_then(|i| i.parse::<usize>().ok());
                    (n, Some(i.ok_or_else(|| ConfigError::new(key, format!("bad list index in `{part}`")))?))
                }
                None => (part, None),
            };
            if name.is_empty() {
                return Err(ConfigError::new(key, "empty key segment"));
            }
            Ok(Segment { name, index })
        })
        .collect()
}

impl Patch {
    /// An empty patch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `key = value` (applied after the entries before it).
    pub fn set(&mut self, key: impl Into<String>, value: toml::Value) -> &mut Self {
        self.entries.push((key.into(), value));
        self
    }

    /// Adds `other`'s entries after these (applied after them: a combination of patches).
    pub fn append(&mut self, other: &Patch) -> &mut Self {
        self.entries.extend(other.entries.iter().cloned());
        self
    }

    /// `key = value` with a JSON value (sweep axes, Python). JSON `null` is an error naming the key.
    pub fn set_json(&mut self, key: impl Into<String>, value: &serde_json::Value) -> Result<&mut Self, ConfigError> {
        let key = key.into();
        let v = toml::Value::try_from(value).map_err(|e| ConfigError::new(key.clone(), format!("cannot be set to {value}: {e}")))?;
        Ok(self.set(key, v))
    }

    /// The patch of a table shaped like the configuration (a variant, a platoon override): each
    /// leaf becomes a dotted key, so tables merge key by key.
    pub fn from_table(table: &toml::Table) -> Self {
        fn walk(prefix: &str, t: &toml::Table, out: &mut Vec<(String, toml::Value)>) {
            for (k, v) in t {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                match v {
                    toml::Value::Table(inner) if !inner.is_empty() => walk(&key, inner, out),
                    toml::Value::Table(_) => {}
                    other => out.push((key, other.clone())),
                }
            }
        }
        let mut entries = Vec::new();
        walk("", table, &mut entries);
        Self { entries }
    }

    /// The dotted keys, in order.
    pub fn keys(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|(k, _)| k.as_str())
    }

    /// The entries, in order.
    pub fn entries(&self) -> impl Iterator<Item = (&str, &toml::Value)> {
        self.entries.iter().map(|(k, v)| (k.as_str(), v))
    }

    /// `true` without entries.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Applies the entries to a TOML value in place.
    pub fn apply_value(&self, root: &mut toml::Value) -> Result<(), ConfigError> {
        for (key, value) in &self.entries {
            let mut node = &mut *root;
            for seg in segments(key)? {
                let table = match node {
                    toml::Value::Table(t) => t,
                    _ => return Err(ConfigError::new(key.clone(), format!("`{}` is inside a value that is not a table", seg.name))),
                };
                node = table.entry(seg.name.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
                if let Some(i) = seg.index {
                    let len = node.as_array().map_or(0, Vec::len);
                    node = node
                        .as_array_mut()
                        .and_then(|a| a.get_mut(i))
                        .ok_or_else(|| ConfigError::new(key.clone(), format!("`{}` has no item {i} (length {len})", seg.name)))?;
                }
            }
            *node = value.clone();
        }
        Ok(())
    }

    /// `base` with the patch applied (serialise, patch, deserialise). Errors name the dotted key.
    pub fn apply<T: Serialize + DeserializeOwned>(&self, base: &T) -> Result<T, ConfigError> {
        let mut value = toml::Value::try_from(base).map_err(|e| ConfigError::new("", e.to_string()))?;
        self.apply_value(&mut value)?;
        serde_path_to_error::deserialize(value).map_err(|e| {
            let path = e.path().to_string();
            let msg = e.into_inner().to_string();
            let msg = msg.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or_default().to_string();
            // Only on an error: the patched value again, to name the entry of a tagged table (no
            // copy of every scenario on the success path, which sweeps take once per run).
            let again = toml::Value::try_from(base).ok().and_then(|mut v| self.apply_value(&mut v).is_ok().then_some(v));
            let path = again.and_then(|v| entry_path(&v, &path, &msg)).unwrap_or(path);
            ConfigError::new(if path == "." { String::new() } else { path }, msg)
        })
    }
}

/// The path of an error inside an internally tagged table (`kind = ...`: tracks, phases,
/// conditions, story elements), made to name the entry. serde buffers such a table before it
/// knows the variant, so `serde_path_to_error` reports the table (`track`) for a bad entry
/// (`track.lanes = inf`). When `msg` quotes the offending value (`invalid type: floating point
/// `inf``) and exactly one entry of the table at `path` in `root` holds it, that entry's path is
/// returned; otherwise `None` (the table's path stays, with toml's line and column).
pub(crate) fn entry_path(root: &toml::Value, path: &str, msg: &str) -> Option<String> {
    let mut node = root;
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (name, mut rest) = part.split_once('[').map_or((part, ""), |(n, r)| (n, r));
        node = node.as_table()?.get(name)?;
        while !rest.is_empty() {
            let (i, tail) = rest.split_once(']')?;
            node = node.as_array()?.get(i.parse::<usize>().ok()?)?;
            rest = tail.strip_prefix('[').unwrap_or(tail);
        }
    }
    let table = node.as_table()?;
    let detail = msg.split_once("invalid type: ").or_else(|| msg.split_once("invalid value: "))?.1;
    let quoted = |open: char, close: char| detail.split_once(open).and_then(|(_, r)| r.split_once(close)).map(|(q, _)| q);
    let matches = |v: &toml::Value| -> bool {
        if detail.starts_with("floating point ") {
            let Some(x) = quoted('`', '`').and_then(|q| q.parse::<f64>().ok()) else { return false };
            v.as_float().is_some_and(|f| f == x || (f.is_nan() && x.is_nan()))
        } else if detail.starts_with("integer ") {
            quoted('`', '`').and_then(|q| q.parse::<i64>().ok()).is_some_and(|x| v.as_integer() == Some(x))
        } else if detail.starts_with("boolean ") {
            quoted('`', '`').and_then(|q| q.parse::<bool>().ok()).is_some_and(|x| v.as_bool() == Some(x))
        } else if detail.starts_with("string ") {
            quoted('"', '"').is_some_and(|x| v.as_str() == Some(x))
        } else {
            false
        }
    };
    let mut hits = table.iter().filter(|(_, v)| matches(v));
    match (hits.next(), hits.next()) {
        (Some((k, _)), None) => Some(if path.is_empty() || path == "." { k.clone() } else { format!("{path}.{k}") }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_appended_patch_applies_after_the_first() {
        let mut a = Patch::new();
        a.set("x", toml::Value::Integer(1)).set("y", toml::Value::Integer(2));
        let mut b = Patch::new();
        b.set("y", toml::Value::Integer(3));
        a.append(&b);
        assert_eq!(a.keys().collect::<Vec<_>>(), ["x", "y", "y"]);
        let mut root = toml::Value::Table(toml::Table::new());
        a.apply_value(&mut root).unwrap();
        assert_eq!((root["x"].as_integer(), root["y"].as_integer()), (Some(1), Some(3)));
    }

    #[test]
    fn errors_inside_tagged_tables_name_the_entry() {
        let root: toml::Value = toml::from_str(
            "[track]\nkind = \"straight\"\nlanes = inf\nlength = 2.0\n[[lead.phases]]\nkind = \"hold\"\nlane = 5\nduration = 5\n",
        )
        .unwrap();
        let found = |path: &str, msg: &str| entry_path(&root, path, msg);
        assert_eq!(found("track", "invalid type: floating point `inf`, expected u32"), Some("track.lanes".into()));
        assert_eq!(found("track", "invalid value: floating point `2.0`, expected u32"), Some("track.length".into()));
        assert_eq!(found("track", "invalid value: string \"straight\", expected x"), Some("track.kind".into()));
        // Two entries hold 5: ambiguous, the table's path stays.
        assert_eq!(found("lead.phases[0]", "invalid type: integer `5`, expected f64"), None);
        assert_eq!(found("lead.phases[0]", "invalid type: integer `6`, expected f64"), None);
        assert_eq!(found("track", "missing field `kind`"), None);
        assert_eq!(found("nowhere[3]", "invalid type: integer `5`, expected f64"), None);
    }

    #[test]
    fn a_scenario_file_error_in_a_tagged_table_names_the_entry() {
        let e = crate::Scenario::from_toml_str(
            "[track]\nkind = \"custom\"\nname = \"r\"\ncenterline = [[0.0, 0.0], [100.0, 0.0]]\nlane_width = 3.5\nlanes = 1.5\n",
            "f.toml",
        )
        .unwrap_err();
        assert!(e.to_string().contains("`track.lanes`"), "{e}");
    }

    #[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        a: f64,
        b: Option<f64>,
        list: Vec<f64>,
    }
    impl Default for Inner {
        fn default() -> Self {
            Self { a: 1.0, b: None, list: vec![1.0, 2.0] }
        }
    }
    #[derive(Debug, Clone, Default, PartialEq, Serialize, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Outer {
        x: f64,
        inner: Inner,
        #[serde(skip_serializing_if = "Option::is_none")]
        opt: Option<Inner>,
    }

    #[test]
    fn dotted_keys_indices_and_missing_tables() {
        let mut p = Patch::new();
        p.set("inner.a", 5.0.into()).set("inner.list[1]", 7.0.into()).set("inner.b", 3.0.into()).set("opt.a", 2.0.into());
        let o = p.apply(&Outer::default()).expect("patch");
        assert_eq!(o.inner, Inner { a: 5.0, b: Some(3.0), list: vec![1.0, 7.0] });
        assert_eq!(o.opt, Some(Inner { a: 2.0, ..Inner::default() }));
    }

    #[test]
    fn errors_name_the_key() {
        let mut p = Patch::new();
        p.set("inner.frobnicate", 1.0.into());
        assert!(p.apply(&Outer::default()).expect_err("unknown").to_string().contains("inner"));
        let mut p = Patch::new();
        p.set("inner.list[5]", 1.0.into());
        assert!(p.apply(&Outer::default()).expect_err("index").to_string().contains("inner.list[5]"));
        let mut p = Patch::new();
        p.set("x.y", 1.0.into());
        assert!(p.apply(&Outer::default()).expect_err("not a table").to_string().contains("x.y"));
        let mut p = Patch::new();
        p.set("inner.a", "fast".into());
        assert!(p.apply(&Outer::default()).expect_err("type").to_string().contains("inner.a"));
        assert!(segments("a.b[x]").is_err() && segments("a..b").is_err() && segments("").is_err());
    }

    #[test]
    fn a_table_patch_merges_key_by_key_and_replaces_lists() {
        let t: toml::Table = "inner = { a = 4.0, list = [9.0] }".parse().expect("toml");
        let p = Patch::from_table(&t);
        assert_eq!(p.keys().collect::<Vec<_>>(), ["inner.a", "inner.list"]);
        let o = p.apply(&Outer { x: 2.0, ..Outer::default() }).expect("patch");
        assert_eq!((o.x, o.inner.a, o.inner.b, o.inner.list), (2.0, 4.0, None, vec![9.0]));
    }
}
