//! Standard-normal draws for the LiDAR's per-ray range noise, cheap enough for 24 000 rays a
//! second and deterministic on every platform.
//!
//! A draw is one step of SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number
//! generators", OOPSLA 2014: a Weyl sequence with increment `0x9E37_79B9_7F4A_7C15`, then the
//! `mix64` finaliser) turned into a normal deviate by inverse transform sampling: `z = Φ⁻¹(u)`,
//! `u` uniform in (0, 1) from the draw (its top 12 bits pick the segment, the low 52 the place
//! in it; in the outer segments, its top 53 bits).
//!
//! * Between `u = 2/N` and `1 - 2/N` (`N` = [`KNOTS`] - 1 = 4096 segments), `Φ⁻¹` is
//!   interpolated linearly between knots `Φ⁻¹(k / N)` computed once (Newton's method on
//!   `ln Φ(z)`, `Φ(z) = erfc(-z / √2) / 2`, with [`libm`] so that every platform gets the same
//!   bits). The interpolation error is below 6e-3 standard deviations, largest in the outermost
//!   interpolated segments (`tests::interpolation_is_within_its_bound`): 0.1 mm for the default
//!   2 cm noise.
//! * In the two outermost segments at each end (a draw in 1024), `Φ⁻¹(u)` is solved for the draw
//!   itself, so the tails are the Gaussian's down to `u = 2⁻⁵⁴` (8.2 standard deviations):
//!   nothing is truncated.
//!
//! Against `rand_distr`'s ziggurat on a ChaCha8 stream (57 instructions per draw) a draw costs
//! about 22 in the LiDAR's loop (`docs/benchmarks.md`).

use std::sync::OnceLock;

/// Knots of the interpolated inverse CDF: `Φ⁻¹(k / (KNOTS - 1))`, `k = 0..KNOTS`.
const KNOTS: usize = 4097;
const SEGMENTS: usize = KNOTS - 1;
/// Bits of the draw that pick the segment.
const SEGMENT_BITS: u32 = SEGMENTS.trailing_zeros();
/// Segments at each end where `Φ⁻¹` is solved for the draw instead of interpolated.
const EXACT: usize = 2;

/// A stream of standard-normal deviates.
#[derive(Debug, Clone)]
pub(crate) struct NormalStream {
    state: u64,
    /// Per segment, its lower knot and the rise to the next.
    chords: &'static [[f64; 2]; SEGMENTS],
}

impl NormalStream {
    /// A stream from a 64-bit seed.
    pub(crate) fn new(seed: u64) -> Self {
        Self { state: seed, chords: chords() }
    }

    /// `std` times the next standard-normal deviate, into each of `out` in turn.
    pub(crate) fn fill(&mut self, std: f64, out: &mut [f64]) {
        // The state in a local, so that it stays in a register through the loop.
        let mut state = self.state;
        for o in out {
            *o = std * deviate(next_u64(&mut state), self.chords);
        }
        self.state = state;
    }

    /// The next standard-normal deviate.
    #[cfg(test)]
    pub(crate) fn sample(&mut self) -> f64 {
        deviate(next_u64(&mut self.state), self.chords)
    }
}

/// The next raw 64-bit draw of SplitMix64 from `state`.
#[inline(always)]
fn next_u64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The standard-normal deviate of the raw draw `x`: `Φ⁻¹(u)`.
#[inline(always)]
fn deviate(x: u64, chords: &[[f64; 2]; SEGMENTS]) -> f64 {
    let segment = (x >> (64 - SEGMENT_BITS)) as usize;
    // `segment < EXACT || segment >= SEGMENTS - EXACT` in one compare.
    if segment.wrapping_sub(EXACT) >= SEGMENTS - 2 * EXACT {
        return tail(x);
    }
    // The low 52 bits as the position inside the segment (below 2^52, so the signed conversion
    // is exact).
    let f = (x & ((1 << 52) - 1)) as i64 as f64 * (1.0 / (1u64 << 52) as f64);
    let [lo, rise] = chords[segment];
    lo + f * rise
}

/// `Φ⁻¹(u)` solved for a draw in an outer segment: `u` is the draw's top 53 bits (plus half a
/// step, so that `u` is never 0 or 1), by symmetry always computed in the lower tail.
#[cold]
fn tail(x: u64) -> f64 {
    let k = x >> 11;
    let step = 1.0 / (1u64 << 53) as f64;
    if k < 1 << 52 {
        quantile(k as f64 * step + step / 2.0, -3.0)
    } else {
        -quantile(((1u64 << 53) - 1 - k) as f64 * step + step / 2.0, -3.0)
    }
}

/// The standard normal CDF `Φ(z)`.
fn cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / core::f64::consts::SQRT_2)
}

/// `Φ⁻¹(p)` for `0 < p <= 1/2` by Newton's method from `z0 <= 0`, to the last bit.
fn quantile(p: f64, z0: f64) -> f64 {
    let mut z = z0;
    for _ in 0..100 {
        let density = libm::exp(-0.5 * z * z) / (2.0 * core::f64::consts::PI).sqrt();
        // Newton on `ln Φ(z) = ln p`: nearly linear in the tail, so it converges from any start.
        let phi = cdf(z);
        let dz = phi * (libm::log(p) - libm::log(phi)) / density;
        let next = z + dz;
        if next == z || dz.abs() < 1e-15 * z.abs().max(1.0) {
            return next;
        }
        z = next;
    }
    z
}

/// Per segment `[Φ⁻¹(k / N), Φ⁻¹((k + 1) / N) - Φ⁻¹(k / N)]`, computed on first use (the outer
/// segments' entries are never read).
fn chords() -> &'static [[f64; 2]; SEGMENTS] {
    static CHORDS: OnceLock<[[f64; 2]; SEGMENTS]> = OnceLock::new();
    CHORDS.get_or_init(|| {
        let t = knots();
        core::array::from_fn(|k| if (EXACT..SEGMENTS - EXACT).contains(&k) { [t[k], t[k + 1] - t[k]] } else { [0.0; 2] })
    })
}

/// The knots `Φ⁻¹(k / N)`, `k = 0..=N`.
fn knots() -> [f64; KNOTS] {
    let mut t = [0.0; KNOTS];
    t[0] = f64::NEG_INFINITY;
    t[SEGMENTS] = f64::INFINITY;
    // Lower half by Newton from the previous knot (one or two steps each), upper half by
    // symmetry; the middle knot is 0.
    let mut z = -3.0;
    for k in 1..SEGMENTS / 2 {
        z = quantile(k as f64 / SEGMENTS as f64, z);
        t[k] = z;
        t[SEGMENTS - k] = -z;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knots_are_the_normal_quantiles() {
        let t = knots();
        for k in [1, 2, 100, 1000, 2047, 2048, 2049, 3000, 4095] {
            let p = k as f64 / SEGMENTS as f64;
            assert!((cdf(t[k]) - p).abs() < 1e-15, "knot {k}: Φ({}) = {} vs {p}", t[k], cdf(t[k]));
        }
        assert_eq!(t[2048], 0.0);
        assert!(t.windows(2).all(|w| w[0] < w[1]), "knots ascend");
        // Known values: Φ⁻¹(0.975) = 1.959963984540054, Φ⁻¹(1/4096) = -3.3527...
        assert!((quantile(0.025, -3.0) + 1.959_963_984_540_054).abs() < 1e-12);
    }

    #[test]
    fn interpolation_is_within_its_bound() {
        let t = knots();
        // The largest error of the chord is near a segment's middle; check every inner segment's.
        let mut worst: f64 = 0.0;
        for k in EXACT..SEGMENTS - EXACT {
            let p = (k as f64 + 0.5) / SEGMENTS as f64;
            let exact = if p <= 0.5 { quantile(p, t[k]) } else { -quantile(1.0 - p, -t[k + 1]) };
            worst = worst.max((0.5 * (t[k] + t[k + 1]) - exact).abs());
        }
        assert!(worst < 6e-3, "worst interpolation error {worst} standard deviations");
    }

    #[test]
    fn draws_are_standard_normal() {
        // One million draws: mean, variance, the empirical CDF at nine points and the weight
        // beyond 4 sigma, each against its sampling tolerance (about 5 sigma).
        let mut s = NormalStream::new(7);
        let n = 1_000_000;
        let draws: Vec<f64> = (0..n).map(|_| s.sample()).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|z| (z - mean) * (z - mean)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 5e-3, "mean {mean}");
        assert!((var - 1.0).abs() < 7e-3, "variance {var}");
        for z in [-4.0, -3.0, -2.0, -1.0, 0.0, 0.5, 1.5, 2.5, 3.5] {
            let below = draws.iter().filter(|&&d| d < z).count() as f64 / n as f64;
            let p = cdf(z);
            let tol = 5.0 * (p * (1.0 - p) / n as f64).sqrt() + 1e-6;
            assert!((below - p).abs() < tol, "P(z < {z}) = {below}, Φ = {p}");
        }
        let beyond4 = draws.iter().filter(|d| d.abs() > 4.0).count();
        // Expected 63 beyond 4 sigma: the tails are not truncated.
        assert!((30..=110).contains(&beyond4), "{beyond4} draws beyond 4 sigma");
    }

    #[test]
    fn the_tails_are_solved_exactly_to_the_last_draw() {
        assert_eq!(tail(0), quantile(0.5 / (1u64 << 53) as f64, -3.0));
        assert!(tail(0) < -8.0 && tail(0) > -8.5);
        assert_eq!(tail(u64::MAX), -tail(0));
        // Continuous with the interpolated middle at the segment edges.
        let edge = (EXACT as u64) << (64 - SEGMENT_BITS);
        assert!((tail(edge - 1) - knots()[EXACT]).abs() < 1e-12);
        assert!((tail(!(edge - 1)) - knots()[SEGMENTS - EXACT]).abs() < 1e-12);
    }
}
