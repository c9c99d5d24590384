//! Scalar root finding: zeros bracketed on a grid and refined by Brent's method (folds and
//! resonance positions of docs/model.md §6.4).

use crate::error::{Error, Result};

/// `count` uniform points on [lo, hi] (a bracketing grid of [`zeros_from_values`]).
pub(super) fn uniform_grid(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    (0..count).map(|i| lo + (hi - lo) * i as f64 / (count - 1) as f64).collect()
}

/// Zeros of f bracketed on the points `grid` and refined by Brent; exact zeros at grid points are
/// reported once.
pub(super) fn zeros_on_grid(f: &dyn Fn(f64) -> f64, grid: &[f64], tol: f64) -> Vec<f64> {
    let vals: Vec<f64> = grid.iter().map(|&s| f(s)).collect();
    zeros_from_values(f, grid, &vals, tol)
}

pub(super) fn zeros_from_values(f: &dyn Fn(f64) -> f64, grid: &[f64], vals: &[f64], tol: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for i in 0..grid.len() {
        if vals[i] == 0.0 {
            out.push(grid[i]);
            continue;
        }
        if i + 1 < grid.len()
            && vals[i + 1] != 0.0
            && vals[i].signum() != vals[i + 1].signum()
            && vals[i].is_finite()
            && vals[i + 1].is_finite()
            && let Ok(z) = brent(f, grid[i], grid[i + 1], tol, 200)
        {
            out.push(z);
        }
    }
    out
}

/// Brent's method (Brent 1973, as in Numerical Recipes' `zbrent`): a zero of f in [a, b] with
/// f(a) f(b) ≤ 0, to an absolute tolerance `tol`, at most `max_iter` iterations. A NaN value of
/// f is an error.
pub fn brent(f: impl Fn(f64) -> f64, a: f64, b: f64, tol: f64, max_iter: usize) -> Result<f64> {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    if fa.is_nan() || fb.is_nan() {
        return Err(Error::Numerical("brent: NaN at the bracket".into()));
    }
    if fa == 0.0 {
        return Ok(a);
    }
    if fb == 0.0 {
        return Ok(b);
    }
    if fa.signum() == fb.signum() {
        return Err(Error::Numerical("brent: the interval does not bracket a zero".into()));
    }
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    for _ in 0..max_iter {
        if fb.signum() == fc.signum() {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return Ok(b);
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            let min1 = 3.0 * xm * q - (tol1 * q).abs();
            let min2 = (e * q).abs();
            if 2.0 * p < min1.min(min2) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
        if fb.is_nan() {
            return Err(Error::Numerical("brent: NaN inside the bracket".into()));
        }
    }
    Err(Error::Numerical(format!("brent: no convergence in {max_iter} iterations")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_simple_roots_and_respects_endpoints() {
        let r = brent(|x| x * x - 2.0, 0.0, 2.0, 1e-15, 100).unwrap();
        assert!((r - 2f64.sqrt()).abs() < 1e-14);
        assert_eq!(brent(|x| x - 1.0, 1.0, 3.0, 1e-15, 100).unwrap(), 1.0);
        assert!(brent(|x| x * x + 1.0, -1.0, 1.0, 1e-12, 100).is_err());
        assert!(brent(|_| f64::NAN, -1.0, 1.0, 1e-12, 100).is_err());
        // Cap: never loops forever.
        assert!(brent(|x| x.powi(3), -1.0, 2.0, 0.0, 3).is_err());
    }
}
