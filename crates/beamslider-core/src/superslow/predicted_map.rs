//! A predicted operating map (docs/model.md §6.3, §8): every point of a map configuration by
//! [`predict_point_with`], written through the map results writer ([`crate::map::MapResults`]:
//! lock, resume, header) in the FS map's row format.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::law::{DriftLaw, beam_for};
use super::predict::{MapDrift, PointPrediction, PredictArgs, PredictOptions, SDnRule, predict_point_with};
use super::slowflow::EventKind;
use crate::dynamics::runner::run_batch;
use crate::dynamics::stepper::Counters;
use crate::error::{Error, Result};
use crate::map::{Job, MapConfig, MapOutcome, MapPoint, MapResults, MapRow, MapRunOptions, Progress};
use crate::results::STATUS_PREDICTED;

fn event_name(k: EventKind) -> &'static str {
    match k {
        EventKind::JumpUp => "jump_up",
        EventKind::JumpDown => "jump_down",
        EventKind::Equilibrium => "equilibrium",
        EventKind::Wall => "wall",
    }
}

/// A predicted map row (the FS map's row format; status `predicted`, zero counters; the extra
/// keys `events`, `extrapolated`, `s_dn_source`).
pub fn predicted_row(index: usize, f_ex_hz: f64, a_ex: f64, s0: f64, t_end_s: f64, p: &PointPrediction, wall_s: f64) -> MapRow {
    let c = &p.flow.classification;
    let mut extra = serde_json::Map::new();
    let events: Vec<serde_json::Value> = p.flow.events.iter().map(|e| serde_json::json!([event_name(e.kind), e.t_s, e.s])).collect();
    extra.insert("events".into(), serde_json::Value::Array(events));
    extra.insert("extrapolated".into(), serde_json::Value::Bool(p.extrapolated));
    extra.insert("monostable".into(), serde_json::Value::Bool(p.monostable));
    extra.insert("s_dn_source".into(), serde_json::Value::String(p.s_dn_source.into()));
    extra.insert("robust".into(), p.robust.map_or(serde_json::Value::Null, serde_json::Value::Bool));
    if !p.shifted.is_empty() {
        let alt: Vec<serde_json::Value> = p.shifted.iter().map(|(b, s)| serde_json::json!([b.name(), s])).collect();
        extra.insert("shifted".into(), serde_json::Value::Array(alt));
    }
    let point = MapPoint { index, f_ex_hz, a_ex_m_s2: a_ex, s0 };
    let mut row = MapRow::from_classification(&point, t_end_s, STATUS_PREDICTED, c, Counters::default(), wall_s, None);
    row.extra = extra;
    row
}

/// The predictor's description in a predicted map's header (compared on resume).
pub fn header_value(law: &DriftLaw, opts: &PredictOptions) -> serde_json::Value {
    serde_json::json!({
        "kind": "drift_law_knn",
        "law_fingerprint": law.fingerprint,
        "law_points": law.points.iter().map(|p| [p.0, p.1]).collect::<Vec<_>>(),
        "k": law.k,
        "n_modes": opts.hb.n_modes,
        "d_eff": opts.hb.d_eff,
        "s_dn": match opts.s_dn {
            SDnRule::Law if law.rho_c > 0.0 => "law",
            SDnRule::Law => "hb",
            r => r.name(),
        },
        "nodes": opts.nodes,
        "build_up": if opts.build_up_drift { "drift" } else { "hold" },
        // the low branch capped at grazing (docs/model.md §6.3): maps predicted before it are not resumed
        "low_branch": "grazing",
    })
}

/// Predict every point of `cfg`'s grid with the law (in parallel, `opts.threads` workers),
/// appending each row to the results file as the FS maps do ([`MapResults`]: lock, resume,
/// header; the header also holds the predictor, [`header_value`]). A failed point becomes a row
/// with status `error`; `cancel` stops the map keeping the finished rows.
pub fn run_predicted_map(
    cfg: &MapConfig, law: &DriftLaw, popts: &PredictOptions, opts: &MapRunOptions, cancel: &AtomicBool, progress: Progress<'_>,
) -> Result<MapOutcome> {
    if opts.extend {
        return Err(Error::invalid("extend_to", cfg.duration_s, "a predicted map is not extended (predict it for the longer duration)"));
    }
    let mut popts = popts.clone();
    popts.criteria = cfg.criteria.clone();
    let params = cfg.valid_params()?;
    let header = header_value(law, &popts);
    let beam = beam_for(&params, popts.hb.n_modes)?;
    let mut results = MapResults::open_predicted(cfg, opts, &header)?;
    let jobs = std::mem::take(&mut results.jobs);
    let total = results.total;
    let t_end = cfg.duration_s;
    run_batch(
        &jobs,
        opts.threads,
        cancel,
        |job: &Job| {
            if cancel.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let p = *job.point();
            let t0 = Instant::now();
            let row = match predict_point_with(&params, &beam, law, p.f_ex_hz, p.a_ex_m_s2, p.s0, t_end, &popts) {
                Ok(pr) => predicted_row(p.index, p.f_ex_hz, p.a_ex_m_s2, p.s0, t_end, &pr, t0.elapsed().as_secs_f64()),
                Err(e) => crate::map::error_row(&p, &e.to_string(), t0),
            };
            Ok(Some(row))
        },
        |row: &MapRow| {
            results.append(row.clone())?;
            if let Some(last) = results.rows.last() {
                progress(results.rows.len(), total, last);
            }
            Ok(())
        },
    )?;
    Ok(results.finish())
}

/// A predicted map ([`run_predicted_map`]) with the options `args` names; a design law is blended
/// for the map's parameters, without its learnt jump-down for `s_dn` = "hb" (which then reads
/// "law"). Returns the outcome and why the design lies outside the design law.
pub fn predicted_map(
    cfg: &MapConfig, drift: MapDrift<'_>, args: &PredictArgs, opts: &MapRunOptions, cancel: &AtomicBool, progress: Progress<'_>,
) -> Result<(MapOutcome, Vec<String>)> {
    crate::dynamics::runner::check_threads(opts.threads)?;
    let (mut args, mut why) = (args.clone(), Vec::new());
    let blended;
    let law = match drift {
        MapDrift::Law(law) => law,
        MapDrift::Design(design) => {
            let keep = args.s_dn != SDnRule::Hb.name();
            (blended, why) = design.law_for_rule(&cfg.effective_params(), keep)?;
            args.s_dn = if keep { args.s_dn } else { SDnRule::Law.name().into() };
            &blended
        }
    };
    Ok((run_predicted_map(cfg, law, &args.options()?, opts, cancel, progress)?, why))
}
