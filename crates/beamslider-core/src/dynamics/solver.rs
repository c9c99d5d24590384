//! Local contact problem of docs/model.md §5 and its two solvers.
//!
//! For k closed contacts find P = (P_N, P_T)ᵢ with ξ = G P + c such that per contact
//! Signorini–Newton (ξ_N ≥ 0, P_N ≥ 0, ξ_N P_N = 0) and Coulomb (|P_T| ≤ μ P_N, P_T opposing
//! ξ_T when sliding) hold.
//!
//! * [`gauss_seidel`]: the reference augmented-Lagrangian / proximal-point nonlinear
//!   Gauss–Seidel, exactly as docs/model.md §5 writes it (order, rᵢ, warm start, stop rule).
//! * [`exact`]: an exact solution — each contact is open, sticking or sliding in one of two
//!   directions; for a guessed pattern the conditions are a linear system. The previous step's
//!   pattern is tried first, then a few active-set corrections, then all 4^k patterns, and the
//!   tightly converged Gauss–Seidel as a last resort.

/// The problem's sizes come from the slider's geometry (four contact points, two directions each).
pub use crate::physics::slider::{DIM, MAX_CLOSED};

/// A local contact problem with k closed contacts (only the leading 2k entries are used).
#[derive(Debug, Clone)]
pub struct LocalProblem {
    /// Number of closed contacts k.
    pub k: usize,
    /// Delassus matrix G = Wᵀ M⁻¹ W (rows/cols 2i = normal, 2i+1 = tangential of contact i).
    pub g: [[f64; DIM]; DIM],
    /// Free velocity term c.
    pub c: [f64; DIM],
    /// Friction coefficient μ.
    pub mu: f64,
}

/// State of one closed contact in an exact solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ContactMode {
    /// Lifted off: P = 0, ξ_N ≥ 0.
    Open,
    /// Sticking: ξ = 0, |P_T| ≤ μ P_N.
    #[default]
    Stick,
    /// Sliding with ξ_T > 0: P_T = −μ P_N.
    SlidePos,
    /// Sliding with ξ_T < 0: P_T = +μ P_N.
    SlideNeg,
}

const ALL_MODES: [ContactMode; 4] = [ContactMode::Stick, ContactMode::Open, ContactMode::SlidePos, ContactMode::SlideNeg];

impl LocalProblem {
    /// Empty problem for k contacts.
    pub fn new(k: usize, mu: f64) -> Self {
        LocalProblem { k, g: [[0.0; DIM]; DIM], c: [0.0; DIM], mu }
    }

    /// ξ = G P + c.
    pub fn velocity(&self, p: &[f64; DIM]) -> [f64; DIM] {
        let m = 2 * self.k;
        let mut xi = [0.0; DIM];
        for a in 0..m {
            let mut s = self.c[a];
            for b in 0..m {
                s += self.g[a][b] * p[b];
            }
            xi[a] = s;
        }
        xi
    }

    /// Largest violation of the contact laws as the natural-map (proximal) residual
    /// |P − prox(P − ρ ξ)| / scale with ρ = P-scale / ξ-scale: zero exactly when Signorini–Newton
    /// complementarity and the Coulomb law (cone, sliding opposite ξ_T) hold.
    pub fn residual(&self, p: &[f64; DIM]) -> f64 {
        let xi = self.velocity(p);
        let (sv, sp) = self.scales(p);
        let rho = sp / sv;
        let mut r: f64 = 0.0;
        for i in 0..self.k {
            let (pn, pt) = (p[2 * i], p[2 * i + 1]);
            let (xn, xt) = (xi[2 * i], xi[2 * i + 1]);
            let pn_new = (pn - rho * xn).max(0.0);
            let lim = self.mu * pn_new;
            let pt_new = (pt - rho * xt).clamp(-lim, lim);
            r = r.max((pn - pn_new).abs() / sp).max((pt - pt_new).abs() / sp);
        }
        r
    }

    fn scales(&self, p: &[f64; DIM]) -> (f64, f64) {
        let m = 2 * self.k;
        let sv = self.c[..m].iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-300);
        let gmax = (0..m).fold(0.0f64, |a, i| a.max(self.g[i][i].abs())).max(1e-300);
        let sp = p[..m].iter().fold(0.0f64, |a, v| a.max(v.abs())).max(sv / gmax);
        (sv, sp)
    }
}

/// Outcome of one local solve, for the run's counters.
#[derive(Debug, Clone, Copy, Default)]
pub struct SolveInfo {
    /// Gauss–Seidel sweeps (reference solver or fallback).
    pub iterations: u32,
    /// The Gauss–Seidel iteration cap was hit.
    pub capped: bool,
    /// Exact solver: the first guess (previous pattern) was right.
    pub first_guess: bool,
    /// Exact solver: number of linear solves.
    pub linear_solves: u32,
    /// Exact solver: full enumeration was needed.
    pub enumerated: bool,
    /// Exact solver: no pattern fitted and Gauss–Seidel was used.
    pub fallback: bool,
}

/// Reference solver of docs/model.md §5. `p` holds the warm start on entry and the result on exit.
pub fn gauss_seidel(prob: &LocalProblem, p: &mut [f64; DIM], tol_rel: f64, tol_abs: f64, max_iter: u32) -> SolveInfo {
    let k = prob.k;
    let m = 2 * k;
    let g = &prob.g;
    // rᵢ from diagonal dominance of G: 2|G_kk| ≥ Σ_j |G_kj| for every row.
    let row_sum = |a: usize| (0..m).map(|b| g[a][b].abs()).sum::<f64>();
    let dominant = (0..m).all(|a| 2.0 * g[a][a].abs() >= row_sum(a));
    let mut r = [0.0; MAX_CLOSED];
    for i in 0..k {
        r[i] = if dominant { 1.0 / g[2 * i][2 * i].max(g[2 * i + 1][2 * i + 1]) } else { 1.0 / row_sum(2 * i).max(row_sum(2 * i + 1)) };
    }
    let mut info = SolveInfo::default();
    loop {
        let mut change = 0.0;
        for i in 0..k {
            let (a, b) = (2 * i, 2 * i + 1);
            let mut xn = prob.c[a];
            let mut xt = prob.c[b];
            for j in 0..m {
                xn += g[a][j] * p[j];
                xt += g[b][j] * p[j];
            }
            let pn = (p[a] - r[i] * xn).max(0.0);
            let lim = prob.mu * pn;
            let pt = (p[b] - r[i] * xt).clamp(-lim, lim);
            change += ((pn - p[a]).powi(2) + (pt - p[b]).powi(2)).sqrt();
            p[a] = pn;
            p[b] = pt;
        }
        info.iterations += 1;
        let norm = p[..m].iter().map(|v| v * v).sum::<f64>().sqrt();
        if change <= norm * tol_rel + tol_abs {
            break;
        }
        if info.iterations >= max_iter {
            info.capped = true;
            break;
        }
    }
    info
}

/// max of two non-NaN numbers (one instruction, unlike `f64::max`).
#[inline(always)]
fn fmax(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// Relative tolerance of the exact solver's feasibility checks (round-off level).
const EXACT_TOL: f64 = 1e-10;

/// Exact solver. `modes[i]` holds the guess for contact i on entry (the previous step's
/// pattern) and the found pattern on exit; `p` receives the percussions. Falls back to
/// Gauss–Seidel with tolerances 1e-12 / 1e-16 N s when no pattern fits.
pub fn exact(prob: &LocalProblem, modes: &mut [ContactMode; MAX_CLOSED], p: &mut [f64; DIM], max_iter: u32) -> SolveInfo {
    match prob.k {
        0 => {
            *p = [0.0; DIM];
            SolveInfo::default()
        }
        1 => exact_k::<1>(prob, modes, p, max_iter),
        2 => exact_k::<2>(prob, modes, p, max_iter),
        3 => exact_k::<3>(prob, modes, p, max_iter),
        _ => exact_k::<4>(prob, modes, p, max_iter),
    }
}

/// [`exact`] for K closed contacts known at compile time (`prob.k` must equal K). Kept out of
/// line: it does not depend on the number of modes, so one copy per K serves every N.
#[inline(never)]
pub fn exact_k<const K: usize>(prob: &LocalProblem, modes: &mut [ContactMode; MAX_CLOSED], p: &mut [f64; DIM], max_iter: u32) -> SolveInfo {
    debug_assert_eq!(prob.k, K);
    let k = K;
    let mut info = SolveInfo::default();
    let mut sv: f64 = 1e-300;
    let mut gmax: f64 = 1e-300;
    for a in 0..2 * k {
        sv = fmax(sv, prob.c[a].abs());
        gmax = fmax(gmax, prob.g[a][a].abs());
    }
    // Percussion scale below which P counts as zero in the checks: |c| / |G|.
    let p_floor = sv / gmax;
    if K == 1 {
        return exact_single(prob, modes, p, max_iter, sv, p_floor);
    }
    // 1. The guess, then active-set corrections of the violated contacts.
    let mut trial = *modes;
    for attempt in 0..(2 * k + 2) {
        info.linear_solves += 1;
        match try_pattern::<K>(prob, &trial, sv, p_floor) {
            Attempt::Solved(sol) => {
                *p = sol;
                *modes = trial;
                info.first_guess = attempt == 0;
                return info;
            }
            Attempt::Next(next) if next != trial => trial = next,
            _ => break,
        }
    }
    enumerate_patterns::<K>(prob, modes, p, max_iter, info, sv, p_floor)
}

/// Outcome of one pattern of the active-set loop of [`exact_k`].
enum Attempt {
    /// The pattern's solution satisfies the contact laws.
    Solved([f64; DIM]),
    /// It does not; the corrected pattern.
    Next([ContactMode; MAX_CLOSED]),
    /// The pattern's linear system is singular.
    Singular,
}

/// Solve and check one pattern. Out of line on purpose: inlined into the loop of [`exact_k`],
/// its pattern-invariant parts (for every pattern) were hoisted in front of the first attempt.
#[inline(never)]
fn try_pattern<const K: usize>(prob: &LocalProblem, trial: &[ContactMode; MAX_CLOSED], sv: f64, p_floor: f64) -> Attempt {
    let sol = if K == 2 { solve_pair(prob, trial) } else { solve_pattern::<K>(prob, trial) };
    let Some(sol) = sol else {
        return Attempt::Singular;
    };
    match check_pattern::<K>(prob, trial, &sol, sv, p_floor) {
        None => Attempt::Solved(sol),
        Some(next) => Attempt::Next(next),
    }
}

/// [`exact_k`] for one contact, written out: the same linear solves and checks as the general
/// path (bitwise the same results) without its bookkeeping.
///   open:   P = 0, needs ξ_N = c_N ≥ 0;
///   stick:  G P = −c (2×2), needs P_N ≥ 0 and |P_T| ≤ μ P_N;
///   slide σ: (G_NN − σμ G_NT) P_N = −c_N, P_T = −σμ P_N, needs P_N ≥ 0 and σ ξ_T ≥ 0.
#[inline(always)]
fn exact_single(prob: &LocalProblem, modes: &mut [ContactMode; MAX_CLOSED], p: &mut [f64; DIM], max_iter: u32, sv: f64, p_floor: f64) -> SolveInfo {
    let g = &prob.g;
    let c = &prob.c;
    let mu = prob.mu;
    let mut info = SolveInfo::default();
    let mut trial = modes[0];
    for attempt in 0..4 {
        info.linear_solves += 1;
        let (pn, pt) = match trial {
            ContactMode::Open => (0.0, 0.0),
            ContactMode::Stick => {
                let mut a = [[g[0][0], g[0][1]], [g[1][0], g[1][1]]];
                let amax = fmax(fmax(fmax(fmax(0.0, a[0][0].abs()), a[0][1].abs()), a[1][0].abs()), a[1][1].abs());
                let Some(y) = gauss_solve::<2>(&mut a, [-c[0], -c[1]], amax) else {
                    break;
                };
                (y[0], y[1])
            }
            ContactMode::SlidePos | ContactMode::SlideNeg => {
                let sigma = if trial == ContactMode::SlidePos { 1.0 } else { -1.0 };
                let f = -sigma * mu;
                let v = g[0][0] + f * g[0][1];
                let Some(y) = gauss_solve::<1>(&mut [[v]], [-c[0]], fmax(0.0, v.abs())) else {
                    break;
                };
                (y[0], f * y[0])
            }
        };
        let pmax = fmax(fmax(0.0, pn.abs()), pt.abs());
        let (tv, tp) = (EXACT_TOL * sv, EXACT_TOL * fmax(pmax, p_floor));
        let row = |a: usize| c[a] + g[a][0] * pn + g[a][1] * pt;
        let next = match trial {
            ContactMode::Open => {
                if row(0) < -tv {
                    ContactMode::Stick
                } else {
                    trial
                }
            }
            ContactMode::Stick => {
                if pn < -tp {
                    ContactMode::Open
                } else if pt.abs() > mu * pn + tp {
                    if pt < 0.0 { ContactMode::SlidePos } else { ContactMode::SlideNeg }
                } else {
                    trial
                }
            }
            ContactMode::SlidePos | ContactMode::SlideNeg => {
                let sigma = if trial == ContactMode::SlidePos { 1.0 } else { -1.0 };
                if pn < -tp {
                    ContactMode::Open
                } else if sigma * row(1) < -tv {
                    ContactMode::Stick
                } else {
                    trial
                }
            }
        };
        if next == trial {
            *p = [0.0; DIM];
            p[0] = pn;
            p[1] = pt;
            modes[0] = trial;
            info.first_guess = attempt == 0;
            return info;
        }
        trial = next;
    }
    enumerate_patterns::<1>(prob, modes, p, max_iter, info, sv, p_floor)
}

/// Steps 2 and 3 of [`exact`]: all 4^k patterns, then Gauss–Seidel (rare; kept out of line).
#[inline(never)]
fn enumerate_patterns<const K: usize>(
    prob: &LocalProblem, modes: &mut [ContactMode; MAX_CLOSED], p: &mut [f64; DIM], max_iter: u32, mut info: SolveInfo, sv: f64, p_floor: f64,
) -> SolveInfo {
    let k = prob.k;
    let mut trial = *modes;
    // 2. All 4^k patterns.
    info.enumerated = true;
    let total = 4usize.pow(k as u32);
    for code in 0..total {
        let mut c = code;
        for mode in trial.iter_mut().take(k) {
            *mode = ALL_MODES[c % 4];
            c /= 4;
        }
        info.linear_solves += 1;
        if let Some(sol) = solve_pattern::<K>(prob, &trial)
            && check_pattern::<K>(prob, &trial, &sol, sv, p_floor).is_none()
        {
            *p = sol;
            *modes = trial;
            return info;
        }
    }
    // 3. Last resort: tightly converged Gauss–Seidel from zero.
    info.fallback = true;
    *p = [0.0; DIM];
    let gs = gauss_seidel(prob, p, 1e-12, 1e-16, max_iter);
    info.iterations = gs.iterations;
    info.capped = gs.capped;
    let xi = prob.velocity(p);
    for i in 0..k {
        modes[i] = classify(prob.mu, p[2 * i], p[2 * i + 1], xi[2 * i + 1]);
    }
    info
}

fn classify(mu: f64, pn: f64, pt: f64, xt: f64) -> ContactMode {
    if pn <= 0.0 {
        ContactMode::Open
    } else if pt.abs() < mu * pn * (1.0 - 1e-9) || xt == 0.0 {
        ContactMode::Stick
    } else if xt > 0.0 {
        ContactMode::SlidePos
    } else {
        ContactMode::SlideNeg
    }
}

/// Unknown of a pattern's linear system: P_N of contact i, with P_T = f·P_N (sliding) or
/// P_T a separate unknown (sticking).
#[derive(Clone, Copy, Default)]
struct Unknown {
    col: usize,
    tangent_col: usize,
    factor: f64,
}

/// Solve the linear system of one contact pattern; None when it is singular.
#[inline(always)]
fn solve_pattern<const K: usize>(prob: &LocalProblem, modes: &[ContactMode; MAX_CLOSED]) -> Option<[f64; DIM]> {
    let k = K;
    // Unknowns: columns of G combined per pattern; equations: rows of G selected per pattern.
    let mut unk = [Unknown::default(); DIM];
    let mut rows = [0usize; DIM];
    let mut nu = 0;
    for i in 0..k {
        match modes[i] {
            ContactMode::Open => {}
            ContactMode::Stick => {
                unk[nu] = Unknown { col: 2 * i, tangent_col: usize::MAX, factor: 0.0 };
                unk[nu + 1] = Unknown { col: 2 * i + 1, tangent_col: usize::MAX, factor: 0.0 };
                rows[nu] = 2 * i;
                rows[nu + 1] = 2 * i + 1;
                nu += 2;
            }
            ContactMode::SlidePos | ContactMode::SlideNeg => {
                let sigma = if modes[i] == ContactMode::SlidePos { 1.0 } else { -1.0 };
                unk[nu] = Unknown { col: 2 * i, tangent_col: 2 * i + 1, factor: -sigma * prob.mu };
                rows[nu] = 2 * i;
                nu += 1;
            }
        }
    }
    match nu {
        0 => Some([0.0; DIM]),
        1 => solve_reduced::<1>(prob, &unk, &rows),
        2 => solve_reduced::<2>(prob, &unk, &rows),
        3 => solve_reduced::<3>(prob, &unk, &rows),
        4 => solve_reduced::<4>(prob, &unk, &rows),
        5 => solve_reduced::<5>(prob, &unk, &rows),
        6 => solve_reduced::<6>(prob, &unk, &rows),
        7 => solve_reduced::<7>(prob, &unk, &rows),
        _ => solve_reduced::<8>(prob, &unk, &rows),
    }
}

/// [`solve_pattern`] for two contacts: one arm per combination of open / sticking / sliding, so
/// that the reduced system's layout is known at compile time (same arithmetic as the general path).
#[inline(always)]
fn solve_pair(prob: &LocalProblem, modes: &[ContactMode; MAX_CLOSED]) -> Option<[f64; DIM]> {
    use ContactMode::*;
    const NO: usize = usize::MAX;
    let stick = |col: usize| Unknown { col, tangent_col: NO, factor: 0.0 };
    // Sliding contact i: P_T = −σμ P_N.
    let slide = |i: usize| Unknown { col: 2 * i, tangent_col: 2 * i + 1, factor: if modes[i] == SlidePos { -prob.mu } else { prob.mu } };
    let class = |m: ContactMode| match m {
        Open => 0,
        Stick => 1,
        SlidePos | SlideNeg => 2,
    };
    match (class(modes[0]), class(modes[1])) {
        (0, 0) => Some([0.0; DIM]),
        (0, 1) => solve_reduced::<2>(prob, &[stick(2), stick(3)], &[2, 3]),
        (0, _) => solve_reduced::<1>(prob, &[slide(1)], &[2]),
        (1, 0) => solve_reduced::<2>(prob, &[stick(0), stick(1)], &[0, 1]),
        (1, 1) => solve_reduced::<4>(prob, &[stick(0), stick(1), stick(2), stick(3)], &[0, 1, 2, 3]),
        (1, _) => solve_reduced::<3>(prob, &[stick(0), stick(1), slide(1)], &[0, 1, 2]),
        (_, 0) => solve_reduced::<1>(prob, &[slide(0)], &[0]),
        (_, 1) => solve_reduced::<3>(prob, &[slide(0), stick(2), stick(3)], &[0, 2, 3]),
        (_, _) => solve_reduced::<2>(prob, &[slide(0), slide(1)], &[0, 2]),
    }
}

#[inline(always)]
fn solve_reduced<const M: usize>(prob: &LocalProblem, unk: &[Unknown], rows: &[usize]) -> Option<[f64; DIM]> {
    let mut a = [[0.0; M]; M];
    let mut b = [0.0; M];
    let mut amax: f64 = 0.0;
    for e in 0..M {
        let g = &prob.g[rows[e]];
        for u in 0..M {
            let x = unk[u];
            let mut v = g[x.col];
            if x.tangent_col != usize::MAX {
                v += x.factor * g[x.tangent_col];
            }
            a[e][u] = v;
            amax = fmax(amax, v.abs());
        }
        b[e] = -prob.c[rows[e]];
    }
    let y = gauss_solve::<M>(&mut a, b, amax)?;
    let mut p = [0.0; DIM];
    for u in 0..M {
        let x = unk[u];
        p[x.col] = y[u];
        if x.tangent_col != usize::MAX {
            p[x.tangent_col] = x.factor * y[u];
        }
    }
    Some(p)
}

/// Gaussian elimination with partial pivoting; None when a pivot is below 1e-13 max|A|.
#[inline(always)]
fn gauss_solve<const M: usize>(a: &mut [[f64; M]; M], mut b: [f64; M], amax: f64) -> Option<[f64; M]> {
    let tiny = 1e-13 * amax;
    let mut inv_diag = [0.0; M];
    for col in 0..M {
        // Partial pivoting: the first row of largest |a[r][col]| is brought up by swaps with the
        // current candidate (all indices fixed at compile time, so the rows stay in registers).
        for r in col + 1..M {
            if a[r][col].abs() > a[col][col].abs() {
                for c in 0..M {
                    let t = a[col][c];
                    a[col][c] = a[r][c];
                    a[r][c] = t;
                }
                b.swap(col, r);
            }
        }
        if !(a[col][col].abs() > tiny) {
            return None;
        }
        let inv = 1.0 / a[col][col];
        inv_diag[col] = inv;
        for r in col + 1..M {
            let f = a[r][col] * inv;
            for c in col..M {
                a[r][c] -= f * a[col][c];
            }
            b[r] -= f * b[col];
        }
    }
    let mut y = [0.0; M];
    for r in (0..M).rev() {
        let mut s = b[r];
        for c in r + 1..M {
            s -= a[r][c] * y[c];
        }
        y[r] = s * inv_diag[r];
    }
    Some(y)
}

/// None when the solution fits its pattern; otherwise the corrected pattern. Only the
/// conditions a pattern leaves open are checked (sticking contacts have ξ = 0 by construction,
/// sliding ones ξ_N = 0 and P_T on the cone, open ones P = 0).
#[inline(always)]
fn check_pattern<const K: usize>(
    prob: &LocalProblem, modes: &[ContactMode; MAX_CLOSED], p: &[f64; DIM], sv: f64, p_floor: f64,
) -> Option<[ContactMode; MAX_CLOSED]> {
    let m = 2 * K;
    let mut pmax: f64 = 0.0;
    for v in &p[..m] {
        pmax = fmax(pmax, v.abs());
    }
    let (tv, tp) = (EXACT_TOL * sv, EXACT_TOL * fmax(pmax, p_floor));
    let row = |a: usize| {
        let mut x = prob.c[a];
        for b in 0..m {
            x += prob.g[a][b] * p[b];
        }
        x
    };
    let mut next = *modes;
    let mut ok = true;
    for i in 0..K {
        let (pn, pt) = (p[2 * i], p[2 * i + 1]);
        match modes[i] {
            ContactMode::Open => {
                if row(2 * i) < -tv {
                    next[i] = ContactMode::Stick;
                    ok = false;
                }
            }
            ContactMode::Stick => {
                if pn < -tp {
                    next[i] = ContactMode::Open;
                    ok = false;
                } else if pt.abs() > prob.mu * pn + tp {
                    next[i] = if pt < 0.0 { ContactMode::SlidePos } else { ContactMode::SlideNeg };
                    ok = false;
                }
            }
            ContactMode::SlidePos | ContactMode::SlideNeg => {
                let sigma = if modes[i] == ContactMode::SlidePos { 1.0 } else { -1.0 };
                if pn < -tp {
                    next[i] = ContactMode::Open;
                    ok = false;
                } else if sigma * row(2 * i + 1) < -tv {
                    next[i] = ContactMode::Stick;
                    ok = false;
                }
            }
        }
    }
    if ok { None } else { Some(next) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem(k: usize, mu: f64, seed: u64) -> LocalProblem {
        // Deterministic pseudo-random SPD G = A Aᵀ + δI and c.
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let m = 2 * k;
        let mut a = [[0.0; DIM]; DIM];
        for row in a.iter_mut().take(m) {
            for v in row.iter_mut().take(m) {
                *v = rnd();
            }
        }
        let mut prob = LocalProblem::new(k, mu);
        for i in 0..m {
            for j in 0..m {
                prob.g[i][j] = (0..m).map(|l| a[i][l] * a[j][l]).sum::<f64>() + if i == j { 0.1 } else { 0.0 };
            }
            prob.c[i] = rnd();
        }
        prob
    }

    #[test]
    fn exact_solution_satisfies_contact_laws() {
        for seed in 0..500 {
            let k = 1 + (seed as usize % 4);
            let prob = problem(k, 0.3, seed);
            let mut modes = [ContactMode::Stick; MAX_CLOSED];
            let mut p = [0.0; DIM];
            let info = exact(&prob, &mut modes, &mut p, 100_000);
            assert!(!info.fallback, "seed {seed}: no exact pattern");
            let r = prob.residual(&p);
            assert!(r < 1e-9, "seed {seed}: residual {r}");
        }
    }

    #[test]
    fn tight_gauss_seidel_agrees_with_exact() {
        for seed in 0..100 {
            let k = 1 + (seed as usize % 2);
            let prob = problem(k, 0.2, seed + 1000);
            let mut modes = [ContactMode::Stick; MAX_CLOSED];
            let mut pe = [0.0; DIM];
            exact(&prob, &mut modes, &mut pe, 100_000);
            let mut pg = [0.0; DIM];
            let info = gauss_seidel(&prob, &mut pg, 1e-13, 1e-18, 1_000_000);
            assert!(!info.capped);
            let scale = pe.iter().fold(1e-12f64, |a, v| a.max(v.abs()));
            for i in 0..2 * k {
                assert!((pe[i] - pg[i]).abs() < 1e-7 * scale, "seed {seed}: {pe:?} vs {pg:?}");
            }
        }
    }

    #[test]
    fn single_contact_cases_by_hand() {
        // G = I, μ = 0.5: approaching with ξ_N = −1, ξ_T = 0.2 → stick, P = (1, −0.2).
        let mut prob = LocalProblem::new(1, 0.5);
        prob.g[0][0] = 1.0;
        prob.g[1][1] = 1.0;
        prob.c[0] = -1.0;
        prob.c[1] = 0.2;
        let mut modes = [ContactMode::Open; MAX_CLOSED];
        let mut p = [0.0; DIM];
        exact(&prob, &mut modes, &mut p, 100);
        assert_eq!(modes[0], ContactMode::Stick);
        assert!((p[0] - 1.0).abs() < 1e-15 && (p[1] + 0.2).abs() < 1e-15);
        // ξ_T = 2 → slide, P_T = −μ P_N.
        prob.c[1] = 2.0;
        exact(&prob, &mut modes, &mut p, 100);
        assert_eq!(modes[0], ContactMode::SlidePos);
        assert!((p[1] + 0.5).abs() < 1e-15);
        // Separating → open.
        prob.c[0] = 1.0;
        exact(&prob, &mut modes, &mut p, 100);
        assert_eq!(modes[0], ContactMode::Open);
        assert_eq!(p[0], 0.0);
    }
}
