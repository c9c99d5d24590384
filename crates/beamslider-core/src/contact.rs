//! Contact kinematics of MODEL.md §4 for one potential contact point: pre-check, contact frame,
//! normal gap, force directions Wᵢ = (∂g/∂q)ᵀ and the gap velocity imposed by the base motion.

use crate::beam::{Beam, Loc};
use crate::slider::{Slider, ZETA_Z};

/// Kinematics of a closed contact: the two columns (normal, tangential) of W and w̃.
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

impl<const N: usize> ClosedContact<N> {
    /// Placeholder value (no contact).
    pub const EMPTY: Self = ClosedContact {
        index: 0,
        gap_n: 0.0,
        wb: [[0.0; N]; 2],
        ws: [[0.0; 3]; 2],
        wtilde: [0.0; 2],
    };
}

/// Base motion at one instant: w₀ and ẇ₀.
#[derive(Debug, Clone, Copy)]
pub struct Base {
    /// Base displacement w₀ [m].
    pub w0: f64,
    /// Base velocity ẇ₀ [m/s].
    pub w0_dot: f64,
}

/// MODEL.md §4 for point `i` at configuration (beam q, slider (x_C, z_C, β)); `x_kin` is the
/// x_C used for the kinematics (x_C itself for the free slider, s·L for the PCS).
///
/// Returns the point's x-coordinate and, when the contact is closed (g_N < 0), its kinematics.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn kinematics<const N: usize>(
    beam: &Beam,
    slider: &Slider,
    i: usize,
    x_kin: f64,
    z_c: f64,
    sin_b: f64,
    cos_b: f64,
    q: &[f64; N],
    base: Base,
) -> (f64, Option<ClosedContact<N>>) {
    let pr = probe(beam, slider, i, x_kin, z_c, sin_b, cos_b, q);
    if !may_close(i, pr.z_p, base.w0, pr.w, slider.half_thickness) {
        return (pr.x_p, None);
    }
    let mut c = ClosedContact::EMPTY;
    let closed = finish(beam, slider, i, &pr, sin_b, cos_b, q, base, &mut c);
    (pr.x_p, closed.then_some(c))
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

impl<const N: usize> Probe<N> {
    /// Is x_P inside the tabulated range (where [`Beam::slope_bound`] holds)?
    pub fn in_table(&self) -> bool {
        self.loc.inside()
    }
}

/// Position of point `i` and the beam deflection under it (mode values via the table).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn probe<const N: usize>(
    beam: &Beam,
    slider: &Slider,
    i: usize,
    x_kin: f64,
    z_c: f64,
    sin_b: f64,
    cos_b: f64,
    q: &[f64; N],
) -> Probe<N> {
    let [x_p, z_p] = slider.point(i, x_kin, z_c, sin_b, cos_b);
    let loc = beam.locate(x_p);
    let phi = beam.phi_n::<N>(&loc);
    let mut w = 0.0;
    for m in 0..N {
        w += phi[m] * q[m];
    }
    Probe { x_p, z_p, w, loc, phi }
}

/// Step 1, the pre-check: can point `i` (at height z_P over deflection w) be closed?
/// ζZ (z_P − w₀ − w) − h/2 < 1e-5 h/2.
#[inline(always)]
pub fn may_close(i: usize, z_p: f64, w0: f64, w: f64, half_thickness: f64) -> bool {
    ZETA_Z[i] * (z_p - w0 - w) - half_thickness < 1e-5 * half_thickness
}

/// Steps 2–6 for a point that passed the pre-check; writes `out` and returns whether the
/// contact is closed (g_N < 0).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn finish<const N: usize>(
    beam: &Beam,
    slider: &Slider,
    i: usize,
    pr: &Probe<N>,
    sin_b: f64,
    cos_b: f64,
    q: &[f64; N],
    base: Base,
    out: &mut ClosedContact<N>,
) -> bool {
    let zz = ZETA_Z[i];
    let hh = slider.half_thickness;
    let rel = pr.z_p - base.w0 - pr.w;
    let phi = &pr.phi;
    let dphi = beam.dphi_n::<N>(&pr.loc);
    let mut wp = 0.0;
    for m in 0..N {
        wp += dphi[m] * q[m];
    }
    // 2. α = atan(w'); contact frame A_CN = ζZ [[−sin α, cos α], [−cos α, −sin α]].
    let inv = 1.0 / (1.0 + wp * wp).sqrt();
    let (sa, ca) = (wp * inv, inv);
    let a = [[-zz * sa, zz * ca], [-zz * ca, -zz * sa]];
    // 3.–4. r_P − r_B with r_B = (x_P, w₀ + w) + ζZ (h/2)(−w', 1); g = A_CN (r_P − r_B).
    let d = [zz * hh * wp, rel - zz * hh];
    let g_n = a[0][0] * d[0] + a[0][1] * d[1];
    if g_n >= 0.0 {
        return false;
    }
    let g_t = a[1][0] * d[0] + a[1][1] * d[1];
    // 5. Slider part A_CN [I₂ | A'(β) r_CP].
    let [dx, dz] = slider.point_dbeta(i, sin_b, cos_b);
    out.index = i;
    out.gap_n = g_n;
    out.ws = [
        [a[0][0], a[0][1], a[0][0] * dx + a[0][1] * dz],
        [a[1][0], a[1][1], a[1][0] * dx + a[1][1] * dz],
    ];
    // Beam part −A_CN ∂r_B/∂q_b + (A_CN' (r_P − r_B)) ⊗ φ', with A_CN'(r_P − r_B) = (g_T, −g_N)
    // and ∂r_B/∂q_b = (ζZ (h/2)(w'² − 1) φ', φ − ζZ (h/2) w' φ'): each row is c_φ φ + c_φ' φ'.
    let e = [g_t, -g_n];
    for r in 0..2 {
        let c_phi = -a[r][1];
        let c_dphi = -a[r][0] * zz * hh * (wp * wp - 1.0) + a[r][1] * zz * hh * wp + e[r];
        for m in 0..N {
            out.wb[r][m] = c_phi * phi[m] + c_dphi * dphi[m];
        }
    }
    // 6. w̃ = −A_CN (0, ẇ₀).
    out.wtilde = [-a[0][1] * base.w0_dot, -a[1][1] * base.w0_dot];
    true
}
