//! Parameters of an OpenSCENARIO file: `ParameterDeclarations` (typed, with `ConstraintGroup`s),
//! overrides (`--param`, a distribution run, a catalog reference's `ParameterAssignments`),
//! scopes (the file, then a catalog entry while it is read), the resolution of attribute values
//! (`$name`, `${expr}`, literal text) and typed attribute getters whose errors name the file,
//! the line and `Element@attribute`. Also `VariableDeclarations` (OpenSCENARIO 1.2).

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;

use super::error::ImportError;
use super::expr::{self, Value};
use super::xml;

/// Longest `string`/`dateTime` parameter or variable value, bytes (every `$name` reference
/// copies the value, so a huge one referenced many times would multiply memory).
pub const MAX_TEXT: usize = 4096;

/// The declared type of a parameter or variable (`parameterType` / `variableType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamType {
    /// `double`: a finite number.
    Double,
    /// `integer` (also the deprecated `int`): a whole number in the range of a 32-bit signed integer.
    Integer,
    /// `unsignedInt`: a whole number in `0..=4294967295`.
    UnsignedInt,
    /// `unsignedShort`: a whole number in `0..=65535`.
    UnsignedShort,
    /// `boolean`: `true` or `false`.
    Boolean,
    /// `string`: any text.
    String,
    /// `dateTime`: an ISO 8601 date and time (`YYYY-MM-DDThh:mm:ss`, then optional fraction and
    /// zone; at most 64 bytes), kept as text.
    DateTime,
}

impl ParamType {
    /// The type named `name` in a file (`double`, `integer`, `int`, `unsignedInt`,
    /// `unsignedShort`, `boolean`, `string`, `dateTime`).
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "double" => Self::Double,
            "integer" | "int" => Self::Integer,
            "unsignedInt" => Self::UnsignedInt,
            "unsignedShort" => Self::UnsignedShort,
            "boolean" => Self::Boolean,
            "string" => Self::String,
            "dateTime" => Self::DateTime,
            _ => return None,
        })
    }

    /// The type's name as the standard spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Double => "double",
            Self::Integer => "integer",
            Self::UnsignedInt => "unsignedInt",
            Self::UnsignedShort => "unsignedShort",
            Self::Boolean => "boolean",
            Self::String => "string",
            Self::DateTime => "dateTime",
        }
    }

    fn is_numeric(self) -> bool {
        matches!(self, Self::Double | Self::Integer | Self::UnsignedInt | Self::UnsignedShort)
    }

    /// Converts `v` (a resolved value or literal text) to this type: numbers must be finite,
    /// whole numbers whole and in range (`2.5` is not an `integer`), booleans `true`/`false`;
    /// a number or boolean given for a `string` becomes its text.
    pub fn convert(self, v: Value) -> Result<Value, String> {
        match self {
            Self::Double | Self::Integer | Self::UnsignedInt | Self::UnsignedShort => {
                let x = match v {
                    Value::Num(x) => x,
                    Value::Str(s) => parse_num(&s)?,
                    Value::Bool(b) => return Err(format!("a boolean ({b}) is not a {}", self.name())),
                };
                if !x.is_finite() {
                    return Err(format!("{x} is not a finite number"));
                }
                let (lo, hi) = match self {
                    Self::Double => return Ok(Value::Num(x)),
                    Self::Integer => (f64::from(i32::MIN), f64::from(i32::MAX)),
                    Self::UnsignedInt => (0.0, f64::from(u32::MAX)),
                    _ => (0.0, f64::from(u16::MAX)),
                };
                if x.fract() != 0.0 {
                    return Err(format!("{x} is not a whole number ({} expected)", self.name()));
                }
                if x < lo || x > hi {
                    return Err(format!("{x} is outside the range of {} ({lo}..={hi})", self.name()));
                }
                Ok(Value::Num(x))
            }
            Self::Boolean => match v {
                Value::Bool(b) => Ok(Value::Bool(b)),
                Value::Str(s) => match s.trim() {
                    "true" => Ok(Value::Bool(true)),
                    "false" => Ok(Value::Bool(false)),
                    other => Err(format!("`{other}` is not a boolean (true or false)")),
                },
                Value::Num(x) => Err(format!("a number ({x}) is not a boolean")),
            },
            Self::String => {
                let s = v.to_string();
                if s.len() > MAX_TEXT {
                    return Err(format!("a text of {} bytes is longer than the limit of {MAX_TEXT}", s.len()));
                }
                Ok(Value::Str(s))
            }
            Self::DateTime => match v {
                Value::Str(s) if s.trim().len() <= 64 && is_date_time(s.trim()) => Ok(Value::Str(s.trim().to_string())),
                other => Err(format!("`{other}` is not a dateTime (YYYY-MM-DDThh:mm:ss)")),
            },
        }
    }
}

/// A finite number written as text (surrounding white space allowed).
fn parse_num(s: &str) -> Result<f64, String> {
    let t = s.trim();
    match t.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(format!("`{t}` is not a finite number")),
        Err(_) => Err(format!("`{t}` is not a number")),
    }
}

/// `YYYY-MM-DDThh:mm:ss` followed by anything (fraction, zone).
fn is_date_time(s: &str) -> bool {
    let b = s.as_bytes();
    let pattern = b"dddd-dd-ddTdd:dd:dd";
    b.len() >= pattern.len() && pattern.iter().zip(b).all(|(p, c)| if *p == b'd' { c.is_ascii_digit() } else { p == c })
}

/// One declared parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Name, without `$`.
    pub name: String,
    /// Declared type.
    pub ty: ParamType,
    /// Value, converted to `ty` (numbers as [`Value::Num`], `string`/`dateTime` as [`Value::Str`]).
    pub value: Value,
}

impl Param {
    /// The value as JSON, typed by its declaration: whole-number types as integers, `double` as
    /// a number, `boolean` as a boolean, `string` and `dateTime` as text.
    pub fn to_json(&self) -> serde_json::Value {
        match (&self.value, self.ty) {
            (Value::Num(x), ParamType::Integer | ParamType::UnsignedInt | ParamType::UnsignedShort) => serde_json::Value::from(*x as i64),
            (Value::Num(x), _) => serde_json::Value::from(*x),
            (Value::Bool(b), _) => serde_json::Value::Bool(*b),
            (Value::Str(s), _) => serde_json::Value::String(s.clone()),
        }
    }
}

#[derive(Debug, Clone, Default)]
struct Scope {
    params: Vec<Param>,
    index: BTreeMap<String, usize>,
}

impl Scope {
    fn get(&self, name: &str) -> Option<&Param> {
        self.index.get(name).and_then(|&i| self.params.get(i))
    }
}

/// The parameters in force: a stack of scopes (the file's, then a catalog entry's while it is
/// read); a name is looked up from the innermost scope outwards.
#[derive(Debug, Clone, Default)]
pub struct Params {
    file: Scope,
    inner: Vec<Scope>,
    /// `--strict`: what esmini accepts but the standard does not (its expression extensions, a
    /// value its declaration's constraints forbid) is an error instead of a warning.
    strict: bool,
    /// Warning lines about such uses, keyed (one per kind), for [`Params::take_notes`].
    notes: RefCell<BTreeMap<String, String>>,
}

/// The (case-sensitive) rules of a `ValueConstraint`.
const RULES: [&str; 6] = ["equalTo", "notEqualTo", "greaterThan", "greaterOrEqual", "lessThan", "lessOrEqual"];

impl Params {
    /// No parameters; one (file) scope.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets `--strict` (see [`Params::strict`]).
    pub fn set_strict(&mut self, strict: bool) {
        self.strict = strict;
    }

    /// Whether esmini's extensions of the standard are refused (`--strict`) rather than
    /// accepted with a warning.
    pub fn strict(&self) -> bool {
        self.strict
    }

    /// The warning lines gathered so far (key, line; one per key, the first kept), emptied.
    pub fn take_notes(&self) -> Vec<(String, String)> {
        std::mem::take(&mut *self.notes.borrow_mut()).into_iter().collect()
    }

    /// Attribute `attr` of `node` (text `raw`) used the esmini extensions `ext`: an error with
    /// `--strict`, else one warning line per extension.
    fn extensions(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str, raw: &str, ext: &[&str]) -> Result<(), ImportError> {
        for e in ext {
            let what = if *e == "pi" { "the constant `pi`".to_string() } else { format!("the function `{e}`") };
            if self.strict {
                return Err(attr_error(
                    node,
                    attr,
                    file,
                    format!("`{raw}` uses {what}, an esmini extension, not OpenSCENARIO (refused with --strict)"),
                ));
            }
            let line = format!(
                "{file}:{}: <{}@{attr}>: `{raw}` uses {what}: an esmini extension, not OpenSCENARIO; evaluated as esmini does (--strict refuses it)",
                xml::line(node),
                node.tag_name().name()
            );
            self.notes.borrow_mut().entry(format!("expr:{e}")).or_insert(line);
        }
        Ok(())
    }

    /// Opens an inner scope (a catalog entry's parameters) on top of the current ones.
    pub fn push_scope(&mut self) {
        self.inner.push(Scope::default());
    }

    /// Closes the innermost scope; the file scope is never closed (returns `false` then).
    pub fn pop_scope(&mut self) -> bool {
        self.inner.pop().is_some()
    }

    /// The parameter `name` (without `$`), innermost scope first.
    pub fn get(&self, name: &str) -> Option<&Param> {
        self.inner.iter().rev().chain(std::iter::once(&self.file)).find_map(|s| s.get(name))
    }

    /// The value of the parameter `name` (without `$`), innermost scope first.
    pub fn value(&self, name: &str) -> Option<&Value> {
        self.get(name).map(|p| &p.value)
    }

    /// Every parameter in force, outer scopes first, each scope in declaration order (a name
    /// shadowed by an inner scope appears twice).
    pub fn iter(&self) -> impl Iterator<Item = &Param> {
        std::iter::once(&self.file).chain(self.inner.iter()).flat_map(|s| s.params.iter())
    }

    /// Reads the `ParameterDeclarations` element `decls` of `file` into the innermost scope, in
    /// order: each `ParameterDeclaration name parameterType value`, the value being literal
    /// text, `$other` or `${expr}` over parameters declared before (in this or an outer scope).
    /// An entry of `overrides` (parameter name -> value text, taken literally) replaces the
    /// declared value of that name; an override of a name this element does not declare is an
    /// error. Values are converted to the declared type and checked against the declaration's
    /// `ConstraintGroup`s (a group holds when all its `ValueConstraint`s do; the value must
    /// satisfy at least one group). Errors name the file, line, element and parameter.
    pub fn declare(&mut self, decls: roxmltree::Node<'_, '_>, file: &str, overrides: &BTreeMap<String, String>) -> Result<(), ImportError> {
        if decls.tag_name().name() != "ParameterDeclarations" {
            return Err(ImportError::at(file, decls, "expected <ParameterDeclarations>"));
        }
        let mut used = 0usize;
        for d in xml::elements(decls) {
            if d.tag_name().name() != "ParameterDeclaration" {
                return Err(ImportError::at(file, d, "unexpected element in <ParameterDeclarations>"));
            }
            let name = d.attribute("name").unwrap_or_default();
            if name.is_empty() || name.starts_with('$') {
                return Err(ImportError::at(file, d, format!("parameter name `{name}` must be non-empty and written without `$`")));
            }
            let fail = |m: String| ImportError::at(file, d, format!("parameter `{name}`: {m}"));
            let ty_name = d.attribute("parameterType").ok_or_else(|| fail("attribute `parameterType` is missing".into()))?;
            let ty = ParamType::parse(ty_name).ok_or_else(|| fail(format!("unknown parameterType `{ty_name}`")))?;
            if self.inner.last().unwrap_or(&self.file).index.contains_key(name) {
                return Err(fail("declared twice in the same scope".into()));
            }
            let value = match overrides.get(name) {
                Some(text) => {
                    used += 1;
                    ty.convert(Value::Str(text.clone())).map_err(|m| fail(format!("value `{text}` given for it: {m}")))?
                }
                None => {
                    let raw = d.attribute("value").ok_or_else(|| fail("attribute `value` is missing".into()))?;
                    let (v, ext) = self.resolve_excluding(raw, Some(name)).map_err(fail)?;
                    self.extensions(d, "value", file, raw, &ext)?;
                    ty.convert(v).map_err(|m| fail(format!("value `{raw}`: {m}")))?
                }
            };
            self.check_constraints(d, file, name, ty, &value)?;
            let scope = self.innermost();
            scope.index.insert(name.to_string(), scope.params.len());
            scope.params.push(Param { name: name.to_string(), ty, value });
        }
        if used < overrides.len() {
            let declared = |k: &str| xml::children(decls, "ParameterDeclaration").any(|d| d.attribute("name") == Some(k));
            let missing: Vec<String> = overrides.keys().filter(|k| !declared(k)).map(|k| format!("`{k}`")).collect();
            return Err(ImportError::at(
                file,
                decls,
                format!(
                    "parameter(s) {} given a value (--param, distribution or ParameterAssignment) but not declared here",
                    missing.join(", ")
                ),
            ));
        }
        Ok(())
    }

    /// [`Params::declare`] on the `ParameterDeclarations` child of `parent` (a scenario root, a
    /// catalog entry, ...); without one, any override is an error (nothing is declared).
    pub fn declare_in(
        &mut self,
        parent: roxmltree::Node<'_, '_>,
        file: &str,
        overrides: &BTreeMap<String, String>,
    ) -> Result<(), ImportError> {
        match xml::child(parent, "ParameterDeclarations") {
            Some(decls) => self.declare(decls, file, overrides),
            None if overrides.is_empty() => Ok(()),
            None => {
                let names: Vec<String> = overrides.keys().map(|k| format!("`{k}`")).collect();
                Err(ImportError::at(
                    file,
                    parent,
                    format!("parameter(s) {} given a value but <{}> declares no parameters", names.join(", "), parent.tag_name().name()),
                ))
            }
        }
    }

    fn innermost(&mut self) -> &mut Scope {
        match self.inner.last_mut() {
            Some(s) => s,
            None => &mut self.file,
        }
    }

    fn check_constraints(
        &self,
        d: roxmltree::Node<'_, '_>,
        file: &str,
        name: &str,
        ty: ParamType,
        value: &Value,
    ) -> Result<(), ImportError> {
        let mut groups = Vec::new();
        for c in xml::elements(d) {
            match c.tag_name().name() {
                "ConstraintGroup" => groups.push(c),
                "ConstraintGroups" => {
                    for g in xml::elements(c) {
                        if g.tag_name().name() != "ConstraintGroup" {
                            return Err(ImportError::at(file, g, "unexpected element in <ConstraintGroups>"));
                        }
                        groups.push(g);
                    }
                }
                _ => return Err(ImportError::at(file, c, format!("unexpected element in the declaration of parameter `{name}`"))),
            }
        }
        if groups.is_empty() {
            return Ok(());
        }
        let mut described = Vec::new();
        for g in groups {
            let mut holds = true;
            let mut terms = Vec::new();
            for vc in xml::elements(g) {
                if vc.tag_name().name() != "ValueConstraint" {
                    return Err(ImportError::at(file, vc, "unexpected element in <ConstraintGroup>"));
                }
                let rule = self.req_enum(vc, "rule", file, &RULES)?;
                let raw = self.req_str(vc, "value", file)?;
                let bound = ty
                    .convert(Value::Str(raw.clone()))
                    .map_err(|m| ImportError::at(file, vc, format!("constraint value `{raw}` for parameter `{name}`: {m}")))?;
                let ok = match (value, &bound) {
                    (Value::Num(a), Value::Num(b)) => match rule.as_str() {
                        "equalTo" => a == b,
                        "notEqualTo" => a != b,
                        "greaterThan" => a > b,
                        "greaterOrEqual" => a >= b,
                        "lessThan" => a < b,
                        _ => a <= b,
                    },
                    (a, b) if matches!(rule.as_str(), "equalTo" | "notEqualTo") => (a == b) == (rule == "equalTo"),
                    _ => {
                        return Err(ImportError::at(
                            file,
                            vc,
                            format!("rule `{rule}` needs a numeric parameter; `{name}` is a {}", ty.name()),
                        ));
                    }
                };
                holds &= ok;
                terms.push(format!("{rule} {bound}"));
            }
            if terms.is_empty() {
                return Err(ImportError::at(file, g, "empty <ConstraintGroup>"));
            }
            if holds {
                return Ok(());
            }
            described.push(format!("({})", terms.join(" and ")));
        }
        let kind = if ty.is_numeric() { "value" } else { "text" };
        let message = format!("parameter `{name}`: {kind} {value} violates its constraints: {}", described.join(" or "));
        if self.strict {
            return Err(ImportError::at(file, d, format!("{message} (refused with --strict)")));
        }
        // esmini does not check constraints and plays the value: so does flc, with one warning
        // per declaration (a distribution's runs share it).
        let line = format!(
            "{file}:{}: <ParameterDeclaration>: {message}: played as esmini plays it (esmini does not check constraints; --strict refuses)",
            xml::line(d)
        );
        self.notes.borrow_mut().entry(format!("constraint:{file}:{}", xml::line(d))).or_insert(line);
        Ok(())
    }

    /// Resolves an attribute value: `$name` is the parameter's value, `${expr}` the
    /// expression's, anything else the literal text (as [`Value::Str`]). An undeclared
    /// parameter, a malformed reference or a failing expression is an error message.
    pub fn resolve(&self, raw: &str) -> Result<Value, String> {
        self.resolve_excluding(raw, None).map(|(v, _)| v)
    }

    /// [`Params::resolve`], where a reference to `own` (the parameter being declared) is an
    /// error; also the esmini extensions an expression used.
    fn resolve_excluding(&self, raw: &str, own: Option<&str>) -> Result<(Value, Vec<&'static str>), String> {
        let t = raw.trim();
        let Some(rest) = t.strip_prefix('$') else {
            return Ok((Value::Str(raw.to_string()), Vec::new()));
        };
        if let Some(inner) = rest.strip_prefix('{') {
            let Some(src) = inner.strip_suffix('}') else {
                return Err(format!("expression `{t}` has no closing `}}`"));
            };
            let selfref = Cell::new(false);
            let lookup = |n: &str| {
                if own == Some(n) {
                    selfref.set(true);
                    None
                } else {
                    self.value(n).cloned()
                }
            };
            return expr::eval_ext(src, &lookup).map_err(|e| {
                if selfref.get() { format!("`{t}` refers to the parameter itself") } else { format!("expression `{t}`: {e}") }
            });
        }
        if rest.is_empty() {
            return Err("`$` without a parameter name".into());
        }
        if own == Some(rest) {
            return Err(format!("`{t}` refers to the parameter itself"));
        }
        self.value(rest).cloned().map(|v| (v, Vec::new())).ok_or_else(|| format!("parameter `{rest}` is not declared"))
    }

    /// The resolved value of attribute `attr` of `node` (`None` when absent).
    fn attr_value(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<Option<(Value, String)>, ImportError> {
        let Some(raw) = node.attribute(attr) else { return Ok(None) };
        let (v, ext) = self.resolve_excluding(raw, None).map_err(|m| attr_error(node, attr, file, m))?;
        self.extensions(node, attr, file, raw, &ext)?;
        Ok(Some((v, raw.to_string())))
    }

    /// Attribute `attr` of `node` as text (`$name`/`${expr}` resolved; numbers and booleans
    /// written out); `None` when absent.
    pub fn str_attr(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<Option<String>, ImportError> {
        Ok(self.attr_value(node, attr, file)?.map(|(v, _)| v.to_string()))
    }

    /// [`Params::str_attr`] of a required attribute.
    pub fn req_str(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<String, ImportError> {
        self.str_attr(node, attr, file)?.ok_or_else(|| missing(node, attr, file))
    }

    /// Attribute `attr` of `node` as a finite number (NaN and infinities are errors); `None` when absent.
    pub fn num_attr(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<Option<f64>, ImportError> {
        let Some((v, raw)) = self.attr_value(node, attr, file)? else { return Ok(None) };
        match ParamType::Double.convert(v) {
            Ok(Value::Num(x)) => Ok(Some(x)),
            Ok(other) => Err(attr_error(node, attr, file, format!("`{raw}` is not a number ({other})"))),
            Err(m) => Err(attr_error(node, attr, file, format!("`{raw}`: {m}"))),
        }
    }

    /// [`Params::num_attr`] of a required attribute.
    pub fn req_num(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<f64, ImportError> {
        self.num_attr(node, attr, file)?.ok_or_else(|| missing(node, attr, file))
    }

    /// Attribute `attr` of `node` as a whole number (`2.0` is accepted, `2.5` is not);
    /// `None` when absent.
    pub fn int_attr(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<Option<i64>, ImportError> {
        let Some(x) = self.num_attr(node, attr, file)? else { return Ok(None) };
        // 2^63 is exactly representable; every whole f64 below it in magnitude fits in an i64.
        const LIMIT: f64 = 9_223_372_036_854_775_808.0;
        if x.fract() != 0.0 || !(-LIMIT..LIMIT).contains(&x) {
            return Err(attr_error(node, attr, file, format!("{x} is not a whole number")));
        }
        Ok(Some(x as i64))
    }

    /// [`Params::int_attr`] of a required attribute.
    pub fn req_int(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<i64, ImportError> {
        self.int_attr(node, attr, file)?.ok_or_else(|| missing(node, attr, file))
    }

    /// Attribute `attr` of `node` as a boolean (`true`/`false`); `None` when absent.
    pub fn bool_attr(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<Option<bool>, ImportError> {
        let Some((v, raw)) = self.attr_value(node, attr, file)? else { return Ok(None) };
        match ParamType::Boolean.convert(v) {
            Ok(Value::Bool(b)) => Ok(Some(b)),
            Ok(other) => Err(attr_error(node, attr, file, format!("`{raw}` is not a boolean ({other})"))),
            Err(m) => Err(attr_error(node, attr, file, format!("`{raw}`: {m}"))),
        }
    }

    /// [`Params::bool_attr`] of a required attribute.
    pub fn req_bool(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> Result<bool, ImportError> {
        self.bool_attr(node, attr, file)?.ok_or_else(|| missing(node, attr, file))
    }

    /// Attribute `attr` of `node`, which must be one of `allowed` (exact spelling); `None` when absent.
    pub fn enum_attr(
        &self,
        node: roxmltree::Node<'_, '_>,
        attr: &str,
        file: &str,
        allowed: &[&str],
    ) -> Result<Option<String>, ImportError> {
        let Some(s) = self.str_attr(node, attr, file)? else { return Ok(None) };
        if allowed.contains(&s.as_str()) {
            Ok(Some(s))
        } else {
            Err(attr_error(node, attr, file, format!("`{s}` is not one of {}", allowed.join(", "))))
        }
    }

    /// [`Params::enum_attr`] of a required attribute.
    pub fn req_enum(&self, node: roxmltree::Node<'_, '_>, attr: &str, file: &str, allowed: &[&str]) -> Result<String, ImportError> {
        self.enum_attr(node, attr, file, allowed)?.ok_or_else(|| missing(node, attr, file))
    }

    /// Reads the `VariableDeclarations` element `decls` (OpenSCENARIO 1.2): each
    /// `VariableDeclaration name variableType value`, the value resolved against these
    /// parameters and converted to the declared type, in file order. Names must be unique.
    pub fn read_variables(&self, decls: roxmltree::Node<'_, '_>, file: &str) -> Result<Vec<(String, Value)>, ImportError> {
        if decls.tag_name().name() != "VariableDeclarations" {
            return Err(ImportError::at(file, decls, "expected <VariableDeclarations>"));
        }
        let mut out: Vec<(String, Value)> = Vec::new();
        let mut seen = BTreeMap::new();
        for d in xml::elements(decls) {
            if d.tag_name().name() != "VariableDeclaration" {
                return Err(ImportError::at(file, d, "unexpected element in <VariableDeclarations>"));
            }
            let name = d.attribute("name").unwrap_or_default();
            if name.is_empty() || name.starts_with('$') {
                return Err(ImportError::at(file, d, format!("variable name `{name}` must be non-empty and written without `$`")));
            }
            let fail = |m: String| ImportError::at(file, d, format!("variable `{name}`: {m}"));
            let ty_name = d.attribute("variableType").ok_or_else(|| fail("attribute `variableType` is missing".into()))?;
            let ty = ParamType::parse(ty_name).ok_or_else(|| fail(format!("unknown variableType `{ty_name}`")))?;
            let raw = d.attribute("value").ok_or_else(|| fail("attribute `value` is missing".into()))?;
            let (v, ext) = self.resolve_excluding(raw, None).map_err(fail)?;
            self.extensions(d, "value", file, raw, &ext)?;
            let v = ty.convert(v).map_err(|m| fail(format!("value `{raw}`: {m}")))?;
            if seen.insert(name.to_string(), ()).is_some() {
                return Err(fail("declared twice".into()));
            }
            out.push((name.to_string(), v));
        }
        Ok(out)
    }
}

/// Reads the `VariableDeclarations` element `decls` of `file` with no parameters in force (a
/// `$name` value is an error); see [`Params::read_variables`] to resolve parameters.
pub fn variables(decls: roxmltree::Node<'_, '_>, file: &str) -> Result<Vec<(String, Value)>, ImportError> {
    Params::new().read_variables(decls, file)
}

fn attr_error(node: roxmltree::Node<'_, '_>, attr: &str, file: &str, message: String) -> ImportError {
    ImportError { file: file.to_string(), line: xml::line(node), element: format!("{}@{attr}", node.tag_name().name()), message }
}

fn missing(node: roxmltree::Node<'_, '_>, attr: &str, file: &str) -> ImportError {
    attr_error(node, attr, file, "required attribute is missing".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: &str = "t.xosc";

    fn declare(xml_text: &str, overrides: &[(&str, &str)]) -> Result<Params, ImportError> {
        let doc = xml::parse(xml_text, F)?;
        let mut p = Params::new();
        let o: BTreeMap<String, String> = overrides.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        p.declare(doc.root_element(), F, &o)?;
        Ok(p)
    }

    fn decl(body: &str) -> String {
        format!("<ParameterDeclarations>\n{body}\n</ParameterDeclarations>")
    }

    /// The error of declaring `xml_text` with `--strict` (which refuses what non-strict warns of).
    fn err(xml_text: &str, overrides: &[(&str, &str)]) -> String {
        let strict = || -> Result<Params, ImportError> {
            let doc = xml::parse(xml_text, F)?;
            let mut p = Params::new();
            p.set_strict(true);
            let o: BTreeMap<String, String> = overrides.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            p.declare(doc.root_element(), F, &o)?;
            Ok(p)
        };
        match strict() {
            Err(e) => e.to_string(),
            Ok(p) => panic!("expected an error, got {:?}", p.iter().collect::<Vec<_>>()),
        }
    }

    #[test]
    fn declarations_in_order_with_references_and_expressions() {
        let x = decl(
            r#"<ParameterDeclaration name="speed" parameterType="double" value="50"/>
<ParameterDeclaration name="ms" parameterType="double" value="${$speed / 3.6}"/>
<ParameterDeclaration name="copy" parameterType="double" value="$speed"/>
<ParameterDeclaration name="lanes" parameterType="integer" value="${round(2.6)}"/>
<ParameterDeclaration name="port" parameterType="unsignedShort" value="8080"/>
<ParameterDeclaration name="big" parameterType="unsignedInt" value="4294967295"/>
<ParameterDeclaration name="on" parameterType="boolean" value="${$speed > 30 and not false}"/>
<ParameterDeclaration name="off" parameterType="boolean" value="false"/>
<ParameterDeclaration name="who" parameterType="string" value="Ego"/>
<ParameterDeclaration name="num_text" parameterType="string" value="${1 + 1}"/>
<ParameterDeclaration name="when" parameterType="dateTime" value="2024-05-01T12:00:00+02:00"/>"#,
        );
        let p = declare(&x, &[]).expect("declare");
        assert_eq!(p.value("ms"), Some(&Value::Num(50.0 / 3.6)));
        assert_eq!(p.value("copy"), Some(&Value::Num(50.0)));
        assert_eq!(p.value("lanes"), Some(&Value::Num(3.0)));
        assert_eq!(p.value("port"), Some(&Value::Num(8080.0)));
        assert_eq!(p.value("big"), Some(&Value::Num(4294967295.0)));
        assert_eq!(p.value("on"), Some(&Value::Bool(true)));
        assert_eq!(p.value("off"), Some(&Value::Bool(false)));
        assert_eq!(p.value("who"), Some(&Value::Str("Ego".into())));
        assert_eq!(p.value("num_text"), Some(&Value::Str("2".into())));
        assert_eq!(p.get("when").map(|q| q.ty), Some(ParamType::DateTime));
        assert_eq!(p.iter().count(), 11);
    }

    #[test]
    fn overrides_replace_and_are_converted() {
        let x = decl(
            r#"<ParameterDeclaration name="speed" parameterType="double" value="50"/>
<ParameterDeclaration name="ms" parameterType="double" value="${$speed / 2}"/>
<ParameterDeclaration name="n" parameterType="integer" value="1"/>"#,
        );
        let p = declare(&x, &[("speed", "80"), ("n", "-4")]).expect("declare");
        assert_eq!(p.value("ms"), Some(&Value::Num(40.0)), "later declarations see the override");
        assert_eq!(p.value("n"), Some(&Value::Num(-4.0)));
        let e = err(&x, &[("sped", "80")]);
        assert!(e.contains("`sped`") && e.contains("not declared"), "{e}");
        let e = err(&x, &[("n", "2.5")]);
        assert!(e.starts_with("t.xosc:4: <ParameterDeclaration>: parameter `n`") && e.contains("not a whole number"), "{e}");
        let e = err(&x, &[("speed", "fast")]);
        assert!(e.contains("`fast` is not a number"), "{e}");
        let e = err(&x, &[("speed", "NaN")]);
        assert!(e.contains("not a finite number"), "{e}");
    }

    #[test]
    fn declaration_errors_name_file_line_element_and_parameter() {
        let e = err(&decl(r#"<ParameterDeclaration name="n" parameterType="integer" value="2.5"/>"#), &[]);
        assert!(e.starts_with("t.xosc:2: <ParameterDeclaration>: parameter `n`: value `2.5`"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="u" parameterType="unsignedShort" value="70000"/>"#), &[]);
        assert!(e.contains("outside the range"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="u" parameterType="unsignedInt" value="-1"/>"#), &[]);
        assert!(e.contains("outside the range"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="b" parameterType="boolean" value="yes"/>"#), &[]);
        assert!(e.contains("not a boolean"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="d" parameterType="double" value="inf"/>"#), &[]);
        assert!(e.contains("not a finite number"), "{e}");
        let long = "y".repeat(MAX_TEXT + 1);
        let e = err(&decl(&format!(r#"<ParameterDeclaration name="s" parameterType="string" value="{long}"/>"#)), &[]);
        assert!(e.contains("longer than the limit"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="t" parameterType="dateTime" value="today"/>"#), &[]);
        assert!(e.contains("not a dateTime"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="float" value="1"/>"#), &[]);
        assert!(e.contains("unknown parameterType `float`"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double"/>"#), &[]);
        assert!(e.contains("`value` is missing"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double" value="$y"/>"#), &[]);
        assert!(e.contains("parameter `y` is not declared"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double" value="$x"/>"#), &[]);
        assert!(e.contains("refers to the parameter itself"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double" value="${$x + 1}"/>"#), &[]);
        assert!(e.contains("refers to the parameter itself"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double" value="${1/0}"/>"#), &[]);
        assert!(e.contains("division by zero"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="x" parameterType="double" value="${1 + 2"/>"#), &[]);
        assert!(e.contains("no closing"), "{e}");
        let e = err(
            &decl(
                r#"<ParameterDeclaration name="x" parameterType="double" value="1"/>
<ParameterDeclaration name="x" parameterType="double" value="2"/>"#,
            ),
            &[],
        );
        assert!(e.starts_with("t.xosc:3:") && e.contains("declared twice"), "{e}");
        let e = err(&decl(r#"<ParameterDeclaration name="$x" parameterType="double" value="2"/>"#), &[]);
        assert!(e.contains("without `$`"), "{e}");
        let e = err(&decl(r#"<Parameter name="x"/>"#), &[]);
        assert!(e.contains("unexpected element"), "{e}");
        // A later declaration cannot be referenced by an earlier one.
        let e = err(
            &decl(
                r#"<ParameterDeclaration name="a" parameterType="double" value="$b"/>
<ParameterDeclaration name="b" parameterType="double" value="1"/>"#,
            ),
            &[],
        );
        assert!(e.contains("parameter `b` is not declared"), "{e}");
    }

    #[test]
    fn constraint_groups_are_ored_and_constraints_anded() {
        let x = |v: &str| {
            decl(&format!(
                r#"<ParameterDeclaration name="v" parameterType="double" value="{v}">
  <ConstraintGroup><ValueConstraint rule="greaterThan" value="0"/><ValueConstraint rule="lessOrEqual" value="10"/></ConstraintGroup>
  <ConstraintGroup><ValueConstraint rule="equalTo" value="100"/></ConstraintGroup>
</ParameterDeclaration>"#
            ))
        };
        for ok in ["5", "10", "100"] {
            assert!(declare(&x(ok), &[]).is_ok(), "{ok}");
        }
        let e = err(&x("0"), &[]);
        assert!(e.starts_with("t.xosc:2: <ParameterDeclaration>: parameter `v`: value 0 violates"), "{e}");
        assert!(e.ends_with("(refused with --strict)"), "{e}");
        // Without --strict: played as esmini plays it, one warning line per declaration.
        let p = declare(&x("0"), &[]).expect("warned, not refused");
        assert_eq!(p.value("v"), Some(&Value::Num(0.0)));
        let notes = p.take_notes();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].1.contains("value 0 violates") && notes[0].1.contains("as esmini plays it"), "{notes:?}");
        assert!(p.take_notes().is_empty());
        assert!(e.contains("(greaterThan 0 and lessOrEqual 10) or (equalTo 100)"), "{e}");
        let e = err(&x("5"), &[("v", "11")]);
        assert!(e.contains("value 11 violates"), "{e}");
        let s = decl(
            r#"<ParameterDeclaration name="s" parameterType="string" value="a">
  <ConstraintGroup><ValueConstraint rule="notEqualTo" value="b"/></ConstraintGroup>
</ParameterDeclaration>"#,
        );
        assert!(declare(&s, &[]).is_ok());
        assert!(err(&s, &[("s", "b")]).contains("violates"));
        let bad = decl(
            r#"<ParameterDeclaration name="s" parameterType="string" value="a">
  <ConstraintGroup><ValueConstraint rule="greaterThan" value="b"/></ConstraintGroup>
</ParameterDeclaration>"#,
        );
        assert!(err(&bad, &[]).contains("needs a numeric parameter"));
        let bad_rule = decl(
            r#"<ParameterDeclaration name="v" parameterType="double" value="1">
  <ConstraintGroup><ValueConstraint rule="bigger" value="0"/></ConstraintGroup>
</ParameterDeclaration>"#,
        );
        let e = err(&bad_rule, &[]);
        assert!(e.starts_with("t.xosc:3: <ValueConstraint@rule>:") && e.contains("`bigger` is not one of"), "{e}");
    }

    #[test]
    fn esmini_extensions_warn_once_each_or_are_refused_with_strict() {
        let text = decl(
            r#"<ParameterDeclaration name="a" parameterType="double" value="90"/>
<ParameterDeclaration name="r" parameterType="double" value="${$a*pi/180}"/>
<ParameterDeclaration name="s" parameterType="double" value="${sin($r) + cos(0) + pi}"/>
<ParameterDeclaration name="q" parameterType="double" value="${sqrt(pow(2, 2)) + round(0.4)}"/>"#,
        );
        let p = declare(&text, &[]).expect("accepted");
        assert_eq!(p.value("r"), Some(&Value::Num(std::f64::consts::FRAC_PI_2)));
        assert_eq!(p.value("s"), Some(&Value::Num(2.0 + std::f64::consts::PI)));
        let notes = p.take_notes();
        let keys: Vec<&str> = notes.iter().map(|(k, _)| k.as_str()).collect();
        // One line per extension (pi used twice: one line, the first use); the standard's
        // sqrt, pow and round give none.
        assert_eq!(keys, vec!["expr:cos", "expr:pi", "expr:sin"], "{notes:?}");
        let pi = &notes[1].1;
        assert!(
            pi.starts_with("t.xosc:3: <ParameterDeclaration@value>: `${$a*pi/180}` uses the constant `pi`: an esmini extension"),
            "{pi}"
        );
        let e = err(&text, &[]);
        assert!(e.starts_with("t.xosc:3: <ParameterDeclaration@value>:") && e.contains("`pi`") && e.contains("--strict"), "{e}");
    }

    #[test]
    fn scopes_and_lookup() {
        let doc = xml::parse(
            r#"<R>
<ParameterDeclarations><ParameterDeclaration name="a" parameterType="double" value="1"/></ParameterDeclarations>
<Entry><ParameterDeclarations><ParameterDeclaration name="a" parameterType="double" value="2"/>
<ParameterDeclaration name="b" parameterType="double" value="${$a * 10}"/></ParameterDeclarations></Entry>
</R>"#,
            F,
        )
        .expect("xml");
        let root = doc.root_element();
        let mut p = Params::new();
        p.declare_in(root, F, &BTreeMap::new()).expect("file scope");
        let entry = xml::child(root, "Entry").expect("entry");
        p.push_scope();
        let assign: BTreeMap<String, String> = [("a".to_string(), "5".to_string())].into();
        p.declare_in(entry, F, &assign).expect("catalog scope");
        assert_eq!(p.value("a"), Some(&Value::Num(5.0)));
        assert_eq!(p.value("b"), Some(&Value::Num(50.0)));
        assert!(p.pop_scope());
        assert_eq!(p.value("a"), Some(&Value::Num(1.0)));
        assert_eq!(p.value("b"), None);
        assert!(!p.pop_scope(), "the file scope stays");
        let e = p.declare_in(entry.first_element_child().expect("decls"), F, &assign).expect_err("no decls");
        assert!(e.to_string().contains("declares no parameters"), "{e}");
    }

    #[test]
    fn resolution_and_typed_getters() {
        let doc = xml::parse(
            r#"<R>
<ParameterDeclarations>
  <ParameterDeclaration name="v" parameterType="double" value="12.5"/>
  <ParameterDeclaration name="n" parameterType="integer" value="3"/>
  <ParameterDeclaration name="b" parameterType="boolean" value="true"/>
  <ParameterDeclaration name="s" parameterType="string" value="linear"/>
</ParameterDeclarations>
<SpeedAction rate="$v" twice="${$v * 2}" lit="7" n="$n" half="2.5" b="$b" bl="false" shape="$s" bad="$w" nan="NaN" text="abc" e="${1/0}"/>
</R>"#,
            F,
        )
        .expect("xml");
        let root = doc.root_element();
        let mut p = Params::new();
        p.declare_in(root, F, &BTreeMap::new()).expect("decl");
        let a = xml::child(root, "SpeedAction").expect("action");
        assert_eq!(p.resolve("$v"), Ok(Value::Num(12.5)));
        assert_eq!(p.resolve("${$n + 1}"), Ok(Value::Num(4.0)));
        assert_eq!(p.resolve("Ego"), Ok(Value::Str("Ego".into())));
        assert!(p.resolve("$").is_err());
        assert_eq!(p.req_num(a, "rate", F), Ok(12.5));
        assert_eq!(p.req_num(a, "twice", F), Ok(25.0));
        assert_eq!(p.num_attr(a, "lit", F), Ok(Some(7.0)));
        assert_eq!(p.num_attr(a, "absent", F), Ok(None));
        assert_eq!(p.int_attr(a, "n", F), Ok(Some(3)));
        assert_eq!(p.req_int(a, "lit", F), Ok(7));
        assert_eq!(p.bool_attr(a, "b", F), Ok(Some(true)));
        assert_eq!(p.req_bool(a, "bl", F), Ok(false));
        assert_eq!(p.str_attr(a, "rate", F), Ok(Some("12.5".into())));
        assert_eq!(p.req_str(a, "shape", F), Ok("linear".into()));
        assert_eq!(p.enum_attr(a, "shape", F, &["linear", "cubic"]), Ok(Some("linear".into())));
        let e = p.req_num(a, "missing", F).expect_err("missing").to_string();
        assert_eq!(e, "t.xosc:8: <SpeedAction@missing>: required attribute is missing");
        let e = p.req_num(a, "bad", F).expect_err("undeclared").to_string();
        assert!(e.starts_with("t.xosc:8: <SpeedAction@bad>:") && e.contains("parameter `w` is not declared"), "{e}");
        assert!(p.req_num(a, "nan", F).expect_err("nan").to_string().contains("not a finite number"));
        assert!(p.req_num(a, "text", F).expect_err("text").to_string().contains("`abc` is not a number"));
        assert!(p.req_num(a, "b", F).expect_err("bool").to_string().contains("boolean"));
        assert!(p.req_num(a, "e", F).expect_err("expr").to_string().contains("division by zero"));
        assert!(p.int_attr(a, "half", F).expect_err("half").to_string().contains("not a whole number"));
        assert!(p.bool_attr(a, "lit", F).expect_err("bool").to_string().contains("not a boolean"));
        let e = p.enum_attr(a, "shape", F, &["step", "cubic"]).expect_err("enum").to_string();
        assert!(e.contains("`linear` is not one of step, cubic"), "{e}");
    }

    #[test]
    fn variables_are_typed() {
        let doc = xml::parse(
            r#"<R>
<ParameterDeclarations><ParameterDeclaration name="p" parameterType="double" value="4"/></ParameterDeclarations>
<VariableDeclarations>
  <VariableDeclaration name="count" variableType="integer" value="0"/>
  <VariableDeclaration name="flag" variableType="boolean" value="false"/>
  <VariableDeclaration name="gap" variableType="double" value="$p"/>
</VariableDeclarations>
<VariableDeclarations><VariableDeclaration name="x" variableType="integer" value="0.5"/></VariableDeclarations>
</R>"#,
            F,
        )
        .expect("xml");
        let root = doc.root_element();
        let mut p = Params::new();
        p.declare_in(root, F, &BTreeMap::new()).expect("decl");
        let mut vds = xml::children(root, "VariableDeclarations");
        let (v1, v2) = (vds.next().expect("v1"), vds.next().expect("v2"));
        let vars = p.read_variables(v1, F).expect("vars");
        assert_eq!(vars, vec![("count".into(), Value::Num(0.0)), ("flag".into(), Value::Bool(false)), ("gap".into(), Value::Num(4.0))]);
        let e = variables(v1, F).expect_err("no params").to_string();
        assert!(e.starts_with("t.xosc:6: <VariableDeclaration>: variable `gap`") && e.contains("not declared"), "{e}");
        let e = variables(v2, F).expect_err("integer").to_string();
        assert!(e.contains("not a whole number"), "{e}");
    }
}
