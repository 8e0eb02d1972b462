//! Random streams and V2V relaying of the loop.

use flc_core::V2vMessage;

use crate::v2v::V2vChannel;

/// Seeds of the random processes, derived from the scenario seed (SplitMix64 steps), so that each
/// process has its own stream and changing one impairment does not reshuffle another.
pub(crate) fn sub_seed(seed: u64, stream: u64) -> u64 {
    let mut z = seed.wrapping_add(stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Random stream `j` of follower `k` (1-based): follower 1 keeps the single-follower streams
/// (1 = LiDAR, 2 = V2V link, 3 = second V2V link, 4 = own GNSS), follower `k` uses `j + 16 (k - 1)`.
pub(super) fn follower_stream(k: usize, j: u64) -> u64 {
    j + 16 * (k as u64 - 1)
}

/// Relay link: forwards `pending` (a lead speed the sender received and has not forwarded yet)
/// on the first due broadcast slot (`consumed` tells), then delivers what has arrived.
pub(super) fn relay_tick(ch: &mut V2vChannel, t: f64, pending: Option<f64>, consumed: &mut bool) -> Option<V2vMessage> {
    if let Some(v) = pending {
        if ch.broadcast_due(t) {
            ch.send(t, v);
            *consumed = true;
        }
    }
    ch.receive(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follower_one_keeps_the_single_follower_streams() {
        assert_eq!([1, 2, 3].map(|j| follower_stream(1, j)), [1, 2, 3]);
        assert_eq!(follower_stream(2, 1), 17);
        // Distinct streams for every follower and process.
        let mut all: Vec<u64> = (1..=64).flat_map(|k| (1..=3).map(move |j| follower_stream(k, j))).collect();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), 64 * 3);
    }
}
