//! Pseudo-arclength continuation of the harmonic-balance manifold over the slider position
//! (docs/model.md §6.4), fold detection and the sampling of branches on the grid.

use std::cell::RefCell;
use std::sync::{Arc, Mutex};

use nalgebra::{DMatrix, DVector};

use super::branch::{Fold, HbBranch, HbManifold, HbOptions};
use super::hb::{EvalWork, HbSystem};
use super::hb_terms::Param;
use super::lu::LuWork;
use super::roots::{brent, uniform_grid, zeros_from_values};
use crate::error::{Error, Result};
use crate::params::{Params, ParamsArg};

/// Reused buffers of one continuation.
pub(super) struct ContWork {
    pub(super) eval: EvalWork,
    /// The bordered (nx + 1)-square systems of the corrector and the tangent.
    pub(super) bordered: LuWork,
    /// ∂R/∂x alone (stability).
    pub(super) jx: LuWork,
    pub(super) rhs: DVector<f64>,
    pub(super) diff: DVector<f64>,
}

impl ContWork {
    pub(super) fn new(sys: &HbSystem) -> RefCell<ContWork> {
        let d = sys.nx + 1;
        RefCell::new(ContWork { eval: EvalWork::new(sys), bordered: LuWork::new(d), jx: LuWork::new(sys.nx), rhs: DVector::zeros(d), diff: DVector::zeros(d) })
    }
}

pub(super) struct Corrected {
    pub(super) y: DVector<f64>,
    pub(super) j: DMatrix<f64>,
    pub(super) iters: usize,
}

pub(super) struct Run {
    pub(super) points: Vec<(DVector<f64>, bool)>,
    pub(super) folds: Vec<DVector<f64>>,
    /// Index into `points` of each fold (the fold point itself is inserted into `points`).
    pub(super) fold_idx: Vec<usize>,
    pub(super) complete: bool,
    pub(super) steps: usize,
}

/// Pseudo-arclength continuation of the HB system.
pub(super) struct Continuation<'a> {
    pub(super) sys: &'a HbSystem,
    pub(super) par: Param,
    pub(super) max_steps: usize,
    pub(super) h_max: f64,
    pub(super) h_min: f64,
    /// Stop (complete) right after the first fold.
    pub(super) stop_at_fold: bool,
    pub(super) work: RefCell<ContWork>,
}

impl Continuation<'_> {
    pub(super) fn dim(&self) -> usize {
        self.sys.nx + 1
    }

    /// Newton on [R(y); tᵀ(y − y_pred)] = 0 from y_pred.
    pub(super) fn correct(&self, y_pred: &DVector<f64>, t: &DVector<f64>) -> Option<Corrected> {
        self.newton(y_pred, y_pred, t, 12, 1e-11)
    }

    /// Newton on [R(y); tᵀ(y − y_pred)] = 0 from `start`, at most `max_iter` iterations, converged
    /// when the step is below `tol` · (1 + max|y|).
    pub(super) fn newton(&self, start: &DVector<f64>, y_pred: &DVector<f64>, t: &DVector<f64>, max_iter: usize, tol: f64) -> Option<Corrected> {
        let d = self.dim();
        let mut y = start.clone();
        let ws = &mut *self.work.borrow_mut();
        for it in 0..max_iter {
            self.sys.eval_into(&y, self.par, true, &mut ws.eval);
            ws.bordered.load_bordered(&ws.eval.j, t);
            for i in 0..d - 1 {
                ws.rhs[i] = -ws.eval.r[i];
            }
            for i in 0..d {
                ws.diff[i] = y[i] - y_pred[i];
            }
            ws.rhs[d - 1] = -t.dot(&ws.diff);
            if !ws.bordered.factor_solve(&mut ws.rhs) {
                return None;
            }
            let dy = &ws.rhs;
            if !dy.iter().all(|v| v.is_finite()) {
                return None;
            }
            y += dy;
            if dy.amax() <= tol * (1.0 + y.amax()) {
                self.sys.eval_into(&y, self.par, true, &mut ws.eval);
                return Some(Corrected { y, j: ws.eval.j.clone(), iters: it + 1 });
            }
        }
        None
    }

    /// Unit tangent: [J; borderᵀ] t = e_last; with the stability flag det ∂R/∂x > 0, from the
    /// same factorisation (Cramer: t_p = det(∂R/∂x)/det[J; borderᵀ] before normalising).
    pub(super) fn tangent_stable(&self, j: &DMatrix<f64>, border: &DVector<f64>) -> Option<(DVector<f64>, bool)> {
        let d = self.dim();
        let lu = &mut self.work.borrow_mut().bordered;
        lu.load_bordered(j, border);
        lu.factor();
        let det_a = lu.determinant();
        let mut t = DVector::zeros(d);
        t[d - 1] = 1.0;
        if !lu.solve(&mut t) {
            return None;
        }
        let nrm = t.norm();
        let stable = t[d - 1] * det_a > 0.0;
        (nrm.is_finite() && nrm > 0.0).then(|| {
            t /= nrm;
            (t, stable)
        })
    }

    pub(super) fn tangent(&self, j: &DMatrix<f64>, border: &DVector<f64>) -> Option<DVector<f64>> {
        self.tangent_stable(j, border).map(|(t, _)| t)
    }

    pub(super) fn stable(&self, j: &DMatrix<f64>) -> bool {
        let lu = &mut self.work.borrow_mut().jx;
        lu.a.copy_from(&j.columns(0, self.sys.nx));
        lu.factor();
        lu.determinant() > 0.0
    }

    /// Fold between (ya, ta) and yb: zero of the tangent's parameter component along the
    /// hyperplanes taᵀ(y − ya) = σ, by Brent's method in σ.
    pub(super) fn refine_fold(&self, ya: &DVector<f64>, ta: &DVector<f64>, yb: &DVector<f64>) -> Option<DVector<f64>> {
        let d = self.dim();
        let sigma_b = ta.dot(&(yb - ya));
        let point = |sigma: f64| -> Option<(DVector<f64>, f64)> {
            let w = if sigma_b != 0.0 { sigma / sigma_b } else { 0.0 };
            let guess = ya + (yb - ya) * w;
            let y_pred = ya + ta * sigma;
            // Start from the chord point; the hyperplane is taᵀ(y − y_pred) = 0.
            let c = self.correct_from(&guess, &y_pred, ta)?;
            let t = self.tangent(&c.j, ta)?;
            Some((c.y, t[d - 1]))
        };
        let f = |sigma: f64| point(sigma).map(|p| p.1).unwrap_or(f64::NAN);
        let sig = brent(f, 0.0, sigma_b, 1e-14 * sigma_b.abs().max(1e-300), 100).ok()?;
        point(sig).map(|p| p.0)
    }

    pub(super) fn correct_from(&self, start: &DVector<f64>, y_pred: &DVector<f64>, t: &DVector<f64>) -> Option<Corrected> {
        self.newton(start, y_pred, t, 15, 1e-13)
    }

    /// Trace from y0 in the direction of increasing (dir > 0) or decreasing parameter until it
    /// leaves [p_lo, p_hi]; the exit point is solved exactly at the bound.
    pub(super) fn trace(&self, y0: DVector<f64>, dir: f64, p_lo: f64, p_hi: f64) -> Run {
        let d = self.dim();
        let mut run = Run { points: Vec::new(), folds: Vec::new(), fold_idx: Vec::new(), complete: false, steps: 0 };
        let (_, j0) = self.sys.eval(&y0, self.par, true);
        let mut border = DVector::zeros(d);
        border[d - 1] = dir;
        let Some(mut t) = self.tangent(&j0, &border) else {
            return run;
        };
        run.points.push((y0.clone(), self.stable(&j0)));
        let mut y = y0;
        let mut h = (0.25 * self.h_max).min(0.01);
        while run.steps < self.max_steps {
            run.steps += 1;
            let y_pred = &y + &t * h;
            let Some(c) = self.correct(&y_pred, &t) else {
                h *= 0.5;
                if h < self.h_min {
                    return run;
                }
                continue;
            };
            let Some((t_new, st)) = self.tangent_stable(&c.j, &t) else {
                h *= 0.5;
                if h < self.h_min {
                    return run;
                }
                continue;
            };
            if t.dot(&t_new) < 0.97 && h > 4.0 * self.h_min {
                h *= 0.5;
                continue;
            }
            // Resolve the response, not only the arclength: near a weakly forced resonance the
            // curve is flat at the arclength scale but its phase turns by π over a tiny s-range
            // (a step over it would miss a narrow fold pair).
            if matches!(self.par, Param::S { .. }) && h > 4.0 * self.h_min && !self.sys.response_close(&y, &c.y) {
                h *= 0.5;
                continue;
            }
            let p_new = c.y[d - 1];
            if p_new > p_hi || p_new < p_lo {
                let bound = if p_new > p_hi { p_hi } else { p_lo };
                let w = (bound - y[d - 1]) / (p_new - y[d - 1]);
                let mut guess = &y + (&c.y - &y) * w;
                guess[d - 1] = bound;
                if let Some(yb) = self.sys.newton_fixed(&guess, self.par) {
                    let (_, jb) = self.sys.eval(&yb, self.par, true);
                    run.points.push((yb, self.stable(&jb)));
                }
                run.complete = true;
                return run;
            }
            if t[d - 1] * t_new[d - 1] < 0.0 || t_new[d - 1] == 0.0 {
                if let Some(yf) = self.refine_fold(&y, &t, &c.y) {
                    run.fold_idx.push(run.points.len());
                    run.points.push((yf.clone(), true));
                    run.folds.push(yf);
                } else {
                    // Refinement failed: take the chord midpoint as the fold (flagged by the
                    // caller through the tolerance of its tests).
                    let ym = (&y + &c.y) * 0.5;
                    run.fold_idx.push(run.points.len());
                    run.points.push((ym.clone(), true));
                    run.folds.push(ym);
                }
                if self.stop_at_fold {
                    run.complete = true;
                    return run;
                }
            }
            run.points.push((c.y.clone(), st));
            y = c.y;
            t = t_new;
            h = if c.iters <= 3 {
                (h * 1.5).min(self.h_max)
            } else if c.iters >= 6 {
                h * 0.6
            } else {
                h
            };
        }
        run
    }
}

/// Solution at fixed s by continuation in the load factor from 0 to its first arrival at 1
/// (the lowest-amplitude solution reached from rest).
pub(super) fn solve_from_rest(sys: &HbSystem, s: f64, opts: &HbOptions) -> Result<DVector<f64>> {
    let n2 = sys.nx;
    let cont = Continuation {
        sys,
        par: Param::Load { s },
        max_steps: opts.max_steps,
        h_max: opts.max_step * 5.0,
        h_min: 1e-10,
        stop_at_fold: false,
        work: ContWork::new(sys),
    };
    let y0 = DVector::zeros(n2 + 1);
    let run = cont.trace(y0, 1.0, -1.0, 1.0);
    if !run.complete {
        return Err(Error::Numerical(format!(
            "HB: continuation in the excitation level at s = {} did not reach a_ex within {} steps",
            crate::error::short_number(s),
            run.steps
        )));
    }
    let (y, _) = run.points.last().cloned().ok_or_else(|| Error::Numerical("HB: empty load continuation".into()))?;
    if (y[n2] - 1.0).abs() > 1e-12 {
        return Err(Error::Numerical(format!("HB: load continuation at s = {} ended at load {}", crate::error::short_number(s), y[n2])));
    }
    let mut out = y;
    out[n2] = s;
    Ok(out)
}

pub(super) fn check_grid(s: &[f64], lo: f64, hi: f64) -> Result<()> {
    if s.len() < 2 {
        return Err(Error::invalid("s", format!("{} values", s.len()), "need at least two slider positions"));
    }
    if s.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid("s", "non-finite", "all slider positions must be finite"));
    }
    if s.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::invalid("s", "unsorted", "slider positions must be strictly increasing"));
    }
    let tol = 1e-12;
    if s[0] < lo - tol || s[s.len() - 1] > hi + tol {
        return Err(Error::invalid("s", format!("[{}, {}]", s[0], s[s.len() - 1]), &format!("slider positions must lie in [B/(2L), {hi}] = [{lo}, {hi}]")));
    }
    Ok(())
}

/// Default grid: `count` values from B/(2L) to 0.5.
pub fn default_grid(params: &Params, count: usize) -> Vec<f64> {
    let lo = params.s_min();
    let count = count.max(2);
    (0..count).map(|i| lo + (0.5 - lo) * i as f64 / (count - 1) as f64).collect()
}

/// The HB super-slow manifold (docs/model.md §6.4) at (f_ex [Hz], a_ex [m/s²]).
pub fn hb_manifold<'a>(params: impl Into<ParamsArg<'a>>, f_ex_hz: f64, a_ex: f64, opts: &HbOptions) -> Result<HbManifold> {
    let arg = params.into().check()?;
    let params = arg.get();
    let sys = HbSystem::new(arg, f_ex_hz, a_ex, opts)?;
    let grid = opts.s.clone().unwrap_or_else(|| default_grid(params, 201));
    check_grid(&grid, params.s_min(), 0.5)?;
    if opts.max_steps == 0 {
        return Err(Error::invalid("max_steps", 0, "must be >= 1"));
    }
    if !(opts.max_step.is_finite() && opts.max_step > 0.0) {
        return Err(Error::invalid("max_step", opts.max_step, "must be finite and > 0"));
    }
    let (s_lo, s_hi) = (grid[0], grid[grid.len() - 1]);
    let n2 = sys.nx;
    let cont = Continuation {
        sys: &sys,
        par: Param::S { load: 1.0 },
        max_steps: opts.max_steps,
        h_max: opts.max_step,
        h_min: 1e-10,
        stop_at_fold: false,
        work: ContWork::new(&sys),
    };
    let mut out = HbManifold {
        s_range: (s_lo, s_hi),
        n_modes: sys.n,
        harmonic_orders: sys.mhb.as_ref().map_or_else(Vec::new, |m| m.orders.clone()),
        ..Default::default()
    };

    let y_lo = solve_from_rest(&sys, s_lo, opts)?;
    let up = cont.trace(y_lo, 1.0, s_lo, s_hi);
    let y_hi = solve_from_rest(&sys, s_hi, opts)?;
    let down = Continuation { stop_at_fold: opts.low_branch_only, ..cont }.trace(y_hi, -1.0, s_lo, s_hi);
    out.steps = up.steps + down.steps;
    for (name, run) in [("upward", &up), ("downward", &down)] {
        if !run.complete {
            out.warnings
                .push(format!("{name} continuation stopped after {} steps before leaving [{s_lo}, {s_hi}] (max_steps = {})", run.steps, opts.max_steps));
        }
    }
    let to_branch = |pts: &[(DVector<f64>, bool)]| {
        let mut b = HbBranch::default();
        for (y, st) in pts {
            b.push(&sys.point_out(y, *st));
        }
        b
    };
    out.up_run = to_branch(&up.points);
    out.down_run = to_branch(&down.points);
    let first = |run: &Run| run.fold_idx.first().copied();
    match first(&up) {
        Some(k) => {
            out.high = to_branch(&up.points[..=k]);
            out.s_dn = Some(up.points[k].0[n2]);
            let end = up.fold_idx.get(1).copied().unwrap_or(up.points.len() - 1);
            out.middle = to_branch(&up.points[k..=end]);
        }
        None => out.high = to_branch(&up.points),
    }
    match first(&down) {
        Some(k) => {
            out.low = to_branch(&down.points[..=k]);
            out.s_up = Some(down.points[k].0[n2]);
            if out.middle.is_empty() {
                let end = down.fold_idx.get(1).copied().unwrap_or(down.points.len() - 1);
                out.middle = to_branch(&down.points[k..=end]);
            }
        }
        None => out.low = to_branch(&down.points),
    }
    let mut folds: Vec<Fold> = up
        .folds
        .iter()
        .chain(down.folds.iter())
        .map(|y| {
            let p = sys.point_out(y, true);
            Fold { s: p.s, amplitude_h: p.amplitude_h }
        })
        .collect();
    folds.sort_by(|a, b| a.s.total_cmp(&b.s));
    folds.dedup_by(|a, b| (a.s - b.s).abs() < 1e-7 && (a.amplitude_h - b.amplitude_h).abs() < 1e-6 * (1.0 + b.amplitude_h));
    out.folds = folds;
    if opts.sample_on_grid {
        out.s_grid = grid.clone();
        out.high_on_grid = grid.iter().map(|&x| sample_branch(&sys, &out.high, x)).collect();
        out.low_on_grid = grid.iter().map(|&x| sample_branch(&sys, &out.low, x)).collect();
    }
    // Linear resonance positions: bracketed on a 26-point grid, refined by Brent.
    let g = |s: f64| sys.linear_frequency(s) - sys.omega_ex;
    let res_grid = uniform_grid(s_lo, s_hi, RES_GRID);
    let vals: Vec<f64> = linear_frequencies(&sys, params, opts, &res_grid).iter().map(|w| w - sys.omega_ex).collect();
    out.s_res = zeros_from_values(&g, &res_grid, &vals, 1e-13);
    Ok(out)
}

/// Points of the grid on which the linear resonance positions are bracketed.
const RES_GRID: usize = 26;

/// The lowest linear frequency of (Λ, M(s)) at the points `grid` (the bracketing grid of the
/// resonance positions). It does not depend on the excitation, so the points of an operating map
/// share it: kept for the last few (parameters, modes, detuning, grid).
fn linear_frequencies(sys: &HbSystem, params: &Params, opts: &HbOptions, grid: &[f64]) -> Arc<Vec<f64>> {
    type Key = (Params, usize, u64, Vec<u64>);
    static CACHE: Mutex<Vec<(Key, Arc<Vec<f64>>)>> = Mutex::new(Vec::new());
    let key: Key = (params.clone(), opts.n_modes, opts.omega1_factor.to_bits(), grid.iter().map(|s| s.to_bits()).collect());
    if let Ok(cache) = CACHE.lock()
        && let Some((_, w)) = cache.iter().rev().find(|(k, _)| *k == key)
    {
        return w.clone();
    }
    let w = Arc::new(grid.iter().map(|&s| sys.linear_frequency(s)).collect::<Vec<f64>>());
    if let Ok(mut cache) = CACHE.lock() {
        if cache.len() >= 16 {
            cache.remove(0);
        }
        cache.push((key, w.clone()));
    }
    w
}

/// The first segment [sᵢ, sᵢ₊₁] of a branch that holds s, and s's weight w within it (s = sᵢ +
/// w (sᵢ₊₁ − sᵢ)); None outside the branch.
fn segment(b: &HbBranch, s: f64) -> Option<(usize, f64)> {
    (0..b.len().saturating_sub(1)).find_map(|i| {
        let (a, c) = (b.s[i], b.s[i + 1]);
        let (lo, hi) = if a <= c { (a, c) } else { (c, a) };
        (!(s < lo || s > hi)).then(|| (i, if c != a { (s - a) / (c - a) } else { 0.0 }))
    })
}

/// Â of a branch (monotone in s) at s: Newton at fixed s from Q interpolated between the
/// neighbouring continuation points (the interpolated Â if Newton fails); NaN outside the branch.
pub(super) fn sample_branch(sys: &HbSystem, b: &HbBranch, s: f64) -> f64 {
    if sys.mhb.is_some() {
        return sample_branch_state(sys, b, s);
    }
    let n = sys.n;
    let Some((i, w)) = segment(b, s) else { return f64::NAN };
    let lerp = |v: &[f64], k: usize| v[i * n + k] + w * (v[(i + 1) * n + k] - v[i * n + k]);
    let u: Vec<f64> = (0..n).map(|k| lerp(&b.q_re, k)).collect();
    let v: Vec<f64> = (0..n).map(|k| lerp(&b.q_im, k)).collect();
    match sys.solve_point(s, &u, &v) {
        Ok((u, v)) => {
            let wr: f64 = sys.p47.iter().zip(&u).map(|(a, b)| a * b).sum();
            let wi: f64 = sys.p47.iter().zip(&v).map(|(a, b)| a * b).sum();
            wr.hypot(wi) / sys.thickness
        }
        Err(_) => b.amplitude_h[i] + w * (b.amplitude_h[i + 1] - b.amplitude_h[i]),
    }
}

/// [`sample_branch`] for the multi-harmonic / sag system: Newton at fixed s on all unknowns.
pub(super) fn sample_branch_state(sys: &HbSystem, b: &HbBranch, s: f64) -> f64 {
    let nx = sys.nx;
    let Some((i, w)) = segment(b, s) else { return f64::NAN };
    let mut y = DVector::zeros(nx + 1);
    for k in 0..nx {
        y[k] = (b.state[i * nx + k] + w * (b.state[(i + 1) * nx + k] - b.state[i * nx + k])) / sys.q_ref;
    }
    y[nx] = s;
    match sys.newton_fixed(&y, Param::S { load: 1.0 }) {
        Some(y) => sys.point_out(&y, true).amplitude_h,
        None => b.amplitude_h[i] + w * (b.amplitude_h[i + 1] - b.amplitude_h[i]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::superslow::roots::zeros_on_grid;

    /// The resonance positions of manifolds that share one design's linear frequencies on the
    /// bracketing grid (two frequencies, two levels) are those of the frequencies evaluated afresh.
    #[test]
    fn resonance_positions_from_the_shared_grid_are_the_fresh_ones() {
        let p = Params::default();
        let opts = HbOptions { low_branch_only: true, ..HbOptions::default() };
        let mut found = 0;
        for (f, a) in [(112.0, 10.0), (124.0, 14.0), (112.0, 14.0), (128.0, 10.0)] {
            let m = hb_manifold(&p, f, a, &opts).unwrap();
            let sys = HbSystem::new(&p, f, a, &opts).unwrap();
            let g = |s: f64| sys.linear_frequency(s) - sys.omega_ex;
            let fresh = zeros_on_grid(&g, &uniform_grid(m.s_range.0, m.s_range.1, RES_GRID), 1e-13);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&m.s_res), bits(&fresh), "f = {f}, a = {a}");
            found += fresh.len();
        }
        assert!(found > 0, "no resonance position in the range: the test compares nothing");
    }
}
