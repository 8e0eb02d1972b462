//! Input helpers shared by the fuzz targets.
#![allow(dead_code)]

use arbitrary::Arbitrary;

/// A number as the fuzzer builds it: any bit pattern (NaN, infinities, subnormals, huge), or a
/// value spread over a plausible range (so that the control laws, not only the input checks, are
/// explored).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Num {
    Raw(f64),
    Unit(u16),
    Special(u8),
}

impl Num {
    /// The value, `Unit` mapped onto `[lo, hi]`.
    pub fn get(self, lo: f64, hi: f64) -> f64 {
        match self {
            Num::Raw(v) => v,
            Num::Unit(u) => lo + (hi - lo) * (f64::from(u) / 65535.0),
            Num::Special(k) => [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, -1.0, f64::MAX, f64::MIN_POSITIVE, 1e-300, lo, hi]
                [usize::from(k) % 11],
        }
    }
}

/// A parameter: the default most of the time, or anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Param {
    Default,
    Value(Num),
}

impl Param {
    pub fn get(self, default: f64, lo: f64, hi: f64) -> f64 {
        match self {
            Param::Default => default,
            Param::Value(n) => n.get(lo, hi),
        }
    }
}

/// Bit-exact equality of two doubles (NaN == NaN).
pub fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}
