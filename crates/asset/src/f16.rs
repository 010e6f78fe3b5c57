//! IEEE 754 binary16 ("half", `f16` sections) conversions without any dependency.
//!
//! Layout of binary16: 1 sign bit, 5 exponent bits (bias 15), 10 mantissa bits. Exponent 0
//! encodes zero and subnormals (value = mantissa × 2⁻²⁴), exponent 31 infinity (mantissa 0)
//! and NaN (mantissa ≠ 0). Largest finite value 65504, smallest normal 2⁻¹⁴, smallest
//! subnormal 2⁻²⁴.

/// Converts an `f32` to binary16 bits, rounding to nearest, ties to even (IEEE default).
///
/// - finite values above the f16 range (|x| ≥ 65520) become ±infinity, as IEEE rounding says;
/// - values below half the smallest subnormal (|x| ≤ 2⁻²⁵) become ±0 (2⁻²⁵ itself is a tie and
///   rounds to the even 0); everything in between rounds correctly to a subnormal;
/// - ±infinity stays ±infinity; a NaN stays a NaN with the same sign and the top 10 bits of
///   its payload; if those 10 bits are all zero, the quiet bit (0x0200) is set so the result
///   cannot turn into infinity. Consequently `f32_to_f16_bits(f16_bits_to_f32(h)) == h` for
///   every one of the 65536 bit patterns `h`.
pub fn f32_to_f16_bits(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xFF) as i32;
    let man = bits & 0x007F_FFFF;

    if exp == 0xFF {
        if man == 0 {
            return sign | 0x7C00;
        }
        let payload = (man >> 13) as u16;
        return sign | 0x7C00 | if payload == 0 { 0x0200 } else { payload };
    }

    // Biased f16 exponent of x (f32 bias 127, f16 bias 15).
    let e = exp - 127 + 15;
    if e >= 0x1F {
        return sign | 0x7C00;
    }
    if e <= 0 {
        // Result is subnormal (or zero, or rounds up to the smallest normal). With the implicit
        // bit, x = full × 2^(exp-150) and one f16 subnormal ulp is 2^-24, so the result in ulps
        // is full >> (14 - e), rounded.
        let shift = 14 - e;
        if shift > 25 {
            // |x| < 2^-26 (the quotient is below a quarter ulp; includes f32 subnormals): ±0.
            return sign;
        }
        let shift = shift as u32; // 14..=25
        let full = man | 0x0080_0000;
        let mut m = full >> shift;
        let rem = full & ((1u32 << shift) - 1);
        let half = 1u32 << (shift - 1);
        if rem > half || (rem == half && m & 1 == 1) {
            m += 1; // may carry into the exponent field: 0x400 is the smallest normal, correct.
        }
        return sign | m as u16;
    }

    let mut h = ((e as u32) << 10) | (man >> 13);
    let rem = man & 0x1FFF;
    if rem > 0x1000 || (rem == 0x1000 && h & 1 == 1) {
        h += 1; // a carry out of the mantissa bumps the exponent; from e = 30 it gives infinity.
    }
    sign | h as u16
}

/// Converts binary16 bits to the `f32` of the same value (exact: every f16 is an f32).
/// NaN payloads are kept (shifted into the top of the f32 mantissa).
pub fn f16_bits_to_f32(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exp = u32::from((h >> 10) & 0x1F);
    let man = u32::from(h & 0x03FF);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, _) => {
            // Subnormal: man × 2^-24. Normalise: shift the leading 1 into the implicit bit.
            // With the leading 1 at bit p (0..=9), x = 1.f × 2^(p-24); lz = 9 - p.
            let lz = man.leading_zeros() - 22;
            let m = (man << (lz + 1)) & 0x03FF;
            let e = 127 - 15 - lz; // biased f32 exponent of 2^(p-24) = 2^(-15 - lz)
            sign | (e << 23) | (m << 13)
        }
        (0x1F, _) => sign | 0x7F80_0000 | (man << 13),
        _ => sign | ((exp + 127 - 15) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        let cases: &[(f32, u16)] = &[
            (0.0, 0x0000),
            (-0.0, 0x8000),
            (1.0, 0x3C00),
            (-2.0, 0xC000),
            (0.5, 0x3800),
            (65504.0, 0x7BFF),
            (-65504.0, 0xFBFF),
            (65519.996, 0x7BFF),
            (65520.0, 0x7C00),
            (1.0e6, 0x7C00),
            (f32::INFINITY, 0x7C00),
            (f32::NEG_INFINITY, 0xFC00),
            (f32::MAX, 0x7C00),
            (6.103_515_6e-5, 0x0400), // 2^-14, smallest normal
            (6.097_555e-5, 0x03FF),   // largest subnormal
            (5.960_464_5e-8, 0x0001), // 2^-24, smallest subnormal
            (2.980_232_2e-8, 0x0000), // 2^-25: tie, rounds to even 0
            (-2.980_232_2e-8, 0x8000),
            (2.980_232_6e-8, 0x0001), // just above 2^-25
            (8.940_697e-8, 0x0002),   // 3 × 2^-25: tie between 1 and 2, even is 2
            (1.0e-10, 0x0000),
            (f32::MIN_POSITIVE, 0x0000),
            (1.0e-45, 0x0000), // f32 subnormal
            (0.1, 0x2E66),
            (1.0 / 3.0, 0x3555),
            (core::f32::consts::PI, 0x4248),
            (1.000_488_3, 0x3C00), // 1 + 2^-11: tie, rounds to even 1.0
            (1.001_464_8, 0x3C02), // 1 + 3·2^-11: tie, rounds to even 1+2^-9
            (2047.5, 0x6800),      // tie between 2047 (odd) and 2048: even wins
            (2046.5, 0x67FE),
            (2048.5, 0x6800),
        ];
        for &(x, h) in cases {
            assert_eq!(f32_to_f16_bits(x), h, "{x:e} -> {:#06x}, want {h:#06x}", f32_to_f16_bits(x));
        }
        assert_eq!(f16_bits_to_f32(0x3C00), 1.0);
        assert_eq!(f16_bits_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_bits_to_f32(0x03FF), 1023.0 * 2f32.powi(-24));
        assert_eq!(f16_bits_to_f32(0x0200), 2f32.powi(-15));
        assert_eq!(f16_bits_to_f32(0x0400), 2f32.powi(-14));
        assert_eq!(f16_bits_to_f32(0x7BFF), 65504.0);
        assert_eq!(f16_bits_to_f32(0xFC00), f32::NEG_INFINITY);
        assert!(f16_bits_to_f32(0x7E00).is_nan());
        assert!(f16_bits_to_f32(0x8000).is_sign_negative());
    }

    #[test]
    fn nan_stays_nan() {
        assert_eq!(f32_to_f16_bits(f32::NAN) & 0x7C00, 0x7C00);
        assert_ne!(f32_to_f16_bits(f32::NAN) & 0x03FF, 0);
        // A NaN whose payload lives only in the low 13 bits must not become infinity.
        let low_payload = f32::from_bits(0x7F80_0001);
        assert!(low_payload.is_nan());
        assert_eq!(f32_to_f16_bits(low_payload), 0x7E00);
        assert_eq!(f32_to_f16_bits(f32::from_bits(0xFF80_0001)), 0xFE00);
    }

    /// Every one of the 65536 patterns survives f16 -> f32 -> f16 bit for bit, and the f32 value
    /// is the exact value of the f16 (checked in f64 from the definition).
    #[test]
    fn exhaustive_round_trip_and_exact_values() {
        for h in 0..=u16::MAX {
            let f = f16_bits_to_f32(h);
            assert_eq!(f32_to_f16_bits(f), h, "pattern {h:#06x}");
            let exp = i32::from((h >> 10) & 0x1F);
            let man = f64::from(h & 0x3FF);
            let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
            let expected = match exp {
                0 => sign * man * 2f64.powi(-24),
                31 if man == 0.0 => sign * f64::INFINITY,
                31 => f64::NAN,
                _ => sign * (1.0 + man / 1024.0) * 2f64.powi(exp - 15),
            };
            if expected.is_nan() {
                assert!(f.is_nan(), "{h:#06x}");
                assert_eq!(f.is_sign_negative(), h & 0x8000 != 0);
            } else {
                assert_eq!(f64::from(f), expected, "{h:#06x}");
                assert_eq!(f.is_sign_negative(), h & 0x8000 != 0, "{h:#06x}");
            }
        }
    }

    /// For every pair of adjacent finite f16 values (both signs, including the overflow
    /// threshold 65520 between 65504 and infinity), the exact midpoint rounds to the even one
    /// and the f32 neighbours of the midpoint round to the nearer one.
    #[test]
    fn exhaustive_rounding_at_midpoints() {
        for lo in 0u16..0x7C00 {
            let hi = lo + 1; // 0x7C00 = infinity: midpoint 65520 is the overflow threshold
            let a = f64::from(f16_bits_to_f32(lo));
            let b = if hi == 0x7C00 { 65536.0 } else { f64::from(f16_bits_to_f32(hi)) };
            let mid = ((a + b) / 2.0) as f32;
            assert_eq!(f64::from(mid), (a + b) / 2.0, "midpoint exact in f32");
            let even = if lo & 1 == 0 { lo } else { hi };
            let below = f32::from_bits(mid.to_bits() - 1);
            let above = f32::from_bits(mid.to_bits() + 1);
            for (sign, sbit) in [(1.0f32, 0u16), (-1.0, 0x8000)] {
                assert_eq!(f32_to_f16_bits(sign * mid), even | sbit, "mid of {lo:#06x}");
                assert_eq!(f32_to_f16_bits(sign * below), lo | sbit, "below mid of {lo:#06x}");
                assert_eq!(f32_to_f16_bits(sign * above), hi | sbit, "above mid of {lo:#06x}");
            }
        }
    }
}
