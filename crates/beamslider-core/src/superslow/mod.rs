//! The super-slow scale of docs/model.md §6.3–§6.5: the harmonic-balance manifold (layer (a)), the drift law from PCS runs and its blend over the design box, the slow flow and the predicted operating maps.
//!
//! Layer (a), the super-slow manifold by harmonic balance (HB):
//!
//! On the super-slow scale the slider is taken as rigidly attached to the beam at x = sL
//! (docs/model.md §6.4). A Ritz reduction with the N beam modes of docs/model.md §2 gives
//!
//! ```text
//! M(s) q̈ + C q̇ + Λ q + f_nl(q) = Γ(s) a_ex cos Ωt,
//! M(s) = I + m Φ(s)Φ(s)ᵀ + J_G Φ′(s)Φ′(s)ᵀ,  J_G = J_C + m d²,
//! Λ = diag(ωₙ²) + H₀ K,  C = diag(2Dₙωₙ),  Γ(s) = γ + m Φ(s),
//! f_nl(q) = (k_ax/2)(qᵀKq) K q,
//! ```
//!
//! with the project's extensions of docs/model.md §2: the axial preload H₀ adds H₀K to Λ, and the
//! amplitude-dependent damping D₂ (modal damping ratio D + 4D₂(w(L/2)/h)²) enters through the
//! exact first harmonic of its cubic term. The slider's weight is neglected (no static sag).
//!
//! * [`closed_form_n1`] — one mode, one harmonic. With A = a², δ = ω² − M₁Ω²,
//!   c = 2DωΩ, F = (γ + mφ)a_ex, b = (k_ax/2)K₁₁²:
//!   (9/16)b²A³ + (3/2)bδA² + (δ² + c²)A − F² = 0; its real roots (all positive), the
//!   discriminant Δ, folds = zeros of Δ(s) bracketed on the s-grid and refined with Brent's
//!   method, s_res from M₁(s_res) = ω²/Ω², and the backbone Ω²M₁(s) = ω² + ¾ b a².
//! * [`hb_manifold`] — N modes, one harmonic, q = Re(Q e^{iΩt}):
//!   R(Q, s) = (Λ − Ω²M(s) + iΩC)Q + (k_ax/8)[(QᵀKQ)KQ̄ + 2(QᴴKQ)KQ] − Γ(s)a_ex = 0,
//!   written in (Re Q, Im Q) with its analytic Jacobian (also ∂R/∂s), solved by
//!   pseudo-arclength continuation from s_min = B/(2L) up to 0.5 (the branch continuous with the
//!   high branch near the clamping) and from 0.5 down (the low branch, started at 0.5 by
//!   continuation in the forcing level from zero). Folds are where the s-component of the
//!   tangent changes sign, refined by Brent's method on it; a point is stable when
//!   det ∂R/∂(Re Q, Im Q) > 0 (sign between folds).
//!
//! Options (docs/model.md §6.4): the equivalent damping D_eff (replaces Dₙ of all modes), a detuning
//! factor of ω₁ (for a sensitivity check), multi-harmonic HB (`harmonics` = 3, 5, 7:
//! odd harmonics up to H) and the static sag under the slider's weight (`static_sag`, a zeroth
//! harmonic); the last two are solved by the alternating frequency–time residual of
//! the multi-harmonic module (`superslow/mhb.rs`) with the same continuation.

mod branch;
mod closed_form;
mod continuation;
pub mod design_law;
pub mod drift;
mod hb;
mod hb_terms;
pub mod law;
mod lu;
mod mhb;
pub mod predict;
mod predict_options;
pub mod predicted_map;
mod roots;
pub mod slowflow;

pub use branch::{Fold, HbBranch, HbManifold, HbOptions};
pub use closed_form::{ClosedFormN1, backbone, closed_form_n1, closed_form_n1_scaled, closed_form_n1_with_beam};
pub use continuation::{default_grid, hb_manifold};
pub use hb::HbSystem;
pub use roots::brent;
