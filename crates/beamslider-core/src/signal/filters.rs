//! Post-processing of docs/model.md §7: analytic-signal envelope (Hilbert transform via FFT) and
//! the centred moving average.

use crate::error::{Error, Result};
use rustfft::{FftPlanner, num_complex::Complex};

/// |analytic signal| of x: FFT, zero the negative frequencies, double the positive ones, inverse
/// FFT (the discrete Hilbert transform of Marple 1999, as MATLAB's `hilbert`).
pub fn hilbert_envelope(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let mut planner = FftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut buf: Vec<Complex<f64>> = x.iter().map(|&v| Complex::new(v, 0.0)).collect();
    fwd.process(&mut buf);
    // Weights: 1 at DC (and Nyquist for even n), 2 for positive frequencies, 0 for negative.
    let half = n / 2;
    for (k, v) in buf.iter_mut().enumerate() {
        let w = if k == 0 || (n % 2 == 0 && k == half) {
            1.0
        } else if k < n.div_ceil(2) {
            2.0
        } else {
            0.0
        };
        *v *= w;
    }
    inv.process(&mut buf);
    let scale = 1.0 / n as f64;
    buf.iter().map(|c| c.norm() * scale).collect()
}

/// Centred moving average over `window` samples, shrinking at the ends (as MATLAB's `movmean`:
/// for an even window, window/2 samples before and window/2 − 1 after).
pub fn moving_average(x: &[f64], window: usize) -> Vec<f64> {
    let n = x.len();
    let window = window.max(1);
    let before = window / 2;
    let after = window - 1 - before;
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    let mut acc = 0.0;
    for &v in x {
        acc += v;
        prefix.push(acc);
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(before);
            let hi = (i + after + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// Envelope of docs/model.md §7: |Hilbert(x)| followed by a moving average over `window_s` seconds
/// of samples spaced `dt_s`.
pub fn envelope(x: &[f64], dt_s: f64, window_s: f64) -> Vec<f64> {
    let k = (window_s / dt_s).round().max(1.0) as usize;
    moving_average(&hilbert_envelope(x), k)
}

/// [`envelope`] with its inputs checked: `dt_s` and `window_s` finite and > 0.
pub fn envelope_checked(x: &[f64], dt_s: f64, window_s: f64) -> Result<Vec<f64>> {
    positive("dt_s", dt_s, "")?;
    positive("window", window_s, " (seconds)")?;
    Ok(envelope(x, dt_s, window_s))
}

/// `value` finite and > 0, or an error naming `field` (`unit` appended to the rule).
pub fn positive(field: &str, value: f64, unit: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(field, value, &format!("must be finite and > 0{unit}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_of_am_signal() {
        // x = (1 + 0.5 cos 2π·0.5 t) cos 2π·100 t sampled at 10 kHz for 4 s.
        let dt = 1e-4;
        let t: Vec<f64> = (0..40000).map(|i| i as f64 * dt).collect();
        let tau = std::f64::consts::TAU;
        let a: Vec<f64> = t.iter().map(|t| 1.0 + 0.5 * (tau * 0.5 * t).cos()).collect();
        let x: Vec<f64> = t.iter().zip(&a).map(|(t, a)| a * (tau * 100.0 * t).cos()).collect();
        let e = hilbert_envelope(&x);
        // Away from the ends the envelope is the modulation.
        for i in 2000..38000 {
            assert!((e[i] - a[i]).abs() < 2e-3, "{i}: {} vs {}", e[i], a[i]);
        }
    }

    #[test]
    fn moving_average_matches_direct_sum() {
        let x: Vec<f64> = (0..50).map(|i| (i * i % 7) as f64).collect();
        for w in [1, 2, 5, 10] {
            let m = moving_average(&x, w);
            for i in 0..x.len() {
                let lo = i.saturating_sub(w / 2);
                let hi = (i + w - w / 2).min(x.len());
                let direct: f64 = x[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
                assert!((m[i] - direct).abs() < 1e-12);
            }
        }
    }
}
