//! The native floor: the fastest plain read of a sweep's 12-byte points this processor allows.
//!
//! [`frames::coordinate_sum`](crate::frames::coordinate_sum) keeps eight accumulators of three coordinates and is
//! compiled for the target's baseline (SSE2 on x86-64); it measured 2.3x slower than a `-march=native` C++ loop
//! over the same points (issue #16). [`native_sum`] reads the points as one flat run of `f32` into 64 independent
//! lanes (8 AVX2 registers), so that nothing but the loads bounds it, and is compiled a second time with AVX2,
//! chosen at run time when the processor has it (as the monitor's rasterize loop is). It adds in another order
//! than `coordinate_sum`, so the sums differ in their last bits; only the time matters.

/// Floats per step: 64 independent accumulators (8 AVX2 or 16 SSE2 registers).
const LANES: usize = 64;

/// The sum of every coordinate of every point, in `LANES` independent lanes, with the widest vector unit the
/// processor offers ([`native_instruction_set`]).
#[must_use]
pub fn native_sum(points: &[[f32; 3]]) -> f32 {
    wide::sum(points.as_flattened())
}

/// The instruction set [`native_sum`] runs with here: `"avx2"` or `"baseline"`.
#[must_use]
pub fn native_instruction_set() -> &'static str {
    if wide::available() {
        "avx2"
    } else {
        "baseline"
    }
}

/// The loop, inlined into each instruction set's version: lane-wise additions only (no reassociation needed, so
/// the compiler vectorises it whatever the instruction set).
#[inline(always)]
fn lanes_sum(values: &[f32]) -> f32 {
    let mut acc = [0.0f32; LANES];
    let (chunks, rest) = values.as_chunks::<LANES>();
    for chunk in chunks {
        for (a, v) in acc.iter_mut().zip(chunk) {
            *a += *v;
        }
    }
    acc.iter().sum::<f32>() + rest.iter().sum::<f32>()
}

/// Run-time choice of AVX2. The only `unsafe` of this crate: calling a function compiled with
/// `#[target_feature(enable = "avx2")]`, sound exactly when the processor has AVX2, which is checked first.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod wide {
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    pub(super) fn sum(values: &[f32]) -> f32 {
        if available() {
            // SAFETY: the processor has AVX2 (checked on the line above), the one requirement of `sum_avx2`.
            unsafe { sum_avx2(values) }
        } else {
            super::lanes_sum(values)
        }
    }

    #[target_feature(enable = "avx2")]
    fn sum_avx2(values: &[f32]) -> f32 {
        super::lanes_sum(values)
    }
}

/// Off x86-64: the loop as the target's features compile it (`-C target-cpu=native` widens it).
#[cfg(not(target_arch = "x86_64"))]
mod wide {
    pub(super) fn available() -> bool {
        false
    }

    pub(super) fn sum(values: &[f32]) -> f32 {
        super::lanes_sum(values)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_every_coordinate_whatever_the_length() {
        for n in [0usize, 1, 5, 21, 22, 64, 100, 1000] {
            // Small whole numbers: every order of addition gives the exact sum.
            let points: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, 1.0, -2.0 * (i % 3) as f32]).collect();
            let want: f32 = points.iter().map(|p| p[0] + p[1] + p[2]).sum();
            assert_eq!(native_sum(&points), want, "{n} points");
            assert_eq!(lanes_sum(points.as_flattened()), want, "{n} points, baseline");
        }
        assert!(["avx2", "baseline"].contains(&native_instruction_set()));
    }
}
