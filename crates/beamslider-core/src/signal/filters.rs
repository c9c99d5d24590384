//! Post-processing of docs/model.md §7: analytic-signal envelope (Hilbert transform via FFT) and
//! the centred moving average.

use crate::error::{Error, Result};
use rayon::prelude::*;
use rustfft::{FftPlanner, num_complex::Complex};

/// The FFTs of the analytic signal for one length, planned once.
struct Analytic {
    fwd: std::sync::Arc<dyn rustfft::Fft<f64>>,
    inv: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

/// Lengths whose plans are kept (a discover's runs share one length; the plan of a length with a
/// large prime factor, such as the 600,001 samples of a 60-s run, costs more than its FFTs).
const PLANS_KEPT: usize = 8;

impl Analytic {
    /// The plans for length `n`: planned once per process and shared (the same plan, so the same
    /// results, as a fresh planner's); at most [`PLANS_KEPT`] lengths are kept.
    fn for_len(n: usize) -> std::sync::Arc<Analytic> {
        use std::collections::HashMap;
        use std::sync::{Arc, Mutex, OnceLock};
        static PLANS: OnceLock<Mutex<HashMap<usize, Arc<Analytic>>>> = OnceLock::new();
        let mut plans = PLANS.get_or_init(|| Mutex::new(HashMap::new())).lock().unwrap_or_else(|e| e.into_inner());
        if let Some(a) = plans.get(&n) {
            return Arc::clone(a);
        }
        if plans.len() >= PLANS_KEPT {
            plans.clear();
        }
        let mut planner = FftPlanner::<f64>::new();
        let a = Arc::new(Analytic { fwd: planner.plan_fft_forward(n), inv: planner.plan_fft_inverse(n) });
        plans.insert(n, Arc::clone(&a));
        a
    }

    /// |analytic signal| of x (length the planned one).
    fn magnitude(&self, x: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        self.magnitude_into(x, &mut EnvelopeBuffers::default(), &mut out);
        out
    }

    /// [`Analytic::magnitude`] into `out`, the spectrum and the FFTs' scratch in `bufs` (the same
    /// arithmetic: `process` is `process_with_scratch` with a fresh scratch).
    fn magnitude_into(&self, x: &[f64], bufs: &mut EnvelopeBuffers, out: &mut Vec<f64>) {
        let n = x.len();
        let buf = &mut bufs.spectrum;
        buf.clear();
        buf.extend(x.iter().map(|&v| Complex::new(v, 0.0)));
        let (nf, ni) = (self.fwd.get_inplace_scratch_len(), self.inv.get_inplace_scratch_len());
        if bufs.scratch.len() < nf.max(ni) {
            bufs.scratch.resize(nf.max(ni), Complex::new(0.0, 0.0));
        }
        self.fwd.process_with_scratch(buf, &mut bufs.scratch[..nf]);
        // Weights: 1 at DC (and Nyquist for even n), 2 for positive frequencies, 0 for negative.
        let half = n / 2;
        for (k, v) in buf.iter_mut().enumerate() {
            let w = if k == 0 || (n.is_multiple_of(2) && k == half) {
                1.0
            } else if k < n.div_ceil(2) {
                2.0
            } else {
                0.0
            };
            *v *= w;
        }
        self.inv.process_with_scratch(buf, &mut bufs.scratch[..ni]);
        let scale = 1.0 / n as f64;
        out.clear();
        out.extend(buf.iter().map(|c| c.norm() * scale));
    }
}

/// Buffers of [`envelope_every`] kept from call to call (one set per worker): a 60-s run's
/// spectrum and scratch are tens of MB, which allocated and first touched anew for every run
/// cost about 5 % of the run.
#[derive(Debug, Default)]
pub struct EnvelopeBuffers {
    spectrum: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    magnitude: Vec<f64>,
    prefix: Vec<f64>,
}

/// |analytic signal| of x: FFT, zero the negative frequencies, double the positive ones, inverse
/// FFT (the discrete Hilbert transform of Marple 1999, as MATLAB's `hilbert`).
pub fn hilbert_envelope(x: &[f64]) -> Vec<f64> {
    if x.is_empty() {
        return Vec::new();
    }
    Analytic::for_len(x.len()).magnitude(x)
}

/// [`hilbert_envelope`] of a long signal by FFTs of overlapping blocks of `block` samples (a power
/// of two: fast FFTs), each keeping its middle (`margin` samples dropped at either inner edge;
/// the last block is aligned with the end, so all blocks have one length) (docs/model.md §7).
/// The Hilbert kernel decays as 1/t, so the kept samples differ from the whole-signal FFT by far
/// less than a figure's line width; the cost is O(n log block), the memory one block. A signal
/// shorter than `block` uses the largest power of two that fits; below 4·`margin` samples a block,
/// the whole-signal FFT. Blocks run in parallel (rayon); the result does not depend on it.
pub fn blocked_hilbert_envelope(x: &[f64], block: usize, margin: usize) -> Vec<f64> {
    let n = x.len();
    let block = if n < block { 1usize << (usize::BITS - 1 - n.max(1).leading_zeros()) } else { block };
    if block < 4 * margin.max(1) {
        return hilbert_envelope(x);
    }
    // The blocks: (start, first kept sample, end of the kept part).
    let step = block - 2 * margin;
    let mut parts = Vec::new();
    let (mut a, mut kept) = (0, 0);
    while kept < n {
        let last = a + block >= n;
        if last {
            a = n - block;
        }
        let hi = if last { n } else { a + block - margin };
        parts.push((a, kept, hi));
        kept = hi;
        a += step;
    }
    // Blocks are independent: a few at a time in parallel (memory: one block per thread).
    let plan = Analytic::for_len(block);
    let mut amp = vec![0.0; n];
    for group in parts.chunks(rayon::current_num_threads().max(1)) {
        let done: Vec<Vec<f64>> = group.par_iter().map(|&(a, kept, hi)| plan.magnitude(&x[a..a + block])[kept - a..hi - a].to_vec()).collect();
        for (&(_, kept, hi), z) in group.iter().zip(done) {
            amp[kept..hi].copy_from_slice(&z);
        }
    }
    amp
}

/// Centred moving average over `window` samples, shrinking at the ends (as MATLAB's `movmean`:
/// for an even window, window/2 samples before and window/2 − 1 after).
pub fn moving_average(x: &[f64], window: usize) -> Vec<f64> {
    moving_average_every(x, window, 1, &mut Vec::new())
}

/// [`moving_average`] at every `every`-th sample only (samples 0, every, 2·every, …; the same
/// values), its prefix sums in `prefix`.
pub fn moving_average_every(x: &[f64], window: usize, every: usize, prefix: &mut Vec<f64>) -> Vec<f64> {
    let n = x.len();
    let mean = windowed_mean(x, window, prefix);
    (0..n).step_by(every.max(1)).map(mean).collect()
}

/// The centred moving average of [`moving_average`] as a function of the sample index, from the
/// prefix sums of `x` (written to `prefix`).
fn windowed_mean<'a>(x: &[f64], window: usize, prefix: &'a mut Vec<f64>) -> impl Fn(usize) -> f64 + 'a {
    let n = x.len();
    let window = window.max(1);
    let before = window / 2;
    let after = window - 1 - before;
    prefix.clear();
    prefix.reserve(n + 1);
    prefix.push(0.0);
    let mut acc = 0.0;
    for &v in x {
        acc += v;
        prefix.push(acc);
    }
    let prefix = &*prefix;
    move |i| {
        let lo = i.saturating_sub(before);
        let hi = (i + after + 1).min(n);
        (prefix[hi] - prefix[lo]) / (hi - lo) as f64
    }
}

/// `x` minus its centred moving average over `window` samples (the window clipped at the ends,
/// as [`moving_average_every`]), in place: the detrending of docs/model.md §7. `prefix`: the
/// prefix sums' buffer, reused across calls. Bitwise the same as subtracting
/// `moving_average_every(x, window, 1, prefix)`, without the second signal-long vector.
pub fn subtract_moving_average(x: &mut [f64], window: usize, prefix: &mut Vec<f64>) {
    let mean = windowed_mean(x, window, prefix);
    for (i, v) in x.iter_mut().enumerate() {
        *v -= mean(i);
    }
}

/// Envelope of docs/model.md §7: |Hilbert(x)| followed by a moving average over `window_s` seconds
/// of samples spaced `dt_s`.
pub fn envelope(x: &[f64], dt_s: f64, window_s: f64) -> Vec<f64> {
    moving_average(&hilbert_envelope(x), window_samples(dt_s, window_s))
}

/// [`envelope`] with the analytic signal of [`blocked_hilbert_envelope`] (figures and summaries of
/// long runs, docs/model.md §7); inputs checked as [`envelope_checked`].
pub fn blocked_envelope(x: &[f64], dt_s: f64, window_s: f64, block: usize, margin: usize) -> Result<Vec<f64>> {
    positive("dt_s", dt_s, "")?;
    positive("window", window_s, " (seconds)")?;
    Ok(moving_average(&blocked_hilbert_envelope(x, block, margin), window_samples(dt_s, window_s)))
}

/// Samples of a `window_s` moving average at spacing `dt_s` (at least 1).
fn window_samples(dt_s: f64, window_s: f64) -> usize {
    (window_s / dt_s).round().max(1.0) as usize
}

/// [`envelope`] with its inputs checked: `dt_s` and `window_s` finite and > 0.
pub fn envelope_checked(x: &[f64], dt_s: f64, window_s: f64) -> Result<Vec<f64>> {
    positive("dt_s", dt_s, "")?;
    positive("window", window_s, " (seconds)")?;
    Ok(envelope(x, dt_s, window_s))
}

/// [`envelope_checked`] at every `every`-th sample only (the same values), with the buffers of
/// `bufs` (docs/model.md §7).
pub fn envelope_every(x: &[f64], dt_s: f64, window_s: f64, every: usize, bufs: &mut EnvelopeBuffers) -> Result<Vec<f64>> {
    positive("dt_s", dt_s, "")?;
    positive("window", window_s, " (seconds)")?;
    if x.is_empty() {
        return Ok(Vec::new());
    }
    let mut magnitude = std::mem::take(&mut bufs.magnitude);
    Analytic::for_len(x.len()).magnitude_into(x, bufs, &mut magnitude);
    let out = moving_average_every(&magnitude, window_samples(dt_s, window_s), every, &mut bufs.prefix);
    bufs.magnitude = magnitude;
    Ok(out)
}

/// `value` finite and > 0, or an error naming `field` (`unit` appended to the rule).
pub fn positive(field: &str, value: f64, unit: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 { Ok(()) } else { Err(Error::invalid(field, value, &format!("must be finite and > 0{unit}"))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_plans_give_a_fresh_planners_results() {
        // A length with a large prime factor (19·1373), planned once and reused: bitwise the
        // results of a fresh planner's plan, and again on the second call.
        let n = 19 * 1373;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() * (1.0 + 0.3 * (i as f64 * 1e-3).cos())).collect();
        let mut planner = FftPlanner::<f64>::new();
        let fresh = Analytic { fwd: planner.plan_fft_forward(n), inv: planner.plan_fft_inverse(n) }.magnitude(&x);
        let first = hilbert_envelope(&x);
        let second = hilbert_envelope(&x);
        assert!(fresh.iter().zip(&first).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(first.iter().zip(&second).all(|(a, b)| a.to_bits() == b.to_bits()));
        // More lengths than are kept: still the same results.
        for m in 1..=PLANS_KEPT + 2 {
            assert_eq!(hilbert_envelope(&x[..n - m]).len(), n - m);
        }
        assert!(hilbert_envelope(&x).iter().zip(&fresh).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

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
    fn blocked_envelope_is_the_whole_fft_away_from_block_edges() {
        // A modulated tone over 3.5 blocks: the blocks' kept middles agree with one FFT of all
        // (away from the signal's two ends, where each FFT wraps around differently).
        let n = 7 * 1024 + 13;
        let x: Vec<f64> = (0..n).map(|i| (1.0 + 0.3 * (i as f64 * 1e-3).sin()) * (i as f64 * 0.9).cos()).collect();
        let whole = hilbert_envelope(&x);
        let blocked = blocked_hilbert_envelope(&x, 2048, 256);
        assert_eq!(blocked.len(), n);
        let worst = (256..n - 256).map(|i| (blocked[i] - whole[i]).abs()).fold(0.0, f64::max);
        assert!(worst < 2e-2, "{worst}");
        // Below 4 margins a block: the whole-signal FFT, bitwise.
        assert_eq!(blocked_hilbert_envelope(&x, 2048, 4096), whole);
        assert!(blocked_envelope(&x, 0.0, 1.0, 2048, 256).is_err());
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

    #[test]
    fn detrending_in_place_is_bitwise_the_subtracted_average() {
        let x: Vec<f64> = (0..1001).map(|i| (0.37 * i as f64).sin() + 1e-3 * i as f64).collect();
        let mut prefix = Vec::new();
        for w in [1, 2, 7, 100, 1000, 2003] {
            let mean = moving_average_every(&x, w, 1, &mut prefix);
            let expected: Vec<f64> = x.iter().zip(&mean).map(|(a, m)| a - m).collect();
            let mut y = x.clone();
            subtract_moving_average(&mut y, w, &mut prefix);
            assert_eq!(y, expected, "window {w}");
        }
    }
}
