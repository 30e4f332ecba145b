//! The host side of the exact per-pixel accumulator (`shaders/accumulate.wgsl`): reading a channel's
//! long-accumulator sum as an f64, adding two of them (merging partial renders), and a CPU mirror of the
//! device's addition of one sample.
//!
//! A channel's sum is a 192-bit unsigned integer held as [`ACCUM_LIMBS`] u32 limbs (least significant
//! first; on the GPU interleaved with the other channels', see [`channel`]), in
//! units of 2^-96. Samples in [2^-73, 2^64) add into it exactly; smaller ones are rounded to the grid
//! (ties to even), larger ones clamped (accumulate.wgsl explains the window). Adding two such integers is
//! exact and associative: whatever way the samples were split (passes, tiles, checkpoints, sample
//! ranges), the total has the same bits, and so does the image computed from it.

use crate::kernel::abi::{ACCUM_LIMBS, GpuAccum, GpuSplatAccum};

/// The accumulator's unit, as a power of two: one unit of limb 0 is 2^-96.
pub const UNIT_EXP: i32 = -96;

/// The largest sample value the accumulator holds, (2^24 - 1) 2^40 (the largest f32 below 2^64);
/// larger samples are clamped to it.
pub const MAX_SAMPLE: f32 = f32::from_bits(0x5f7f_ffff);

/// The three channels' exact sums as the GPU keeps them, limb-major: `sum[3 k + c]` is limb k of channel
/// c (`GpuAccum::sum`, and `GpuSplatAccum::sum` for the splatted sums of w L).
pub type Sums = [u32; 3 * ACCUM_LIMBS];

/// One channel's limbs of `sum`, least significant first: `sum[3 k + c]` for k = 0..ACCUM_LIMBS (the
/// GPU keeps the limbs limb-major, so that one vec3 operation adds a limb of all three channels).
pub fn sums_channel(sum: &Sums, c: usize) -> [u32; ACCUM_LIMBS] {
    std::array::from_fn(|k| sum[3 * k + c])
}

/// One channel's limbs of a pixel's sums of samples ([`sums_channel`]).
pub fn channel(accum: &GpuAccum, c: usize) -> [u32; ACCUM_LIMBS] {
    sums_channel(&accum.sum, c)
}

/// `acc += other`, channel by channel, exactly. Returns false on overflow (see [`add`]).
pub fn add_channels(acc: &mut Sums, other: &Sums) -> bool {
    let mut ok = true;
    for c in 0..3 {
        let mut limbs = sums_channel(acc, c);
        ok &= add(&mut limbs, &sums_channel(other, c));
        set_sums_channel(acc, c, &limbs);
    }
    ok
}

/// Adds `other`'s sums into `acc`'s, channel by channel, exactly. Returns false on overflow (see [`add`]).
pub fn add_sums(acc: &mut GpuAccum, other: &GpuAccum) -> bool {
    add_channels(&mut acc.sum, &other.sum)
}

/// Writes channel c's limbs (least significant first) into `sum`.
pub fn set_sums_channel(sum: &mut Sums, c: usize, limbs: &[u32; ACCUM_LIMBS]) {
    for (k, &l) in limbs.iter().enumerate() {
        sum[3 * k + c] = l;
    }
}

/// Writes channel c's limbs (least significant first) into a pixel's sums of samples.
pub fn set_channel(accum: &mut GpuAccum, c: usize, limbs: &[u32; ACCUM_LIMBS]) {
    set_sums_channel(&mut accum.sum, c, limbs);
}

/// `acc += other` for splatted sums (`GpuSplatAccum`): each channel's exact sum of w L and the weights'
/// 64-bit integer, with carry: exact. Returns false on an overflow (more than 2^32 samples of the
/// largest value).
pub fn add_splat(acc: &mut GpuSplatAccum, other: &GpuSplatAccum) -> bool {
    add_channels(&mut acc.sum, &other.sum) & add(&mut acc.weight, &other.weight)
}

/// The f64 nearest to the exact sum held in `limbs` (round to nearest, ties to even): the only rounding
/// between the accumulated samples and the image.
///
/// The top three limbs from the highest non-zero one (96 bits, at least 65 significant when there are
/// lower limbs) are converted by Rust's correctly rounded u128 -> f64; every lower non-zero limb is
/// folded into bit 0 as a sticky bit, which lies far below the rounding position, so the result is
/// rounded as the whole integer would be. Scaling by a power of two is then exact.
pub fn to_f64(limbs: &[u32]) -> f64 {
    let Some(top) = limbs.iter().rposition(|&l| l != 0) else {
        return 0.0;
    };
    let low = top.saturating_sub(2);
    let mut v: u128 = 0;
    for k in (low..=top).rev() {
        v = (v << 32) | u128::from(limbs[k]);
    }
    if limbs[..low].iter().any(|&l| l != 0) {
        v |= 1;
    }
    v as f64 * pow2(32 * low as i32 + UNIT_EXP)
}

/// 2^e for e in f64's normal range, built from its bits (exact).
fn pow2(e: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&e));
    f64::from_bits(((e + 1023) as u64) << 52)
}

/// `acc += other`, limb by limb with carry: exact. Returns false if the sum overflowed, which would take
/// more than 2^32 samples of the largest value (a render holds at most 2^32 - 1 samples).
/// `other` may be shorter than `acc` (its missing high limbs are 0); the carry goes up through all of
/// `acc`'s limbs.
pub fn add(acc: &mut [u32], other: &[u32]) -> bool {
    let mut carry = 0u64;
    for (k, a) in acc.iter_mut().enumerate() {
        let b = other.get(k).copied().unwrap_or(0);
        let t = u64::from(*a) + u64::from(b) + carry;
        *a = t as u32;
        carry = t >> 32;
    }
    carry == 0
}

/// `acc += x` as `accumulate_exact` in accumulate.wgsl does it on the device (non-finite and negative
/// values add nothing; tiny ones are rounded to the 2^-96 grid, ties to even; huge ones clamped to
/// [`MAX_SAMPLE`]). Written independently of the shader's shifts: x / 2^-96 is computed in f64 (exact:
/// a 24-bit significand times a power of two) and rounded with `round_ties_even`.
pub fn add_f32(acc: &mut [u32], x: f32) {
    if !(x.is_finite() && x > 0.0) {
        return;
    }
    let units = f64::from(x.min(MAX_SAMPLE)) * pow2(-UNIT_EXP);
    if units < 2f64.powi(64) {
        let q = units.round_ties_even() as u64;
        add(acc, &[q as u32, (q >> 32) as u32]);
        return;
    }
    // A multiple of 2^11 or more: split into an exact integer mantissa and a shift.
    let shift = (units.log2().floor() as i32 - 52).max(0);
    let mantissa = (units / 2f64.powi(shift)) as u128;
    debug_assert_eq!(mantissa as f64 * 2f64.powi(shift), units);
    let mut term = [0u32; ACCUM_LIMBS];
    let (k, o) = ((shift / 32) as usize, shift % 32);
    let wide = mantissa << o;
    for (j, limb) in term.iter_mut().enumerate().skip(k).take(4) {
        *limb = (wide >> (32 * (j - k))) as u32;
    }
    add(acc, &term);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sum_of(xs: &[f32]) -> [u32; ACCUM_LIMBS] {
        let mut acc = [0u32; ACCUM_LIMBS];
        for &x in xs {
            add_f32(&mut acc, x);
        }
        acc
    }

    #[test]
    fn reads_small_integers_and_powers_of_two() {
        assert_eq!(to_f64(&[0; ACCUM_LIMBS]), 0.0);
        assert_eq!(to_f64(&[1, 0, 0, 0, 0, 0]), 2f64.powi(-96));
        // 1.0 = 2^96 units: limb 3.
        let one = [0, 0, 0, 1, 0, 0];
        assert_eq!(to_f64(&one), 1.0);
        assert_eq!(sum_of(&[1.0]), one);
        assert_eq!(sum_of(&[2f32.powi(-96)]), [1, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn tiny_samples_round_to_the_grid_ties_to_even_and_huge_ones_clamp() {
        let unit = 2f32.powi(-96);
        assert_eq!(sum_of(&[0.5 * unit])[0], 0, "a tie rounds to even (0)");
        assert_eq!(sum_of(&[1.5 * unit])[0], 2, "a tie rounds to even (2)");
        assert_eq!(sum_of(&[0.75 * unit])[0], 1);
        assert_eq!(sum_of(&[f32::from_bits(1)])[0], 0, "the smallest subnormal");
        assert_eq!(sum_of(&[f32::MAX]), sum_of(&[MAX_SAMPLE]));
        assert_eq!(to_f64(&sum_of(&[f32::MAX])), f64::from(MAX_SAMPLE));
        assert!(f64::from(MAX_SAMPLE) < 2f64.powi(64));
        assert_eq!(
            sum_of(&[-1.0, -0.0, f32::NAN, f32::INFINITY]),
            [0; ACCUM_LIMBS]
        );
    }

    #[test]
    fn rounds_the_whole_integer_once() {
        // 1 + 2^-60 + 2^-96: the f64 nearest is 1 (the tail is far below half an ulp of 1, 2^-53).
        let acc = sum_of(&[1.0, 2f32.powi(-60), 2f32.powi(-96)]);
        assert_eq!(to_f64(&acc), 1.0);
        // 1 + 2^-53 + 2^-96: just above the tie between 1 and 1 + 2^-52, so it rounds up; without the
        // sticky bit for the 2^-96 (in limb 0, below the three limbs read) it would tie to even, down to 1.
        let acc = sum_of(&[1.0, 2f32.powi(-53), 2f32.powi(-96)]);
        assert_eq!(to_f64(&acc), 1.0 + 2f64.powi(-52));
    }

    #[test]
    fn the_largest_sample_2_to_the_32_times_does_not_overflow() {
        let mut chunk = sum_of(&[MAX_SAMPLE]);
        // Doubling 32 times: 2^32 samples.
        for _ in 0..32 {
            let c = chunk;
            assert!(add(&mut chunk, &c));
        }
        assert_eq!(to_f64(&chunk), f64::from(MAX_SAMPLE) * 2f64.powi(32));
        // Half of 2^96 more does not fit.
        assert!(
            !add(&mut chunk, &[0, 0, 0, 0, 0, 1 << 31]),
            "past 2^96 it overflows"
        );
    }

    #[test]
    fn any_grouping_gives_the_same_bits() {
        let xs: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919 % 1000) as f32 * 0.17).exp2() * 1e-25)
            .collect();
        let all = sum_of(&xs);
        let mut a = [0u32; ACCUM_LIMBS];
        for &x in xs[..377].iter().rev() {
            add_f32(&mut a, x);
        }
        let mut b = sum_of(&xs[377..]);
        assert!(add(&mut b, &a));
        assert_eq!(b, all);
    }
}
