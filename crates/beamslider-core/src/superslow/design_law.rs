//! The drift law over the design box (docs/model.md §6.5): per-design laws blended by design
//! distance.
//!
//! A design law holds the fitted drift laws ([`DriftLaw`]) of training designs drawn over a box of
//! the parameters that a designer changes or does not know, each design described by its
//! coordinates ([`design_coordinates`]). For a new design, [`DesignLaw::law_for`] blends the laws
//! of its `k_sets` nearest training designs (in the box scaled to [0, 1], one length scale per
//! coordinate) with inverse-distance weights: V on a 26 × 51 grid of the law's inputs
//! (Â/max Â_H, s) is the weighted mean of the neighbours' V (no lift-off gate), the scalars
//! (Λ_c, s_up shift, V resolution) their weighted means, ρ_c and s_p the weighted means over the
//! neighbours that learnt them (0 when those weigh less than half), and the monostability samples
//! the neighbours' together. At a training design (to rounding) its own law is returned unchanged.
//!
//! Outside what the law covers — a coordinate beyond the box, a parameter that is not a coordinate
//! changed from the base design, or a clearance below `jam_gap_ratio` — the reasons are the
//! law's `outside_design` ([`DesignLaw::outside`]) and predictions from it are extrapolated.
//!
//! Fitted: the per-design laws and the length scales (the Python package, `fit_design_law`);
//! the blend itself is a fixed rule.

use std::collections::HashMap;
use std::path::Path;
use std::sync::OnceLock;

use serde::Deserialize;

use super::law::{DriftLaw, LawFile, NF};
use crate::error::{Error, Result};
use crate::params::Params;
use crate::physics::beam::Beam;

/// The `kind` of a design-law file.
pub const DESIGN_KIND: &str = "beamslider design drift law";

/// Names of the design coordinates (docs/model.md §6.5), in the shipped box's order.
pub const COORDINATES: [&str; 9] = [
    "gap_ratio",
    "slider_mass_kg",
    "contact_spacing_m",
    "inertia_factor",
    "com_offset_m",
    "friction_coefficient",
    "restitution",
    "natural_frequency_factor",
    "damping_factor",
];

/// Fields that are not coordinates: a design that changes one of them lies outside the law.
pub const FIXED: [&str; 8] =
    ["length_m", "thickness_m", "density_kg_m3", "beam_mass_kg", "damping_ratio_quadratic", "axial_preload_n", "gravity_m_s2", "tilt_rad"];

/// Grid of Â/max Â_H on which a blended law is materialised (start, stop, nodes).
pub const GRID_AMP: (f64, f64, usize) = (0.0, 1.25, 26);
/// Grid of s on which a blended law is materialised.
pub const GRID_S: (f64, f64, usize) = (0.0, 0.5, 51);

/// One coordinate of the design box.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct BoxCoordinate {
    /// Its name ([`COORDINATES`]).
    pub name: String,
    /// Lower end.
    pub low: f64,
    /// Upper end.
    pub high: f64,
    /// Sampled on a log scale.
    #[serde(default)]
    pub log: bool,
}

impl BoxCoordinate {
    /// `x` mapped to [0, 1] over the range (log scale where `log`).
    pub fn unit(&self, x: f64) -> f64 {
        if self.log { (x / self.low).ln() / (self.high / self.low).ln() } else { (x - self.low) / (self.high - self.low) }
    }
}

fn field(p: &Params, name: &str) -> f64 {
    match name {
        "length_m" => p.length_m,
        "thickness_m" => p.thickness_m,
        "density_kg_m3" => p.density_kg_m3,
        "beam_mass_kg" => p.beam_mass_kg,
        "damping_ratio_quadratic" => p.damping_ratio_quadratic,
        "axial_preload_n" => p.axial_preload_n,
        "gravity_m_s2" => p.gravity_m_s2,
        "tilt_rad" => p.tilt_rad,
        _ => f64::NAN,
    }
}

fn omega1(p: &Params) -> Result<f64> {
    Ok(Beam::shared(p)?.omega[0])
}

/// The design coordinates of `params` relative to `base` ([`COORDINATES`] order): the inertia
/// factor J_C / (J_C0 (m/m0)(B/B0)²), the natural-frequency factor ω₁/ω₁0 (1 when E, k_r and k_t
/// are the base's) and the damping factor D/D0; the others are the parameters themselves.
pub fn design_coordinates(params: &Params, base: &Params) -> Result<[f64; 9]> {
    let (p, b) = (params, base);
    let ratio = p.contact_spacing_m / b.contact_spacing_m;
    let j_similar = b.slider_inertia_kg_m2 * (p.slider_mass_kg / b.slider_mass_kg) * (ratio * ratio);
    let same_beam = p.youngs_modulus_pa == b.youngs_modulus_pa && p.k_r_nm_per_rad == b.k_r_nm_per_rad && p.k_t_n_per_m == b.k_t_n_per_m;
    let nf = if same_beam { 1.0 } else { omega1(p)? / omega1(b)? };
    Ok([
        p.gap_ratio,
        p.slider_mass_kg,
        p.contact_spacing_m,
        p.slider_inertia_kg_m2 / j_similar,
        p.com_offset_m,
        p.friction_coefficient,
        p.restitution,
        nf,
        if b.damping_ratio > 0.0 { p.damping_ratio / b.damping_ratio } else { 1.0 },
    ])
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DesignFile {
    kind: String,
    version: i64,
    #[serde(rename = "box")]
    box_: Vec<BoxCoordinate>,
    base: serde_json::Value,
    k_sets: usize,
    scales: Vec<f64>,
    #[serde(default = "jam")]
    jam_gap_ratio: f64,
    #[serde(default)]
    #[allow(dead_code)]
    loo: serde_json::Value,
    designs: Vec<serde_json::Value>,
}

fn jam() -> f64 {
    1.03
}

/// Drift laws of training designs over a box, blended for any design inside it (module docs).
#[derive(Debug, Clone)]
pub struct DesignLaw {
    /// The box's coordinates (permuted into [`COORDINATES`] order).
    pub coordinates: Vec<BoxCoordinate>,
    /// The base design (its coordinates are the reference of the inertia, frequency and damping factors).
    pub base: Params,
    /// Training designs in the unit box ([`COORDINATES`] order).
    pub unit: Vec<[f64; 9]>,
    /// Their laws as read (raw: the blend's grid and a training design's own law are built from them).
    pub files: Vec<LawFile>,
    /// Their laws, parsed.
    pub laws: Vec<DriftLaw>,
    /// Length scale of each coordinate in the unit box.
    pub scales: [f64; 9],
    /// Designs blended.
    pub k_sets: usize,
    /// Below this clearance ratio a design lies outside the law (sliders barely move).
    pub jam_gap_ratio: f64,
    /// Each training law's V on the blend's grid ([`grid`]), low and high branch, tabulated on
    /// the law's first blend: the blend's summands depend on the law alone, not on the design.
    tables: Vec<OnceLock<[Vec<f64>; 2]>>,
}

/// The blend's grid of the law's inputs (Â/max Â_H, s): [`GRID_S`] outer, [`GRID_AMP`] inner,
/// so sorted by s.
fn grid() -> &'static [[f64; NF]] {
    static GRID: OnceLock<Vec<[f64; NF]>> = OnceLock::new();
    GRID.get_or_init(|| {
        let amp = linspace(GRID_AMP.0, GRID_AMP.1, GRID_AMP.2);
        let ss = linspace(GRID_S.0, GRID_S.1, GRID_S.2);
        ss.iter().flat_map(|&s| amp.iter().map(move |&a| [a, s])).collect()
    })
}

fn bad(source: &str, why: &str) -> Error {
    Error::invalid("law", source, why)
}

fn finite_number(x: f64) -> bool {
    x.is_finite()
}

impl DesignLaw {
    /// Parse the JSON text of a design-law file (`source` names it in errors).
    pub fn from_json_str(text: &str, source: &str) -> Result<DesignLaw> {
        let f: DesignFile = serde_json::from_str(text).map_err(|e| bad(source, &format!("not a {DESIGN_KIND} file ({e})")))?;
        Self::from_design_file(f, source)
    }

    /// [`DesignLaw::from_json_str`] of a design-law file's content already parsed (a front end's table).
    pub fn from_json_value(value: serde_json::Value, source: &str) -> Result<DesignLaw> {
        let f: DesignFile = serde_json::from_value(value).map_err(|e| bad(source, &format!("not a {DESIGN_KIND} file ({e})")))?;
        Self::from_design_file(f, source)
    }

    fn from_design_file(f: DesignFile, source: &str) -> Result<DesignLaw> {
        if f.kind != DESIGN_KIND {
            return Err(bad(source, &format!("not a {DESIGN_KIND} file (kind)")));
        }
        if f.version != 1 {
            return Err(bad(source, &format!("version = {}, expected 1 (this build)", f.version)));
        }
        let mut coordinates = Vec::with_capacity(9);
        let mut perm = [0usize; 9];
        for (i, name) in COORDINATES.iter().enumerate() {
            let Some(j) = f.box_.iter().position(|c| c.name == *name) else {
                return Err(bad(source, &format!("box lacks the coordinate `{name}`")));
            };
            let c = &f.box_[j];
            if !(c.low.is_finite() && c.high.is_finite() && c.low < c.high) || (c.log && c.low <= 0.0) {
                return Err(bad(source, &format!("box[{j}] needs finite low < high")));
            }
            perm[i] = j;
            coordinates.push(c.clone());
        }
        if f.box_.len() != 9 {
            return Err(bad(source, &format!("box has {} coordinates, this version knows {COORDINATES:?}", f.box_.len())));
        }
        if f.scales.len() != 9 || f.scales.iter().any(|&s| !(s.is_finite() && s > 0.0)) {
            return Err(bad(source, "`scales` needs 9 finite values > 0"));
        }
        let scales: [f64; 9] = std::array::from_fn(|i| f.scales[perm[i]]);
        if !(f.jam_gap_ratio.is_finite() && f.jam_gap_ratio >= 1.0) {
            return Err(bad(source, "jam_gap_ratio must be a finite number >= 1"));
        }
        if f.k_sets < 1 || f.designs.len() < f.k_sets {
            return Err(bad(source, "needs k_sets >= 1 and at least k_sets designs"));
        }
        let base: Params = serde_json::from_value(f.base).map_err(|e| bad(source, &format!("base: {e}")))?;
        base.validate()?;
        let (mut unit, mut files, mut laws) = (Vec::new(), Vec::new(), Vec::new());
        for (i, e) in f.designs.into_iter().enumerate() {
            let (Some(x), Some(law)) = (e.get("x").and_then(|x| x.as_object()), e.get("law").filter(|l| l.is_object())) else {
                return Err(bad(source, &format!("designs[{i}] needs `x` and `law`")));
            };
            let mut u = [0.0; 9];
            for (k, c) in coordinates.iter().enumerate() {
                match x.get(&c.name).and_then(|v| v.as_f64()) {
                    Some(x) if finite_number(x) => u[k] = c.unit(x),
                    _ => return Err(bad(source, &format!("designs[{i}].x lacks `{}`", c.name))),
                }
            }
            let lf: LawFile = serde_json::from_value(law.clone()).map_err(|er| bad(source, &format!("designs[{i}].law: {er}")))?;
            let law = DriftLaw::from_law_file(lf.clone()).map_err(|er| bad(source, &format!("designs[{i}].law: {}", er.to_string().replace('\n', " "))))?;
            unit.push(u);
            files.push(lf);
            laws.push(law);
        }
        let tables = laws.iter().map(|_| OnceLock::new()).collect();
        Ok(DesignLaw { coordinates, base, unit, files, laws, scales, k_sets: f.k_sets, jam_gap_ratio: f.jam_gap_ratio, tables })
    }

    /// Read a design-law file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<DesignLaw> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.display().to_string(), source: e })?;
        DesignLaw::from_json_str(&text, &path.display().to_string())
    }

    /// V of training law `i` on the blend's grid, (low, high) (empty for a branch without samples).
    fn table(&self, i: usize) -> &[Vec<f64>; 2] {
        self.tables[i].get_or_init(|| {
            let law = &self.laws[i];
            [false, true].map(|high| {
                if law.branch_len(high) == 0 {
                    return Vec::new();
                }
                grid().iter().map(|x| law.evaluate(high, x, f64::INFINITY).0).collect()
            })
        })
    }

    /// The design coordinates of `params` relative to this law's base ([`COORDINATES`] order).
    pub fn coordinates_of(&self, params: &Params) -> Result<[f64; 9]> {
        design_coordinates(params, &self.base)
    }

    /// Why `params` (with coordinates `c`) lie outside what the law covers (empty inside).
    pub fn outside(&self, params: &Params, c: &[f64; 9]) -> Vec<String> {
        let mut why: Vec<String> = FIXED
            .iter()
            .filter(|f| field(params, f) != field(&self.base, f))
            .map(|f| format!("`{f}` = {} differs from the base design's {}", py_repr(field(params, f)), py_repr(field(&self.base, f))))
            .collect();
        for (b, &x) in self.coordinates.iter().zip(c) {
            if !(b.low - 1e-9 * b.low.abs().max(1.0) <= x && x <= b.high + 1e-9 * b.high.abs().max(1.0)) {
                why.push(format!("{} = {} outside the box [{}, {}]", b.name, fmt_g(x, 6), fmt_g(b.low, 6), fmt_g(b.high, 6)));
            }
        }
        if c[0] < self.jam_gap_ratio {
            why.push(format!("gap_ratio = {} below {}, where sliders barely move", fmt_g(c[0], 4), fmt_g(self.jam_gap_ratio, 6)));
        }
        why
    }

    /// The `k_sets` nearest training designs to the unit-box point `u` and their normalised
    /// inverse-distance weights; also the distance of the nearest.
    fn neighbours(&self, u: &[f64; 9]) -> (Vec<usize>, Vec<f64>, f64) {
        let d: Vec<f64> = self
            .unit
            .iter()
            .map(|x| {
                // Summed in numpy's pairwise order (the blend's weights to the last bit of the
                // Python fit's leave-one-design-out, `loo_design_error`).
                let t: [f64; 9] = std::array::from_fn(|i| ((x[i] - u[i]) / self.scales[i]).powi(2));
                ((((t[0] + t[1]) + (t[2] + t[3])) + ((t[4] + t[5]) + (t[6] + t[7]))) + t[8]).sqrt()
            })
            .collect();
        let mut o: Vec<usize> = (0..d.len()).collect();
        o.sort_by(|&a, &b| d[a].total_cmp(&d[b]));
        o.truncate(self.k_sets);
        let w: Vec<f64> = o.iter().map(|&i| 1.0 / d[i].max(1e-9)).collect();
        let mut tot = 0.0;
        for x in &w {
            tot += x;
        }
        let d0 = d[o[0]];
        (o, w.iter().map(|x| x / tot).collect(), d0)
    }

    /// The blended law file of design `params` (docs/model.md §6.5) and why it lies outside the law
    /// (also the law's `outside_design`; empty inside).
    pub fn law_file_for(&self, params: &Params) -> Result<(LawFile, Vec<String>)> {
        let c = self.coordinates_of(params)?;
        let u: [f64; 9] = std::array::from_fn(|i| self.coordinates[i].unit(c[i]));
        let why = self.outside(params, &c);
        let (o, w, d0) = self.neighbours(&u);
        if d0 < 1e-6 {
            let mut f = self.files[o[0]].clone();
            f.outside_design = why.clone();
            return Ok((f, why));
        }
        let parts: Vec<&DriftLaw> = o.iter().map(|&i| &self.laws[i]).collect();
        let pfiles: Vec<&LawFile> = o.iter().map(|&i| &self.files[i]).collect();
        let grid = grid();
        let (mut xs, mut vs) = (HashMap::new(), HashMap::new());
        for (name, high) in [("L", false), ("H", true)] {
            let (mut acc, mut ws) = (vec![0.0; grid.len()], 0.0);
            for (&i, &wi) in o.iter().zip(&w) {
                if self.laws[i].branch_len(high) == 0 {
                    continue;
                }
                // Σ wᵢ Vᵢ(x) over the neighbours in order: the tabulated Vᵢ are the evaluations.
                for (a, v) in acc.iter_mut().zip(&self.table(i)[usize::from(high)]) {
                    *a += wi * v;
                }
                ws += wi;
            }
            if ws > 0.0 {
                xs.insert(name.to_string(), grid.iter().map(|x| x.to_vec()).collect());
                vs.insert(name.to_string(), acc.iter().map(|a| a / ws).collect());
            } else {
                xs.insert(name.to_string(), Vec::new());
                vs.insert(name.to_string(), Vec::new());
            }
        }
        let n = grid.len() as f64;
        let mut mean = [0.0; NF];
        for x in grid {
            for i in 0..NF {
                mean[i] += x[i];
            }
        }
        for m in mean.iter_mut() {
            *m /= n;
        }
        let mut var = [0.0; NF];
        for x in grid {
            for i in 0..NF {
                let t = x[i] - mean[i];
                var[i] += t * t;
            }
        }
        let std: Vec<f64> = var.iter().map(|v| (v / n).sqrt()).collect();
        let wmean = |f: &dyn Fn(&DriftLaw) -> f64| {
            let mut s = 0.0;
            for (law, &wi) in parts.iter().zip(&w) {
                s += wi * f(law);
            }
            s
        };
        let wmean_learnt = |f: &dyn Fn(&DriftLaw) -> f64| {
            let (mut tot, mut s) = (0.0, 0.0);
            for (law, &wi) in parts.iter().zip(&w) {
                if f(law) > 0.0 {
                    tot += wi;
                }
            }
            for (law, &wi) in parts.iter().zip(&w) {
                if f(law) > 0.0 {
                    s += wi * f(law);
                }
            }
            if tot >= 0.5 { s / tot } else { 0.0 }
        };
        let mut lo = parts[0].lo;
        let mut hi = parts[0].hi;
        for law in &parts[1..] {
            for i in 0..NF {
                lo[i] = lo[i].min(law.lo[i]);
                hi[i] = hi[i].max(law.hi[i]);
            }
        }
        let mut points: Vec<(f64, f64)> = parts.iter().flat_map(|l| l.points.iter().copied()).collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        points.dedup();
        let mut mono_std = [0.0; 2];
        for (law, &wi) in parts.iter().zip(&w) {
            for (m, x) in mono_std.iter_mut().zip(law.mono_std) {
                *m += wi * x;
            }
        }
        let file = LawFile {
            kind: "beamslider drift law".into(),
            version: 1,
            features: super::law::FEATURES.iter().map(|s| s.to_string()).collect(),
            k: 4,
            x: xs,
            v: vs,
            mean: mean.to_vec(),
            std,
            lo: lo.to_vec(),
            hi: hi.to_vec(),
            points: points.iter().map(|p| vec![p.0, p.1]).collect(),
            s_up_shift: wmean(&|q| q.s_up_shift),
            mono_x: pfiles.iter().flat_map(|f| f.mono_x.iter().cloned()).collect(),
            mono_y: pfiles.iter().flat_map(|f| f.mono_y.iter().copied()).collect(),
            mono_std: mono_std.to_vec(),
            lift_c: wmean(&|q| q.lift_c),
            rho_c: wmean_learnt(&|q| q.rho_c),
            jump_down_s: wmean_learnt(&|q| q.jump_down_s),
            v_resolution: wmean(&|q| q.v_resolution),
            outside_design: why.clone(),
        };
        Ok((file, why))
    }

    /// The blended [`DriftLaw`] of design `params` ([`DesignLaw::law_file_for`]).
    pub fn law_for(&self, params: &Params) -> Result<DriftLaw> {
        self.law_for_rule(params, true).map(|x| x.0)
    }

    /// [`DesignLaw::law_for`], with the law's forcing-ratio rule of the jump-down kept or off
    /// (ρ_c = 0: the HB manifold's own jump-down only), and why the design lies outside the law.
    pub fn law_for_rule(&self, params: &Params, keep_rho_c: bool) -> Result<(DriftLaw, Vec<String>)> {
        let (mut f, why) = self.law_file_for(params)?;
        if !keep_rho_c {
            f.rho_c = 0.0;
        }
        Ok((DriftLaw::from_law_file(f)?, why))
    }
}

fn linspace(a: f64, z: f64, n: usize) -> Vec<f64> {
    let step = (z - a) / (n - 1) as f64;
    let mut v: Vec<f64> = (0..n).map(|i| i as f64 * step + a).collect();
    v[n - 1] = z;
    v
}

/// Python's `repr` of a float (shortest round trip, `.0` for integral values, `inf`).
fn py_repr(x: f64) -> String {
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let s = format!("{x:?}");
    if let Some((m, e)) = s.split_once('e') {
        let e: i32 = e.parse().unwrap_or(0);
        let m = if m.contains('.') { m.to_string() } else { format!("{m}.0") };
        let m = m.trim_end_matches(".0").to_string();
        return format!("{m}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs());
    }
    s
}

/// Python's `format(x, '.{p}g')`.
fn fmt_g(x: f64, p: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return py_repr(x);
    }
    let e = format!("{:.*e}", p - 1, x);
    let (m, exp) = e.split_once('e').unwrap_or((&e, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if exp < -4 || exp >= p as i32 {
        let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
        format!("{m}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
    } else {
        let dec = (p as i32 - 1 - exp).max(0) as usize;
        let s = format!("{x:.dec$}");
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> DesignLaw {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../python/beamslider/data");
        DesignLaw::from_file(dir.join("default_design_law.json")).unwrap()
    }

    #[test]
    fn at_the_base_design_the_blend_is_the_default_law_itself() {
        let dl = shipped();
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../python/beamslider/data");
        let own = DriftLaw::from_file(dir.join("default_law.json")).unwrap();
        let law = dl.law_for(&dl.base.clone()).unwrap();
        assert_eq!(law.fingerprint, own.fingerprint);
        assert!(law.outside_design.is_empty());
    }

    #[test]
    fn a_new_design_gets_the_grid_and_weights_that_sum_to_one() {
        let dl = shipped();
        let mut p = dl.base.clone();
        p.friction_coefficient = 0.27;
        p.gap_ratio = 1.11;
        let c = dl.coordinates_of(&p).unwrap();
        let u: [f64; 9] = std::array::from_fn(|i| dl.coordinates[i].unit(c[i]));
        let (o, w, d0) = dl.neighbours(&u);
        assert_eq!(o.len(), dl.k_sets);
        assert!(d0 > 1e-6 && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12 && w.windows(2).all(|x| x[0] >= x[1]));
        let (f, why) = dl.law_file_for(&p).unwrap();
        assert!(why.is_empty());
        assert_eq!(f.x["H"].len(), GRID_AMP.2 * GRID_S.2);
        assert!((f.mean[0] - 0.625).abs() < 1e-12 && (f.mean[1] - 0.25).abs() < 1e-12);
        p.friction_coefficient = 0.5;
        p.length_m = 0.15;
        let (_, why) = dl.law_file_for(&p).unwrap();
        assert_eq!(why.len(), 2, "{why:?}");
        assert!(why[0].starts_with("`length_m` = 0.15 differs") && why[1].starts_with("friction_coefficient = 0.5 outside the box [0.1, 0.4]"), "{why:?}");
    }

    /// The blend from the tabulated laws is Σ wᵢ Vᵢ(x) / Σ wᵢ with each Vᵢ(x) evaluated afresh, to the bit.
    #[test]
    fn the_blend_from_tabulated_laws_is_the_direct_weighted_mean() {
        let dl = shipped();
        let mut p = dl.base.clone();
        (p.gap_ratio, p.friction_coefficient, p.com_offset_m) = (1.17, 0.21, 3e-3);
        let c = dl.coordinates_of(&p).unwrap();
        let u: [f64; 9] = std::array::from_fn(|i| dl.coordinates[i].unit(c[i]));
        let (o, w, d0) = dl.neighbours(&u);
        assert!(d0 > 1e-6);
        let (f, _) = dl.law_file_for(&p).unwrap();
        for (name, high) in [("L", false), ("H", true)] {
            let mut ws = 0.0;
            for (&i, &wi) in o.iter().zip(&w) {
                if dl.laws[i].branch_len(high) > 0 {
                    ws += wi;
                }
            }
            assert_eq!(f.v[name].len(), GRID_AMP.2 * GRID_S.2);
            for (x, got) in grid().iter().zip(&f.v[name]) {
                let mut acc = 0.0;
                for (&i, &wi) in o.iter().zip(&w) {
                    if dl.laws[i].branch_len(high) > 0 {
                        acc += wi * dl.laws[i].evaluate(high, x, f64::INFINITY).0;
                    }
                }
                assert_eq!((acc / ws).to_bits(), got.to_bits(), "{name} at {x:?}");
            }
        }
    }

    #[test]
    fn g_format_as_python() {
        assert_eq!(fmt_g(1.025, 4), "1.025");
        assert_eq!(fmt_g(0.5, 6), "0.5");
        assert_eq!(fmt_g(1.03, 6), "1.03");
        assert_eq!(fmt_g(1e-5, 6), "1e-05");
        assert_eq!(fmt_g(0.008, 6), "0.008");
        assert_eq!(fmt_g(123456789.0, 6), "1.23457e+08");
        assert_eq!(fmt_g(0.1, 6), "0.1");
        assert_eq!(py_repr(0.15), "0.15");
        assert_eq!(py_repr(0.14), "0.14");
        assert_eq!(py_repr(2.0), "2.0");
        assert_eq!(py_repr(1e-7), "1e-07");
    }

    #[test]
    fn unit_box_maps_ends_to_zero_and_one() {
        let c = BoxCoordinate { name: "damping_factor".into(), low: 0.5, high: 2.0, log: true };
        assert!((c.unit(0.5)).abs() < 1e-15 && (c.unit(2.0) - 1.0).abs() < 1e-15 && (c.unit(1.0) - 0.5).abs() < 1e-15);
        let l = BoxCoordinate { name: "gap_ratio".into(), low: 1.02, high: 1.3, log: false };
        assert!((l.unit(1.16) - 0.5).abs() < 1e-12);
    }
}
