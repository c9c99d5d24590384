//! Multi-harmonic HB and static sag (docs/model.md §6.4; module `superslow_mhb`).

use beamslider_core::Params;
use beamslider_core::superslow::{HbOptions, HbSystem, hb_manifold};

fn opts(n: usize, h: usize, sag: bool) -> HbOptions {
    HbOptions { n_modes: n, harmonics: h, static_sag: sag, ..HbOptions::default() }
}

/// Deterministic pseudo-random numbers in [-1, 1] (LCG).
fn rand_vec(seed: &mut u64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| {
            *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
        .collect()
}

/// The AFT residual with 𝒦 = {0, 1} and g = 0 (Q₀ = 0) equals the closed-form single-term
/// residual at random Q (with the amplitude-dependent damping D₂ on), to rounding.
#[test]
fn aft_first_harmonic_equals_closed_form_residual() {
    for d2 in [0.0, 2e-3] {
        let p = Params { gravity_m_s2: 0.0, damping_ratio_quadratic: d2, ..Params::default() };
        let single = HbSystem::new(&p, 124.0, 10.0, &opts(5, 1, false)).unwrap();
        let aft = HbSystem::new(&p, 124.0, 10.0, &opts(5, 1, true)).unwrap();
        let mut seed = 7;
        for _ in 0..20 {
            let u: Vec<f64> = rand_vec(&mut seed, 5).iter().map(|x| x * 2e-4).collect();
            let v: Vec<f64> = rand_vec(&mut seed, 5).iter().map(|x| x * 2e-4).collect();
            let s = 0.05 + 0.45 * (rand_vec(&mut seed, 1)[0] * 0.5 + 0.5);
            let (r1, i1) = single.residual(&u, &v, s, 1.0);
            let (r2, i2) = aft.residual(&u, &v, s, 1.0);
            let scale = r1.iter().chain(&i1).fold(0.0f64, |m, x| m.max(x.abs()));
            for (a, b) in r1.iter().chain(&i1).zip(r2.iter().chain(&i2)) {
                assert!((a - b).abs() <= 1e-12 * scale, "D2 = {d2}: {a} vs {b} (scale {scale})");
            }
        }
    }
}

/// harmonics = 1 through the AFT path (sag with g = 0, Q₀ ≡ 0) equals the single-term manifold.
#[test]
fn aft_manifold_equals_single_term_manifold() {
    let p = Params { gravity_m_s2: 0.0, ..Params::default() };
    for (f, a) in [(124.0, 14.0), (124.0, 8.0)] {
        let o1 = HbOptions { sample_on_grid: true, ..opts(5, 1, false) };
        let o2 = HbOptions { sample_on_grid: true, ..opts(5, 1, true) };
        let m1 = hb_manifold(&p, f, a, &o1).unwrap();
        let m2 = hb_manifold(&p, f, a, &o2).unwrap();
        assert_eq!(m2.harmonic_orders, vec![1, 0]);
        assert_eq!(m1.s_up.is_some(), m2.s_up.is_some());
        assert_eq!(m1.s_dn.is_some(), m2.s_dn.is_some());
        if let (Some(x), Some(y)) = (m1.s_up, m2.s_up) {
            assert!((x - y).abs() <= 1e-10, "s_up {x} vs {y}");
        }
        for (g, (x, y)) in m1.high_on_grid.iter().zip(&m2.high_on_grid).enumerate() {
            assert!(x.is_nan() && y.is_nan() || (x - y).abs() <= 1e-10 * (1.0 + x.abs()), "high at {g}: {x} vs {y}");
        }
        for (g, (x, y)) in m1.low_on_grid.iter().zip(&m2.low_on_grid).enumerate() {
            assert!(x.is_nan() && y.is_nan() || (x - y).abs() <= 1e-10 * (1.0 + x.abs()), "low at {g}: {x} vs {y}");
        }
        // The static part stays exactly zero without gravity.
        assert!(m2.high.harmonic_amplitude_h.chunks(2).all(|c| c[1].abs() < 1e-14));
    }
}

/// The analytic AFT Jacobian agrees with central differences of the residual at a random state
/// in all unknowns (H = 3; H = 5 with sag: orders 1, 2, 3, 4, 5, 0; with D₂).
#[test]
fn aft_jacobian_matches_finite_differences() {
    let p = Params { damping_ratio_quadratic: 1e-3, ..Params::default() };
    for (h, sag) in [(3, false), (5, true)] {
        let n = 3;
        let sys = HbSystem::new(&p, 124.0, 10.0, &opts(n, h, sag)).unwrap();
        let nx = if sag { n + 2 * n * h } else { 2 * n * (h + 1) / 2 };
        assert_eq!(sys.n_unknowns(), nx);
        let mut seed = 11;
        let x: Vec<f64> = rand_vec(&mut seed, nx).iter().enumerate().map(|(i, r)| r * if i < 2 * n { 3e-4 } else { 3e-5 }).collect();
        let s = 0.31;
        let j = sys.jacobian_state(&x, s);
        assert_eq!((j.nrows(), j.ncols()), (nx, nx + 1));
        let eps = 1e-10;
        for col in 0..=nx {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            let (sp, sm) = if col < nx {
                xp[col] += eps;
                xm[col] -= eps;
                (s, s)
            } else {
                (s + 1e-7, s - 1e-7)
            };
            let h_step = if col < nx { 2.0 * eps } else { 2e-7 };
            let rp = sys.residual_state(&xp, sp);
            let rm = sys.residual_state(&xm, sm);
            let col_scale = (0..nx).fold(0.0f64, |m, r| m.max(j[(r, col)].abs()));
            for row in 0..nx {
                let fd = (rp[row] - rm[row]) / h_step;
                let an = j[(row, col)];
                assert!((fd - an).abs() <= 1e-6 * col_scale, "H={h} sag={sag} ({row},{col}): fd {fd} vs {an}");
            }
        }
    }
}

/// N = 1 Duffing oscillator with the slider, M₁q̈ + cq̇ + ω²q + bq³ = F cos Ωt: balancing the third
/// harmonic of q = a cos θ + a₃ cos 3θ (+ small phase shifts) gives
/// (ω² − 9Ω²M₁ + (3/2)b a²) a₃ ≈ −(b/4) a³, i.e. a₃ ≈ b a³ / (4(9Ω²M₁ − ω² − (3/2)b a²))
/// (for Ω ≈ ω, M₁ = 1 and small a: the textbook b a³/(32ω²)); damping and O(a₃²) terms neglected.
#[test]
fn third_harmonic_of_single_mode_matches_duffing_estimate() {
    let p = Params::default();
    let (f, a_ex) = (124.0, 14.0);
    let sys = HbSystem::new(&p, f, a_ex, &opts(1, 3, false)).unwrap();
    let m = hb_manifold(&p, f, a_ex, &opts(1, 3, false)).unwrap();
    assert_eq!(m.harmonic_orders, vec![1, 3]);
    let beam = sys.beam();
    let b = beam.hardening_b();
    let w2 = beam.omega[0].powi(2);
    let om = 2.0 * std::f64::consts::PI * f;
    let phi47 = beam.phi_exact(0, 4.0 / 7.0 * p.length_m).abs();
    let mut checked = 0;
    for (i, &s) in m.high.s.iter().enumerate() {
        let a1 = m.high.harmonic_amplitude_h[2 * i] * p.thickness_m / phi47;
        let a3 = m.high.harmonic_amplitude_h[2 * i + 1] * p.thickness_m / phi47;
        if a1 < 0.5 * p.thickness_m / phi47 {
            continue;
        }
        let m1 = sys.mass_matrix(s)[(0, 0)];
        let est = b * a1.powi(3) / (4.0 * (9.0 * om * om * m1 - w2 - 1.5 * b * a1 * a1));
        let lead = b * a1.powi(3) / (4.0 * (9.0 * om * om * m1 - w2));
        assert!((a3 - est).abs() <= 2e-3 * est, "s = {s}: a3 = {a3:e}, estimate {est:e}");
        // The (3/2)b a² detuning of the third harmonic is up to ~10 % on the high branch.
        assert!((a3 - lead).abs() <= 0.2 * lead, "s = {s}: a3 = {a3:e}, leading-order {lead:e}");
        checked += 1;
    }
    assert!(checked > 10, "high branch points with Â > 0.5: {checked}");
}

/// Multi-harmonic N = 5: higher harmonics are small, and the truncation converges (H = 3 vs 5
/// differ much less than H = 1 vs 3).
#[test]
fn higher_harmonics_are_small_and_converge() {
    let p = Params::default();
    let ms: Vec<_> = [1usize, 3, 5].iter().map(|&h| hb_manifold(&p, 124.0, 14.0, &HbOptions { sample_on_grid: true, ..opts(5, h, false) }).unwrap()).collect();
    for m in &ms {
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }
    let m5 = &ms[2];
    assert_eq!(m5.harmonic_orders, vec![1, 3, 5]);
    let mut max3: f64 = 0.0;
    let mut max5: f64 = 0.0;
    for c in m5.high.harmonic_amplitude_h.chunks(3) {
        max3 = max3.max(c[1] / c[0]);
        max5 = max5.max(c[2] / c[0]);
    }
    assert!(max3 < 0.05 && max3 > 0.0, "a3/a1 on the high branch up to {max3}");
    assert!(max5 < 0.2 * max3, "a5/a1 up to {max5}, a3/a1 up to {max3}");
    let diff = |x: &[f64], y: &[f64]| x.iter().zip(y).filter(|(a, b)| a.is_finite() && b.is_finite()).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // Compare on the part of the high branch away from the folds (s ≤ 0.3 exists for all three).
    let n_lo = m5.s_grid.iter().filter(|&&s| s <= 0.3).count();
    let d13 = diff(&ms[0].high_on_grid[..n_lo], &ms[1].high_on_grid[..n_lo]);
    let d35 = diff(&ms[1].high_on_grid[..n_lo], &ms[2].high_on_grid[..n_lo]);
    assert!(d13 > 0.0 && d35 < 0.2 * d13, "max |Â(H=1) − Â(H=3)| = {d13}, |Â(H=3) − Â(H=5)| = {d35}");
    let (u3, u5) = (ms[1].s_up.unwrap(), ms[2].s_up.unwrap());
    let u1 = ms[0].s_up.unwrap();
    assert!((u3 - u5).abs() <= (u1 - u3).abs().max(1e-4), "s_up: H1 {u1}, H3 {u3}, H5 {u5}");
}

/// Static sag, N = 1, H = 1 (orders {1, 0}): the zeroth-harmonic balance of
/// ω²q + b q³ = −m g φ₁(sL) + F cos Ωt with q = Q₀ + a cos(Ωt − ϑ) is, exactly,
/// ω²Q₀ + b (Q₀³ + (3/2) a² Q₀) = −m g φ₁(sL).
#[test]
fn static_sag_matches_static_single_mode_equation() {
    let p = Params::default();
    let a_ex = 2.0;
    let m = hb_manifold(&p, 124.0, a_ex, &opts(1, 1, true)).unwrap();
    let sys = HbSystem::new(&p, 124.0, a_ex, &opts(1, 1, true)).unwrap();
    assert_eq!(m.harmonic_orders, vec![1, 0]);
    let beam = sys.beam();
    let (b, w2) = (beam.hardening_b(), beam.omega[0].powi(2));
    let mg = p.slider_mass_kg * p.gravity_m_s2;
    let run = &m.up_run;
    let nx = 3;
    for (i, &s) in run.s.iter().enumerate().step_by(5) {
        let q0 = run.state[i * nx + 2];
        let a2 = run.state[i * nx].powi(2) + run.state[i * nx + 1].powi(2);
        let phi = beam.phi_exact(0, s * p.length_m);
        // Newton on ω²x + b(x³ + (3/2)a²x) + mgφ = 0.
        let mut x = -mg * phi / w2;
        for _ in 0..30 {
            x -= (w2 * x + b * (x.powi(3) + 1.5 * a2 * x) + mg * phi) / (w2 + b * (3.0 * x * x + 1.5 * a2));
        }
        assert!((q0 - x).abs() <= 1e-9 * x.abs(), "s = {s}: Q0 = {q0:e}, static {x:e}");
        assert!(q0 < 0.0, "the slider's weight pushes the beam down");
    }
}
