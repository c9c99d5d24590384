//! The super-slow signals of a free-slider run (docs/model.md §7), computed while the run goes, so
//! that a run continued from a saved state gives bitwise the signals of the run that never
//! stopped (operating maps extended in time, [`crate::map`]).
//!
//! - Amplitude: |analytic signal| of w(4L/7), A = √(w² + H[w]²), with the Hilbert transform H
//!   as a Hann-windowed FIR filter, H[w]ᵢ = Σ_{m odd, m ≤ M} (2/(π m)) · ½(1 + cos(π m/(M+1))) ·
//!   (wᵢ₋ₘ − wᵢ₊ₘ), M = [`HILBERT_HALF_S`] (0.05 s; flat response from ≈ 20 Hz up to the
//!   sampling limit, the excitation is 100–130 Hz). Samples before t = 0 are 0 (the beam starts
//!   at rest). Unlike the FFT form of [`crate::signal::hilbert_envelope`] the value at a sample
//!   depends only on the samples within ±M of it.
//! - Both A and s are averaged over fixed bins of [`BIN_S`] (0.2 s) counted from the start;
//!   a bin is final once M samples past its end are known. [`EnvelopeStream::super_slow`] then
//!   takes the centred moving average of A over 1 s (5 bins) of the final bins, the paper's
//!   super-slow amplitude, and hands s and A to the classifier ([`crate::classify`]).
//!
//! The stream's state (final bins, the raw samples still needed) is serialisable; the f64
//! vectors are written as hexadecimal bit patterns so that they read back exactly.

use serde::{Deserialize, Serialize};

use super::filters::{envelope, moving_average};
use crate::error::{Error, Result};

/// Bin length of the super-slow signals [s].
pub const BIN_S: f64 = 0.2;
/// Half length M of the FIR Hilbert transformer [s].
pub const HILBERT_HALF_S: f64 = 0.05;
/// Steps between the samples a map keeps for the classifier (its default `record_every`).
pub const DEFAULT_RECORD_EVERY: usize = 20;

/// The super-slow signals of one run, sampled uniformly.
#[derive(Debug, Clone, PartialEq)]
pub struct SuperSlow {
    /// Time of the first sample [s].
    pub t0_s: f64,
    /// Sample spacing [s].
    pub dt_s: f64,
    /// Slider position s = x_C/L.
    pub s: Vec<f64>,
    /// Super-slow amplitude of w(4L/7) in units of h.
    pub amplitude_h: Vec<f64>,
}

impl SuperSlow {
    /// From a recorded displacement w(4L/7) [m] and s, sampled every `dt_s`: A = 1-s (`window_s`)
    /// moving average of |Hilbert(w)|, divided by the thickness `h_m` (MODEL.md §7).
    pub fn from_displacement(t0_s: f64, dt_s: f64, w_m: &[f64], s: &[f64], h_m: f64, window_s: f64) -> Result<SuperSlow> {
        if w_m.len() != s.len() {
            return Err(Error::invalid("w", w_m.len(), "w and s must have the same length"));
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(Error::invalid("dt_s", dt_s, "must be finite and > 0"));
        }
        let amplitude_h = envelope(w_m, dt_s, window_s).into_iter().map(|a| a / h_m).collect();
        Ok(SuperSlow { t0_s, dt_s, s: s.to_vec(), amplitude_h })
    }

    pub(crate) fn t(&self, i: usize) -> f64 {
        self.t0_s + i as f64 * self.dt_s
    }
}

/// Streaming computation of the binned super-slow signals (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvelopeStream {
    /// Sample spacing of the pushed samples [s].
    pub sample_dt_s: f64,
    /// Samples per bin.
    pub bin: usize,
    /// Half length M of the Hilbert filter in samples.
    pub half: usize,
    /// Samples pushed so far.
    pub n: u64,
    /// Final bins: mean |analytic signal| of w [m].
    #[serde(with = "hexf")]
    pub bins_a: Vec<f64>,
    /// Final bins: mean s.
    #[serde(with = "hexf")]
    pub bins_s: Vec<f64>,
    /// Sample index of `w_buf[0]`.
    pub buf_start: u64,
    /// Raw w samples still needed (from `buf_start` on) [m].
    #[serde(with = "hexf")]
    pub w_buf: Vec<f64>,
    /// Raw s samples of the bins not yet final (from `bins_s.len() · bin` on).
    #[serde(with = "hexf")]
    pub s_buf: Vec<f64>,
    #[serde(skip)]
    taps: Vec<f64>,
}

fn taps(half: usize) -> Vec<f64> {
    // taps[j] for m = 2j + 1.
    (0..half.div_ceil(2))
        .map(|j| {
            let m = (2 * j + 1) as f64;
            2.0 / (std::f64::consts::PI * m) * 0.5 * (1.0 + (std::f64::consts::PI * m / (half as f64 + 1.0)).cos())
        })
        .collect()
}

impl EnvelopeStream {
    /// A stream for samples spaced `sample_dt_s` (the map's record interval).
    pub fn new(sample_dt_s: f64) -> Result<EnvelopeStream> {
        if !(sample_dt_s.is_finite() && sample_dt_s > 0.0 && sample_dt_s <= 0.5 * BIN_S) {
            return Err(Error::invalid("sample_dt_s", sample_dt_s, &format!("must be finite, > 0 and <= {} s", 0.5 * BIN_S)));
        }
        let bin = ((BIN_S / sample_dt_s).round() as usize).max(1);
        let half = ((HILBERT_HALF_S / sample_dt_s).round() as usize).max(1);
        Ok(EnvelopeStream { sample_dt_s, bin, half, n: 0, bins_a: vec![], bins_s: vec![], buf_start: 0, w_buf: vec![], s_buf: vec![], taps: taps(half) })
    }

    /// Check a stream read back from a file (sizes consistent with its settings).
    pub fn validate(&mut self, sample_dt_s: f64) -> Result<()> {
        let fresh = EnvelopeStream::new(sample_dt_s)?;
        let nb = self.bins_a.len() as u64;
        let ok = self.sample_dt_s == fresh.sample_dt_s
            && self.bin == fresh.bin
            && self.half == fresh.half
            && self.bins_s.len() as u64 == nb
            && self.buf_start + self.w_buf.len() as u64 == self.n
            && nb * self.bin as u64 + self.s_buf.len() as u64 == self.n
            && self.buf_start == (nb * self.bin as u64).saturating_sub(self.half as u64);
        if !ok {
            return Err(Error::invalid("end state", "super-slow signals", "inconsistent with the map's recording interval"));
        }
        self.taps = fresh.taps;
        Ok(())
    }

    /// w at sample `i` as far as known (`n_known` samples): 0 outside.
    #[inline]
    fn w_at(&self, i: i64, n_known: u64) -> f64 {
        if i < self.buf_start as i64 || i >= n_known as i64 {
            // before the start (rest) or not yet known; below buf_start only samples < 0 are asked
            0.0
        } else {
            self.w_buf[(i - self.buf_start as i64) as usize]
        }
    }

    /// |analytic signal| at sample i, with the samples known so far.
    fn amplitude(&self, i: u64, n_known: u64) -> f64 {
        let i = i as i64;
        let mut h = 0.0;
        for (j, &c) in self.taps.iter().enumerate() {
            let m = (2 * j + 1) as i64;
            h += c * (self.w_at(i - m, n_known) - self.w_at(i + m, n_known));
        }
        let w = self.w_at(i, n_known);
        (w * w + h * h).sqrt()
    }

    /// Mean amplitude and s of bin `b` with the samples known so far (a partial last bin: over
    /// its samples).
    fn bin_values(&self, b: usize, n_known: u64) -> (f64, f64) {
        let lo = (b * self.bin) as u64;
        let hi = (lo + self.bin as u64).min(n_known);
        let mut sa = 0.0;
        let mut ss = 0.0;
        let s_lo = (self.bins_s.len() * self.bin) as u64;
        for i in lo..hi {
            sa += self.amplitude(i, n_known);
            ss += self.s_buf[(i - s_lo) as usize];
        }
        let k = (hi - lo) as f64;
        (sa / k, ss / k)
    }

    /// Add one sample of w(4L/7) [m] and s.
    pub fn push(&mut self, w: f64, s: f64) {
        self.w_buf.push(w);
        self.s_buf.push(s);
        self.n += 1;
        let b = self.bins_a.len();
        let end = ((b + 1) * self.bin) as u64;
        if self.n >= end + self.half as u64 {
            let (a, sm) = self.bin_values(b, self.n);
            self.bins_a.push(a);
            self.bins_s.push(sm);
            self.s_buf.drain(..self.bin);
            // Keep the samples the next bin looks back to.
            let keep_from = end.saturating_sub(self.half as u64);
            if keep_from > self.buf_start {
                self.w_buf.drain(..(keep_from - self.buf_start) as usize);
                self.buf_start = keep_from;
            }
        }
    }

    /// Number of samples pushed.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// Whether no sample was pushed.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// All bins: the final ones and, provisionally, those of the last samples (the Hilbert
    /// filter sees zeros past the end): (mean amplitude [m], mean s) per bin.
    pub fn bins(&self) -> (Vec<f64>, Vec<f64>) {
        let mut a = self.bins_a.clone();
        let mut s = self.bins_s.clone();
        let mut b = a.len();
        while ((b * self.bin) as u64) < self.n {
            let (x, y) = self.bin_values(b, self.n);
            a.push(x);
            s.push(y);
            b += 1;
        }
        (a, s)
    }

    /// The super-slow signals of whole recorded series: w(4L/7) [m] and s sampled every
    /// `sample_dt_s` from a run from rest, pushed in order, then [`EnvelopeStream::super_slow`]
    /// with thickness `h_m` and window `window_s` (inputs checked).
    pub fn of_series(w: &[f64], s: &[f64], sample_dt_s: f64, h_m: f64, window_s: f64) -> Result<SuperSlow> {
        super::filters::positive("window", window_s, " (seconds)")?;
        super::filters::positive("thickness_m", h_m, "")?;
        if w.len() != s.len() {
            return Err(Error::invalid("s", format!("{} samples", s.len()), &format!("w and s must have the same length ({} samples of w)", w.len())));
        }
        let mut st = EnvelopeStream::new(sample_dt_s)?;
        for (a, b) in w.iter().zip(s) {
            st.push(*a, *b);
        }
        Ok(st.super_slow(h_m, window_s))
    }

    /// The super-slow signals for the classifier: s per bin and A = centred `window_s` moving
    /// average (1 s in the paper) of the binned amplitude divided by the thickness `h_m`, over
    /// the final bins only (the last ≤ 0.25 s of a run, whose Hilbert filter would see past the
    /// end, are left out: no end effect, and a run continued later sees the same values).
    pub fn super_slow(&self, h_m: f64, window_s: f64) -> SuperSlow {
        let (a, s) = (&self.bins_a, self.bins_s.clone());
        let dt = self.bin as f64 * self.sample_dt_s;
        let k = ((window_s / dt).round() as usize).max(1);
        let a_h: Vec<f64> = a.iter().map(|v| v / h_m).collect();
        SuperSlow { t0_s: 0.5 * (self.bin - 1) as f64 * self.sample_dt_s, dt_s: dt, s, amplitude_h: moving_average(&a_h, k) }
    }
}

/// Serde of `Vec<f64>` as one string of 16 hex digits per value (the IEEE bit pattern): exact,
/// NaN included.
pub mod hexf {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Encode.
    pub fn encode(v: &[f64]) -> String {
        let mut s = String::with_capacity(16 * v.len());
        for x in v {
            s.push_str(&format!("{:016x}", x.to_bits()));
        }
        s
    }

    /// Decode (None when malformed).
    pub fn decode(s: &str) -> Option<Vec<f64>> {
        if !s.len().is_multiple_of(16) || !s.is_ascii() {
            return None;
        }
        (0..s.len() / 16).map(|i| u64::from_str_radix(&s[16 * i..16 * i + 16], 16).ok().map(f64::from_bits)).collect()
    }

    /// serde serialize.
    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&encode(v))
    }

    /// serde deserialize.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let s = String::deserialize(d)?;
        decode(&s).ok_or_else(|| serde::de::Error::custom("expected hexadecimal f64 bit patterns (16 digits each)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signal(i: usize, dt: f64) -> (f64, f64) {
        let t = i as f64 * dt;
        let a = 1e-3 * (1.0 + 0.5 * (0.3 * t).sin());
        (a * (2.0 * std::f64::consts::PI * 118.0 * t).cos(), 0.3 + 0.01 * (0.1 * t).sin())
    }

    #[test]
    fn amplitude_of_a_modulated_cosine() {
        let dt = 4e-4;
        let mut st = EnvelopeStream::new(dt).unwrap();
        for i in 0..25_000 {
            let (w, s) = signal(i, dt);
            st.push(w, s);
        }
        let (a, s) = st.bins();
        assert_eq!(a.len(), 50);
        for b in 2..48 {
            let tc = (b as f64 + 0.5) * 0.2;
            let want = 1e-3 * (1.0 + 0.5 * (0.3 * tc).sin());
            assert!((a[b] - want).abs() < 3e-3 * want, "{b}: {} vs {want}", a[b]);
            assert!((s[b] - (0.3 + 0.01 * (0.1 * tc).sin())).abs() < 1e-4);
        }
    }

    #[test]
    fn split_and_serialised_stream_is_bitwise_the_whole() {
        let dt = 4e-4;
        let mut whole = EnvelopeStream::new(dt).unwrap();
        let mut part = EnvelopeStream::new(dt).unwrap();
        for i in 0..7_777 {
            let (w, s) = signal(i, dt);
            whole.push(w, s);
            part.push(w, s);
        }
        let text = serde_json::to_string(&part).unwrap();
        let mut back: EnvelopeStream = serde_json::from_str(&text).unwrap();
        back.validate(dt).unwrap();
        for i in 7_777..20_001 {
            let (w, s) = signal(i, dt);
            whole.push(w, s);
            back.push(w, s);
        }
        let (a1, s1) = whole.bins();
        let (a2, s2) = back.bins();
        assert_eq!(a1.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), a2.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        assert_eq!(s1.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), s2.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        assert!(whole.w_buf.len() <= whole.bin + 2 * whole.half + 1);
    }

    #[test]
    fn hex_roundtrip() {
        let v = vec![0.1, -0.0, f64::NAN, 1e-300, f64::INFINITY];
        let back = hexf::decode(&hexf::encode(&v)).unwrap();
        assert_eq!(v.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), back.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        assert!(hexf::decode("12").is_none());
    }
}
