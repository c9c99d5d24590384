//! Contact kinematics of docs/model.md §4 for one potential contact point: pre-check, contact frame,
//! normal gap, force directions Wᵢ = (∂g/∂q)ᵀ and the gap velocity imposed by the base motion.

use crate::arith::{dot, fma};
use crate::physics::beam::{Beam, Loc};
use crate::physics::excitation::BaseState;
use crate::physics::slider::{DIM, MAX_CLOSED, Slider, ZETA_Z};

/// Kinematics of a closed contact: the two columns (normal, tangential) of W and w̃ (the
/// unit tests' view of one contact; the time loop works on [`Jacobians`]).
#[cfg(test)]
#[derive(Debug, Clone, Copy)]
pub struct ClosedContact<const N: usize> {
    /// Which of the four points (0..4).
    pub index: usize,
    /// Normal gap g_N (< 0 when closed) [m].
    pub gap_n: f64,
    /// Beam part of W: row 0 normal, row 1 tangential.
    pub wb: [[f64; N]; 2],
    /// Slider part of W (x_C, z_C, β): row 0 normal, row 1 tangential.
    pub ws: [[f64; 3]; 2],
    /// Imposed gap velocity w̃ = −A_CN (0, ẇ₀).
    pub wtilde: [f64; 2],
}

#[cfg(test)]
impl<const N: usize> ClosedContact<N> {
    /// Placeholder value (no contact).
    pub const EMPTY: Self = ClosedContact { index: 0, gap_n: 0.0, wb: [[0.0; N]; 2], ws: [[0.0; 3]; 2], wtilde: [0.0; 2] };
}

/// W of the closed contacts of one step, transposed: column a = 2j + r belongs to the j-th
/// closed contact (r = 0 normal, 1 tangential), and row m holds ∂g_a/∂q_m. With this layout
/// the Delassus matrix G = Wᵀ M⁻¹ W = Σ_m (row m)ᵀ (M⁻¹ row m) is a sum of outer products of
/// short vectors, and Wᵀ u = Σ_m u_m (row m).
///
/// The columns (and w̃) are stored without the contact frame's normalisation: the true ones
/// are `scale[j]` = 1/√(1 + w'²) times the stored ones. So the square root and division of
/// the frame run in parallel with the assembly of G and c, which are scaled at the end.
#[derive(Debug, Clone, Copy)]
pub struct Jacobians<const N: usize> {
    /// Beam part: rows m = 0..N (modal coordinates).
    pub beam: [[f64; DIM]; N],
    /// Slider part: rows x_C, z_C, β.
    pub slider: [[f64; DIM]; 3],
    /// Imposed gap velocities w̃ per column.
    pub wtilde: [f64; DIM],
    /// Contact point (0..4) of the j-th closed contact.
    pub index: [usize; MAX_CLOSED],
    /// Normal gap g_N (< 0) of the j-th closed contact [m].
    pub gap_n: [f64; MAX_CLOSED],
    /// 1/√(1 + w'²) of the j-th closed contact: true columns = scale × stored columns.
    pub scale: [f64; MAX_CLOSED],
}

impl<const N: usize> Jacobians<N> {
    /// All zero.
    pub const EMPTY: Self = Jacobians {
        beam: [[0.0; DIM]; N],
        slider: [[0.0; DIM]; 3],
        wtilde: [0.0; DIM],
        index: [0; MAX_CLOSED],
        gap_n: [0.0; MAX_CLOSED],
        scale: [0.0; MAX_CLOSED],
    };
}

#[cfg(test)]
/// docs/model.md §4 for point `i` at configuration (beam q, slider (x_C, z_C, β)); `x_kin` is the
/// x_C used for the kinematics (x_C itself for the free slider, s·L for the PCS).
///
/// Returns the point's x-coordinate and, when the contact is closed (g_N < 0), its kinematics.
#[inline(always)]
pub fn kinematics<const N: usize>(beam: &Beam, slider: &Slider, i: usize, pose: Pose, q: &[f64; N], base: BaseState) -> (f64, Option<ClosedContact<N>>) {
    let Pose { sin_b, cos_b, .. } = pose;
    let pr = probe(beam, slider, i, pose, q);
    if !may_close(i, pr.z_p, base.w0, pr.w, slider.half_thickness) {
        return (pr.x_p, None);
    }
    let mut jac = Jacobians::<N>::EMPTY;
    if !finish(beam, slider, i, &pr, sin_b, cos_b, q, base, &mut jac, 0) {
        return (pr.x_p, None);
    }
    let sc = jac.scale[0];
    let c = ClosedContact {
        index: i,
        gap_n: jac.gap_n[0],
        wb: [std::array::from_fn(|m| sc * jac.beam[m][0]), std::array::from_fn(|m| sc * jac.beam[m][1])],
        ws: [std::array::from_fn(|m| sc * jac.slider[m][0]), std::array::from_fn(|m| sc * jac.slider[m][1])],
        wtilde: [sc * jac.wtilde[0], sc * jac.wtilde[1]],
    };
    (pr.x_p, Some(c))
}

/// First half of the kinematics: the point's position and the beam's deflection under it.
#[derive(Debug, Clone, Copy)]
pub struct Probe<const N: usize> {
    /// x of the point [m].
    pub x_p: f64,
    /// z of the point [m].
    pub z_p: f64,
    /// Elastic deflection w(x_P) [m].
    pub w: f64,
    loc: Loc,
    phi: [f64; N],
}

/// The slider's configuration as the contact kinematics read it (docs/model.md §4): `x_kin` (x_C
/// for the free slider, s·L for the PCS), z_C, and sin β, cos β.
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    /// x used for the kinematics [m].
    pub x_kin: f64,
    /// z_C [m].
    pub z_c: f64,
    /// sin β.
    pub sin_b: f64,
    /// cos β.
    pub cos_b: f64,
}

/// Position of point `i` and the beam deflection under it (mode values via the table).
#[inline(always)]
pub fn probe<const N: usize>(beam: &Beam, slider: &Slider, i: usize, pose: Pose, q: &[f64; N]) -> Probe<N> {
    let [x_p, z_p] = slider.point(i, pose.x_kin, pose.z_c, pose.sin_b, pose.cos_b);
    probe_at(beam, x_p, z_p, q)
}

/// [`probe`] for a point already placed at (x_P, z_P).
#[inline(always)]
pub fn probe_at<const N: usize>(beam: &Beam, x_p: f64, z_p: f64, q: &[f64; N]) -> Probe<N> {
    probe_located(beam, beam.locate(x_p), z_p, q)
}

/// [`probe_at`] for the time loop, which has checked all four points at once: `on_beam` says
/// that 0 ≤ x_P ≤ L (then the table is read without a range check).
///
/// # Safety
/// `on_beam` only if 0 ≤ x_P ≤ L.
#[inline(always)]
pub(crate) unsafe fn probe_checked<const N: usize>(beam: &Beam, on_beam: bool, x_p: f64, z_p: f64, q: &[f64; N]) -> Probe<N> {
    // (Two calls, so that in the first the table's `inside` flag is a known constant.)
    if on_beam {
        // SAFETY: forwarded from the caller.
        probe_located(beam, unsafe { beam.locate_on_beam(x_p) }, z_p, q)
    } else {
        probe_located(beam, beam.locate(x_p), z_p, q)
    }
}

#[inline(always)]
fn probe_located<const N: usize>(beam: &Beam, loc: Loc, z_p: f64, q: &[f64; N]) -> Probe<N> {
    let x_p = loc.x();
    let phi = beam.phi_n::<N>(&loc);
    let w = dot(&phi, q);
    Probe { x_p, z_p, w, loc, phi }
}

/// Step 1, the pre-check: can point `i` (at height z_P over deflection w) be closed?
/// ζZ (z_P − w₀ − w) − h/2 < 1e-5 h/2.
#[inline(always)]
pub fn may_close(i: usize, z_p: f64, w0: f64, w: f64, half_thickness: f64) -> bool {
    ZETA_Z[i] * (z_p - w0 - w) - half_thickness < 1e-5 * half_thickness
}

/// Steps 2–6 for a point that passed the pre-check. When the contact is closed (g_N < 0),
/// writes it as the `j`-th closed contact of `out` (columns 2j, 2j + 1) and returns true.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn finish<const N: usize>(
    beam: &Beam, slider: &Slider, i: usize, pr: &Probe<N>, sin_b: f64, cos_b: f64, q: &[f64; N], base: BaseState, out: &mut Jacobians<N>, j: usize,
) -> bool {
    let zz = ZETA_Z[i];
    let hh = slider.half_thickness;
    let rel = pr.z_p - base.w0 - pr.w;
    let phi = &pr.phi;
    let dphi = beam.dphi_n::<N>(&pr.loc);
    let wp = dot(&dphi, q);
    // 2. α = atan(w'); contact frame A_CN = ζZ [[−sin α, cos α], [−cos α, −sin α]]
    //    = (1/√(1 + w'²)) A with A = ζZ [[−w', 1], [−1, −w']]; everything below is linear in
    //    A_CN, so it is computed with A and scaled by `inv` afterwards (see [`Jacobians`]).
    let inv = 1.0 / fma(wp, wp, 1.0).sqrt();
    let a = [[-zz * wp, zz], [-zz, -zz * wp]];
    // 3.–4. r_P − r_B with r_B = (x_P, w₀ + w) + ζZ (h/2)(−w', 1); g = A_CN (r_P − r_B).
    let d = [zz * hh * wp, rel - zz * hh];
    let g_n = fma(a[0][1], d[1], a[0][0] * d[0]);
    if g_n >= 0.0 {
        return false;
    }
    let g_t = fma(a[1][1], d[1], a[1][0] * d[0]);
    let col = 2 * j;
    debug_assert!(j < MAX_CLOSED);
    // 5. Slider part A_CN [I₂ | A'(β) r_CP].
    let [dx, dz] = slider.point_dbeta(i, sin_b, cos_b);
    out.index[j] = i;
    out.gap_n[j] = inv * g_n;
    out.scale[j] = inv;
    for r in 0..2 {
        out.slider[0][col + r] = a[r][0];
        out.slider[1][col + r] = a[r][1];
        out.slider[2][col + r] = fma(a[r][1], dz, a[r][0] * dx);
    }
    // Beam part −A_CN ∂r_B/∂q_b + (A_CN' (r_P − r_B)) ⊗ φ', with A_CN'(r_P − r_B) = (g_T, −g_N)
    // and ∂r_B/∂q_b = (ζZ (h/2)(w'² − 1) φ', φ − ζZ (h/2) w' φ'): each row is c_φ φ + c_φ' φ'.
    let e = [g_t, -g_n];
    let mut c_phi = [0.0; 2];
    let mut c_dphi = [0.0; 2];
    for r in 0..2 {
        c_phi[r] = -a[r][1];
        c_dphi[r] = fma(-a[r][0] * zz * hh, fma(wp, wp, -1.0), fma(a[r][1] * zz * hh, wp, e[r]));
    }
    for m in 0..N {
        for r in 0..2 {
            out.beam[m][col + r] = fma(c_dphi[r], dphi[m], c_phi[r] * phi[m]);
        }
    }
    // 6. w̃ = −A_CN (0, ẇ₀).
    out.wtilde[col] = -a[0][1] * base.w0_dot;
    out.wtilde[col + 1] = -a[1][1] * base.w0_dot;
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::*;

    /// Gap velocities (normal) of the closed contacts at the midpoint of a step.
    fn normal_gap_velocities(model: &Model, qb: &[f64], ub: &[f64], qs: [f64; 3], us: [f64; 3], ue_b: &[f64], ue_s: [f64; 3]) -> Vec<(f64, f64)> {
        let dt = model.params.dt_s;
        let slider = Slider::new(&model.params);
        let mut qm = [0.0; 5];
        for i in 0..5 {
            qm[i] = qb[i] + 0.5 * dt * ub[i];
        }
        let qsm: Vec<f64> = (0..3).map(|i| qs[i] + 0.5 * dt * us[i]).collect();
        let (sb, cb) = qsm[2].sin_cos();
        let mut out = Vec::new();
        for i in 0..4 {
            let (_, c) =
                kinematics::<5>(&model.beam, &slider, i, Pose { x_kin: qsm[0], z_c: qsm[1], sin_b: sb, cos_b: cb }, &qm, BaseState { w0: 0.0, w0_dot: 0.0 });
            if let Some(c) = c {
                let v =
                    |ubv: &[f64], usv: [f64; 3]| -> f64 { (0..5).map(|m| c.wb[0][m] * ubv[m]).sum::<f64>() + (0..3).map(|m| c.ws[0][m] * usv[m]).sum::<f64>() };
                out.push((v(ub, us), v(ue_b, ue_s)));
            }
        }
        out
    }

    #[test]
    fn released_slider_rebounds_with_restitution() {
        for eps in [0.0, 0.5, 1.0] {
            let model = Model::new(Params { restitution: eps, ..Params::default() }).unwrap();
            let exc = Excitation::new(124.0, 0.0);
            let mut start = model.initial_state(0.3, &exc).unwrap();
            start.slider_u = [0.0, -0.05, 0.0];
            let opts = RunOptions {
                excitation: exc,
                model: SliderModel::Free,
                duration_s: 2e-3,
                record_every: 1,
                channels: vec![Channel::ModalQ, Channel::ModalU, Channel::XC, Channel::ZC, Channel::Beta, Channel::SliderU, Channel::Percussions],
                audit_contacts: false,
            };
            let mut rec = MemoryRecorder::new();
            model.run(&start, &opts, &mut rec, &mut ()).unwrap();
            let w = rec.names.len();
            let rows: Vec<&[f64]> = rec.data.chunks(w).collect();
            // First step with a percussion: the impact.
            let k = rows.iter().position(|r| r[w - 8..].iter().any(|p| *p != 0.0)).expect("no impact");
            let (b, e) = (rows[k - 1], rows[k]);
            let gv = normal_gap_velocities(&model, &b[0..5], &b[5..10], [b[10], b[11], b[12]], [b[13], b[14], b[15]], &e[5..10], [e[13], e[14], e[15]]);
            assert!(!gv.is_empty());
            for (before, after) in gv {
                eprintln!("eps {eps}: gap velocity before {before:e}, after {after:e}");
                assert!(before < -1e-3, "approaching");
                assert!((after + eps * before).abs() < 1e-10 * before.abs(), "eps {eps}: {after} vs {}", -eps * before);
            }
        }
    }
}
