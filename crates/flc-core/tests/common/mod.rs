//! Deterministic inputs shared by the C-interface test (`tests/c_api.rs`), the benchmarks
//! (`benches/core.rs`) and the instruction-count example (`examples/instructions.rs`).
//!
//! `examples/c/main.c` implements the very same generators in C: integer LCG, exact conversions
//! and the same order of floating-point operations, so that both sides produce bit-identical
//! inputs (the C program also prints a hash of its inputs, which the test compares).
#![allow(dead_code)]

/// 64-bit LCG (Knuth's MMIX constants); `uniform` is exact in any IEEE-754 double implementation.
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / 9007199254740992.0)
    }
}

/// A synthetic LiDAR scan of `n` points: the rear face of a car `width` m wide centred at
/// `(d, yc)` (bulging 0.1 m at its corners, +-2 cm noise) and, when `rails`, two guard rails at
/// y = +-5 m from x = 1 to 70 m taking two thirds of the points.
pub fn scan(seed: u64, d: f64, yc: f64, width: f64, n: usize, rails: bool) -> Vec<[f64; 2]> {
    let mut rng = Lcg(seed);
    let n_face = if rails { n / 3 } else { n };
    let mut pts = Vec::with_capacity(n);
    for i in 0..n_face {
        let t = if n_face > 1 { i as f64 / (n_face - 1) as f64 } else { 0.5 };
        let y = yc - 0.5 * width + width * t;
        let u = 2.0 * t - 1.0;
        let x = d + 0.1 * u * u + 0.04 * (rng.uniform() - 0.5);
        pts.push([x, y]);
    }
    if rails {
        let n_rail = n - n_face;
        let half = n_rail / 2;
        for side in 0..2 {
            let count = if side == 0 { half } else { n_rail - half };
            let sign = if side == 0 { 1.0 } else { -1.0 };
            for j in 0..count {
                let x = 1.0 + 69.0 * (j as f64 / count as f64);
                let y = sign * (5.0 + 0.05 * (rng.uniform() - 0.5));
                pts.push([x, y]);
            }
        }
    }
    pts
}

/// FNV-1a over the bit patterns of a sequence of doubles (the C program prints the same hash).
pub fn hash_f64(h: &mut u64, v: f64) {
    for b in v.to_bits().to_le_bytes() {
        *h ^= u64::from(b);
        *h = h.wrapping_mul(0x100000001b3);
    }
}

pub const FNV_OFFSET: u64 = 0xcbf29ce484222325;

/// Values that must be refused: NaN, infinities, negative and implausibly large.
pub const SPECIAL: [f64; 5] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1.0, 1.0e9];
