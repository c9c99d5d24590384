//! Operating maps: configuration, thread-count independence, resume after a truncated write.

use std::sync::atomic::AtomicBool;

use beamslider_core::map::{self, MapConfig, MapRow, MapRunOptions, run_map};
use beamslider_core::results::{self, read_results};

fn small(duration: f64) -> MapConfig {
    MapConfig::from_toml_str(&format!(
        "duration_s = {duration}\n[grid]\nf_ex_hz = {{ start = 118.0, stop = 124.0, step = 2.0 }}\na_ex_m_s2 = [6.0, 14.0]\ns0 = 0.3\n"
    ))
    .unwrap()
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bs-map-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Rows as JSON with the wall time zeroed (the only field allowed to differ).
fn canon(rows: &[MapRow]) -> Vec<String> {
    rows.iter().map(|r| MapRow { wall_time_s: 0.0, ..r.clone() }.to_json()).collect()
}

fn none(_: usize, _: usize, _: &MapRow) {}

#[test]
fn default_config_is_the_papers_map() {
    let c = MapConfig::default();
    let pts = c.points().unwrap();
    assert_eq!(pts.len(), 16 * 7);
    assert_eq!(pts[0].f_ex_hz, 100.0);
    assert_eq!(pts[15].f_ex_hz, 130.0);
    assert_eq!(pts[16].a_ex_m_s2, 6.0);
    assert_eq!(pts[111].a_ex_m_s2, 16.0);
    assert!(pts.iter().all(|p| p.s0 == 0.3));
    assert_eq!(c.duration_s, 120.0);
    // Round trip through TOML.
    let back = MapConfig::from_toml_str(&c.to_toml_string()).unwrap();
    assert_eq!(back, c);
}

#[test]
fn config_errors_name_the_field() {
    let e = MapConfig::from_toml_str("[grid]\nf_ex_hz = [-1.0]\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("f_ex_hz"), "{e}");
    let e = MapConfig::from_toml_str("[grid]\nf_ex_hz = { start = 130.0, stop = 100.0, step = 2.0 }\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("grid.f_ex_hz"), "{e}");
    let e = MapConfig::from_toml_str("duration_s = 0.0\n[grid]\nf_ex_hz = 100.0\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("duration_s"), "{e}");
    let e = MapConfig::from_toml_str("[grid]\nf_ex_hz = 100.0\na_ex_m_s2 = 4.0\n[params]\nslider_mass_kg = -1.0\n").unwrap_err().to_string();
    assert!(e.contains("slider_mass_kg"), "{e}");
    let e = MapConfig::from_toml_str("[grid]\nf_ex_hz = 100.0\na_ex_m_s2 = 4.0\nbogus = 1\n").unwrap_err().to_string();
    assert!(e.contains("bogus"), "{e}");
}

#[test]
fn durations_and_sample_spacings_that_cannot_finish_are_refused_by_name() {
    let e = MapConfig::from_toml_str("duration_s = 1e300\n[grid]\nf_ex_hz = 100.0\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("duration_s") && e.contains("1e300") && e.contains("1e11"), "{e}");
    let e = MapConfig::from_toml_str("record_every = 100000000\n[grid]\nf_ex_hz = 100.0\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("record_every") && e.contains("record_every <= 5000"), "{e}");
    let e = MapConfig::from_toml_str("[grid]\nf_ex_hz = 1e-200\na_ex_m_s2 = 4.0\n").unwrap_err().to_string();
    assert!(e.contains("f_ex_hz"), "{e}");
}

#[test]
fn rows_do_not_depend_on_the_number_of_threads() {
    let cfg = small(2.0);
    let cancel = AtomicBool::new(false);
    let d = tmp("threads");
    let mut all = Vec::new();
    for threads in [1, 2, 3] {
        let out = d.join(format!("t{threads}.jsonl"));
        let o = run_map(&cfg, &MapRunOptions { out: Some(out.clone()), resume: false, threads: Some(threads), extend: false }, &cancel, &none).unwrap();
        assert_eq!(o.rows.len(), 8);
        assert_eq!(o.computed, 8);
        // The file holds the same rows (in completion order).
        let mut file_rows = read_results(&out).unwrap().rows;
        file_rows.sort_by_key(|r| r.index);
        assert_eq!(canon(&file_rows), canon(&o.rows));
        all.push(canon(&o.rows));
    }
    assert_eq!(all[0], all[1]);
    assert_eq!(all[0], all[2]);
    // In memory only, too.
    let o = run_map(&cfg, &MapRunOptions::default(), &cancel, &none).unwrap();
    assert_eq!(canon(&o.rows), all[0]);
}

#[test]
fn resume_after_a_truncated_last_line_loses_nothing_and_duplicates_nothing() {
    let cfg = small(2.0);
    let cancel = AtomicBool::new(false);
    let d = tmp("resume");
    let full_path = d.join("full.jsonl");
    let full = run_map(&cfg, &MapRunOptions { out: Some(full_path.clone()), resume: false, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    // A killed run: the header, three complete rows and half of a fourth.
    let text = std::fs::read_to_string(&full_path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cut = d.join("cut.jsonl");
    let mut partial = lines[..4].join("\n");
    partial.push('\n');
    partial.push_str(&lines[4][..lines[4].len() / 2]);
    std::fs::write(&cut, &partial).unwrap();
    let r = read_results(&cut).unwrap();
    assert!(r.truncated);
    assert_eq!(r.rows.len(), 3);
    // Without --resume an existing file is refused.
    assert!(run_map(&cfg, &MapRunOptions { out: Some(cut.clone()), resume: false, threads: Some(2), extend: false }, &cancel, &none).is_err());
    let o = run_map(&cfg, &MapRunOptions { out: Some(cut.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!(o.resumed, 3);
    assert_eq!(o.computed, 5);
    assert_eq!(canon(&o.rows), canon(&full.rows));
    let after = read_results(&cut).unwrap();
    assert!(!after.truncated);
    assert_eq!(after.rows.len(), 8);
    let mut idx: Vec<usize> = after.rows.iter().map(|r| r.index).collect();
    idx.sort();
    assert_eq!(idx, (0..8).collect::<Vec<_>>());
    // Resuming a complete map computes nothing.
    let o = run_map(&cfg, &MapRunOptions { out: Some(cut.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!((o.resumed, o.computed), (8, 0));
    assert_eq!(read_results(&cut).unwrap().rows.len(), 8);
    // Other settings cannot resume the file; a grown grid can.
    let mut other = cfg.clone();
    other.duration_s = 1.0;
    let e = run_map(&other, &MapRunOptions { out: Some(cut.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap_err();
    assert!(e.to_string().contains("other settings"), "{e}");
    let mut grown = cfg.clone();
    grown.grid.a_ex_m_s2 = beamslider_core::Axis::List(vec![6.0, 10.0, 14.0]);
    let o = run_map(&grown, &MapRunOptions { out: Some(cut.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!((o.resumed, o.computed, o.rows.len()), (8, 4, 12));
    assert!(map::text_table(&o.rows).lines().count() == 5);
}

#[test]
fn cancelled_map_keeps_finished_points() {
    let cfg = small(2.0);
    let cancel = AtomicBool::new(true);
    let o = run_map(&cfg, &MapRunOptions::default(), &cancel, &none).unwrap();
    assert!(o.cancelled);
    assert!(o.rows.is_empty());
}

/// Regression: a failed point has NaN features, written as `null`; reading them back failed, so
/// `--resume` refused the file. Also: a failing point no longer stops the others.
#[test]
fn failed_points_are_rows_that_read_back_and_resume() {
    let cfg = MapConfig::from_toml_str("duration_s = 0.3\nrecord_every = 10\n[grid]\nf_ex_hz = [120.0, 124.0]\na_ex_m_s2 = [6.0, 1e6]\n").unwrap();
    let cancel = AtomicBool::new(false);
    let path = tmp("failing").join("map.jsonl");
    let o = run_map(&cfg, &MapRunOptions { out: Some(path.clone()), resume: false, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!(o.rows.len(), 4);
    let failed: Vec<usize> = o.failures().iter().map(|r| r.index).collect();
    assert_eq!(failed, vec![2, 3]);
    assert!(o.rows[2].s_final.is_nan() || o.rows[2].status != "completed");
    let back = read_results(&path).unwrap();
    assert_eq!(back.rows.len(), 4);
    let o = run_map(&cfg, &MapRunOptions { out: Some(path.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!((o.resumed, o.computed), (4, 0));
}

#[test]
fn grids_that_are_typing_errors_are_refused() {
    for (text, word) in [
        ("[grid]\nf_ex_hz = [120.0, 120.0]\na_ex_m_s2 = 6.0\n", "twice"),
        ("[grid]\nf_ex_hz = { start = 100.0, stop = 1e12, step = 1e-3 }\na_ex_m_s2 = 6.0\n", "at most"),
        ("[grid]\nf_ex_hz = { start = 100.0, stop = 130.0, step = 1e-300 }\na_ex_m_s2 = 6.0\n", "at most"),
        ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\ns0 = 0.99\n", "grid.s0"),
        ("[grid]\nf_ex_hz = 1e5\na_ex_m_s2 = 6.0\n", "grid.f_ex_hz"),
    ] {
        let e = MapConfig::from_toml_str(text).unwrap_err().to_string();
        assert!(e.contains(word), "{text}: {e}");
    }
}

/// Extending a map in time (docs/classify.md): a 3-s map extended to 6 s continues exactly its not-settled points from their saved
/// end states; each continued row is bitwise the row of the 6-s map (all fields but the wall
/// time), the settled rows are kept, and only the not-settled points are re-run.
#[test]
fn extended_map_rows_are_bitwise_those_of_the_longer_map() {
    let cancel = AtomicBool::new(false);
    let dir = tmp("extend");
    // Windows of 1 s: with the default ones (15 s, drift over 30 s) no 3-s run is settled.
    let grid = "[grid]\nf_ex_hz = [100.0, 120.0, 124.0]\na_ex_m_s2 = [4.0, 14.0]\ns0 = [0.3, 0.7]\n\
                [criteria]\nsteady_window_s = 1.0\nsteady_drift_window_s = 1.0\n";
    let cfg = |d: f64| MapConfig::from_toml_str(&format!("duration_s = {d}\n{grid}")).unwrap();
    let long = run_map(&cfg(6.0), &MapRunOptions { out: None, resume: false, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    let path = dir.join("map.jsonl");
    let short = run_map(&cfg(3.0), &MapRunOptions { out: Some(path.clone()), resume: false, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    // Continued: every row with settled = false, and the undetermined ones.
    let unsettled: Vec<usize> = short
        .rows
        .iter()
        .filter(|r| !r.settled || matches!(r.behaviour, beamslider_core::Behaviour::NotSettled | beamslider_core::Behaviour::Undetermined))
        .map(|r| r.index)
        .collect();
    assert!(!unsettled.is_empty() && unsettled.len() < short.rows.len(), "need both kinds: {:?}", short.rows.iter().map(|r| r.behaviour).collect::<Vec<_>>());
    assert!(short.rows.iter().all(|r| r.end.is_some()));
    // Extend: only the not-settled points run.
    let ext = run_map(&cfg(6.0), &MapRunOptions { out: Some(path.clone()), resume: false, threads: Some(2), extend: true }, &cancel, &none).unwrap();
    assert_eq!(ext.extended, unsettled.len());
    assert_eq!(ext.computed, unsettled.len());
    assert_eq!(ext.resumed, short.rows.len() - unsettled.len());
    let (a, b, c) = (canon(&ext.rows), canon(&long.rows), canon(&short.rows));
    for i in 0..a.len() {
        if unsettled.contains(&i) {
            assert_eq!(a[i], b[i], "continued point {i} differs from the 6-s run");
        } else {
            assert_eq!(a[i], c[i], "settled point {i} was not kept");
        }
    }
    // The file reads back to the extended rows (later rows replace earlier ones).
    let back = read_results(&path).unwrap();
    assert_eq!(back.settings.unwrap().duration_s, 6.0);
    let mut rows = results::latest(back.rows.clone());
    rows.sort_by_key(|r| r.index);
    assert_eq!(canon(&rows), a);
    // Nothing left to extend: a second call re-runs nothing.
    let again = run_map(&cfg(6.0), &MapRunOptions { out: Some(path.clone()), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!((again.extended, again.computed), (0, 0));
    // Extending to a shorter duration, or a map that is not there, is an error naming extend_to.
    let e =
        run_map(&cfg(4.0), &MapRunOptions { out: Some(path.clone()), resume: false, threads: Some(2), extend: true }, &cancel, &none).unwrap_err().to_string();
    assert!(e.contains("extend_to"), "{e}");
    let e = run_map(&cfg(6.0), &MapRunOptions { out: Some(dir.join("none.jsonl")), resume: false, threads: Some(2), extend: true }, &cancel, &none)
        .unwrap_err()
        .to_string();
    assert!(e.contains("extend_to"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A results file of format version 2 (rows without `settled` and the drifts, labels of the
/// rules before the flag) reads back with `settled` derived from `steady`, and resumes and extends
/// after an upgrade to version 3: every completed row is reclassified from the signals of its
/// end state, bitwise the row of a version-3 map (docs/model.md §8).
#[test]
fn version_2_files_read_back_resume_and_extend() {
    use beamslider_core::Behaviour;
    let cancel = AtomicBool::new(false);
    let dir = tmp("v2");
    let grid = "[grid]\nf_ex_hz = [100.0, 120.0, 124.0]\na_ex_m_s2 = [4.0, 14.0]\ns0 = [0.3, 0.7]\n\
                [criteria]\nsteady_window_s = 1.0\nsteady_drift_window_s = 1.0\n";
    let cfg = |d: f64| MapConfig::from_toml_str(&format!("duration_s = {d}\n{grid}")).unwrap();
    let v3 = dir.join("v3.jsonl");
    let short = run_map(&cfg(3.0), &MapRunOptions { out: Some(v3.clone()), resume: false, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!(read_results(&v3).unwrap().version, 3);
    // The same map as version 2 wrote it: no flag, no drifts, a behaviour that has not settled
    // labelled not_settled.
    let text = std::fs::read_to_string(&v3).unwrap();
    let mut lines = text.lines();
    let mut v2 = lines.next().unwrap().replacen("\"beamslider_map\":3", "\"beamslider_map\":2", 1);
    v2.push('\n');
    for l in lines {
        let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
        let o = v.as_object_mut().unwrap();
        let settled = o.remove("settled").unwrap().as_bool().unwrap();
        o.remove("drift_s");
        o.remove("drift_a_h");
        if !settled && o["behaviour"] != "relaxation_oscillation" {
            o.insert("behaviour".into(), "not_settled".into());
        }
        v2.push_str(&v.to_string());
        v2.push('\n');
    }
    let old = read_results(&v3).unwrap().rows;
    for name in ["resume.jsonl", "extend.jsonl"] {
        std::fs::write(dir.join(name), &v2).unwrap();
    }
    let back = read_results(&dir.join("resume.jsonl")).unwrap();
    assert_eq!(back.version, 2);
    for (b, o) in back.rows.iter().zip(&old) {
        assert_eq!(b.settled, o.settled, "point {}", o.index);
        assert!(b.drift_s.is_nan());
    }
    // Resume: nothing to compute; the file is rewritten as version 3 with the rows of the
    // version-3 map.
    let o = run_map(&cfg(3.0), &MapRunOptions { out: Some(dir.join("resume.jsonl")), resume: true, threads: Some(2), extend: false }, &cancel, &none).unwrap();
    assert_eq!((o.resumed, o.computed), (short.rows.len(), 0));
    assert_eq!(canon(&o.rows), canon(&short.rows));
    let up = read_results(&dir.join("resume.jsonl")).unwrap();
    assert_eq!(up.version, 3);
    let mut rows = up.rows;
    rows.sort_by_key(|r| r.index);
    assert_eq!(canon(&rows), canon(&short.rows));
    // Extend: the same rows as the extension of the version-3 file.
    let a = run_map(&cfg(6.0), &MapRunOptions { out: Some(dir.join("extend.jsonl")), resume: false, threads: Some(2), extend: true }, &cancel, &none).unwrap();
    let b = run_map(&cfg(6.0), &MapRunOptions { out: Some(v3.clone()), resume: false, threads: Some(2), extend: true }, &cancel, &none).unwrap();
    assert_eq!(a.extended, b.extended);
    assert_eq!(canon(&a.rows), canon(&b.rows));
    assert!(a.extended > 0);
    assert!(a.rows.iter().all(|r| r.settled || r.behaviour == Behaviour::NotSettled || r.t_end_s == 6.0));
    // Version 1 is read, never resumed.
    let v1 = v2.replacen("\"beamslider_map\":2", "\"beamslider_map\":1", 1);
    std::fs::write(dir.join("v1.jsonl"), &v1).unwrap();
    let e = run_map(&cfg(3.0), &MapRunOptions { out: Some(dir.join("v1.jsonl")), resume: true, threads: Some(2), extend: false }, &cancel, &none)
        .unwrap_err()
        .to_string();
    assert!(e.contains("format version 1"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The text table marks a behaviour reached but not settled with `*`.
#[test]
fn text_table_marks_unsettled_rows() {
    let cfg = small(2.0);
    let cancel = AtomicBool::new(false);
    let mut o = run_map(&cfg, &MapRunOptions::default(), &cancel, &none).unwrap();
    for r in &mut o.rows {
        r.behaviour = beamslider_core::Behaviour::TrivialAdaption;
        r.settled = true;
    }
    o.rows[0].settled = false;
    let t = map::text_table(&o.rows);
    assert_eq!(t.matches("T*").count(), 1, "{t}");
    assert!(t.contains("* reached, not yet settled"), "{t}");
    o.rows[0].behaviour = beamslider_core::Behaviour::NotSettled;
    assert_eq!(map::text_table(&o.rows).matches('*').count(), 1);
}

/// The checkpointed run continued with `run_from` is bitwise the run that never stopped.
#[test]
fn run_from_checkpoint_is_bitwise_the_uninterrupted_run() {
    use beamslider_core::{Channel, Excitation, MemoryRecorder, Model, Params, RunOptions, SliderModel};
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let start = model.initial_state(0.3, &exc).unwrap();
    let opts = |d: f64| RunOptions {
        excitation: exc,
        model: SliderModel::Free,
        duration_s: d,
        record_every: 7,
        channels: vec![Channel::W4L7, Channel::S, Channel::Percussions],
        audit_contacts: false,
    };
    let mut whole = MemoryRecorder::new();
    let (sum_whole, _) = model.run_checkpointed(&start, &opts(0.5), &mut whole, &mut ()).unwrap();
    let mut first = MemoryRecorder::new();
    let (_, cp) = model.run_checkpointed(&start, &opts(0.2), &mut first, &mut ()).unwrap();
    let mut second = MemoryRecorder::new();
    let (sum, _) = model.run_from(&cp, &opts(0.5), &mut second, &mut ()).unwrap();
    assert_eq!(sum.state, sum_whole.state);
    assert_eq!(sum.counters, sum_whole.counters);
    let bits = |r: &MemoryRecorder| r.data.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut joined = bits(&first);
    joined.extend(bits(&second));
    assert_eq!(joined, bits(&whole));
}
