//! Contact kinematics of MODEL.md §4 for one potential contact point: pre-check, contact frame,
//! normal gap, force directions Wᵢ = (∂g/∂q)ᵀ and the gap velocity imposed by the base motion.

use crate::beam::Beam;
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
    let [x_p, z_p] = slider.point(i, x_kin, z_c, sin_b, cos_b);
    let zz = ZETA_Z[i];
    let hh = slider.half_thickness;
    let (phi, dphi) = beam.eval_n::<N>(x_p);
    let mut w = 0.0;
    for m in 0..N {
        w += phi[m] * q[m];
    }
    // 1. Pre-check: the point must be at (or beyond) the beam surface on its side.
    let rel = z_p - base.w0 - w;
    if zz * rel - hh >= 1e-5 * hh {
        return (x_p, None);
    }
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
        return (x_p, None);
    }
    let g_t = a[1][0] * d[0] + a[1][1] * d[1];
    // 5. Slider part A_CN [I₂ | A'(β) r_CP].
    let [dx, dz] = slider.point_dbeta(i, sin_b, cos_b);
    let ws = [
        [a[0][0], a[0][1], a[0][0] * dx + a[0][1] * dz],
        [a[1][0], a[1][1], a[1][0] * dx + a[1][1] * dz],
    ];
    // Beam part −A_CN ∂r_B/∂q_b + (A_CN' (r_P − r_B)) ⊗ φ', with A_CN'(r_P − r_B) = (g_T, −g_N)
    // and ∂r_B/∂q_b = (ζZ (h/2)(w'² − 1) φ', φ − ζZ (h/2) w' φ'): each row is c_φ φ + c_φ' φ'.
    let e = [g_t, -g_n];
    let mut wb = [[0.0; N]; 2];
    for r in 0..2 {
        let c_phi = -a[r][1];
        let c_dphi = -a[r][0] * zz * hh * (wp * wp - 1.0) + a[r][1] * zz * hh * wp + e[r];
        for m in 0..N {
            wb[r][m] = c_phi * phi[m] + c_dphi * dphi[m];
        }
    }
    // 6. w̃ = −A_CN (0, ẇ₀).
    let wtilde = [-a[0][1] * base.w0_dot, -a[1][1] * base.w0_dot];
    (
        x_p,
        Some(ClosedContact {
            index: i,
            gap_n: g_n,
            wb,
            ws,
            wtilde,
        }),
    )
}
