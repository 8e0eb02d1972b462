//! The `${...}` expression language of ASAM OpenSCENARIO XML 1.x (section "Expressions" of the
//! 1.2 standard), evaluated with a small tokenizer and a recursive-descent parser that computes
//! the value while it parses (no syntax tree, so no recursion over long operator chains).
//!
//! Grammar, from the loosest to the tightest binding level (binary operators associate to the
//! left):
//!
//! ```text
//! or      := and ("or" and)*
//! and     := not ("and" not)*
//! not     := "not" not | cmp
//! cmp     := add (("<" | "<=" | ">" | ">=" | "==" | "!=") add)*
//! add     := mul (("+" | "-") mul)*
//! mul     := unary (("*" | "/" | "%") unary)*
//! unary   := "-" unary | primary
//! primary := number | "$"name | "true" | "false" | "(" or ")" | function "(" or ("," or)* ")"
//! ```
//!
//! Numbers are `12`, `1.5`, `.5`, `2.`, `1e-3`, `1.5E+2`. Functions of the standard (1.1 on):
//! `round` (half away from zero), `floor`, `ceil`, `sqrt` (one argument) and `pow` (two).
//! esmini's extensions, not in the standard ([`EXTENSIONS`]; [`eval_ext`] says which an
//! expression used, so the importer can warn, or refuse with `--strict`): the constant `pi`,
//! `abs`, `sign`, `sin`, `cos`, `tan`, `asin`, `acos`, `atan` (one argument, radians) and
//! `min`, `max` (two). `sign(0)` is 0 (esmini 3.6.0 gives 1). There is no `^` (the standard
//! has `pow(a, b)`), no unary `+`, no string operators.
//!
//! Types: arithmetic takes and gives numbers, comparisons give booleans (`==`/`!=` also compare
//! two booleans), `not`/`and`/`or` take and give booleans. Both sides of `and`/`or` are always
//! evaluated (so an error on either side is reported). Division or `%` by zero, `sqrt` of a
//! negative number and any non-finite result are errors.
//!
//! Hostile input is bounded: at most [`MAX_LEN`] bytes and [`MAX_DEPTH`] nested parentheses,
//! function calls, unary minus or `not` (each costs a few stack frames); nothing panics.

use std::fmt;

use thiserror::Error;

/// esmini's extensions of the expression language (esmini 3.6.0, `simple_expr.c`): words and
/// functions that are not OpenSCENARIO.
pub const EXTENSIONS: [&str; 11] = ["pi", "abs", "sign", "sin", "cos", "tan", "asin", "acos", "atan", "min", "max"];

/// Longest expression text accepted, bytes.
pub const MAX_LEN: usize = 4096;
/// Deepest nesting of parentheses, function calls, unary minus and `not` accepted.
pub const MAX_DEPTH: usize = 64;

/// A parameter value or an expression result. `Num` covers the numeric parameter types
/// (`double`, `integer`, `unsignedInt`, `unsignedShort`); `Str` covers `string` and `dateTime`.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number (double precision).
    Num(f64),
    /// A boolean.
    Bool(bool),
    /// A text.
    Str(String),
}

impl Value {
    /// The name of the value's kind in messages: `number`, `boolean` or `string`.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Num(_) => "number",
            Value::Bool(_) => "boolean",
            Value::Str(_) => "string",
        }
    }
}

impl fmt::Display for Value {
    /// Numbers in Rust's shortest round-trip form (`3`, `0.1`, `-2.5`), booleans as
    /// `true`/`false`, strings as they are.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Num(v) => write!(f, "{v}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Str(s) => f.write_str(s),
        }
    }
}

/// An expression was rejected: what is wrong and where (1-based character column in the text
/// inside `${ }`; 0 for the expression as a whole).
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{message} (column {column})")]
pub struct ExprError {
    /// 1-based character column of the offending token (0: the whole expression).
    pub column: usize,
    /// What is wrong, naming the offending token.
    pub message: String,
}

impl ExprError {
    fn new(column: usize, message: impl Into<String>) -> Self {
        Self { column, message: message.into() }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Param(String),
    Ident(String),
    LParen,
    RParen,
    Comma,
    Plus,
    Minus,
    Star,
    Slash,
    Percent,
    Lt,
    Le,
    Gt,
    Ge,
    EqEq,
    Ne,
}

impl fmt::Display for Tok {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Num(v) => write!(f, "number `{v}`"),
            Tok::Param(n) => write!(f, "`${n}`"),
            Tok::Ident(n) => write!(f, "`{n}`"),
            Tok::LParen => f.write_str("`(`"),
            Tok::RParen => f.write_str("`)`"),
            Tok::Comma => f.write_str("`,`"),
            Tok::Plus => f.write_str("`+`"),
            Tok::Minus => f.write_str("`-`"),
            Tok::Star => f.write_str("`*`"),
            Tok::Slash => f.write_str("`/`"),
            Tok::Percent => f.write_str("`%`"),
            Tok::Lt => f.write_str("`<`"),
            Tok::Le => f.write_str("`<=`"),
            Tok::Gt => f.write_str("`>`"),
            Tok::Ge => f.write_str("`>=`"),
            Tok::EqEq => f.write_str("`==`"),
            Tok::Ne => f.write_str("`!=`"),
        }
    }
}

fn is_name_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Splits `src` into tokens with their 1-based character columns.
fn tokenize(src: &str) -> Result<Vec<(Tok, usize)>, ExprError> {
    let chars: Vec<char> = src.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    while let Some(&c) = chars.get(i) {
        let col = i + 1;
        let next = chars.get(i + 1).copied();
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let (tok, len) = match c {
            '(' => (Tok::LParen, 1),
            ')' => (Tok::RParen, 1),
            ',' => (Tok::Comma, 1),
            '+' => (Tok::Plus, 1),
            '-' => (Tok::Minus, 1),
            '*' => (Tok::Star, 1),
            '/' => (Tok::Slash, 1),
            '%' => (Tok::Percent, 1),
            '<' if next == Some('=') => (Tok::Le, 2),
            '<' => (Tok::Lt, 1),
            '>' if next == Some('=') => (Tok::Ge, 2),
            '>' => (Tok::Gt, 1),
            '=' if next == Some('=') => (Tok::EqEq, 2),
            '!' if next == Some('=') => (Tok::Ne, 2),
            '=' => return Err(ExprError::new(col, "`=` is not an operator (comparison is `==`)")),
            '!' => return Err(ExprError::new(col, "`!` is not an operator (negation is `not`, inequality `!=`)")),
            '^' => return Err(ExprError::new(col, "`^` is not an OpenSCENARIO operator (use pow(a, b))")),
            '$' => {
                let len = chars.iter().skip(i + 1).take_while(|c| is_name_char(**c)).count();
                if len == 0 {
                    return Err(ExprError::new(col, "`$` must be followed by a parameter name"));
                }
                let name: String = chars.iter().skip(i + 1).take(len).collect();
                (Tok::Param(name), len + 1)
            }
            c if c.is_ascii_digit() || (c == '.' && next.is_some_and(|n| n.is_ascii_digit())) => {
                let (v, len) = number(&chars, i)?;
                (Tok::Num(v), len)
            }
            c if c.is_alphabetic() || c == '_' => {
                let len = chars.iter().skip(i).take_while(|c| is_name_char(**c)).count();
                (Tok::Ident(chars.iter().skip(i).take(len).collect()), len)
            }
            other => return Err(ExprError::new(col, format!("unexpected character `{other}`"))),
        };
        toks.push((tok, col));
        i += len;
    }
    Ok(toks)
}

/// Reads the number starting at `chars[start]`: digits, an optional fraction and an optional
/// exponent. Returns the value and its length in characters.
fn number(chars: &[char], start: usize) -> Result<(f64, usize), ExprError> {
    let digits = |from: usize| chars.iter().skip(from).take_while(|c| c.is_ascii_digit()).count();
    let mut end = start + digits(start);
    if chars.get(end) == Some(&'.') {
        end += 1 + digits(end + 1);
    }
    if matches!(chars.get(end), Some('e' | 'E')) {
        let mut exp = end + 1;
        if matches!(chars.get(exp), Some('+' | '-')) {
            exp += 1;
        }
        let n = digits(exp);
        if n == 0 {
            let text: String = chars.iter().skip(start).take(exp - start).collect();
            return Err(ExprError::new(start + 1, format!("number `{text}` has an exponent without digits")));
        }
        end = exp + n;
    }
    if chars.get(end).is_some_and(|c| is_name_char(*c) || *c == '.') {
        let text: String = chars.iter().skip(start).take(end + 1 - start).collect();
        return Err(ExprError::new(start + 1, format!("malformed number `{text}`")));
    }
    let text: String = chars.iter().skip(start).take(end - start).collect();
    let v: f64 = text.parse().map_err(|_| ExprError::new(start + 1, format!("malformed number `{text}`")))?;
    if !v.is_finite() {
        return Err(ExprError::new(start + 1, format!("number `{text}` is out of range")));
    }
    Ok((v, end - start))
}

/// Evaluates `src`, the text inside `${ }`; `lookup` gives the value of a parameter by name
/// (without `$`), `None` if it is not declared.
///
/// ```
/// use flc_sim::openscenario::expr::{eval, Value};
/// let lookup = |name: &str| (name == "v").then_some(Value::Num(10.0));
/// assert_eq!(eval("$v * 3.6 + 1", &lookup), Ok(Value::Num(37.0)));
/// assert_eq!(eval("not $v > 5 or true", &lookup), Ok(Value::Bool(true)));
/// ```
pub fn eval(src: &str, lookup: &dyn Fn(&str) -> Option<Value>) -> Result<Value, ExprError> {
    eval_ext(src, lookup).map(|(v, _)| v)
}

/// [`eval`], and the esmini extensions ([`EXTENSIONS`]) the expression used, each once, in
/// the order of first use.
///
/// ```
/// use flc_sim::openscenario::expr::{eval_ext, Value};
/// let lookup = |name: &str| (name == "a").then_some(Value::Num(90.0));
/// let (v, ext) = eval_ext("sin($a * pi / 180) + max(1, 2)", &lookup).expect("ok");
/// assert_eq!((v, ext), (Value::Num(3.0), vec!["sin", "pi", "max"]));
/// ```
pub fn eval_ext(src: &str, lookup: &dyn Fn(&str) -> Option<Value>) -> Result<(Value, Vec<&'static str>), ExprError> {
    if src.len() > MAX_LEN {
        return Err(ExprError::new(0, format!("expression is {} bytes long, more than the limit of {MAX_LEN}", src.len())));
    }
    let toks = tokenize(src)?;
    if toks.is_empty() {
        return Err(ExprError::new(0, "empty expression"));
    }
    let end_col = src.chars().count() + 1;
    let mut p = Parser { toks: &toks, at: 0, end_col, lookup, used: Vec::new() };
    let v = p.or(0)?;
    if let Some((t, col)) = toks.get(p.at) {
        return Err(ExprError::new(*col, format!("unexpected {t} after a complete expression")));
    }
    Ok((v, p.used))
}

struct Parser<'a> {
    toks: &'a [(Tok, usize)],
    at: usize,
    end_col: usize,
    lookup: &'a dyn Fn(&str) -> Option<Value>,
    /// The esmini extensions used so far.
    used: Vec<&'static str>,
}

fn num(v: Value, col: usize, what: &str) -> Result<f64, ExprError> {
    match v {
        Value::Num(x) => Ok(x),
        other => Err(ExprError::new(col, format!("{what} needs a number, got a {}", other.kind()))),
    }
}

fn boolean(v: Value, col: usize, what: &str) -> Result<bool, ExprError> {
    match v {
        Value::Bool(b) => Ok(b),
        other => Err(ExprError::new(col, format!("{what} needs a boolean, got a {}", other.kind()))),
    }
}

fn finite(x: f64, col: usize, what: &str) -> Result<Value, ExprError> {
    if x.is_finite() { Ok(Value::Num(x)) } else { Err(ExprError::new(col, format!("{what} gives a non-finite result ({x})"))) }
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.at).map(|(t, _)| t)
    }

    /// Column of the current token (end of text when there is none).
    fn col(&self) -> usize {
        self.toks.get(self.at).map_or(self.end_col, |(_, c)| *c)
    }

    fn eat(&mut self, t: &Tok) -> bool {
        if self.peek() == Some(t) {
            self.at += 1;
            true
        } else {
            false
        }
    }

    fn eat_word(&mut self, w: &str) -> bool {
        if matches!(self.peek(), Some(Tok::Ident(n)) if n == w) {
            self.at += 1;
            true
        } else {
            false
        }
    }

    fn enter(&self, depth: usize) -> Result<usize, ExprError> {
        if depth >= MAX_DEPTH {
            Err(ExprError::new(self.col(), format!("expression nested deeper than {MAX_DEPTH} levels")))
        } else {
            Ok(depth + 1)
        }
    }

    fn or(&mut self, depth: usize) -> Result<Value, ExprError> {
        let mut v = self.and(depth)?;
        loop {
            let col = self.col();
            if !self.eat_word("or") {
                return Ok(v);
            }
            let l = boolean(v, col, "`or`")?;
            let r = boolean(self.and(depth)?, col, "`or`")?;
            v = Value::Bool(l || r);
        }
    }

    fn and(&mut self, depth: usize) -> Result<Value, ExprError> {
        let mut v = self.not(depth)?;
        loop {
            let col = self.col();
            if !self.eat_word("and") {
                return Ok(v);
            }
            let l = boolean(v, col, "`and`")?;
            let r = boolean(self.not(depth)?, col, "`and`")?;
            v = Value::Bool(l && r);
        }
    }

    fn not(&mut self, depth: usize) -> Result<Value, ExprError> {
        let col = self.col();
        if self.eat_word("not") {
            let inner = self.enter(depth)?;
            let b = boolean(self.not(inner)?, col, "`not`")?;
            return Ok(Value::Bool(!b));
        }
        self.cmp(depth)
    }

    fn cmp(&mut self, depth: usize) -> Result<Value, ExprError> {
        let mut v = self.add(depth)?;
        loop {
            let col = self.col();
            let op = match self.peek() {
                Some(t @ (Tok::Lt | Tok::Le | Tok::Gt | Tok::Ge | Tok::EqEq | Tok::Ne)) => t.clone(),
                _ => return Ok(v),
            };
            self.at += 1;
            let r = self.add(depth)?;
            v = Value::Bool(match (v, r) {
                (Value::Num(a), Value::Num(b)) => match op {
                    Tok::Lt => a < b,
                    Tok::Le => a <= b,
                    Tok::Gt => a > b,
                    Tok::Ge => a >= b,
                    Tok::EqEq => a == b,
                    _ => a != b,
                },
                (Value::Bool(a), Value::Bool(b)) if matches!(op, Tok::EqEq | Tok::Ne) => (a == b) == (op == Tok::EqEq),
                (a, b) => {
                    return Err(ExprError::new(col, format!("{op} cannot compare a {} with a {}", a.kind(), b.kind())));
                }
            });
        }
    }

    fn add(&mut self, depth: usize) -> Result<Value, ExprError> {
        let mut v = self.mul(depth)?;
        loop {
            let col = self.col();
            let minus = match self.peek() {
                Some(Tok::Plus) => false,
                Some(Tok::Minus) => true,
                _ => return Ok(v),
            };
            self.at += 1;
            let what = if minus { "`-`" } else { "`+`" };
            let a = num(v, col, what)?;
            let b = num(self.mul(depth)?, col, what)?;
            v = finite(if minus { a - b } else { a + b }, col, what)?;
        }
    }

    fn mul(&mut self, depth: usize) -> Result<Value, ExprError> {
        let mut v = self.unary(depth)?;
        loop {
            let col = self.col();
            let op = match self.peek() {
                Some(t @ (Tok::Star | Tok::Slash | Tok::Percent)) => t.clone(),
                _ => return Ok(v),
            };
            self.at += 1;
            let what = op.to_string();
            let a = num(v, col, &what)?;
            let b = num(self.unary(depth)?, col, &what)?;
            let x = match op {
                Tok::Star => a * b,
                _ if b == 0.0 => return Err(ExprError::new(col, format!("{what}: division by zero"))),
                Tok::Slash => a / b,
                _ => a % b,
            };
            v = finite(x, col, &what)?;
        }
    }

    fn unary(&mut self, depth: usize) -> Result<Value, ExprError> {
        let col = self.col();
        if self.eat(&Tok::Minus) {
            let inner = self.enter(depth)?;
            let x = num(self.unary(inner)?, col, "unary `-`")?;
            return Ok(Value::Num(-x));
        }
        if self.peek() == Some(&Tok::Plus) {
            return Err(ExprError::new(col, "unary `+` is not an OpenSCENARIO operator"));
        }
        self.primary(depth)
    }

    fn primary(&mut self, depth: usize) -> Result<Value, ExprError> {
        let col = self.col();
        let Some(tok) = self.peek().cloned() else {
            return Err(ExprError::new(col, "expression ends where a value is expected"));
        };
        self.at += 1;
        match tok {
            Tok::Num(v) => Ok(Value::Num(v)),
            Tok::Param(name) => match (self.lookup)(&name) {
                Some(Value::Num(x)) if !x.is_finite() => Err(ExprError::new(col, format!("parameter `{name}` is not finite"))),
                Some(v) => Ok(v),
                None => Err(ExprError::new(col, format!("parameter `{name}` is not declared"))),
            },
            Tok::LParen => {
                let inner = self.enter(depth)?;
                let v = self.or(inner)?;
                if !self.eat(&Tok::RParen) {
                    return Err(self.expected("`)` closing the `(`", col));
                }
                Ok(v)
            }
            Tok::Ident(name) => match name.as_str() {
                "true" => Ok(Value::Bool(true)),
                "false" => Ok(Value::Bool(false)),
                "and" | "or" | "not" => Err(ExprError::new(col, format!("`{name}` where a value is expected"))),
                "pi" => {
                    self.extension("pi");
                    Ok(Value::Num(std::f64::consts::PI))
                }
                _ => self.call(&name, col, depth),
            },
            other => Err(ExprError::new(col, format!("unexpected {other} where a value is expected"))),
        }
    }

    /// The error "expected `what`" at the current token (or the end), mentioning `open_col`.
    fn expected(&self, what: &str, open_col: usize) -> ExprError {
        match self.toks.get(self.at) {
            Some((t, c)) => ExprError::new(*c, format!("expected {what} (opened at column {open_col}), found {t}")),
            None => ExprError::new(self.end_col, format!("expected {what} (opened at column {open_col}), found the end")),
        }
    }

    /// Notes the use of the esmini extension `name` (one of [`EXTENSIONS`]).
    fn extension(&mut self, name: &str) {
        if let Some(e) = EXTENSIONS.iter().find(|e| **e == name) {
            if !self.used.contains(e) {
                self.used.push(e);
            }
        }
    }

    fn call(&mut self, name: &str, col: usize, depth: usize) -> Result<Value, ExprError> {
        let arity = match name {
            "abs" | "sign" | "round" | "floor" | "ceil" | "sqrt" | "sin" | "cos" | "tan" | "asin" | "acos" | "atan" => 1,
            "min" | "max" | "pow" => 2,
            _ => return Err(ExprError::new(col, format!("unknown function or word `{name}`"))),
        };
        let open = self.col();
        if !self.eat(&Tok::LParen) {
            return Err(ExprError::new(open, format!("function `{name}` must be followed by `(`")));
        }
        self.extension(name);
        let inner = self.enter(depth)?;
        let mut args = Vec::with_capacity(arity);
        if self.peek() != Some(&Tok::RParen) {
            loop {
                let acol = self.col();
                let v = self.or(inner)?;
                args.push(num(v, acol, &format!("`{name}`"))?);
                if !self.eat(&Tok::Comma) {
                    break;
                }
            }
        }
        if !self.eat(&Tok::RParen) {
            return Err(self.expected(&format!("`,` or `)` of `{name}(`"), open));
        }
        let (a, b) = match (args.as_slice(), arity) {
            ([a], 1) => (*a, 0.0),
            ([a, b], 2) => (*a, *b),
            _ => {
                return Err(ExprError::new(col, format!("`{name}` takes {arity} argument(s), got {}", args.len())));
            }
        };
        let x = match name {
            "abs" => a.abs(),
            "sign" => {
                if a > 0.0 {
                    1.0
                } else if a < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            "round" => a.round(),
            "floor" => a.floor(),
            "ceil" => a.ceil(),
            "sqrt" if a < 0.0 => return Err(ExprError::new(col, format!("sqrt of a negative number ({a})"))),
            "sqrt" => a.sqrt(),
            "sin" => a.sin(),
            "cos" => a.cos(),
            "tan" => a.tan(),
            "asin" => a.asin(),
            "acos" => a.acos(),
            "atan" => a.atan(),
            "min" => a.min(b),
            "max" => a.max(b),
            _ => a.powf(b),
        };
        finite(x, col, &format!("`{name}`"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lookup(name: &str) -> Option<Value> {
        match name {
            "a" => Some(Value::Num(3.0)),
            "b" => Some(Value::Bool(false)),
            "c" => Some(Value::Bool(true)),
            "s" => Some(Value::Str("x".into())),
            "Ego_Speed" => Some(Value::Num(50.0)),
            _ => None,
        }
    }

    fn ev(s: &str) -> Result<Value, ExprError> {
        eval(s, &lookup)
    }

    fn n(s: &str) -> f64 {
        match ev(s) {
            Ok(Value::Num(x)) => x,
            other => panic!("{s}: {other:?}"),
        }
    }

    fn b(s: &str) -> bool {
        match ev(s) {
            Ok(Value::Bool(x)) => x,
            other => panic!("{s}: {other:?}"),
        }
    }

    fn err(s: &str) -> String {
        match ev(s) {
            Err(e) => e.to_string(),
            Ok(v) => panic!("{s}: expected an error, got {v:?}"),
        }
    }

    #[test]
    fn precedence() {
        assert_eq!(n("1+2*3"), 7.0);
        assert_eq!(n("(1+2)*3"), 9.0);
        assert_eq!(n("10 % 4"), 2.0);
        assert_eq!(n("-$a + 1"), -2.0);
        assert_eq!(n("2 - 3 - 4"), -5.0);
        assert_eq!(n("24 / 4 / 2"), 3.0);
        assert_eq!(n("2 * -3"), -6.0);
        assert_eq!(n("--2"), 2.0);
        assert_eq!(n("-7 % 3"), -1.0);
        assert_eq!(n("1 + 10 % 4 * 2"), 5.0);
        assert!(!b("not $c and $c"));
        assert!(b("not $b and $c"));
        assert!(b("not ($b and $c)"));
        assert!(b("1 < 2 or 3 < 2"));
        assert!(b("$c or $c and $b"), "and binds tighter than or");
        assert!(!b("($c or $c) and $b"));
        assert!(b("not 1 > 2"), "comparison binds tighter than not");
        assert!(b("1 + 1 == 2"));
        assert!(b("$b == false"));
        assert!(b("$b != $c"));
        assert!(b("2 <= 2 and 2 >= 2 and 1 != 2"));
        assert_eq!(n("$Ego_Speed / 3.6"), 50.0 / 3.6);
        assert_eq!(n("1.5e2 + .5 + 2."), 152.5);
        assert_eq!(n("  3  "), 3.0);
    }

    #[test]
    fn functions() {
        assert_eq!(n("min(3, 2)"), 2.0);
        assert_eq!(n("max(-1, $a)"), 3.0);
        assert_eq!(n("abs(-2.5)"), 2.5);
        assert_eq!(n("sign(-2)"), -1.0);
        assert_eq!(n("sign(0)"), 0.0);
        assert_eq!(n("sign(4)"), 1.0);
        assert_eq!(n("round(2.5)"), 3.0);
        assert_eq!(n("round(-2.5)"), -3.0);
        assert_eq!(n("round(2.4)"), 2.0);
        assert_eq!(n("floor(-1.5)"), -2.0);
        assert_eq!(n("ceil(1.2)"), 2.0);
        assert_eq!(n("sqrt(16)"), 4.0);
        assert_eq!(n("pow(2, 10)"), 1024.0);
        assert_eq!(n("pow(2, 0.5) * sqrt(2)"), 2f64.sqrt() * 2f64.sqrt());
        assert_eq!(n("cos(0) + sin(0) + atan(0)"), 1.0);
        assert_eq!(n("max(min(1, 2), pow(1 + 1, 2))"), 4.0);
        assert_eq!(n("-abs(-1)"), -1.0);
    }

    #[test]
    fn pi_and_the_extensions_used() {
        assert_eq!(n("pi"), std::f64::consts::PI);
        assert_eq!(n("$a * pi / 180"), 3.0 * std::f64::consts::PI / 180.0);
        let lookup = |_: &str| None;
        let used = |s: &str| eval_ext(s, &lookup).map(|(_, u)| u).unwrap_or_default();
        assert_eq!(used("round(1.5) + floor(1) + ceil(1) + sqrt(4) + pow(2, 2)"), Vec::<&str>::new());
        assert_eq!(used("atan(1) * 4 - pi + abs(-1) + atan(0)"), vec!["atan", "pi", "abs"]);
        assert_eq!(used("min(1, 2) + max(1, sign(-1))"), vec!["min", "max", "sign"]);
        assert!(err("pi(1)").contains("unexpected"), "{}", err("pi(1)"));
    }

    #[test]
    fn errors() {
        assert!(err("$nope + 1").contains("parameter `nope` is not declared"));
        assert!(err("foo(1)").contains("unknown function or word `foo`"));
        assert!(err("min(1)").contains("`min` takes 2 argument(s), got 1"));
        assert!(err("abs(1, 2)").contains("`abs` takes 1 argument(s), got 2"));
        assert!(err("pow()").contains("got 0"));
        assert!(err("1/0").contains("division by zero"));
        assert!(err("1 % 0").contains("division by zero"));
        assert!(err("sqrt(-1)").contains("sqrt of a negative"));
        assert!(err("pow(10, 400)").contains("non-finite"));
        assert!(err("asin(2)").contains("non-finite"));
        assert!(err("1e400").contains("out of range"));
        assert!(err("(1 + 2").contains("expected `)`"));
        assert!(err("1 + 2)").contains("unexpected `)` after a complete expression"));
        assert!(err("1 2").contains("unexpected number `2`"));
        assert!(err("1 +").contains("ends where a value is expected"));
        assert!(err("").contains("empty"));
        assert!(err("2^3").contains("`^`"));
        assert!(err("+1").contains("unary `+`"));
        assert!(err("1 = 1").contains("`==`"));
        assert!(err("1 @ 1").contains("unexpected character `@`"));
        assert!(err("1.2.3").contains("malformed number"));
        assert!(err("1e").contains("exponent"));
        assert!(err("$").contains("parameter name"));
        assert!(err("true + 1").contains("`+` needs a number, got a boolean"));
        assert!(err("-true").contains("needs a number"));
        assert!(err("not 1").contains("`not` needs a boolean"));
        assert!(err("1 and true").contains("`and` needs a boolean"));
        assert!(err("$b < $c").contains("cannot compare a boolean with a boolean"));
        assert!(err("1 < 2 < 3").contains("cannot compare a boolean with a number"));
        assert!(err("$s + 1").contains("got a string"));
        assert!(err("min").contains("must be followed by `(`"));
        assert!(err("min(1 2)").contains("expected `,` or `)`"));
        assert!(err("not").contains("ends where a value is expected"));
        assert!(err("and").contains("where a value is expected"));
        // Columns are 1-based characters.
        assert_eq!(ev("1 + $x"), Err(ExprError::new(5, "parameter `x` is not declared")));
    }

    #[test]
    fn limits() {
        let ok = "(".repeat(MAX_DEPTH - 1) + "1" + &")".repeat(MAX_DEPTH - 1);
        assert_eq!(n(&ok), 1.0);
        let deep = "(".repeat(MAX_DEPTH + 1) + "1" + &")".repeat(MAX_DEPTH + 1);
        assert!(err(&deep).contains("nested deeper"));
        assert!(err(&"-".repeat(1000)).contains("nested deeper"));
        assert!(err(&"not ".repeat(500)).contains("nested deeper"));
        assert!(err(&"abs(".repeat(100)).contains("nested deeper"));
        let long = "1+".repeat(MAX_LEN);
        assert!(err(&long).contains("limit"));
        // A long flat chain is no deeper than one level.
        let chain = "1".to_string() + &"+1".repeat(1000);
        assert_eq!(n(&chain), 1001.0);
    }

    proptest! {
        #[test]
        fn random_text_never_panics(s in "\\PC{0,64}") {
            let _ = ev(&s);
        }

        #[test]
        fn random_expression_text_never_panics(s in "[-+*/%()<>=! ,.0-9e$abcnotrudmixspwlf]{0,80}") {
            let _ = ev(&s);
        }
    }
}
