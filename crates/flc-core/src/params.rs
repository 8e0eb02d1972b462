//! Parameter validation shared by all constructors.

/// A parameter was rejected by a constructor (`new(params) -> Result`).
///
/// `field` is the parameter's name exactly as in the parameter struct (and as the Python keyword).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamError {
    /// Name of the offending field, e.g. `"time_gap"`.
    pub field: &'static str,
    /// What is wrong with it, e.g. `"must be finite and > 0"`.
    pub problem: &'static str,
}

impl core::fmt::Display for ParamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "invalid parameter `{}`: {}", self.field, self.problem)
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ParamError {}

/// Checks `lo <= v <= hi` and finiteness; returns a [`ParamError`] naming `field` otherwise.
pub(crate) fn check_range(field: &'static str, v: f64, lo: f64, hi: f64, problem: &'static str) -> Result<(), ParamError> {
    if v.is_finite() && v >= lo && v <= hi { Ok(()) } else { Err(ParamError { field, problem }) }
}

/// Checks `v` finite and strictly positive (and at most `hi`).
pub(crate) fn check_positive(field: &'static str, v: f64, hi: f64, problem: &'static str) -> Result<(), ParamError> {
    if v.is_finite() && v > 0.0 && v <= hi { Ok(()) } else { Err(ParamError { field, problem }) }
}

/// The name of a field of a nested parameter struct as `prefix.field` (a `&'static str`, as
/// [`ParamError::field`] needs) for each field the nested struct's `validate` can name; `prefix`
/// itself for any other. Errors then name the key a scenario file or Python sets.
macro_rules! nested_field {
    ($prefix:literal, $field:expr, [$($f:literal),* $(,)?]) => {
        match $field {
            $( $f => concat!($prefix, ".", $f), )*
            _ => $prefix,
        }
    };
}
pub(crate) use nested_field;
