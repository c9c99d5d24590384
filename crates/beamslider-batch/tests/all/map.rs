//! `beamslider-batch map`: kill a map mid-run, resume it, compare with an uninterrupted run.

use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common::{bin, rows};

#[test]
fn killed_map_resumes_without_loss_or_duplicates() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-map-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("map.toml");
    std::fs::write(&cfg, "duration_s = 3.0\n[grid]\nf_ex_hz = { start = 110.0, stop = 130.0, step = 2.0 }\na_ex_m_s2 = [6.0, 10.0, 14.0]\n").unwrap();
    let n_points = 33;
    // Uninterrupted reference.
    let st = bin().args(["map", "-q", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(dir.join("full")).stdout(Stdio::null()).status().unwrap();
    assert!(st.success());
    let full = rows(&dir.join("full/map.jsonl"));
    assert_eq!(full.len(), n_points);
    // Killed run: one thread, killed once a few rows are in.
    let killed = dir.join("killed");
    let mut child = bin().args(["map", "-q", "-j", "1", "-c"]).arg(&cfg).arg("-o").arg(&killed).stdout(Stdio::null()).spawn().unwrap();
    let results = killed.join("map.jsonl");
    let t0 = Instant::now();
    loop {
        let n = std::fs::read_to_string(&results).map(|t| t.lines().count()).unwrap_or(0);
        if n >= 4 || t0.elapsed() > Duration::from_secs(60) {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = rows(&results);
    assert!(!before.is_empty() && before.len() < n_points, "killed after {} rows", before.len());
    // Every row written before the kill is a row of the reference.
    for r in &before {
        assert!(full.contains(r), "{r}");
    }
    // Simulate a kill in the middle of a write as well: append half a row.
    let mut text = std::fs::read_to_string(&results).unwrap();
    text.push_str("{\"index\":99,\"f_ex_hz\":1");
    std::fs::write(&results, text).unwrap();
    // Without --resume the folder is refused.
    let st = bin().args(["map", "-q", "-c"]).arg(&cfg).arg("-o").arg(&killed).stdout(Stdio::null()).stderr(Stdio::null()).status().unwrap();
    assert!(!st.success());
    let out = bin().args(["map", "-q", "--resume", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(&killed).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(&format!("{} from the results file", before.len())), "{stderr}");
    let after = rows(&results);
    assert_eq!(after, full, "resumed map differs from the uninterrupted one");
    // The letter table was written.
    let table = std::fs::read_to_string(killed.join("map.txt")).unwrap();
    assert_eq!(table.lines().count(), 5, "{table}");
}

#[test]
fn print_config_is_the_papers_map() {
    let out = bin().args(["map", "--print-config", "-o", "unused"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("duration_s = 120.0"), "{text}");
    assert!(text.contains("start = 100.0") && text.contains("stop = 130.0"), "{text}");
}

/// `--extend-to T` continues the not-settled points of the map in DIR (configuration from
/// DIR/map.toml), prints how many it re-ran, and refuses T ≤ the map's duration.
#[test]
fn extend_to_reruns_the_not_settled_points() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-extend-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("c.toml");
    std::fs::write(&cfg, "duration_s = 2.0\n[grid]\nf_ex_hz = [100.0, 124.0]\na_ex_m_s2 = [4.0, 14.0]\n").unwrap();
    let out = dir.join("m");
    let st = bin().args(["map", "-q", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(&out).status().unwrap();
    assert!(st.success());
    let o = bin().args(["map", "-q", "-j", "2", "--extend-to", "3", "-o"]).arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("re-ran") && err.contains("(settled = false, or undetermined)"), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("t_end = 3 s"));
    let o = bin().args(["map", "-q", "--extend-to", "2.5", "-o"]).arg(&out).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("extend-to"));
    let _ = std::fs::remove_dir_all(&dir);
}
