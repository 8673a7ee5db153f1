//! Seeds for the simulated devices' noise streams, derived from the world's.

/// Two rounds of the SplitMix64 finaliser: every input bit reaches every
/// output bit, so nearby seeds (a device index, an instant) give unrelated
/// streams.
pub(crate) fn splitmix_finalise(mut z: u64) -> u64 {
    for _ in 0..2 {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
    }
    z
}
