//! What the summary and the figure of a run need, gathered while its rows stream to a file
//! (docs/model.md §7), so that neither reads the trajectory back:
//!
//! - the super-slow signals of [`crate::signal::envelope_stream`] (0.2-s bins of |analytic signal| of
//!   w(4L/7) and of s, then the centred moving average): fed with the samples an operating map
//!   uses (every [`crate::signal::envelope_stream::DEFAULT_RECORD_EVERY`]-th step when `record_every` divides it), so
//!   a run's final amplitude is the one its map point reports;
//! - the min/max decimation of w(4L/7) and s for the figure's time panels: the run's expected
//!   rows split into `columns` equal runs of n // columns samples, and of each run the samples of
//!   its minimum and its maximum (first occurrence; NaN counts as an extreme, as numpy's
//!   argmin/argmax), in time order, then the extremes of the remainder (the same samples as
//!   `beamslider.plotting.decimate_minmax`).

use crate::dynamics::record::Recorder;
use crate::error::Result;
use crate::signal::envelope_stream::EnvelopeStream;

/// The extremes of one run of samples.
#[derive(Debug, Clone, Copy)]
struct Extremes {
    i_min: u64,
    t_min: f64,
    v_min: f64,
    i_max: u64,
    t_max: f64,
    v_max: f64,
}

impl Extremes {
    fn new(i: u64, t: f64, v: f64) -> Self {
        Extremes { i_min: i, t_min: t, v_min: v, i_max: i, t_max: t, v_max: v }
    }

    /// numpy's argmin/argmax rule: the first NaN, else the first strict extreme.
    fn add(&mut self, i: u64, t: f64, v: f64) {
        if !self.v_min.is_nan() && (v.is_nan() || v < self.v_min) {
            (self.i_min, self.t_min, self.v_min) = (i, t, v);
        }
        if !self.v_max.is_nan() && (v.is_nan() || v > self.v_max) {
            (self.i_max, self.t_max, self.v_max) = (i, t, v);
        }
    }

    /// The two samples in time order (a remainder lists a sample that is both only once).
    fn emit(&self, t: &mut Vec<f64>, y: &mut Vec<f64>, dedup: bool) {
        let (a, b) =
            if self.i_min <= self.i_max { ((self.t_min, self.v_min), (self.t_max, self.v_max)) } else { ((self.t_max, self.v_max), (self.t_min, self.v_min)) };
        t.push(a.0);
        y.push(a.1);
        if !(dedup && self.i_min == self.i_max) {
            t.push(b.0);
            y.push(b.1);
        }
    }
}

/// Min/max decimation of one signal into a fixed number of columns (module header).
#[derive(Debug, Clone)]
pub struct MinMaxColumns {
    n: u64,
    per: u64,
    full: u64,
    i: u64,
    /// Samples left in the current column before the next one starts.
    left: u64,
    cur: Option<Extremes>,
    /// Times of the kept samples [s].
    pub t: Vec<f64>,
    /// Values of the kept samples.
    pub y: Vec<f64>,
}

impl MinMaxColumns {
    /// A decimation of `n` samples into `columns` columns; None when `n < 4 · columns` (short
    /// traces are drawn as they are).
    pub fn new(n: u64, columns: usize) -> Option<MinMaxColumns> {
        let c = columns as u64;
        if columns == 0 || n < 4 * c {
            return None;
        }
        let per = n / c;
        Some(MinMaxColumns { n, per, full: per * c, i: 0, left: 0, cur: None, t: Vec::with_capacity(2 * columns + 2), y: Vec::with_capacity(2 * columns + 2) })
    }

    /// The next sample (time t [s], value v).
    pub fn push(&mut self, t: f64, v: f64) {
        let i = self.i;
        self.i += 1;
        if self.left == 0 {
            // a new column (or the remainder after the last full one)
            if let Some(e) = self.cur.take() {
                e.emit(&mut self.t, &mut self.y, false);
            }
            self.cur = Some(Extremes::new(i, t, v));
            self.left = if i < self.full { self.per - 1 } else { u64::MAX };
        } else {
            self.left -= 1;
            if let Some(e) = self.cur.as_mut() {
                e.add(i, t, v);
            }
        }
    }

    /// The kept samples (times, values); None when fewer or more samples came than planned.
    pub fn finish(mut self) -> Option<(Vec<f64>, Vec<f64>)> {
        if self.i != self.n {
            return None;
        }
        if let Some(e) = self.cur.take() {
            e.emit(&mut self.t, &mut self.y, self.n > self.full);
        }
        Some((self.t, self.y))
    }
}

/// The summary's and the figure's data of a finished run ([`OverviewRecorder::finish`]).
#[derive(Debug, Clone)]
pub struct Overview {
    /// Min/max decimation of w(4L/7): times [s] and values [m]; None for short or shortened runs.
    pub w: Option<(Vec<f64>, Vec<f64>)>,
    /// Min/max decimation of s; None as for `w`.
    pub s: Option<(Vec<f64>, Vec<f64>)>,
    /// The super-slow stream (None when the run records no t, w or s, or its samples are spaced
    /// too far apart for 0.2-s bins).
    pub signals: Option<EnvelopeStream>,
}

/// A recorder that keeps only the [`Overview`] of the rows it sees (channels `t_s`, `w_4L7_m`,
/// `s`; others are ignored). Used beside a [`crate::FileRecorder`] through [`crate::dynamics::record::Tee`].
#[derive(Debug, Clone)]
pub struct OverviewRecorder {
    expected_rows: u64,
    columns: usize,
    stride: u64,
    sample_dt_s: f64,
    idx: Option<(usize, usize, usize)>,
    /// Rows until the next one that feeds the super-slow stream.
    skip: u64,
    w: Option<MinMaxColumns>,
    s: Option<MinMaxColumns>,
    signals: Option<EnvelopeStream>,
}

impl OverviewRecorder {
    /// For a run of `expected_rows` rows spaced `record_every` steps of `dt_s`, decimated to
    /// `columns` pixel columns.
    pub fn new(expected_rows: u64, columns: usize, dt_s: f64, record_every: usize) -> OverviewRecorder {
        let k = record_every.max(1);
        let stride = ((crate::signal::envelope_stream::DEFAULT_RECORD_EVERY as f64 / k as f64).round() as u64).max(1);
        OverviewRecorder { expected_rows, columns, stride, sample_dt_s: dt_s * k as f64 * stride as f64, idx: None, skip: 0, w: None, s: None, signals: None }
    }

    /// The overview (see [`Overview`]).
    pub fn finish(self) -> Overview {
        let both = |x: Option<MinMaxColumns>| x.and_then(MinMaxColumns::finish);
        Overview { w: both(self.w), s: both(self.s), signals: self.signals }
    }
}

impl Recorder for OverviewRecorder {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        let at = |n: &str| names.iter().position(|x| x == n);
        self.idx = match (at("t_s"), at("w_4L7_m"), at("s")) {
            (Some(t), Some(w), Some(s)) => Some((t, w, s)),
            _ => None,
        };
        if self.idx.is_some() {
            self.w = MinMaxColumns::new(self.expected_rows, self.columns);
            self.s = MinMaxColumns::new(self.expected_rows, self.columns);
            self.signals = EnvelopeStream::new(self.sample_dt_s).ok();
        }
        Ok(())
    }

    fn push(&mut self, row: &[f64]) -> Result<()> {
        let Some((it, iw, is)) = self.idx else { return Ok(()) };
        let (t, w, s) = (row[it], row[iw], row[is]);
        if let Some(d) = self.w.as_mut() {
            d.push(t, w);
        }
        if let Some(d) = self.s.as_mut() {
            d.push(t, s);
        }
        if self.skip == 0 {
            if let Some(st) = self.signals.as_mut() {
                st.push(w, s);
            }
            self.skip = self.stride - 1;
        } else {
            self.skip -= 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy's decimate_minmax, written out plainly.
    fn reference(t: &[f64], y: &[f64], columns: usize) -> (Vec<f64>, Vec<f64>) {
        let n = t.len();
        let per = n / columns;
        let (mut ot, mut oy) = (vec![], vec![]);
        let arg = |a: usize, b: usize, better: fn(f64, f64) -> bool| {
            let mut k = a;
            for i in a..b {
                if better(y[i], y[k]) {
                    k = i;
                }
            }
            k
        };
        for c in 0..columns {
            let (a, b) = (c * per, (c + 1) * per);
            let (i, j) = (arg(a, b, |x, m| x < m), arg(a, b, |x, m| x > m));
            for k in [i.min(j), i.max(j)] {
                ot.push(t[k]);
                oy.push(y[k]);
            }
        }
        if per * columns < n {
            let (a, b) = (per * columns, n);
            let (i, j) = (arg(a, b, |x, m| x < m), arg(a, b, |x, m| x > m));
            let mut ks = vec![i.min(j), i.max(j)];
            ks.dedup();
            for k in ks {
                ot.push(t[k]);
                oy.push(y[k]);
            }
        }
        (ot, oy)
    }

    #[test]
    fn decimation_keeps_each_columns_first_extremes() {
        for (n, columns) in [(4000usize, 1000usize), (4321, 1000), (10_007, 7), (12, 3)] {
            let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
            // ties on purpose: a rounded sine
            let y: Vec<f64> = (0..n).map(|i| ((i as f64 * 0.37).sin() * 8.0).round()).collect();
            let mut d = MinMaxColumns::new(n as u64, columns).unwrap();
            for (a, b) in t.iter().zip(&y) {
                d.push(*a, *b);
            }
            assert_eq!(d.finish().unwrap(), reference(&t, &y, columns), "n = {n}");
        }
        assert!(MinMaxColumns::new(3999, 1000).is_none());
        let mut d = MinMaxColumns::new(4000, 1000).unwrap();
        d.push(0.0, 1.0);
        assert!(d.finish().is_none(), "fewer samples than planned");
    }

    #[test]
    fn stream_sees_the_map_samples() {
        // record_every 1 at dt: every 20th row feeds the super-slow stream, as a map point does.
        let dt = 2e-5;
        let mut o = OverviewRecorder::new(40_001, 100, dt, 1);
        o.begin(&["t_s".into(), "w_4L7_m".into(), "s".into()]).unwrap();
        let mut map = EnvelopeStream::new(dt * 20.0).unwrap();
        for i in 0..40_001u64 {
            let t = i as f64 * dt;
            let w = 1e-3 * (2.0 * std::f64::consts::PI * 120.0 * t).sin();
            o.push(&[t, w, 0.3]).unwrap();
            if i % 20 == 0 {
                map.push(w, 0.3);
            }
        }
        let ov = o.finish();
        assert_eq!(ov.signals.unwrap(), map);
        assert_eq!(ov.w.unwrap().0.len(), 201, "100 columns of two samples and the one-sample remainder");
    }
}
