//! Floating-point kernels of the time loop.
//!
//! Every product-sum of the step uses the fused multiply-add a·b + c (one rounding). In the
//! AVX2 + FMA build of the time loop (module `dynamics::simulation`) it is a single instruction; in the
//! generic build it is libm's correctly rounded `fma`. Both round identically, so the two builds
//! give bitwise the same results.

/// a·b + c with a single rounding.
#[inline(always)]
pub(crate) fn fma(a: f64, b: f64, c: f64) -> f64 {
    a.mul_add(b, c)
}

/// Σₘ xₘ yₘ as two interleaved chains of fused multiply-adds (even and odd m) and their sum:
/// half the dependency chain of a left-to-right sum.
#[inline(always)]
pub(crate) fn dot<const N: usize>(x: &[f64; N], y: &[f64; N]) -> f64 {
    if N == 1 {
        return x[0] * y[0];
    }
    let mut even = x[0] * y[0];
    let mut odd = x[1] * y[1];
    let mut m = 2;
    while m + 1 < N {
        even = fma(x[m], y[m], even);
        odd = fma(x[m + 1], y[m + 1], odd);
        m += 2;
    }
    if m < N {
        even = fma(x[m], y[m], even);
    }
    even + odd
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_plain_sum() {
        let x = [1.5, -2.0, 0.25, 4.0, 3.0, -1.0, 0.5];
        let y = [2.0, 0.5, -4.0, 0.25, 1.0, 2.0, -8.0];
        assert_eq!(dot(&[x[0]], &[y[0]]), 3.0);
        let p = |n: usize| (0..n).map(|m| x[m] * y[m]).sum::<f64>();
        assert_eq!(dot(&[x[0], x[1]], &[y[0], y[1]]), p(2));
        assert_eq!(dot(&[x[0], x[1], x[2], x[3], x[4]], &[y[0], y[1], y[2], y[3], y[4]]), p(5));
        assert_eq!(dot(&x, &y), p(7));
        // One rounding: (1 + 2⁻³⁰)² − 1 keeps the 2⁻⁶⁰ term that a separate product loses.
        let a = 1.0 + 2f64.powi(-30);
        assert_eq!(fma(a, a, -1.0), 2f64.powi(-29) + 2f64.powi(-60));
    }
}
