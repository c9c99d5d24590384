//! `beamslider-batch map --predictor LAW.json`: a map predicted by the reduced super-slow model
//! (docs/model.md §6.3) through the map results writer: header, resume, refusals, clear errors.

use std::process::Stdio;

use crate::common::{bin, rows};

/// A small law file in the format of `beamslider.slowflow.save_drift_law` (features amp_rel, s):
/// V < 0 on the low branch, a zero of V on the high branch between s = 0.35 and 0.40.
const LAW: &str = r#"{"kind": "beamslider drift law", "version": 1,
 "features": ["amp_rel", "s"], "k": 2,
 "x": {"L": [[0.1, 0.25], [0.1, 0.45]],
       "H": [[0.9, 0.35], [0.9, 0.40]]},
 "v": {"L": [-0.004, -0.004], "H": [0.01, -0.01]},
 "mean": [0.5, 0.35], "std": [0.4, 0.1],
 "lo": [0.1, 0.25], "hi": [0.9, 0.45], "points": [[124.0, 14.0], [120.0, 12.0]]}"#;

#[test]
fn predicted_map_writes_resumes_and_refuses() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-predictor-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let law = dir.join("law.json");
    std::fs::write(&law, LAW).unwrap();
    let cfg = dir.join("map.toml");
    std::fs::write(&cfg, "duration_s = 120.0\n[grid]\nf_ex_hz = [110.0, 124.0]\na_ex_m_s2 = [14.0]\n").unwrap();
    let out = dir.join("pm");
    let o = bin().args(["map", "-q", "-c"]).arg(&cfg).arg("-o").arg(&out).arg("--predictor").arg(&law).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("map.jsonl")).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.contains("\"predictor\":{") && header.contains("\"kind\":\"drift_law_knn\""), "{header}");
    let first = rows(&out.join("map.jsonl"));
    assert_eq!(first.len(), 2);
    assert!(first.iter().all(|r| r.contains("\"status\":\"predicted\"")), "{first:?}");
    // Existing results: refused without --resume; an FS map does not resume a predicted one.
    let st = bin()
        .args(["map", "-q", "-c"])
        .arg(&cfg)
        .arg("-o")
        .arg(&out)
        .arg("--predictor")
        .arg(&law)
        .stderr(Stdio::null())
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(!st.success());
    let o = bin().args(["map", "-q", "--resume", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("predicted map"), "{}", String::from_utf8_lossy(&o.stderr));
    // Resume with a larger grid keeps the rows and adds the new point.
    std::fs::write(&cfg, "duration_s = 120.0\n[grid]\nf_ex_hz = [110.0, 124.0, 126.0]\na_ex_m_s2 = [14.0]\n").unwrap();
    let o = bin().args(["map", "-q", "--resume", "-c"]).arg(&cfg).arg("-o").arg(&out).arg("--predictor").arg(&law).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let after = rows(&out.join("map.jsonl"));
    assert_eq!(after.len(), 3);
    assert_eq!(&after[..2], &first[..]);
    // Deterministic: a fresh predicted map gives the same rows.
    let o = bin().args(["map", "-q", "-j", "1", "-c"]).arg(&cfg).arg("-o").arg(dir.join("pm2")).arg("--predictor").arg(&law).output().unwrap();
    assert!(o.status.success());
    assert_eq!(rows(&dir.join("pm2/map.jsonl")), after);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_or_missing_law_is_a_one_line_error() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-predictor-bad-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{\"kind\": \"something else\"}").unwrap();
    let wrong = dir.join("wrong.json");
    std::fs::write(&wrong, LAW.replace("\"amp_rel\"", "\"slope_mu\"")).unwrap();
    for (law, needle) in [(dir.join("missing.json"), "missing.json"), (bad.clone(), "not a beamslider drift law"), (wrong.clone(), "features")] {
        let o = bin().args(["map", "-q", "-o"]).arg(dir.join("out")).arg("--predictor").arg(&law).output().unwrap();
        assert_eq!(o.status.code(), Some(1));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{err}");
        assert!(!dir.join("out/map.jsonl").exists(), "nothing written for a bad law");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
