//! Runs of the free-slider (FS), pseudo-constrained (PCS) and beam-only models (docs/model.md §5–6):
//! initial states, the time loop with recording, status on faults, cancellation and progress.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::dynamics::record::{Channel, Recorder};
use crate::dynamics::stepper::{Counters, Kinematics, StateN, StepFault, Stepper, StepperMemory};
use crate::error::{Error, Result};
use crate::params::{Params, ParamsArg, Valid};
use crate::physics::beam::Beam;
pub use crate::physics::excitation::Excitation;
use crate::physics::slider::Slider;

/// Most time steps of one run (10¹¹: days of computing at the fastest step rate); a longer
/// duration is a typing error, refused before the run (docs/model.md §5).
pub const MAX_STEPS: u64 = 100_000_000_000;

/// The number of time steps of a `duration_s`-second run at `dt_s`, round(duration/dt), checked:
/// an error naming `field`, its value and the limit when it is not finite or exceeds [`MAX_STEPS`].
pub fn step_count(field: &str, duration_s: f64, dt_s: f64) -> Result<u64> {
    let steps = (duration_s / dt_s).round();
    if !(duration_s.is_finite() && duration_s >= 0.0 && steps.is_finite() && steps >= 0.0) {
        return Err(Error::invalid(field, duration_s, "must be finite and >= 0"));
    }
    if steps > MAX_STEPS as f64 {
        return Err(Error::invalid(
            field,
            duration_s,
            &format!("{steps:.3e} time steps of dt = {dt_s:e} s, more than the limit of {MAX_STEPS:.0e} ({:.3e} s)", MAX_STEPS as f64 * dt_s),
        ));
    }
    Ok(steps as u64)
}

/// Which model to integrate (docs/model.md §6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SliderModel {
    /// Free slider.
    Free,
    /// Pseudo-constrained slider: contact kinematics at the prescribed s (x = s·L).
    PseudoConstrained {
        /// Relative slider position s [-].
        s: f64,
    },
    /// The beam alone (no slider, no contact).
    BeamOnly,
}

/// Full state of the system at time t.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct State {
    /// Time t [s].
    pub t_s: f64,
    /// Modal coordinates q₁..q_N.
    pub q: Vec<f64>,
    /// Modal velocities.
    pub u: Vec<f64>,
    /// Slider (x_C [m], z_C [m], β [rad]).
    pub slider_q: [f64; 3],
    /// Slider velocities.
    pub slider_u: [f64; 3],
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status {
    /// The requested duration was simulated.
    Completed,
    /// A contact point of the free slider left the free length of the beam.
    LeftBeam {
        /// Time of the step that found it [s].
        t_s: f64,
        /// x of the offending contact point [m].
        x_m: f64,
    },
    /// The state blew up (non-finite, or the slider no longer around the beam).
    Diverged {
        /// Time at which it was detected [s].
        t_s: f64,
    },
    /// The monitor asked to stop.
    Interrupted {
        /// Time reached [s].
        t_s: f64,
    },
}

impl Status {
    /// Short name: completed, left_beam, diverged, interrupted.
    pub fn name(&self) -> &'static str {
        match self {
            Status::Completed => "completed",
            Status::LeftBeam { .. } => "left_beam",
            Status::Diverged { .. } => "diverged",
            Status::Interrupted { .. } => "interrupted",
        }
    }

    /// A sentence for the user.
    pub fn message(&self) -> String {
        match self {
            Status::Completed => "completed".into(),
            Status::LeftBeam { t_s, x_m } => {
                format!("stopped at t = {t_s:.6} s: a contact point of the slider left the free length of the beam (x = {x_m:.6} m)")
            }
            Status::Diverged { t_s } => {
                format!("stopped at t = {t_s:.6} s: the state blew up (non-finite values or the slider left the beam); try a smaller dt_s")
            }
            Status::Interrupted { t_s } => format!("interrupted at t = {t_s:.6} s"),
        }
    }
}

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Excitation.
    pub excitation: Excitation,
    /// Model.
    pub model: SliderModel,
    /// Simulated duration from the start state [s].
    pub duration_s: f64,
    /// Record every k-th step (the start state is row 0).
    pub record_every: usize,
    /// Channels to record.
    pub channels: Vec<Channel>,
    /// Check every local contact solution against the contact laws (counters.max_residual).
    pub audit_contacts: bool,
}

impl RunOptions {
    /// Free-slider run with the default channels, recording every 10th step.
    pub fn free(excitation: Excitation, duration_s: f64) -> Self {
        RunOptions { excitation, model: SliderModel::Free, duration_s, record_every: 10, channels: Channel::defaults(), audit_contacts: false }
    }
}

/// Result of a run (the recorded rows went to the recorder).
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// How it ended.
    pub status: Status,
    /// Final state (the last good one when the run stopped on a fault).
    pub state: State,
    /// Solver and contact counters.
    pub counters: Counters,
}

/// A run's state after a number of steps, with everything needed to continue it bitwise as if
/// it had never stopped: the state, the step index counted from the run's start time
/// `t_origin_s` (time = t_origin_s + step·Δt, computed as in the uninterrupted run), and the
/// stepper's memory (warm start, contact patterns, counters, excitation clock).
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Start time of the run [s] (0 for a run from rest).
    pub t_origin_s: f64,
    /// Steps taken since `t_origin_s`.
    pub step: u64,
    /// The state after `step` steps.
    pub state: State,
    /// The stepper's memory after `step` steps.
    pub memory: StepperMemory,
}

/// Polled every few thousand steps; return `false` to interrupt the run.
pub trait Monitor {
    /// `t_s` reached so far of `t_end_s`.
    fn poll(&mut self, t_s: f64, t_end_s: f64) -> bool;

    /// Called once a run's inputs are checked, before its first step ([`crate::signal::run`]):
    /// a front end names bad input before it writes anything; false stops the run.
    fn start(&mut self) -> bool {
        true
    }
}

impl Monitor for () {
    fn poll(&mut self, _: f64, _: f64) -> bool {
        true
    }
}

/// A cancellation flag as a monitor: the run stops once the flag is set.
pub struct CancelFlag<'a>(pub &'a AtomicBool);

impl Monitor for CancelFlag<'_> {
    fn poll(&mut self, _: f64, _: f64) -> bool {
        !self.0.load(Ordering::Relaxed)
    }
}

/// Steps between two monitor polls.
pub const POLL_EVERY: u64 = 4096;

/// The model: parameters and the precomputed beam.
#[derive(Debug, Clone)]
pub struct Model {
    /// Parameters.
    pub params: Params,
    /// Beam modes.
    pub beam: Beam,
}

impl Model {
    /// Validate the parameters, compute the modes and check that Δt resolves the highest mode.
    pub fn new(params: Params) -> Result<Model> {
        Self::of(&Valid::new(params)?)
    }

    /// The modal data of the model's linear beam (docs/model.md §2, §9), the mode shapes sampled
    /// at `x_over_l`.
    pub fn beam_properties(&self, x_over_l: &[f64]) -> crate::physics::BeamProperties {
        crate::physics::BeamProperties::of(&self.beam, &self.params, x_over_l)
    }

    /// [`Model::new`] of parameters validated before (docs/model.md §1): checks nothing again.
    pub fn of(params: &Valid) -> Result<Model> {
        Self::build(params.get().clone())
    }

    fn build(params: Params) -> Result<Model> {
        let beam = Beam::new(ParamsArg::derived(&params))?;
        // Explicit midpoint (Störmer–Verlet) stability: ω_N Δt < 2.
        let wmax = beam.omega[beam.n - 1];
        if wmax * params.dt_s >= 2.0 {
            return Err(Error::invalid(
                "dt_s",
                params.dt_s,
                &format!(
                    "too large for the highest retained mode ({:.1} Hz): need dt_s < {:.3e} s (ω_N dt < 2)",
                    wmax / (2.0 * std::f64::consts::PI),
                    2.0 / wmax
                ),
            ));
        }
        Ok(Model { params, beam })
    }

    /// Free-slider initial state of docs/model.md §5: beam at rest, x_C = s₀L, z_C = −d + w₀(0), β = 0.
    /// Errors when a contact point would lie outside the beam.
    pub fn initial_state(&self, s0: f64, excitation: &Excitation) -> Result<State> {
        excitation.validate()?;
        let p = &self.params;
        let half = 0.5 * p.contact_spacing_m / p.length_m;
        if !(s0.is_finite() && s0 - half >= 0.0 && s0 + half <= 1.0) {
            return Err(Error::invalid("s0", s0, &format!("the slider's contact points must lie on the beam: {half:.4} <= s0 <= {:.4}", 1.0 - half)));
        }
        Ok(self.at_rest(s0 * p.length_m, excitation))
    }

    /// PCS / manifold initial state: all zero except z_C = −d + w₀(0).
    pub fn initial_state_pcs(&self, excitation: &Excitation) -> Result<State> {
        excitation.validate()?;
        Ok(self.at_rest(0.0, excitation))
    }

    /// Beam and slider at rest at t = 0: q = u = 0, x_C = `x_c_m`, z_C = −d + w₀(0), β = 0.
    fn at_rest(&self, x_c_m: f64, excitation: &Excitation) -> State {
        let (w0, _, _) = excitation.at(0.0);
        let n = self.beam.n;
        State { t_s: 0.0, q: vec![0.0; n], u: vec![0.0; n], slider_q: [x_c_m, -self.params.com_offset_m + w0, 0.0], slider_u: [0.0; 3] }
    }

    /// The initial state of a run of `model` (docs/model.md §5–6): [`Self::initial_state`] at s₀ for
    /// the free slider, [`Self::initial_state_pcs`] for the pseudo-constrained slider and the beam
    /// alone. Every front end starts its runs here.
    pub fn start(&self, model: SliderModel, s0: f64, excitation: &Excitation) -> Result<State> {
        match model {
            SliderModel::Free => self.initial_state(s0, excitation),
            SliderModel::PseudoConstrained { .. } | SliderModel::BeamOnly => self.initial_state_pcs(excitation),
        }
    }

    /// Check a run's inputs without running it (what [`Model::run`] checks first): front ends call
    /// it before they create output files, so that bad input overwrites nothing.
    pub fn check_run(&self, start: &State, opts: &RunOptions) -> Result<()> {
        opts.excitation.validate()?;
        // The excitation period must be resolved by the time step (at least 10 steps).
        if opts.excitation.f_ex_hz * self.params.dt_s > 0.1 {
            return Err(Error::invalid(
                "f_ex_hz",
                opts.excitation.f_ex_hz,
                &format!("too high for dt_s = {:e} s: need f_ex_hz <= {:.6e} (10 steps per period)", self.params.dt_s, 0.1 / self.params.dt_s),
            ));
        }
        if !(opts.duration_s.is_finite() && opts.duration_s >= 0.0) {
            return Err(Error::invalid("duration_s", opts.duration_s, "must be finite and >= 0"));
        }
        step_count("duration_s", opts.duration_s, self.params.dt_s)?;
        if opts.record_every == 0 {
            return Err(Error::invalid("record_every", 0, "must be >= 1"));
        }
        let n = self.beam.n;
        if start.q.len() != n || start.u.len() != n {
            return Err(Error::invalid("state", format!("{} modal coordinates", start.q.len()), &format!("the model has {n} modes")));
        }
        let finite = start.q.iter().chain(&start.u).chain(&start.slider_q).chain(&start.slider_u);
        if !start.t_s.is_finite() || finite.into_iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("state", "non-finite", "all state values must be finite"));
        }
        if let SliderModel::PseudoConstrained { s } = opts.model
            && !(0.0..=1.0).contains(&s)
        {
            return Err(Error::invalid("s_pcs", s, "must lie in [0, 1] (slider position x/L)"));
        }
        for ch in &opts.channels {
            if let Channel::WAt(x) = ch
                && !(0.0..=self.params.length_m).contains(x)
            {
                return Err(Error::invalid("channel w@x", x, "x must lie in [0, length_m]"));
            }
        }
        Ok(())
    }

    /// Integrate from `start` for `opts.duration_s`, streaming rows into `rec`.
    pub fn run(&self, start: &State, opts: &RunOptions, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<RunSummary> {
        self.check_run(start, opts)?;
        Ok(self.dispatch(start, None, opts, rec, monitor)?.0)
    }

    /// As [`Model::run`], and also return the checkpoint at the end of the run (meaningful when
    /// the status is `Completed`).
    pub fn run_checkpointed(&self, start: &State, opts: &RunOptions, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<(RunSummary, Checkpoint)> {
        self.check_run(start, opts)?;
        self.dispatch(start, None, opts, rec, monitor)
    }

    /// Continue a run from a checkpoint until `opts.duration_s` after the run's start time
    /// (`checkpoint.t_origin_s`): the steps, recorded rows (every `opts.record_every`-th step
    /// counted from the start; the checkpoint's own row is not repeated), counters and end state
    /// are bitwise those of the run that went there without stopping, given the same model and
    /// options.
    pub fn run_from(&self, checkpoint: &Checkpoint, opts: &RunOptions, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<(RunSummary, Checkpoint)> {
        self.check_run(&checkpoint.state, opts)?;
        let total = (opts.duration_s / self.params.dt_s).round() as u64;
        if checkpoint.step > total {
            return Err(Error::invalid(
                "duration_s",
                opts.duration_s,
                &format!("the checkpoint is already at step {} (t = {} s)", checkpoint.step, checkpoint.state.t_s),
            ));
        }
        self.dispatch(&checkpoint.state, Some(checkpoint), opts, rec, monitor)
    }

    fn dispatch(
        &self, start: &State, resume: Option<&Checkpoint>, opts: &RunOptions, rec: &mut dyn Recorder, monitor: &mut dyn Monitor,
    ) -> Result<(RunSummary, Checkpoint)> {
        let n = self.beam.n;
        macro_rules! go {
            ($($n:literal)*) => {
                match n {
                    $($n => run_n::<$n>(Run { model: self, start, resume, opts }, rec, monitor),)*
                    _ => Err(Error::invalid("n_modes", n, "must lie in 1..=20")),
                }
            };
        }
        go!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20)
    }
}

fn to_state_n<const N: usize>(s: &State) -> StateN<N> {
    let mut qb = [0.0; N];
    let mut ub = [0.0; N];
    qb.copy_from_slice(&s.q);
    ub.copy_from_slice(&s.u);
    StateN { qb, ub, qs: s.slider_q, us: s.slider_u }
}

fn from_state_n<const N: usize>(s: &StateN<N>, t_s: f64) -> State {
    State { t_s, q: s.qb.to_vec(), u: s.ub.to_vec(), slider_q: s.qs, slider_u: s.us }
}

/// Fills one output row from the state.
struct RowWriter {
    channels: Vec<Channel>,
    phi_4l7: Vec<f64>,
    phi_at: Vec<Vec<f64>>,
    length: f64,
    s_fixed: Option<f64>,
}

impl RowWriter {
    fn fill<const N: usize>(&self, row: &mut Vec<f64>, t: f64, s: &StateN<N>, p: &[[f64; 2]; 4]) {
        row.clear();
        let dot = |phi: &[f64]| phi.iter().zip(&s.qb).map(|(a, b)| a * b).sum::<f64>();
        let mut k_at = 0;
        for ch in &self.channels {
            match ch {
                Channel::Time => row.push(t),
                Channel::W4L7 => row.push(dot(&self.phi_4l7)),
                Channel::WAt(_) => {
                    row.push(dot(&self.phi_at[k_at]));
                    k_at += 1;
                }
                Channel::S => row.push(self.s_fixed.unwrap_or(s.qs[0] / self.length)),
                Channel::XC => row.push(s.qs[0]),
                Channel::ZC => row.push(s.qs[1]),
                Channel::Beta => row.push(s.qs[2]),
                Channel::ModalQ => row.extend_from_slice(&s.qb),
                Channel::ModalU => row.extend_from_slice(&s.ub),
                Channel::SliderU => row.extend_from_slice(&s.us),
                Channel::Percussions => {
                    for c in p {
                        row.extend_from_slice(c);
                    }
                }
            }
        }
    }
}

/// Is the state physically sane? (slider still around the beam, beam deflection bounded).
fn sane<const N: usize>(model: &Model, slider: &Slider, s: &StateN<N>, x_kin: f64, w0: f64) -> bool {
    let l = model.params.length_m;
    let xi = (x_kin / l).clamp(0.0, 1.0) * l;
    let mut phi = [0.0; N];
    for (m, v) in phi.iter_mut().enumerate() {
        *v = model.beam.phi_exact(m, xi);
    }
    let w: f64 = phi.iter().zip(&s.qb).map(|(a, b)| a * b).sum();
    let centre = s.qs[1] + slider.com_offset * s.qs[2].cos();
    let opening = model.params.opening_m();
    w.is_finite() && w.abs() < 0.25 * l && (centre - w0 - w).abs() < 2.0 * opening && s.qs[2].abs() < 0.5
}

/// The inputs of one run, handed from [`Model::dispatch`] to the time loop specialised to N modes.
#[derive(Clone, Copy)]
struct Run<'a> {
    model: &'a Model,
    start: &'a State,
    resume: Option<&'a Checkpoint>,
    opts: &'a RunOptions,
}

static SIMD: AtomicBool = AtomicBool::new(true);

/// Use the AVX2 + FMA build of the time loop where the CPU has it (default: on). Both builds do
/// the same IEEE operations in the same order (fused multiply-adds are correctly rounded either
/// way, see `arith`), so results are bitwise identical; the switch exists for tests and benchmarks.
pub fn set_simd(enabled: bool) {
    SIMD.store(enabled, Ordering::Relaxed);
}

fn run_n<const N: usize>(run: Run<'_>, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<(RunSummary, Checkpoint)> {
    #[cfg(target_arch = "x86_64")]
    {
        if SIMD.load(Ordering::Relaxed) && std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            return unsafe { run_n_avx2::<N>(run, rec, monitor) };
        }
    }
    run_n_generic::<N>(run, rec, monitor)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_n_avx2<const N: usize>(run: Run<'_>, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<(RunSummary, Checkpoint)> {
    run_n_generic::<N>(run, rec, monitor)
}

#[inline(always)]
fn run_n_generic<const N: usize>(run: Run<'_>, rec: &mut dyn Recorder, monitor: &mut dyn Monitor) -> Result<(RunSummary, Checkpoint)> {
    let Run { model, start, resume, opts } = run;
    let p = &model.params;
    let dt = p.dt_s;
    let l = p.length_m;
    let base = opts.excitation;
    let kin = match opts.model {
        SliderModel::Free => Kinematics::Free,
        SliderModel::PseudoConstrained { s } => Kinematics::Fixed(s * l),
        SliderModel::BeamOnly => Kinematics::BeamOnly,
    };
    let mut stepper = Stepper::<N>::new(&model.beam, p, base, kin);
    stepper.audit = opts.audit_contacts;
    // A continued run counts its steps from the original start (t = t0 + k Δt as there).
    let (t0, k0) = match resume {
        Some(c) => {
            stepper.restore(&c.memory);
            (c.t_origin_s, c.step)
        }
        None => (start.t_s, 0),
    };
    let slider = Slider::new(p);
    let writer = RowWriter {
        phi_4l7: model.beam.phi_row(4.0 / 7.0 * l),
        phi_at: opts.channels.iter().filter_map(|c| if let Channel::WAt(x) = c { Some(model.beam.phi_row(*x)) } else { None }).collect(),
        channels: opts.channels.clone(),
        length: l,
        s_fixed: if let SliderModel::PseudoConstrained { s } = opts.model { Some(s) } else { None },
    };
    let names: Vec<String> = opts.channels.iter().flat_map(|c| c.names(N)).collect();
    rec.begin(&names)?;
    let mut row = Vec::with_capacity(names.len());
    let mut st = to_state_n::<N>(start);
    let steps = step_count("duration_s", opts.duration_s, dt)?;
    let t_end = t0 + steps as f64 * dt;
    if resume.is_none() {
        writer.fill(&mut row, t0, &st, &stepper.last_p);
        rec.push(&row)?;
    }
    let every = opts.record_every as u64;
    let mut good = st;
    let mut good_t = start.t_s;
    let mut good_k = k0;
    let mut status = Status::Completed;
    let x_kin_of = |s: &StateN<N>| match kin {
        Kinematics::Fixed(x) => x,
        _ => s.qs[0],
    };
    for k in k0..steps {
        let t_b = t0 + k as f64 * dt;
        match stepper.step(&mut st, t_b) {
            Ok(()) => {}
            Err(StepFault::LeftBeam(x_m)) => {
                status = Status::LeftBeam { t_s: t_b, x_m };
                break;
            }
            Err(StepFault::NonFinite) => {
                status = Status::Diverged { t_s: t_b + dt };
                break;
            }
        }
        let done = k + 1;
        let t = t0 + done as f64 * dt;
        if done % 1024 == 0 && kin != Kinematics::BeamOnly && !sane(model, &slider, &st, x_kin_of(&st), base.at(t).0) {
            status = Status::Diverged { t_s: t };
            break;
        }
        if done % every == 0 {
            writer.fill(&mut row, t, &st, &stepper.last_p);
            rec.push(&row)?;
            good = st;
            good_t = t;
            good_k = done;
        }
        if done % POLL_EVERY == 0 && !monitor.poll(t, t_end) {
            status = Status::Interrupted { t_s: t };
            good = st;
            good_t = t;
            good_k = done;
            break;
        }
        if done == steps {
            good = st;
            good_t = t;
            good_k = done;
        }
    }
    monitor.poll(good_t, t_end);
    let state = from_state_n(&good, good_t);
    let checkpoint = Checkpoint { t_origin_s: t0, step: good_k, state: state.clone(), memory: stepper.memory() };
    Ok((RunSummary { status, state, counters: stepper.counters }, checkpoint))
}
