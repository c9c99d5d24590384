//! Moreau's midpoint time-stepping scheme of docs/model.md §5 for the measure differential inclusion
//! M du = h(t, q, u) dt + W dP, specialised at compile time to the number of modes N.

use serde::{Deserialize, Serialize};

use crate::arith::{dot, fma};
use crate::dynamics::solver::{self, ContactMode, LocalProblem};
use crate::params::{ContactSolver, Params};
use crate::physics::beam::Beam;
use crate::physics::contact::{Jacobians, finish, may_close, probe_checked};
use crate::physics::excitation::{BaseState, Excitation};
use crate::physics::slider::{DIM, MAX_CLOSED, N_CONTACTS, Slider, ZETA_Z};

/// Counters of a run, reported with every result (and, without `max_residual`, in every row of a
/// map or study results file).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Counters {
    /// Time steps taken.
    pub steps: u64,
    /// Steps with at least one closed contact.
    pub contact_steps: u64,
    /// Steps by number of closed contacts (0..=4).
    pub closed_histogram: [u64; 5],
    /// Gauss–Seidel sweeps in total (reference solver, or fast solver's fallback).
    pub solver_iterations: u64,
    /// Largest number of sweeps in one step.
    pub max_iterations: u32,
    /// Steps in which the Gauss–Seidel iteration cap was hit.
    pub cap_hits: u64,
    /// Fast solver: steps where the previous pattern was right at once.
    pub first_guess_hits: u64,
    /// Fast solver: linear solves in total.
    pub linear_solves: u64,
    /// Fast solver: steps that needed the enumeration of all patterns.
    pub enumerations: u64,
    /// Fast solver: steps where no pattern fitted and Gauss–Seidel was used.
    pub fallbacks: u64,
    /// Largest natural-map residual of the local contact laws over the run (only computed
    /// when auditing is on; see [`crate::dynamics::solver::LocalProblem::residual`]). Not written to results
    /// rows (maps do not audit; a saved end state keeps it with its state).
    #[serde(skip)]
    pub max_residual: f64,
}

impl Counters {
    /// Add another run's counters.
    pub fn add(&mut self, o: &Counters) {
        self.steps += o.steps;
        self.contact_steps += o.contact_steps;
        for i in 0..5 {
            self.closed_histogram[i] += o.closed_histogram[i];
        }
        self.solver_iterations += o.solver_iterations;
        self.max_iterations = self.max_iterations.max(o.max_iterations);
        self.cap_hits += o.cap_hits;
        self.first_guess_hits += o.first_guess_hits;
        self.linear_solves += o.linear_solves;
        self.enumerations += o.enumerations;
        self.fallbacks += o.fallbacks;
        self.max_residual = self.max_residual.max(o.max_residual);
    }
}

/// Everything the stepper carries from one step to the next besides the state (q, u): the
/// warm-start percussions of the reference solver (docs/model.md §5), the last contact pattern of the
/// fast solver, the last percussions, the counters and the phase of the excitation clock.
/// Restoring it with [`Stepper::restore`] makes a run continued from a saved state bitwise the
/// run that never stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperMemory {
    /// Warm-start percussion (P_N, P_T) of each contact.
    pub warm: [[f64; 2]; N_CONTACTS],
    /// Last contact pattern of each contact (0 open, 1 stick, 2 slide +, 3 slide −).
    pub modes: [u8; N_CONTACTS],
    /// Percussions of the last step.
    pub last_p: [[f64; 2]; N_CONTACTS],
    /// Counters so far.
    pub counters: Counters,
    /// Excitation clock: (cos Ωt, sin Ωt) of the next midpoint, the last midpoint time, and
    /// the steps since the last re-synchronisation.
    pub clock: [f64; 3],
    /// Steps since the clock's last re-synchronisation.
    pub clock_count: u32,
}

fn mode_code(m: ContactMode) -> u8 {
    match m {
        ContactMode::Open => 0,
        ContactMode::Stick => 1,
        ContactMode::SlidePos => 2,
        ContactMode::SlideNeg => 3,
    }
}

fn mode_of(c: u8) -> ContactMode {
    match c {
        0 => ContactMode::Open,
        2 => ContactMode::SlidePos,
        3 => ContactMode::SlideNeg,
        _ => ContactMode::Stick,
    }
}

/// Where the contact kinematics take the slider's horizontal position from (docs/model.md §6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kinematics {
    /// Free slider: x_C itself.
    Free,
    /// Pseudo-constrained slider: the prescribed x = s·L [m].
    Fixed(f64),
    /// Beam only: no contacts, the slider is not integrated.
    BeamOnly,
}

/// State with N modes in fixed-size arrays.
#[derive(Debug, Clone, Copy)]
pub struct StateN<const N: usize> {
    /// Modal coordinates q.
    pub qb: [f64; N],
    /// Modal velocities.
    pub ub: [f64; N],
    /// Slider coordinates (x_C, z_C, β).
    pub qs: [f64; 3],
    /// Slider velocities.
    pub us: [f64; 3],
}

/// Why a step could not be completed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepFault {
    /// A contact point lies outside the free length [0, L] (position x [m]).
    LeftBeam(f64),
    /// The state became non-finite.
    NonFinite,
}

/// The time stepper for N modes.
pub struct Stepper<'a, const N: usize> {
    beam: &'a Beam,
    slider: Slider,
    omega2: [f64; N],
    damp: [f64; N],
    gamma: [f64; N],
    kmat: [[f64; N]; N],
    half_kax: f64,
    /// Axial preload H₀ [N].
    preload: f64,
    /// Amplitude-dependent damping (D₂ > 0): 8 D₂ ωₙ / h² per mode and φₙ(L/2).
    damp2: Option<([f64; N], [f64; N])>,
    dt: f64,
    eps_n: f64,
    /// g cos α: gravity across the beam [m/s²].
    gravity: f64,
    /// g sin α: gravity along the beam (frame tilt α) [m/s²]; used only when non-zero.
    gravity_x: f64,
    inv_m: f64,
    inv_j: f64,
    solver: ContactSolver,
    tol_rel: f64,
    tol_abs: f64,
    max_iter: u32,
    base: Excitation,
    /// Ω = 2π f_ex [rad/s].
    omega: f64,
    /// a/Ω², −a/Ω, −a: amplitudes of w₀, ẇ₀, ẅ₀.
    base_amp: [f64; 3],
    kin: Kinematics,
    /// Last percussion of each contact (warm start of the reference solver).
    warm: [[f64; 2]; N_CONTACTS],
    /// Last pattern of each contact (first guess of the exact solver).
    modes: [ContactMode; N_CONTACTS],
    /// Percussions of the last step per contact (0 when open) [N s].
    pub last_p: [[f64; 2]; N_CONTACTS],
    /// Counters.
    pub counters: Counters,
    /// Check every local solution against the contact laws (costs time; for tests).
    pub audit: bool,
    /// Scratch: W and w̃ of the closed contacts of the current step.
    jac: Jacobians<N>,
    /// Bound of |φₘ'| per mode (for skipping surely-open points).
    slope_bound: [f64; N],
    /// Scratch: the local problem of the current step.
    prob: LocalProblem,
    /// Phasor of the excitation at the next midpoint.
    clock: Clock,
}

/// (cos Ωt, sin Ωt) at successive midpoints by rotation, re-synchronised with the exact values
/// every [`Clock::RESYNC`] steps and whenever the caller's time does not follow on (error ≲ 1e-14).
#[derive(Debug, Clone, Copy)]
struct Clock {
    omega: f64,
    dt: f64,
    rot: (f64, f64),
    prev_t: f64,
    cs: (f64, f64),
    count: u32,
}

impl Clock {
    const RESYNC: u32 = 256;

    fn new(omega: f64, dt: f64) -> Clock {
        let (s, c) = (omega * dt).sin_cos();
        Clock { omega, dt, rot: (c, s), prev_t: f64::NAN, cs: (1.0, 0.0), count: 0 }
    }

    /// (cos Ωt, sin Ωt) at t = t_M of a step.
    #[inline(always)]
    fn at(&mut self, t: f64) -> (f64, f64) {
        if !((t - self.prev_t - self.dt).abs() <= 1e-6 * self.dt) || self.count >= Self::RESYNC {
            let (s, c) = (self.omega * t).sin_cos();
            self.cs = (c, s);
            self.count = 0;
        }
        let (c, s) = self.cs;
        let (rc, rs) = self.rot;
        self.cs = (fma(c, rc, -(s * rs)), fma(s, rc, c * rs));
        self.count += 1;
        self.prev_t = t;
        (c, s)
    }
}

/// sin β and cos β; Taylor series for the small angles the slider has (|β| < 0.1, error
/// below 1e-17), libm otherwise. The series are polynomials in y = β², evaluated by Estrin's
/// scheme with fused multiply-adds (short dependency chain: the contact points wait for them).
#[inline(always)]
fn sin_cos_small(b: f64) -> (f64, f64) {
    if b.abs() < 0.1 {
        let y = b * b;
        let y2 = y * y;
        // sin β = β (1 + s₁y + s₂y² + s₃y³ + s₄y⁴), sₖ = (−1)ᵏ/(2k+1)!.
        let s_lo = fma(y, -1.0 / 6.0, 1.0);
        let s_hi = fma(y2, 1.0 / 362880.0, fma(y, -1.0 / 5040.0, 1.0 / 120.0));
        let s = b * fma(y2, s_hi, s_lo);
        // cos β = 1 + c₁y + … + c₅y⁵, cₖ = (−1)ᵏ/(2k)!.
        let c_lo = fma(y, -0.5, 1.0);
        let c_mid = fma(y, -1.0 / 720.0, 1.0 / 24.0);
        let c_hi = fma(y, -1.0 / 3628800.0, 1.0 / 40320.0);
        let c = fma(y2, fma(y2, c_hi, c_mid), c_lo);
        (s, c)
    } else {
        b.sin_cos()
    }
}

/// The fault of a free slider with a contact point off the beam: the first such point in the
/// order 0, 1, 3, 2 (kept out of line: it ends the run).
#[cold]
#[inline(never)]
fn left_beam(xp: &[f64; N_CONTACTS], length: f64) -> StepFault {
    for i in [0, 1, 3, 2] {
        let x_p = xp[i];
        if !(x_p >= 0.0 && x_p <= length) {
            // Far beyond the beam within one step: a blow-up, not a slider leaving the beam.
            let plausible = x_p.abs() <= 2.0 * length;
            return if plausible { StepFault::LeftBeam(x_p) } else { StepFault::NonFinite };
        }
    }
    StepFault::NonFinite
}

impl<'a, const N: usize> Stepper<'a, N> {
    /// Stepper for the given beam (with N modes), parameters, excitation and kinematics.
    pub fn new(beam: &'a Beam, p: &Params, base: Excitation, kin: Kinematics) -> Self {
        let omega = base.omega_rad_s();
        assert_eq!(beam.n, N, "stepper specialised for the wrong number of modes");
        let mut omega2 = [0.0; N];
        let mut damp = [0.0; N];
        let mut gamma = [0.0; N];
        let mut kmat = [[0.0; N]; N];
        for i in 0..N {
            omega2[i] = beam.omega[i] * beam.omega[i];
            damp[i] = 2.0 * p.damping_ratio * beam.omega[i];
            gamma[i] = beam.gamma[i];
            for j in 0..N {
                kmat[i][j] = beam.k[i * N + j];
            }
        }
        Stepper {
            beam,
            slider: Slider::new(p),
            omega2,
            damp,
            gamma,
            kmat,
            half_kax: 0.5 * beam.k_ax,
            preload: beam.preload_n,
            damp2: (p.damping_ratio_quadratic > 0.0).then(|| {
                let h2 = p.thickness_m * p.thickness_m;
                (std::array::from_fn(|i| 8.0 * p.damping_ratio_quadratic * beam.omega[i] / h2), std::array::from_fn(|i| beam.phi_exact(i, 0.5 * p.length_m)))
            }),
            dt: p.dt_s,
            eps_n: p.restitution,
            // cos 0 = 1 exactly, so a level frame keeps g bit for bit.
            gravity: p.gravity_m_s2 * p.tilt_rad.cos(),
            gravity_x: p.gravity_m_s2 * p.tilt_rad.sin(),
            inv_m: 1.0 / p.slider_mass_kg,
            inv_j: 1.0 / p.slider_inertia_kg_m2,
            solver: p.contact_solver,
            tol_rel: p.solver_tol_rel,
            tol_abs: p.solver_tol_abs,
            max_iter: p.solver_max_iter.min(u32::MAX as usize) as u32,
            base,
            omega,
            base_amp: [base.a_ex_m_s2 / (omega * omega), -base.a_ex_m_s2 / omega, -base.a_ex_m_s2],
            kin,
            warm: [[0.0; 2]; N_CONTACTS],
            modes: [ContactMode::Stick; N_CONTACTS],
            last_p: [[0.0; 2]; N_CONTACTS],
            counters: Counters::default(),
            audit: false,
            jac: Jacobians::EMPTY,
            slope_bound: std::array::from_fn(|m| beam.slope_bound[m]),
            prob: LocalProblem::new(0, p.friction_coefficient),
            clock: Clock::new(omega, p.dt_s),
        }
    }

    /// What the stepper carries between steps (see [`StepperMemory`]).
    pub fn memory(&self) -> StepperMemory {
        StepperMemory {
            warm: self.warm,
            modes: self.modes.map(mode_code),
            last_p: self.last_p,
            counters: self.counters,
            clock: [self.clock.cs.0, self.clock.cs.1, self.clock.prev_t],
            clock_count: self.clock.count,
        }
    }

    /// Continue from a saved [`StepperMemory`] (of a stepper with the same model and excitation).
    pub fn restore(&mut self, m: &StepperMemory) {
        self.warm = m.warm;
        self.modes = m.modes.map(mode_of);
        self.last_p = m.last_p;
        self.counters = m.counters;
        self.clock.cs = (m.clock[0], m.clock[1]);
        self.clock.prev_t = m.clock[2];
        self.clock.count = m.clock_count;
    }

    /// Beam part of docs/model.md §5 step 3 (the beam has no mass matrix to invert): the velocity
    /// u_B + Δt h(t_M, q_M, u_B) with −h = 2Dω u_B + ω² q_M + ((k_ax/2) q_MᵀKq_M + H₀) K q_M + γ ẅ₀
    /// (docs/model.md §2 and the preload), plus the amplitude-dependent damping 8 D₂ ωₙ (w(L/2)/h)² uₙ.
    /// The one place where the beam's forces are written: every stepping path goes through it.
    #[inline(always)]
    fn beam_free_velocity(&self, qm: &[f64; N], ub: &[f64; N], w0_ddot: f64) -> [f64; N] {
        let dt = self.dt;
        // K q_M, accumulated column by column (K is symmetric: row j = column j), in the same
        // order j = 0..N for every entry.
        let mut kq: [f64; N] = std::array::from_fn(|i| self.kmat[0][i] * qm[0]);
        for j in 1..N {
            for i in 0..N {
                kq[i] = fma(self.kmat[j][i], qm[j], kq[i]);
            }
        }
        let fnl = fma(self.half_kax, dot(qm, &kq), self.preload);
        // u_free = u_B + M⁻¹ h_M Δt with −h = D u_B + Ω² q_M + F_nl K q_M + γ ẅ₀.
        let mut vb = [0.0; N];
        for i in 0..N {
            let minus_h = fma(self.gamma[i], w0_ddot, fma(fnl, kq[i], fma(self.omega2[i], qm[i], self.damp[i] * ub[i])));
            vb[i] = fma(-dt, minus_h, ub[i]);
        }
        if let Some((d2, phi_mid)) = &self.damp2 {
            // Damping ratio D + 4 D₂ (w(L/2)/h)²: extra force 8 D₂ ωₙ (w/h)² uₙ.
            let w_mid = dot(phi_mid, qm);
            let w2 = w_mid * w_mid;
            for i in 0..N {
                vb[i] = fma(-dt * d2[i] * w2, ub[i], vb[i]);
            }
        }
        vb
    }

    /// One beam-only step (no slider) from (q_B, u_B) with the base acceleration ẅ₀ at the
    /// midpoint given by the caller: q_M = q_B + Δt/2 u_B, u_E = [`Self::beam_free_velocity`],
    /// q_E = q_M + Δt/2 u_E. The virtual ENMA drives the beam this way with its phase-locked
    /// excitation; [`Self::step`] takes the same path for [`Kinematics::BeamOnly`].
    #[inline]
    pub fn step_beam(&mut self, s: &mut StateN<N>, w0_ddot: f64) -> Result<(), StepFault> {
        let half = 0.5 * self.dt;
        let qm: [f64; N] = std::array::from_fn(|i| fma(half, s.ub[i], s.qb[i]));
        s.ub = self.beam_free_velocity(&qm, &s.ub, w0_ddot);
        for i in 0..N {
            s.qb[i] = fma(half, s.ub[i], qm[i]);
        }
        self.counters.steps += 1;
        if s.ub.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(StepFault::NonFinite) }
    }

    /// One step from t_B to t_B + Δt (docs/model.md §5, steps 1–4).
    #[inline(always)]
    pub fn step(&mut self, s: &mut StateN<N>, t_b: f64) -> Result<(), StepFault> {
        let dt = self.dt;
        let half = 0.5 * dt;
        // 1. Midpoint.
        let t_m = t_b + half;
        let qm: [f64; N] = std::array::from_fn(|i| fma(half, s.ub[i], s.qb[i]));
        let qsm: [f64; 3] = std::array::from_fn(|i| fma(half, s.us[i], s.qs[i]));
        let (w0, w0_dot, w0_ddot) = if self.omega == 0.0 {
            self.base.at(t_m)
        } else {
            // w₀ = (a/Ω²) cos Ωt, ẇ₀ = −(a/Ω) sin Ωt, ẅ₀ = −a cos Ωt.
            let (c, sn) = self.clock.at(t_m);
            let [a0, a1, a2] = self.base_amp;
            (a0 * c, a1 * sn, a2 * c)
        };
        // h_M: beam forces (damping with u_B) and slider gravity.
        let mut vb = self.beam_free_velocity(&qm, &s.ub, w0_ddot);
        self.counters.steps += 1;
        self.last_p = [[0.0; 2]; N_CONTACTS];
        if matches!(self.kin, Kinematics::BeamOnly) {
            s.ub = vb;
            for i in 0..N {
                s.qb[i] = fma(half, s.ub[i], qm[i]);
            }
            return if s.ub.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(StepFault::NonFinite) };
        }
        // h_M of the slider: m (g sin α, −g cos α, 0) (docs/model.md §3, frame tilt α).
        let vs0 = if self.gravity_x != 0.0 { fma(dt, self.gravity_x, s.us[0]) } else { s.us[0] };
        let mut vs = [vs0, fma(-dt, self.gravity, s.us[1]), s.us[2]];

        // 2. Contact kinematics at (t_M, q_M).
        let x_kin = match self.kin {
            Kinematics::Fixed(x) => x,
            _ => qsm[0],
        };
        let (sin_b, cos_b) = sin_cos_small(qsm[2]);
        let base = BaseState { w0, w0_dot };
        let (xp, zp) = self.slider.points(x_kin, qsm[1], sin_b, cos_b);
        // Are all four points on the beam, 0 ≤ x ≤ L? (Evaluated without short-circuit, so that
        // it vectorises.) The free slider must stay on it; then the mode table needs no range
        // checks.
        let mut on_beam = true;
        for x in xp {
            on_beam &= (x >= 0.0) & (x <= self.beam.length_m);
        }
        if !on_beam && matches!(self.kin, Kinematics::Free) {
            return Err(left_beam(&xp, self.beam.length_m));
        }
        // The four points in pairs (top, bottom) on each side. The bottom point of a pair is
        // only evaluated when it may touch: |w(x_bottom) − w(x_top)| ≤ |Δx| Σ|qₘ| max|φₘ'|,
        // so a pre-check that fails for every w in that range skips it (exactly the same outcome).
        // Closed contacts are numbered in the order of docs/model.md §3 (counter-clockwise from
        // top-left: 0, 1, 2, 3), so the right pair's top point 3 is finished last.
        let hh = self.slider.half_thickness;
        let mut slope = 0.0;
        for m in 0..N {
            slope = fma(qm[m].abs(), self.slope_bound[m], slope);
        }
        let beam = self.beam;
        let slider = &self.slider;
        let jac = &mut self.jac;
        let mut k = 0;
        // (The slope bound holds inside the mode table, which covers the beam.)
        let may_touch = |top: usize, bottom: usize, w_top: f64| {
            let margin = (xp[bottom] - xp[top]).abs() * slope * 1.000001 + 1e-15;
            let surely_open = on_beam && ZETA_Z[bottom] * (zp[bottom] - w0 - w_top) - margin - hh >= 1e-5 * hh;
            !surely_open
        };
        // SAFETY: on_beam says 0 ≤ x ≤ L for all four points.
        let probe = |i: usize| unsafe { probe_checked::<N>(beam, on_beam, xp[i], zp[i], &qm) };
        // Left pair: 0 (top), 1 (bottom).
        let p0 = probe(0);
        if may_close(0, p0.z_p, w0, p0.w, hh) && finish::<N>(beam, slider, 0, &p0, sin_b, cos_b, &qm, base, jac, k) {
            k += 1;
        }
        if may_touch(0, 1, p0.w) {
            let p1 = probe(1);
            if may_close(1, p1.z_p, w0, p1.w, hh) && finish::<N>(beam, slider, 1, &p1, sin_b, cos_b, &qm, base, jac, k) {
                k += 1;
            }
        }
        // Right pair: 3 (top), 2 (bottom).
        let p3 = probe(3);
        if may_touch(3, 2, p3.w) {
            let p2 = probe(2);
            if may_close(2, p2.z_p, w0, p2.w, hh) && finish::<N>(beam, slider, 2, &p2, sin_b, cos_b, &qm, base, jac, k) {
                k += 1;
            }
        }
        if may_close(3, p3.z_p, w0, p3.w, hh) && finish::<N>(beam, slider, 3, &p3, sin_b, cos_b, &qm, base, jac, k) {
            k += 1;
        }
        self.counters.closed_histogram[k] += 1;
        match k {
            // 3. No contact: u_E = u_B + M⁻¹ h_M Δt.
            0 => {}
            1 => self.contact_phase::<1>(s, &mut vb, &mut vs),
            2 => self.contact_phase::<2>(s, &mut vb, &mut vs),
            3 => self.contact_phase::<3>(s, &mut vb, &mut vs),
            _ => self.contact_phase::<4>(s, &mut vb, &mut vs),
        }
        s.ub = vb;
        s.us = vs;
        // 4. q_E = q_M + (Δt/2) u_E.
        for i in 0..N {
            s.qb[i] = fma(half, s.ub[i], qm[i]);
        }
        for i in 0..3 {
            s.qs[i] = fma(half, s.us[i], qsm[i]);
        }
        let check: f64 = s.ub.iter().sum::<f64>() + s.us.iter().sum::<f64>();
        if check.is_finite() { Ok(()) } else { Err(StepFault::NonFinite) }
    }
    /// Step 3 with the K closed contacts of `self.jac`: Delassus matrix, free velocity term,
    /// local solve, and u_E = u_free + M⁻¹ W P written into (vb, vs).
    #[inline(always)]
    fn contact_phase<const K: usize>(&mut self, s: &StateN<N>, vb: &mut [f64; N], vs: &mut [f64; 3]) {
        self.counters.contact_steps += 1;
        let jac = &self.jac;
        let prob = &mut self.prob;
        prob.k = K;
        let nc = 2 * K;
        // M⁻¹ W, slider part (the beam's modal mass matrix is the identity).
        let minv_s = [self.inv_m, self.inv_m, self.inv_j];
        let mut ys = [[0.0; DIM]; 3];
        for m in 0..3 {
            for a in 0..nc {
                ys[m][a] = jac.slider[m][a] * minv_s[m];
            }
        }
        // c = (I + E)(Wᵀ u_B + w̃) + Wᵀ M⁻¹ h_M Δt = Wᵀ u_free + w̃ + E (Wᵀ u_B + w̃), E = diag(ε_N, 0),
        // with Wᵀ u = Σ_m u_m (row m of W).
        // Beam and slider parts summed separately (two short chains), then added.
        let mut wu_b = jac.wtilde;
        let mut wu_f = jac.wtilde;
        for m in 0..N {
            for a in 0..nc {
                wu_b[a] = fma(jac.beam[m][a], s.ub[m], wu_b[a]);
                wu_f[a] = fma(jac.beam[m][a], vb[m], wu_f[a]);
            }
        }
        let mut su_b = [0.0; DIM];
        let mut su_f = [0.0; DIM];
        for a in 0..nc {
            su_b[a] = jac.slider[0][a] * s.us[0];
            su_f[a] = jac.slider[0][a] * vs[0];
        }
        for m in 1..3 {
            for a in 0..nc {
                su_b[a] = fma(jac.slider[m][a], s.us[m], su_b[a]);
                su_f[a] = fma(jac.slider[m][a], vs[m], su_f[a]);
            }
        }
        // The frame's normalisation of each column (see `Jacobians`).
        let mut col_scale = [0.0; DIM];
        for a in 0..nc {
            col_scale[a] = jac.scale[a / 2];
        }
        // (ε_T = 0: the tangential rows add 0 · (Wᵀ u_B + w̃), which leaves them unchanged; written
        // for all rows alike so that they vectorise.)
        for a in 0..nc {
            let e = if a % 2 == 0 { self.eps_n } else { 0.0 };
            prob.c[a] = col_scale[a] * fma(e, wu_b[a] + su_b[a], wu_f[a] + su_f[a]);
        }
        // G = Wᵀ M⁻¹ W = Σ_m (row m)ᵀ (M⁻¹ row m): gt[b][a] = G_ab accumulated over the modes, then
        // the slider coordinates; its lower triangle (a ≥ b) is mirrored.
        // (Beam and slider parts accumulated separately, then added: two short chains.)
        let mut gt = [[0.0; DIM]; DIM];
        let mut gs = [[0.0; DIM]; DIM];
        for b in 0..nc {
            for a in 0..nc {
                gt[b][a] = jac.beam[0][a] * jac.beam[0][b];
                gs[b][a] = jac.slider[0][a] * ys[0][b];
            }
        }
        for m in 1..N {
            let x = &jac.beam[m];
            for b in 0..nc {
                for a in 0..nc {
                    gt[b][a] = fma(x[a], x[b], gt[b][a]);
                }
            }
        }
        for m in 1..3 {
            let x = &jac.slider[m];
            for b in 0..nc {
                for a in 0..nc {
                    gs[b][a] = fma(x[a], ys[m][b], gs[b][a]);
                }
            }
        }
        for b in 0..nc {
            for a in 0..nc {
                gt[b][a] = (gt[b][a] + gs[b][a]) * col_scale[a] * col_scale[b];
            }
        }
        // Row b of G gets column b of gt (right on and above the diagonal: G_ba = G_ab for a ≥ b);
        // the entries below the diagonal are then mirrored. (All lanes of gt are used, so that its
        // accumulation stays in whole vectors.)
        for b in 0..nc {
            prob.g[b][..nc].copy_from_slice(&gt[b][..nc]);
        }
        for b in 0..nc {
            for a in b + 1..nc {
                prob.g[a][b] = gt[b][a];
            }
        }
        let index: [usize; K] = std::array::from_fn(|j| jac.index[j]);
        let mut p = [0.0; DIM];
        let info = match self.solver {
            ContactSolver::Reference => {
                for j in 0..K {
                    p[2 * j] = self.warm[index[j]][0];
                    p[2 * j + 1] = self.warm[index[j]][1];
                }
                solver::gauss_seidel(prob, &mut p, self.tol_rel, self.tol_abs, self.max_iter)
            }
            ContactSolver::Fast => {
                let mut modes = [ContactMode::Stick; MAX_CLOSED];
                for j in 0..K {
                    modes[j] = self.modes[index[j]];
                }
                let info = solver::exact_k::<K>(prob, &mut modes, &mut p, self.max_iter);
                for j in 0..K {
                    self.modes[index[j]] = modes[j];
                }
                info
            }
        };
        if self.audit {
            self.counters.max_residual = self.counters.max_residual.max(prob.residual(&p));
        }
        let c = &mut self.counters;
        c.solver_iterations += info.iterations as u64;
        c.max_iterations = c.max_iterations.max(info.iterations);
        c.cap_hits += info.capped as u64;
        c.first_guess_hits += info.first_guess as u64;
        c.linear_solves += info.linear_solves as u64;
        c.enumerations += info.enumerated as u64;
        c.fallbacks += info.fallback as u64;
        // u_E = u_free + M⁻¹ W P, contact by contact (W P = W_stored (scale · P)).
        for j in 0..K {
            let (pn, pt) = (p[2 * j], p[2 * j + 1]);
            self.warm[index[j]] = [pn, pt];
            self.last_p[index[j]] = [pn, pt];
        }
        for a in 0..nc {
            p[a] *= col_scale[a];
        }
        let jac = &self.jac;
        for m in 0..N {
            let x = &jac.beam[m];
            for j in 0..K {
                vb[m] = fma(x[2 * j + 1], p[2 * j + 1], fma(x[2 * j], p[2 * j], vb[m]));
            }
        }
        for m in 0..3 {
            for j in 0..K {
                vs[m] = fma(ys[m][2 * j + 1], p[2 * j + 1], fma(ys[m][2 * j], p[2 * j], vs[m]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_angle_sin_cos_match_libm() {
        for k in -2000..=2000 {
            let b = k as f64 * 0.099999 / 2000.0 + 1e-7 * (k as f64).sin();
            let (s, c) = sin_cos_small(b);
            let (s0, c0) = b.sin_cos();
            assert!((s - s0).abs() <= 2.0 * f64::EPSILON * s0.abs(), "sin({b}): {s} vs {s0}");
            assert!((c - c0).abs() <= 2.0 * f64::EPSILON, "cos({b}): {c} vs {c0}");
        }
        assert_eq!(sin_cos_small(0.3), 0.3f64.sin_cos());
    }
}
