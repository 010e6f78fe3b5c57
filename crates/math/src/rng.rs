//! Hash-based, counter-style random numbers.
//!
//! Every random draw in penumbra is a pure function of `(seed, stage, item, sample)`, so
//! results do not depend on thread count or scheduling (DESIGN §4, determinism). There is
//! no shared stream anywhere.

/// SplitMix64 finaliser: a bijective avalanche mix of 64 bits.
#[inline]
pub const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of a tuple of counters.
#[inline]
pub const fn hash4(seed: u64, stage: u64, item: u64, sample: u64) -> u64 {
    let mut h = mix64(seed ^ 0x9E37_79B9_7F4A_7C15);
    h = mix64(h ^ stage.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    h = mix64(h ^ item.wrapping_mul(0xA076_1D64_78BD_642F));
    mix64(h ^ sample.wrapping_mul(0xE703_7ED1_A0B4_28DB))
}

/// Uniform `f64` in `[0, 1)` with 53 random bits.
#[inline]
pub fn unit_f64(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A deterministic per-item generator: draws are `hash4(seed, stage, item, counter)`.
#[derive(Debug, Clone)]
pub struct ItemRng {
    seed: u64,
    stage: u64,
    item: u64,
    counter: u64,
}

impl ItemRng {
    /// Generator for one work item of one stage.
    pub fn new(seed: u64, stage: u64, item: u64) -> Self {
        Self { seed, stage, item, counter: 0 }
    }

    /// Next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let v = hash4(self.seed, self.stage, self.item, self.counter);
        self.counter += 1;
        v
    }

    /// Next uniform in `[0, 1)`.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        unit_f64(self.next_u64())
    }

    /// Uniform integer in `0..n` (n > 0), by widening multiplication (negligible bias for n ≪ 2⁶⁴).
    #[inline]
    pub fn below(&mut self, n: u64) -> u64 {
        ((self.next_u64() as u128 * n as u128) >> 64) as u64
    }
}

/// Stable stage identifiers so that two stages never share a random stream.
pub mod stage {
    /// Sphere-set initialisation and teleportation.
    pub const SPHERES: u64 = 1;
    /// Monte-Carlo volume estimates.
    pub const VOLUME_MC: u64 = 2;
    /// Ray-traced references.
    pub const REFERENCE: u64 = 3;
    /// Transport gathers.
    pub const TRANSPORT: u64 = 4;
    /// Tables bake test families.
    pub const TABLES: u64 = 5;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniformity_and_independence() {
        let mut r = ItemRng::new(7, stage::TABLES, 3);
        let n = 200_000;
        let mut mean = 0.0;
        let mut buckets = [0usize; 10];
        for _ in 0..n {
            let u = r.next_f64();
            assert!((0.0..1.0).contains(&u));
            mean += u;
            buckets[(u * 10.0) as usize] += 1;
        }
        mean /= n as f64;
        assert!((mean - 0.5).abs() < 0.005);
        for b in buckets {
            assert!((b as f64 - n as f64 / 10.0).abs() < 0.02 * n as f64 / 10.0 * 5.0);
        }
        assert_ne!(hash4(1, 2, 3, 4), hash4(1, 2, 4, 3));
        assert_eq!(ItemRng::new(1, 2, 3).next_u64(), hash4(1, 2, 3, 0));
    }
}
