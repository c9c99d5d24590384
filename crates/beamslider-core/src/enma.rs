//! Virtual Experimental Nonlinear Modal Analysis (ENMA) of the beam without slider (paper §3.1,
//! docs/model.md §9): phase-resonance testing with a phase-locked loop at stepped excitation levels.
//!
//! The beam-only model (N modes, preload and amplitude-dependent damping included) is integrated
//! with the same midpoint scheme as the stepper, but with an excitation phase θ(t) = ∫Ω dt whose
//! frequency Ω is adjusted by a PI phase-locked loop once per excitation period:
//!
//! * phase detector: over each period, least-squares fit of the sensor response
//!   w(x_s, t) ≈ I cos θ + Q sin θ + (3rd harmonic) + offset; the lag of the response behind the
//!   modal excitation force −γ₁ ẅ₀ = γ₁ a cos θ is ψ = atan2(σQ, σI), σ = sign(γ₁ φ₁(x_s));
//! * phase resonance is ψ = 90°; error e = π/2 − ψ (positive below resonance);
//! * controller (velocity form of a PI controller, per period Tₖ):
//!   Ωₖ₊₁ = Ωₖ + K_p (eₖ − eₖ₋₁) + K_i Tₖ eₖ.
//!
//! Near resonance ψ obeys ψ̇ ≈ (Ω − ω̃) − Dω (ψ − π/2), so the closed loop is
//! s² + (K_p + Dω) s + K_i = 0; the defaults K_p = 40 s⁻¹, K_i = 400 s⁻² give a critically damped
//! loop of bandwidth ≈ 20 rad/s (the amplitude itself settles with the slower rate Dω).
//!
//! Steady state (per level): over the last `settle_periods` periods, |e| < `phase_tol_rad`, the
//! sensor amplitude varies by less than `amplitude_tol` (relative) and Ω by less than
//! `frequency_tol` (relative). Then `eval_periods` further periods are evaluated: amplitude
//! ã = |ŵ(L/2)|/h, frequency Ω/2π, complex responses ŵ at x = L/6 … 5L/6 (relative to the base),
//! the damping estimate D̃ = |ŵᴴ 1 a| / (2 ŵᴴŵ Ω²) and the deflection shape.

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::dynamics::beam_only::beam_integrator;
use crate::dynamics::simulation::{Model, Monitor, POLL_EVERY};
use crate::error::{Error, Result};

/// Number of response points x = L/6 … 5L/6 (the paper's multi-point vibrometer).
pub const N_POINTS: usize = 5;
/// Basis of the per-period fit: cos θ, sin θ, cos 3θ, sin 3θ, 1.
const NB: usize = 5;

/// Direction of the level stepping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Run {
    /// Levels stepped upwards.
    Up,
    /// Levels stepped downwards.
    Down,
}

impl std::fmt::Display for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Run::Up => "up",
            Run::Down => "down",
        })
    }
}

/// Settings of a virtual ENMA.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnmaOptions {
    /// Base-acceleration amplitudes a_ex [m/s²], stepped in the given order (then back down).
    pub levels_m_s2: Vec<f64>,
    /// Also step the levels back down after the up run.
    pub up_and_down: bool,
    /// Position of the phase sensor x_s [m]; `None` = L/2.
    pub sensor_x_m: Option<f64>,
    /// Proportional gain K_p of the PLL [rad/s per rad].
    pub kp_per_s: f64,
    /// Integral gain K_i of the PLL [rad/s² per rad].
    pub ki_per_s2: f64,
    /// Frequency at which the PLL starts [Hz]; `None` = linear natural frequency of mode 1.
    pub start_frequency_hz: Option<f64>,
    /// Window of the steady-state test [excitation periods].
    pub settle_periods: usize,
    /// Largest phase error allowed over the window [rad].
    pub phase_tol_rad: f64,
    /// Largest relative change of the sensor amplitude over the window.
    pub amplitude_tol: f64,
    /// Largest relative change of Ω over the window.
    pub frequency_tol: f64,
    /// Periods evaluated once steady.
    pub eval_periods: usize,
    /// Longest hold of one level before it is evaluated as not converged [s].
    pub max_hold_s: f64,
}

impl Default for EnmaOptions {
    fn default() -> Self {
        EnmaOptions {
            levels_m_s2: vec![0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0],
            up_and_down: true,
            sensor_x_m: None,
            kp_per_s: 40.0,
            ki_per_s2: 400.0,
            start_frequency_hz: None,
            settle_periods: 50,
            phase_tol_rad: 1e-4,
            amplitude_tol: 1e-5,
            frequency_tol: 1e-6,
            eval_periods: 100,
            max_hold_s: 60.0,
        }
    }
}

impl EnmaOptions {
    /// Check every option; the error names it.
    pub fn validate(&self, length_m: f64) -> Result<()> {
        if self.levels_m_s2.is_empty() {
            return Err(Error::invalid("levels_m_s2", "[]", "needs at least one excitation level"));
        }
        for &a in &self.levels_m_s2 {
            if !(a.is_finite() && a > 0.0) {
                return Err(Error::invalid("levels_m_s2", a, "every level must be finite and > 0"));
            }
        }
        if let Some(x) = self.sensor_x_m
            && !(x.is_finite() && x > 0.0 && x < length_m)
        {
            return Err(Error::invalid("sensor_x_m", x, "must lie strictly inside the beam (0, L)"));
        }
        for (name, v) in [
            ("kp_per_s", self.kp_per_s),
            ("ki_per_s2", self.ki_per_s2),
            ("phase_tol_rad", self.phase_tol_rad),
            ("amplitude_tol", self.amplitude_tol),
            ("frequency_tol", self.frequency_tol),
            ("max_hold_s", self.max_hold_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(name, v, "must be finite and > 0"));
            }
        }
        if let Some(f) = self.start_frequency_hz
            && !(f.is_finite() && f > 0.0)
        {
            return Err(Error::invalid("start_frequency_hz", f, "must be finite and > 0"));
        }
        if self.settle_periods < 2 {
            return Err(Error::invalid("settle_periods", self.settle_periods, "must be >= 2"));
        }
        if self.eval_periods < 1 {
            return Err(Error::invalid("eval_periods", self.eval_periods, "must be >= 1"));
        }
        Ok(())
    }
}

/// One phase-resonant point (one excitation level of one run).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnmaPoint {
    /// Run direction.
    pub run: Run,
    /// Base-acceleration amplitude a_ex [m/s²].
    pub level_m_s2: f64,
    /// Modal amplitude ã = |ŵ(L/2)|/h [-] (fundamental harmonic).
    pub amplitude_h: f64,
    /// Phase-resonant frequency Ω/2π [Hz].
    pub frequency_hz: f64,
    /// Damping estimate D̃ = |ŵᴴ 1 a| / (2 ŵᴴŵ Ω²) [-] (docs/model.md §9).
    pub damping_ratio: f64,
    /// Mean phase error over the evaluated periods [rad].
    pub phase_error_rad: f64,
    /// |3rd harmonic| / |fundamental| of w(L/2) [-].
    pub third_harmonic_ratio: f64,
    /// Time the level was held before evaluation [s].
    pub settle_time_s: f64,
    /// Did the steady-state test pass (false: evaluated after `max_hold_s`)?
    pub converged: bool,
    /// Points x = L/6 … 5L/6 [m].
    pub x_m: Vec<f64>,
    /// Re ŵ(xⱼ) [m] (cosine part, phase relative to the excitation force).
    pub response_re_m: Vec<f64>,
    /// Im ŵ(xⱼ) [m] (sine part).
    pub response_im_m: Vec<f64>,
    /// Deflection shape: Re(ŵ e^{−iψ_max}) normalised to largest magnitude 1 [-].
    pub shape: Vec<f64>,
}

/// Result of a virtual ENMA.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnmaResult {
    /// One row per level and run.
    pub points: Vec<EnmaPoint>,
    /// Simulated time in total [s].
    pub simulated_s: f64,
    /// Time steps taken.
    pub steps: u64,
}

/// Accumulated normal equations of the fit w(xⱼ) ≈ Σ cₖ bₖ(θ) over a window.
#[derive(Clone, Copy)]
struct Fit {
    gram: SMatrix<f64, NB, NB>,
    rhs: SMatrix<f64, NB, N_POINTS>,
    omega_sum: f64,
    samples: usize,
}

impl Fit {
    fn new() -> Self {
        Fit { gram: SMatrix::zeros(), rhs: SMatrix::zeros(), omega_sum: 0.0, samples: 0 }
    }

    #[inline]
    fn add(&mut self, theta: f64, w: &[f64; N_POINTS], omega: f64) {
        let (s, c) = theta.sin_cos();
        // cos 3θ = 4c³ − 3c, sin 3θ = 3s − 4s³.
        let basis = SVector::<f64, NB>::from([c, s, c * (4.0 * c * c - 3.0), s * (3.0 - 4.0 * s * s), 1.0]);
        self.gram += basis * basis.transpose();
        for (j, &wj) in w.iter().enumerate() {
            let mut col = self.rhs.column_mut(j);
            col += basis * wj;
        }
        self.omega_sum += omega;
        self.samples += 1;
    }

    /// Coefficients (rows: basis, columns: points); `None` if the window is degenerate.
    fn solve(&self) -> Option<SMatrix<f64, NB, N_POINTS>> {
        let chol = self.gram.cholesky()?;
        Some(chol.solve(&self.rhs))
    }
}

/// Wrap an angle into (−π, π].
fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut a = a % two_pi;
    if a > std::f64::consts::PI {
        a -= two_pi;
    } else if a <= -std::f64::consts::PI {
        a += two_pi;
    }
    a
}

/// Run a virtual ENMA of the model's beam (the slider is ignored): levels stepped up (and down),
/// each held under phase-locked-loop control until steady, then evaluated (module docs).
pub fn virtual_enma(model: &Model, opts: &EnmaOptions, monitor: &mut dyn Monitor) -> Result<EnmaResult> {
    let p = &model.params;
    let beam = &model.beam;
    let l = p.length_m;
    opts.validate(l)?;
    let n = beam.n;
    let x_pts: [f64; N_POINTS] = std::array::from_fn(|j| (j + 1) as f64 * l / 6.0);
    let phi_pts: Vec<[f64; N_POINTS]> = (0..n).map(|m| std::array::from_fn(|j| beam.phi_exact(m, x_pts[j]))).collect();
    let sensor_x = opts.sensor_x_m.unwrap_or(0.5 * l);
    let phi_sensor: Vec<f64> = (0..n).map(|m| beam.phi_exact(m, sensor_x)).collect();
    let sigma = (beam.gamma[0] * phi_sensor[0]).signum();
    if sigma == 0.0 {
        return Err(Error::invalid("sensor_x_m", sensor_x, "sensor sits at a node of mode 1"));
    }
    let two_pi = 2.0 * std::f64::consts::PI;
    // Linear frequency of mode 1 including the preload (lowest eigenvalue of diag(ω²) + H₀K).
    let omega_lin = beam.first_mode(p.thickness_m).omega_rad_s;
    let mut omega = opts.start_frequency_hz.map(|f| two_pi * f).unwrap_or(omega_lin);

    let mut levels: Vec<(Run, f64)> = opts.levels_m_s2.iter().map(|&a| (Run::Up, a)).collect();
    if opts.up_and_down && opts.levels_m_s2.len() > 1 {
        levels.extend(opts.levels_m_s2.iter().rev().skip(1).map(|&a| (Run::Down, a)));
    }

    let dt = p.dt_s;
    // The stepper's beam-only path (one integrator and one set of beam forces in the crate).
    let mut beam_int = beam_integrator(beam, p).ok_or_else(|| Error::invalid("n_modes", beam.n, "must lie in 1..=20"))?;
    let mut theta = 0.0_f64;
    let mut t = 0.0_f64;
    let mut steps: u64 = 0;
    let n_levels = levels.len() as f64;
    let mut points = Vec::with_capacity(levels.len());
    let sensor_w = |q: &[f64]| -> f64 { q.iter().zip(&phi_sensor).map(|(q, f)| q * f).sum() };
    let points_w = |q: &[f64]| -> [f64; N_POINTS] {
        let mut w = [0.0; N_POINTS];
        for (m, qm) in q.iter().enumerate() {
            for j in 0..N_POINTS {
                w[j] += phi_pts[m][j] * qm;
            }
        }
        w
    };

    // The monitor sees progress in levels: poll(levels done, number of levels).
    for (li, &(run, a)) in levels.iter().enumerate() {
        let t_level = t;
        let mut e_prev: Option<f64> = None;
        // History of (amplitude, Ω, e) per period over the steady-state window.
        let mut hist: std::collections::VecDeque<(f64, f64, f64)> = std::collections::VecDeque::new();
        let mut period = Fit::new();
        let mut period_start = t;
        let mut eval: Option<(Fit, usize)> = None;
        let mut converged = true;
        let mut settle_time = 0.0;
        let mut phase_err_sum = 0.0;
        loop {
            // Excitation at the midpoint: ẅ₀ = −a cos θ_M.
            let theta_m = theta + 0.5 * omega * dt;
            let stepped = beam_int.step(-a * theta_m.cos());
            theta += omega * dt;
            t += dt;
            steps += 1;
            if steps.is_multiple_of(POLL_EVERY) && !monitor.poll(li as f64, n_levels) {
                return Err(Error::Interrupted { t_s: t });
            }
            if stepped.is_err() {
                return Err(Error::Numerical(format!("virtual ENMA blew up at t = {t:.6} s (level {a} m/s²); try a smaller dt_s")));
            }
            let w_s = sensor_w(beam_int.q());
            let w_pts = points_w(beam_int.q());
            let mut w_period = w_pts;
            w_period[0] = w_s; // column 0 of the per-period fit is the phase sensor
            period.add(theta, &w_period, omega);
            if let Some((fit, _)) = eval.as_mut() {
                fit.add(theta, &w_pts, omega);
            }
            if theta < two_pi {
                continue;
            }
            // One excitation period completed.
            theta -= two_pi;
            let t_period = t - period_start;
            period_start = t;
            let Some(c) = period.solve() else {
                period = Fit::new();
                continue;
            };
            period = Fit::new();
            let (ci, cq) = (sigma * c[(0, 0)], sigma * c[(1, 0)]);
            let amp = ci.hypot(cq);
            let psi = cq.atan2(ci);
            let e = wrap(std::f64::consts::FRAC_PI_2 - psi);
            if let Some((_, done)) = eval.as_mut() {
                *done += 1;
                phase_err_sum += e;
            }
            // PI controller in velocity form; the step is limited to 1 % of Ω per period.
            let de = e - e_prev.unwrap_or(e);
            let step = (opts.kp_per_s * de + opts.ki_per_s2 * t_period * e).clamp(-0.01 * omega, 0.01 * omega);
            e_prev = Some(e);
            omega += step;
            if !(omega.is_finite() && omega > 0.0) {
                return Err(Error::Numerical(format!("PLL lost lock at t = {t:.3} s (level {a} m/s²)")));
            }
            if let Some((fit, done)) = eval {
                if done >= opts.eval_periods {
                    points.push(evaluate(model, run, a, &fit, &x_pts, settle_time, converged, phase_err_sum / done as f64)?);
                    break;
                }
                continue;
            }
            hist.push_back((amp, omega, e));
            if hist.len() > opts.settle_periods {
                hist.pop_front();
            }
            let held = t - t_level;
            let steady = hist.len() == opts.settle_periods && {
                let (mut amin, mut amax, mut wmin, mut wmax, mut emax) = (f64::INFINITY, 0.0_f64, f64::INFINITY, 0.0_f64, 0.0_f64);
                for &(am, w, e) in &hist {
                    amin = amin.min(am);
                    amax = amax.max(am);
                    wmin = wmin.min(w);
                    wmax = wmax.max(w);
                    emax = emax.max(e.abs());
                }
                emax < opts.phase_tol_rad && amax - amin < opts.amplitude_tol * amax && wmax - wmin < opts.frequency_tol * wmax
            };
            if steady || held >= opts.max_hold_s {
                converged = steady;
                settle_time = held;
                eval = Some((Fit::new(), 0));
            }
        }
    }
    Ok(EnmaResult { points, simulated_s: t, steps })
}

/// Evaluate the accumulated window of one level (docs/model.md §9).
#[allow(clippy::too_many_arguments)]
fn evaluate(
    model: &Model, run: Run, a: f64, fit: &Fit, x_pts: &[f64; N_POINTS], settle_time_s: f64, converged: bool, phase_error_rad: f64,
) -> Result<EnmaPoint> {
    let c = fit.solve().ok_or_else(|| Error::Numerical("degenerate ENMA evaluation window".into()))?;
    let omega = fit.omega_sum / fit.samples as f64;
    // Complex amplitude ŵ = Re − i Im for w = Re cos θ + Im sin θ.
    let re: Vec<f64> = (0..N_POINTS).map(|j| c[(0, j)]).collect();
    let im: Vec<f64> = (0..N_POINTS).map(|j| c[(1, j)]).collect();
    let mid = N_POINTS / 2; // x = 3L/6 = L/2
    let amp_mid = re[mid].hypot(im[mid]);
    let third = c[(2, mid)].hypot(c[(3, mid)]);
    // ŵᴴ 1 and ŵᴴ ŵ with ŵⱼ = reⱼ − i imⱼ.
    let (sum_re, sum_im) = (re.iter().sum::<f64>(), im.iter().sum::<f64>());
    let norm2: f64 = re.iter().zip(&im).map(|(r, i)| r * r + i * i).sum();
    let damping = sum_re.hypot(sum_im) * a / (2.0 * norm2 * omega * omega);
    // Shape: project onto the phase of the largest response, normalise to magnitude 1.
    let jmax = (0..N_POINTS).max_by(|&i, &j| re[i].hypot(im[i]).total_cmp(&re[j].hypot(im[j]))).unwrap_or(mid);
    let (pr, pi) = (re[jmax], im[jmax]);
    let pn = pr.hypot(pi).max(f64::MIN_POSITIVE);
    let shape = (0..N_POINTS).map(|j| (re[j] * pr + im[j] * pi) / (pn * pn)).collect();
    Ok(EnmaPoint {
        run,
        level_m_s2: a,
        amplitude_h: amp_mid / model.params.thickness_m,
        frequency_hz: omega / (2.0 * std::f64::consts::PI),
        damping_ratio: damping,
        phase_error_rad,
        third_harmonic_ratio: third / amp_mid.max(f64::MIN_POSITIVE),
        settle_time_s,
        converged,
        x_m: x_pts.to_vec(),
        response_re_m: re,
        response_im_m: im,
        shape,
    })
}

/// Single-mode backbone of docs/model.md §9: ω̃(ã) = √(ω² + ¾ b* ã²) [rad/s], with ω the linear
/// frequency of mode 1 (including a preload, Rayleigh quotient) and b* of the model.
pub fn backbone_rad_s(model: &Model, amplitude_h: f64) -> f64 {
    let b = &model.beam;
    let w2 = b.omega[0].powi(2) + b.preload_n * b.k[0];
    crate::physics::Beam::backbone_omega2(w2, b.b_star(model.params.thickness_m), amplitude_h, 1.0).sqrt()
}

/// The backbone ω̃² = (ω² + ¾ b a²)/M₁ (docs/model.md §9, [`crate::Beam::backbone_omega2`]) at each
/// amplitude of `amplitude`: the curve a backbone fit draws.
pub fn backbone_omega2(omega2: f64, b: f64, amplitude: &[f64], m1: f64) -> Vec<f64> {
    amplitude.iter().map(|&a| crate::physics::Beam::backbone_omega2(omega2, b, a, m1)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Params;
    use crate::dynamics::record::NullRecorder;
    use crate::dynamics::simulation::{Excitation, RunOptions, SliderModel, State};

    /// The ENMA integrator at a fixed frequency is the stepper's beam-only model (same scheme,
    /// same forces, preload and amplitude-dependent damping included).
    #[test]
    fn integrator_matches_stepper_beam_only() {
        let p = Params { axial_preload_n: 3.0, damping_ratio_quadratic: 2e-3, ..Params::default() };
        let model = Model::new(p).unwrap();
        let (f, a) = (262.0, 3.0);
        let omega = 2.0 * std::f64::consts::PI * f;
        let mut b = beam_integrator(&model.beam, &model.params).unwrap();
        let steps = 5000;
        let dt = model.params.dt_s;
        for k in 0..steps {
            let t_m = (k as f64 + 0.5) * dt;
            b.step(-a * (omega * t_m).cos()).unwrap();
        }
        let n = model.beam.n;
        let start = State { t_s: 0.0, q: vec![0.0; n], u: vec![0.0; n], slider_q: [0.0; 3], slider_u: [0.0; 3] };
        let opts = RunOptions { model: SliderModel::BeamOnly, duration_s: steps as f64 * dt, ..RunOptions::free(Excitation::new(f, a), 0.0) };
        let r = model.run(&start, &opts, &mut NullRecorder, &mut ()).unwrap();
        let scale = b.q().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(scale > 1e-6);
        for i in 0..n {
            assert!((r.state.q[i] - b.q()[i]).abs() < 1e-9 * scale, "mode {i}: {} vs {}", r.state.q[i], b.q()[i]);
        }
    }
}
