//! The harmonic-balance manifold of docs/model.md §6.4: the HB super-slow manifold against its closed forms.

use beamslider_core::superslow::{HbOptions, HbSystem, closed_form_n1, default_grid, hb_manifold};
use beamslider_core::{Beam, Error, Params};

fn opts(n: usize) -> HbOptions {
    HbOptions { n_modes: n, ..HbOptions::default() }
}

/// Closed-form roots at the given s values (made strictly increasing).
fn closed_at(p: &Params, f: f64, a: f64, s: &[f64]) -> (Vec<f64>, Vec<[f64; 3]>) {
    let mut g: Vec<f64> = s.to_vec();
    g.sort_by(f64::total_cmp);
    g.dedup();
    let cf = closed_form_n1(p, f, a, &g, None).unwrap();
    (g, cf.roots_h)
}

/// Relative difference between `amp` and the nearest finite closed-form root.
fn nearest_root_error(roots: &[f64], amp: f64) -> f64 {
    roots.iter().filter(|r| r.is_finite()).map(|r| ((r - amp) / amp).abs()).fold(f64::INFINITY, f64::min)
}

#[test]
fn n1_closed_form_equals_n_mode_hb_at_n1() {
    let p = Params::default();
    for (f, a) in [(124.0, 14.0), (124.0, 8.0), (126.0, 10.0), (104.0, 14.0)] {
        let m = hb_manifold(&p, f, a, &opts(1)).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        let fold_s: Vec<f64> = m.folds.iter().map(|f| f.s).collect();
        let mut worst: f64 = 0.0;
        let mut checked = 0;
        for run in [&m.up_run, &m.down_run] {
            let (g, roots) = closed_at(&p, f, a, &run.s);
            for (s, amp) in run.s.iter().zip(&run.amplitude_h) {
                // At a fold the closed-form root is a double root (ill-conditioned): folds are
                // compared in s by their own test.
                if fold_s.iter().any(|fs| (fs - s).abs() < 1e-9) {
                    continue;
                }
                let k = g.iter().position(|x| x == s).unwrap();
                worst = worst.max(nearest_root_error(&roots[k], *amp));
                checked += 1;
            }
        }
        // The branches solved on the grid are roots of the closed form too.
        let o = HbOptions { sample_on_grid: true, ..opts(1) };
        let mg = hb_manifold(&p, f, a, &o).unwrap();
        let cf = closed_form_n1(&p, f, a, &mg.s_grid, None).unwrap();
        for (k, amp) in mg.high_on_grid.iter().chain(&mg.low_on_grid).enumerate() {
            if !amp.is_finite() || fold_s.iter().any(|fs| (fs - mg.s_grid[k % mg.s_grid.len()]).abs() < 1e-4) {
                continue;
            }
            worst = worst.max(nearest_root_error(&cf.roots_h[k % mg.s_grid.len()], *amp));
            checked += 1;
        }
        eprintln!("({f}, {a}): {checked} points, worst relative difference {worst:.2e}");
        assert!(checked > 20);
        assert!(worst < 1e-10, "({f}, {a}): worst relative difference {worst:e}");
    }
}

#[test]
fn folds_from_the_discriminant_match_the_continuation_folds() {
    let p = Params::default();
    let mut with_folds = 0;
    for (f, a) in [(124.0, 14.0), (124.0, 8.0), (126.0, 10.0), (124.0, 6.0), (110.0, 14.0)] {
        let m = hb_manifold(&p, f, a, &opts(1)).unwrap();
        let cf = closed_form_n1(&p, f, a, &default_grid(&p, 201), None).unwrap();
        let hb: Vec<f64> = m.folds.iter().map(|f| f.s).collect();
        eprintln!("({f}, {a}): Δ = 0 at {:?}, continuation folds {:?}", cf.folds, hb);
        assert_eq!(cf.folds.len(), hb.len(), "({f}, {a}): {:?} vs {:?}", cf.folds, hb);
        for (x, y) in cf.folds.iter().zip(&hb) {
            assert!((x - y).abs() < 1e-6, "({f}, {a}): fold {x} vs {y}");
        }
        assert_eq!(cf.s_up, m.s_up.map(|_| cf.folds[0]));
        if let (Some(x), Some(y)) = (cf.s_up, m.s_up) {
            assert!((x - y).abs() < 1e-6);
        }
        if let (Some(x), Some(y)) = (cf.s_dn, m.s_dn) {
            assert!((x - y).abs() < 1e-6);
        }
        assert_eq!(cf.s_dn.is_some(), m.s_dn.is_some());
        with_folds += usize::from(!hb.is_empty());
    }
    assert!(with_folds >= 3, "the test must see folds");
}

/// Without the slider (m, J_G → 0) the backbone is MODEL.md §9's ω̃² = ω² + ¾ b* ã².
#[test]
fn without_slider_the_backbone_is_the_enma_backbone() {
    let p = Params { slider_mass_kg: 1e-15, slider_inertia_kg_m2: 1e-21, com_offset_m: 0.0, damping_ratio: 0.0, ..Params::default() };
    let beam = Beam::new(&p).unwrap();
    let (w, bs) = (beam.omega[0], beam.b_star(p.thickness_m));
    let phi_mid = beam.phi_exact(0, 0.5 * p.length_m);
    let phi47 = beam.phi_exact(0, 4.0 / 7.0 * p.length_m);
    let grid = default_grid(&p, 21);
    for f_ratio in [1.02, 1.1, 1.3] {
        let f_ex = f_ratio * w / (2.0 * std::f64::consts::PI);
        let om2_ex = (2.0 * std::f64::consts::PI * f_ex).powi(2);
        // Undamped, weakly forced: the middle and high roots lie on either side of the free
        // backbone, within O(F/(a Ω²)) ≈ 1e-7 of it.
        let cf = closed_form_n1(&p, f_ex, 1e-3, &grid, None).unwrap();
        let sys = HbSystem::new(&p, f_ex, 1e-3, &opts(1)).unwrap();
        // Backbone amplitude (at 4L/7) from MODEL.md §9: ã² = (Ω² − ω²)/(¾ b*), ŵ(4L/7) = ã φ₁(4L/7)/φ₁(L/2).
        let a_tilde = ((om2_ex - w * w) / (0.75 * bs)).sqrt();
        let a47 = a_tilde * (phi47 / phi_mid).abs();
        for (k, roots) in cf.roots_h.iter().enumerate() {
            assert_eq!(cf.n_roots[k], 3, "above resonance: three roots");
            assert!(roots[1] < a47 && a47 < roots[2], "s = {}: {roots:?} vs backbone {a47}", grid[k]);
            assert!((roots[2] / a47 - 1.0).abs() < 1e-4 && (roots[1] / a47 - 1.0).abs() < 1e-4, "{roots:?} vs {a47}");
            // The backbone function Ω_bb(Â, s) returns Ω at the backbone amplitude.
            let bb = sys.backbone_omega(a47, grid[k]);
            assert!((bb * bb / om2_ex - 1.0).abs() < 1e-9, "{bb}");
            // The high-branch estimate a_H is the same backbone.
            assert!((cf.backbone_h[k] / a47 - 1.0).abs() < 1e-9);
        }
    }
    // With N = 5 and no slider the manifold does not depend on s.
    let m = hb_manifold(&Params { damping_ratio: 1e-3, ..p }, 124.0, 14.0, &opts(5)).unwrap();
    let a = &m.high.amplitude_h;
    let (lo, hi) = a.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
    assert!(hi / lo - 1.0 < 1e-9, "flat manifold without slider: {lo} .. {hi}");
    assert!(m.folds.is_empty() && m.s_up.is_none() && m.s_dn.is_none());
}

#[test]
fn mirror_symmetry_about_the_centre() {
    let p = Params::default();
    // Closed form: the same roots at s and 1 − s.
    let s_min = p.s_min();
    let grid: Vec<f64> = (0..=40).map(|i| s_min + (1.0 - 2.0 * s_min) * i as f64 / 40.0).collect();
    let cf = closed_form_n1(&p, 124.0, 14.0, &grid, None).unwrap();
    for i in 0..grid.len() {
        let j = grid.len() - 1 - i;
        for k in 0..3 {
            let (x, y) = (cf.roots_h[i][k], cf.roots_h[j][k]);
            assert!(x.is_nan() && y.is_nan() || ((x - y) / x).abs() < 1e-9, "s = {}: {x} vs {y}", grid[i]);
        }
    }
    // N modes: R(PQ, 1 − s) = P R(Q, s), P = diag((−1)^(n)) (symmetric / antisymmetric modes).
    let sys = HbSystem::new(&p, 124.0, 10.0, &opts(5)).unwrap();
    let sign: Vec<f64> = (0..5).map(|n| if n % 2 == 0 { 1.0 } else { -1.0 }).collect();
    let u = [2e-4, -3e-5, 1e-5, 4e-6, -2e-6];
    let v = [-5e-5, 2e-5, -3e-6, 1e-6, 5e-7];
    for s in [0.05, 0.2, 0.33, 0.45] {
        let (r1, i1) = sys.residual(&u, &v, s, 1.0);
        let pu: Vec<f64> = u.iter().zip(&sign).map(|(a, b)| a * b).collect();
        let pv: Vec<f64> = v.iter().zip(&sign).map(|(a, b)| a * b).collect();
        let (r2, i2) = sys.residual(&pu, &pv, 1.0 - s, 1.0);
        let scale = r1.iter().chain(&i1).fold(0.0f64, |m, x| m.max(x.abs()));
        for n in 0..5 {
            assert!((r2[n] - sign[n] * r1[n]).abs() < 1e-9 * scale, "s = {s}, mode {n}");
            assert!((i2[n] - sign[n] * i1[n]).abs() < 1e-9 * scale, "s = {s}, mode {n}");
        }
    }
    // A solution mirrored is a solution: Newton from the mirrored point barely moves.
    let m = hb_manifold(&p, 124.0, 14.0, &opts(5)).unwrap();
    let n = 5;
    for idx in [3, m.high.len() / 2, m.high.len() - 2] {
        let s = m.high.s[idx];
        let u: Vec<f64> = (0..n).map(|k| m.high.q_re[idx * n + k] * sign[k]).collect();
        let v: Vec<f64> = (0..n).map(|k| m.high.q_im[idx * n + k] * sign[k]).collect();
        let (u2, v2) = sys_at(&p, 124.0, 14.0).solve_point(1.0 - s, &u, &v).unwrap();
        for k in 0..n {
            assert!((u2[k] - u[k]).abs() < 1e-9 * 1e-3 && (v2[k] - v[k]).abs() < 1e-9 * 1e-3, "s = {s}, mode {k}");
        }
    }
}

fn sys_at(p: &Params, f: f64, a: f64) -> HbSystem {
    HbSystem::new(p, f, a, &opts(5)).unwrap()
}

#[test]
fn analytic_jacobian_matches_finite_differences() {
    // Preload and amplitude-dependent damping switched on: every term of R is exercised.
    let p = Params { axial_preload_n: 3.0, damping_ratio_quadratic: 2e-3, ..Params::default() };
    let sys = HbSystem::new(&p, 124.0, 10.0, &opts(5)).unwrap();
    let u = [2e-4, -3e-5, 1e-5, 4e-6, -2e-6];
    let v = [-5e-5, 2e-5, -3e-6, 1e-6, 5e-7];
    let s = 0.31;
    let j = sys.jacobian(&u, &v, s);
    let r = |u: &[f64], v: &[f64], s: f64| {
        let (a, b) = sys.residual(u, v, s, 1.0);
        [a, b].concat()
    };
    let mut worst: f64 = 0.0;
    let jmax = j.amax();
    for col in 0..11 {
        let mut up = (u.to_vec(), v.to_vec(), s);
        let mut dn = (u.to_vec(), v.to_vec(), s);
        let hstep = if col < 10 { 1e-9 } else { 1e-7 };
        match col {
            c if c < 5 => {
                up.0[c] += hstep;
                dn.0[c] -= hstep;
            }
            c if c < 10 => {
                up.1[c - 5] += hstep;
                dn.1[c - 5] -= hstep;
            }
            _ => {
                up.2 += hstep;
                dn.2 -= hstep;
            }
        }
        let (a, b) = (r(&up.0, &up.1, up.2), r(&dn.0, &dn.1, dn.2));
        for row in 0..10 {
            let fd = (a[row] - b[row]) / (2.0 * hstep);
            let scale = if col < 10 { jmax } else { j.column(10).amax() };
            worst = worst.max((fd - j[(row, col)]).abs() / scale);
        }
    }
    assert!(worst < 1e-6, "worst relative Jacobian error {worst:e}");
}

#[test]
fn fold_exactly_at_a_grid_point_or_at_the_range_end() {
    let p = Params::default();
    let cf = closed_form_n1(&p, 124.0, 14.0, &default_grid(&p, 201), None).unwrap();
    let fold = cf.s_up.expect("a jump-up fold at (124, 14)");
    // A grid that contains the fold exactly.
    let mut grid = default_grid(&p, 51);
    grid.push(fold);
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    let cf2 = closed_form_n1(&p, 124.0, 14.0, &grid, None).unwrap();
    let k = grid.iter().position(|&x| x == fold).unwrap();
    eprintln!("Δ at the fold grid point: {:e}", cf2.discriminant[k]);
    assert_eq!(cf2.folds.len(), cf.folds.len(), "{:?} vs {:?}", cf2.folds, cf.folds);
    assert!((cf2.folds[0] - fold).abs() < 1e-9);
    // Force Δ = 0 at a grid point exactly: a fold on a grid point is reported once.
    // (exercised through the range end below for the continuation)
    for end in [fold, fold + 1e-12, fold - 1e-12] {
        let o = HbOptions { s: Some(vec![p.s_min(), end]), ..opts(1) };
        let m = hb_manifold(&p, 124.0, 14.0, &o).unwrap();
        assert!(m.high.len() > 3 && !m.low.is_empty(), "end {end}");
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        let o5 = HbOptions { s: Some(vec![p.s_min(), end]), ..opts(5) };
        hb_manifold(&p, 124.0, 14.0, &o5).unwrap();
    }
}

#[test]
fn empty_coexistence_interval_gives_no_folds_and_no_panic() {
    let p = Params::default();
    for (f, a) in [(60.0, 14.0), (90.0, 14.0), (124.0, 0.005)] {
        let cf = closed_form_n1(&p, f, a, &default_grid(&p, 201), None).unwrap();
        assert!(cf.folds.is_empty() && cf.s_up.is_none() && cf.s_dn.is_none(), "({f}, {a}): {:?}", cf.folds);
        assert!(cf.n_roots.iter().all(|&k| k == 1));
        for n in [1, 5] {
            let m = hb_manifold(&p, f, a, &opts(n)).unwrap();
            assert!(m.folds.is_empty() && m.s_up.is_none() && m.s_dn.is_none(), "({f}, {a}) N={n}: {:?}", m.folds);
            // One branch: high and low coincide.
            for s in [0.15, 0.45] {
                let (x, y) = (m.high.amplitude_at(s).unwrap(), m.low.amplitude_at(s).unwrap());
                // (linear interpolation between continuation points: ~1e-2)
                assert!((x / y - 1.0).abs() < 2e-2, "({f}, {a}) N={n}: {x} vs {y}");
            }
            // Solved exactly on the grid, both are the same solution.
            let o = HbOptions { sample_on_grid: true, ..opts(n) };
            let m = hb_manifold(&p, f, a, &o).unwrap();
            assert_eq!(m.high_on_grid.len(), 201);
            for (x, y) in m.high_on_grid.iter().zip(&m.low_on_grid) {
                assert!((x / y - 1.0).abs() < 1e-9, "({f}, {a}) N={n}: {x} vs {y}");
            }
            assert!(m.high.stable.iter().all(|&b| b));
        }
    }
}

#[test]
fn branches_folds_and_stability_are_consistent() {
    let p = Params::default();
    let m = hb_manifold(&p, 124.0, 14.0, &opts(5)).unwrap();
    let s_up = m.s_up.expect("jump-up at (124, 14)");
    assert!(m.s_dn.is_none(), "single-term HB: the high branch reaches the centre (docs/model.md §6.4)");
    assert!(s_up > 0.1 && s_up < 0.45, "{s_up}");
    assert!(m.low.stable.iter().all(|&b| b) && m.high.stable.iter().all(|&b| b));
    assert!(m.middle.stable.iter().skip(1).take(m.middle.len().saturating_sub(2)).all(|&b| !b), "middle unstable");
    // Where both exist the high branch is above the low branch.
    for s in [s_up + 0.01, 0.4, 0.5] {
        assert!(m.high.amplitude_at(s).unwrap() > m.low.amplitude_at(s).unwrap());
    }
    assert_eq!(m.s_res.len(), 1);
    assert!(m.s_res[0] < s_up, "resonance lies towards the clamping of the jump-up");
    // A larger equivalent damping ends the high branch before the centre.
    let md = hb_manifold(&p, 124.0, 8.0, &HbOptions { d_eff: Some(0.02), ..opts(5) }).unwrap();
    assert!(md.s_dn.is_some(), "D_eff = 0.02 at (124, 8) ends the high branch: {:?}", md.folds);
}

#[test]
fn bad_inputs_are_errors_naming_the_argument() {
    let p = Params::default();
    let field = |r: Result<_, Error>| match r {
        Err(Error::InvalidParameter { field, .. }) => field,
        Err(e) => panic!("unexpected {e}"),
        Ok(_) => panic!("accepted"),
    };
    let o = opts(5);
    assert_eq!(field(hb_manifold(&p, -1.0, 14.0, &o).map(|_| ())), "f_ex");
    assert_eq!(field(hb_manifold(&p, f64::NAN, 14.0, &o).map(|_| ())), "f_ex");
    assert_eq!(field(hb_manifold(&p, 124.0, 0.0, &o).map(|_| ())), "a_ex");
    assert_eq!(field(hb_manifold(&p, 124.0, f64::INFINITY, &o).map(|_| ())), "a_ex");
    assert_eq!(field(hb_manifold(&p, 124.0, 14.0, &opts(0)).map(|_| ())), "n_modes");
    assert_eq!(field(hb_manifold(&p, 124.0, 14.0, &opts(21)).map(|_| ())), "n_modes");
    for h in [0usize, 2, 4, 9] {
        assert_eq!(field(hb_manifold(&p, 124.0, 14.0, &HbOptions { harmonics: h, ..opts(5) }).map(|_| ())), "harmonics");
    }
    assert_eq!(field(hb_manifold(&p, 124.0, 14.0, &HbOptions { d_eff: Some(-0.1), ..opts(5) }).map(|_| ())), "d_eff");
    for bad in [vec![], vec![0.3], vec![0.3, 0.2], vec![0.01, 0.3], vec![0.2, 0.6], vec![0.2, f64::NAN]] {
        assert_eq!(field(hb_manifold(&p, 124.0, 14.0, &HbOptions { s: Some(bad.clone()), ..opts(5) }).map(|_| ())), "s", "{bad:?}");
    }
    assert_eq!(field(closed_form_n1(&p, 124.0, 14.0, &[0.3, 0.2], None).map(|_| ())), "s");
    assert_eq!(field(closed_form_n1(&p, 0.0, 14.0, &[0.2, 0.3], None).map(|_| ())), "f_ex");
    assert_eq!(field(closed_form_n1(&p, 124.0, -2.0, &[0.2, 0.3], None).map(|_| ())), "a_ex");
    let p2 = Params { damping_ratio_quadratic: 1e-3, ..Params::default() };
    assert_eq!(field(closed_form_n1(&p2, 124.0, 14.0, &[0.2, 0.3], None).map(|_| ())), "damping_ratio_quadratic");
    // Amplitude-dependent damping works in the N-mode HB and lowers the high branch.
    let a0 = hb_manifold(&p, 124.0, 14.0, &o).unwrap().high.amplitude_at(0.5).unwrap();
    let a2 = hb_manifold(&p2, 124.0, 14.0, &o).unwrap().high.amplitude_at(0.5);
    assert!(a2.is_none_or(|a| a < a0));
}

/// `low_branch_only` (the predictor's setting) ends the downward run at its first fold: the
/// stable branches and s_up, s_dn are those of the full manifold, bit for bit, in fewer steps.
#[test]
fn low_branch_only_keeps_the_stable_branches_bitwise() {
    let p = Params::default();
    for (f, a) in [(124.0, 14.0), (124.0, 6.0), (104.0, 14.0), (100.0, 4.0), (130.0, 16.0)] {
        let full = hb_manifold(&p, f, a, &opts(5)).unwrap();
        let short = hb_manifold(&p, f, a, &HbOptions { low_branch_only: true, ..opts(5) }).unwrap();
        assert!(short.warnings.is_empty(), "{:?}", short.warnings);
        assert_eq!(short.low, full.low, "({f}, {a})");
        assert_eq!(short.high, full.high, "({f}, {a})");
        assert_eq!((short.s_up, short.s_dn), (full.s_up, full.s_dn), "({f}, {a})");
        assert_eq!(short.s_res, full.s_res);
        if full.s_up.is_some() {
            assert!(short.steps < full.steps, "({f}, {a}): {} vs {} steps", short.steps, full.steps);
        } else {
            assert_eq!(short.steps, full.steps);
        }
    }
}
