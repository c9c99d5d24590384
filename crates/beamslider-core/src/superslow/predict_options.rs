//! Settings of the reduced predictor (docs/model.md §6.3): [`PredictOptions`], the jump-down rule
//! ([`SDnRule`]), the source of the branches ([`Source`]) and the drift ([`Drift`]: a fitted law or
//! one operating point's PCS drift table, [`TableDrift`]).

use super::branch::HbOptions;
use super::design_law::DesignLaw;
use super::law::DriftLaw;
use super::slowflow::{SlowBranch, SlowModel};
use crate::classify::Criteria;
use crate::error::{Error, Result};

/// Settings of [`predict_point`].
#[derive(Debug, Clone, PartialEq)]
pub struct PredictOptions {
    /// Layer (a) settings (modes, D_eff, ...; default: `low_branch_only`, the predictor uses no
    /// middle branch).
    pub hb: HbOptions,
    /// Nodes per branch (default 121, as the Python package).
    pub nodes: usize,
    /// Build-up time [s]; None: three envelope time constants 3/(DΩ) (D = d_eff or the
    /// parameters' damping ratio), as `beamslider.slowflow.predict`.
    pub build_up_s: Option<f64>,
    /// During the build-up the slider drifts from t = 0 and only a jump waits for its end (the
    /// PCS and FS runs from rest drift at once; the envelope needs the build-up before the beam can
    /// settle on the other branch); false: s stays at s₀ until then (the rule before). Default true.
    pub build_up_drift: bool,
    /// Classification thresholds.
    pub criteria: Criteria,
    /// Also run the slow flow with V shifted by ± the law's `v_resolution` and report whether
    /// the prediction is robust ([`PointPrediction::robust`]; default true).
    pub robustness: bool,
    /// Which jump-down position ends the high branch (default [`SDnRule::Law`]).
    pub s_dn: SDnRule,
    /// Dead band of V [1/s]: V − clamp(V, −v_dead, v_dead), so |V| ≤ v_dead is rest (a drift
    /// slower than the tables resolve; default 0: none).
    pub v_dead: f64,
    /// Where the branches, Â and the folds come from (default [`Source::Hb`]).
    pub source: Source,
}

impl Default for PredictOptions {
    fn default() -> Self {
        PredictOptions {
            hb: HbOptions { low_branch_only: true, ..HbOptions::default() },
            nodes: 121,
            build_up_s: None,
            build_up_drift: true,
            criteria: Criteria::default(),
            robustness: true,
            s_dn: SDnRule::Law,
            v_dead: 0.0,
            source: Source::Hb,
        }
    }
}

/// [`PredictOptions`] as a front end's keyword arguments (flat, rules by name; missing keys take
/// the defaults of [`PredictOptions::default`]).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PredictArgs {
    /// Retained beam modes of layer (a).
    pub n_modes: usize,
    /// Equivalent damping ratio of layer (a) (None: the parameters' damping ratio).
    pub d_eff: Option<f64>,
    /// [`SDnRule`] by name.
    pub s_dn: String,
    /// [`Source`] by name.
    pub source: String,
    /// [`PredictOptions::v_dead`].
    pub v_dead: f64,
    /// [`PredictOptions::build_up_s`].
    pub build_up_s: Option<f64>,
    /// [`PredictOptions::build_up_drift`].
    pub build_up_drift: bool,
    /// [`PredictOptions::robustness`].
    pub robustness: bool,
}

impl Default for PredictArgs {
    fn default() -> Self {
        let d = PredictOptions::default();
        PredictArgs {
            n_modes: d.hb.n_modes,
            d_eff: d.hb.d_eff,
            s_dn: d.s_dn.name().into(),
            source: d.source.name().into(),
            v_dead: d.v_dead,
            build_up_s: d.build_up_s,
            build_up_drift: d.build_up_drift,
            robustness: d.robustness,
        }
    }
}

impl PredictArgs {
    /// The options these arguments name (an unknown rule or source is an invalid parameter).
    pub fn options(&self) -> Result<PredictOptions> {
        let d = PredictOptions::default();
        Ok(PredictOptions {
            hb: HbOptions { n_modes: self.n_modes, d_eff: self.d_eff, ..d.hb },
            s_dn: SDnRule::named(&self.s_dn)?,
            source: Source::named(&self.source)?,
            v_dead: self.v_dead,
            build_up_s: self.build_up_s,
            build_up_drift: self.build_up_drift,
            robustness: self.robustness,
            ..d
        })
    }
}

/// Which jump-down position ends the high branch of the reduced model (docs/model.md §6.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SDnRule {
    /// The HB manifold's own fold, else the law's forcing-ratio rule ([`law_s_dn`]; with a table
    /// drift: the HB manifold's own).
    #[default]
    Law,
    /// The HB manifold's own fold only (none with single-term HB unless D_eff ends the branch).
    Hb,
    /// The PCS jump-down of a drift table ([`TableDrift::s_dn`]; a table drift only).
    Table,
    /// No jump-down: the high branch runs to its end.
    None,
}

impl SDnRule {
    /// The rule's name (`law`, `hb`, `table`, `none`).
    pub fn name(self) -> &'static str {
        match self {
            SDnRule::Law => "law",
            SDnRule::Hb => "hb",
            SDnRule::Table => "table",
            SDnRule::None => "none",
        }
    }

    /// The rule of a name (`law`, `hb`, `table`, `none`); another name is an invalid `s_dn`.
    pub fn named(name: &str) -> Result<SDnRule> {
        let rules = [SDnRule::Law, SDnRule::Hb, SDnRule::Table, SDnRule::None];
        rules.into_iter().find(|r| r.name() == name).ok_or_else(|| Error::invalid("s_dn", format!("{name:?}"), "one of 'law', 'hb', 'table', 'none'"))
    }
}

/// Where the reduced model's branches come from (docs/model.md §6.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Source {
    /// Branches, Â and s_up from the HB manifold (layer (a)), V from the drift.
    #[default]
    Hb,
    /// Everything from a PCS drift table (its rows' Â and V, its sweeps' jumps; no layer (a)).
    Table,
}

impl Source {
    /// The source's name (`hb`, `table`).
    pub fn name(self) -> &'static str {
        match self {
            Source::Hb => "hb",
            Source::Table => "table",
        }
    }

    /// The source of a name (`hb`, `table`); another name is an invalid `source`.
    pub fn named(name: &str) -> Result<Source> {
        match name {
            "hb" => Ok(Source::Hb),
            "table" => Ok(Source::Table),
            _ => Err(Error::invalid("source", format!("{name:?}"), "'hb' or 'table'")),
        }
    }
}

/// The drift V(s, branch) of the reduced model: a fitted law (b2) or one operating point's PCS
/// drift table (b1).
#[derive(Debug, Clone, Copy)]
pub enum Drift<'a> {
    /// A fitted law.
    Law(&'a DriftLaw),
    /// A PCS drift table of the operating point.
    Table(&'a TableDrift),
}

/// A PCS drift table as the drift of the reduced model (b1): V linear between its rows (held
/// constant beyond them), and the table's own branches for [`Source::Table`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TableDrift {
    /// Rows (s′, V) of the low and the high branch in the half coordinate, sorted by s′.
    pub rows: [(Vec<f64>, Vec<f64>); 2],
    /// The table's own branches: nodes s′, Â (the window amplitude) and V of its rows.
    pub own: SlowModel,
    /// Jump-up position of the PCS down sweep (None: it did not jump).
    pub s_up: Option<f64>,
    /// Jump-down position of the PCS up sweep (None: it did not jump).
    pub s_dn: Option<f64>,
}

impl TableDrift {
    /// A table drift from its branches' rows (s′, Â, V; half coordinate, sorted by s′) and its
    /// sweeps' jump positions: a branch of the table's own model ends in a fold where its native
    /// sweep jumped.
    pub fn new(low: SlowBranch, high: SlowBranch, s_up: Option<f64>, s_dn: Option<f64>) -> TableDrift {
        let rows = [(low.s.clone(), low.v_per_s.clone()), (high.s.clone(), high.v_per_s.clone())];
        let own = SlowModel { low_ends_in_fold: s_up.is_some() && !low.s.is_empty(), high_ends_in_fold: s_dn.is_some() && !high.s.is_empty(), low, high };
        TableDrift { rows, own, s_up, s_dn }
    }
}

/// The drift of a predicted map: a fitted law, or a design law (docs/model.md §6.5) blended for
/// the map's parameters.
#[derive(Debug, Clone, Copy)]
pub enum MapDrift<'a> {
    /// A fitted law, as it is.
    Law(&'a DriftLaw),
    /// A design law, blended for the configuration's effective parameters.
    Design(&'a DesignLaw),
}

impl<'a> Drift<'a> {
    /// The drift of one of a law and a table (both or neither: an invalid `drift`).
    pub fn one_of(law: Option<&'a DriftLaw>, table: Option<&'a TableDrift>) -> Result<Drift<'a>> {
        match (law, table) {
            (Some(l), None) => Ok(Drift::Law(l)),
            (None, Some(t)) => Ok(Drift::Table(t)),
            _ => Err(Error::invalid("drift", "\"\"", "one of law and table")),
        }
    }
}

/// Linear interpolation as numpy.interp (constant beyond the ends; 0 without rows).
pub(super) fn interp(x: f64, xp: &[f64], fp: &[f64]) -> f64 {
    let n = xp.len();
    if n == 0 {
        return 0.0;
    }
    if x <= xp[0] {
        return fp[0];
    }
    if x >= xp[n - 1] {
        return fp[n - 1];
    }
    let j = xp.partition_point(|&v| v <= x) - 1;
    if x == xp[j] || xp[j + 1] == xp[j] {
        return fp[j];
    }
    (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
}

/// V − clamp(V, −v_dead, v_dead) on every node (unchanged for v_dead = 0).
pub(super) fn dead_band(model: &SlowModel, v_dead: f64) -> SlowModel {
    let mut m = model.clone();
    if v_dead > 0.0 {
        for v in m.low.v_per_s.iter_mut().chain(m.high.v_per_s.iter_mut()) {
            *v -= v.clamp(-v_dead, v_dead);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interp_is_numpy_interp() {
        let (xp, fp) = ([0.1, 0.2, 0.4], [1.0, 3.0, -1.0]);
        // numpy.interp([0.0, 0.1, 0.15, 0.3, 0.4, 0.9], xp, fp) = [1, 1, 2, 1, -1, -1]
        let got: Vec<f64> = [0.0, 0.1, 0.15, 0.3, 0.4, 0.9].iter().map(|&x| interp(x, &xp, &fp)).collect();
        for (g, w) in got.iter().zip([1.0, 1.0, 2.0, 1.0, -1.0, -1.0]) {
            assert!((g - w).abs() < 1e-12, "{got:?}");
        }
        assert_eq!(interp(0.3, &[], &[]), 0.0);
    }

    #[test]
    fn dead_band_reads_slow_drift_as_rest_and_is_continuous() {
        let br = SlowBranch { s: vec![0.1, 0.2, 0.3, 0.4], amplitude_h: vec![1.0; 4], v_per_s: vec![-3e-4, -1e-4, 5e-5, 2e-4] };
        let m = SlowModel { low: br.clone(), high: br, ..SlowModel::default() };
        let d = dead_band(&m, 1e-4);
        let want = [-2e-4, 0.0, 0.0, 1e-4];
        for (g, w) in d.low.v_per_s.iter().zip(want) {
            assert!((g - w).abs() < 1e-18, "{:?}", d.low.v_per_s);
        }
        assert_eq!(dead_band(&m, 0.0), m);
    }

    #[test]
    fn the_drift_is_one_of_a_law_and_a_table() {
        let table = TableDrift::default();
        assert!(matches!(Drift::one_of(None, Some(&table)), Ok(Drift::Table(_))));
        let err = Drift::one_of(None, None).unwrap_err();
        assert!(err.is_input() && err.to_string().contains("one of law and table"), "{err}");
    }

    #[test]
    fn the_default_arguments_name_the_default_options() {
        assert_eq!(PredictArgs::default().options().unwrap(), PredictOptions::default());
    }

    #[test]
    fn a_table_branch_ends_in_a_fold_only_where_its_sweep_jumped() {
        let br = |n: usize| SlowBranch { s: (0..n).map(|i| 0.1 + 0.1 * i as f64).collect(), amplitude_h: vec![1.0; n], v_per_s: vec![0.0; n] };
        let t = TableDrift::new(br(3), br(3), Some(0.15), None);
        assert!(t.own.low_ends_in_fold && !t.own.high_ends_in_fold);
        assert_eq!(t.rows[0].0, vec![0.1, 0.2, 0.30000000000000004]);
        let empty = TableDrift::new(br(0), br(2), Some(0.15), Some(0.3));
        assert!(!empty.own.low_ends_in_fold && empty.own.high_ends_in_fold);
    }
}
