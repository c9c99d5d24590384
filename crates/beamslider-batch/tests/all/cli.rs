//! Smoke tests of the `beamslider-batch` binary.

use crate::common::bin;

#[test]
fn help_lists_simulate() {
    let out = bin().arg("--help").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("simulate"), "{text}");
    let out = bin().args(["simulate", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for flag in ["--params", "--f-ex", "--a-ex", "--s0", "--duration", "--model", "--out"] {
        assert!(text.contains(flag), "missing {flag}: {text}");
    }
}

#[test]
fn simulate_writes_csv_with_header() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("run.csv");
    let st = bin().args(["simulate", "-q", "--duration", "0.05", "--out"]).arg(&out).status().unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "t_s,w_4L7_m,s,zC_m,beta_rad");
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 251);
    assert!((rows[250][0] - 0.05).abs() < 1e-12);
    assert!((rows[0][2] - 0.3).abs() < 1e-15);
    // PCS through a parameter file.
    let pfile = dir.join("p.toml");
    std::fs::write(&pfile, "n_modes = 3\ncontact_solver = \"reference\"\n").unwrap();
    let st = bin()
        .args(["simulate", "-q", "--duration", "0.01", "--model", "pcs", "--s-pcs", "0.25", "--channels", "t,w,q", "--params"])
        .arg(&pfile)
        .args(["--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let header = std::fs::read_to_string(&out).unwrap().lines().next().unwrap().to_string();
    assert_eq!(header, "t_s,w_4L7_m,q1,q2,q3");
}

#[test]
fn bad_input_gives_clear_error_and_nonzero_exit() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pfile = dir.join("bad.toml");
    std::fs::write(&pfile, "gap_ratio = 0.9\n").unwrap();
    let out = bin().args(["simulate", "--out", "-", "--params"]).arg(&pfile).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("gap_ratio"), "{err}");
    let out = bin().args(["simulate", "--out", "-", "--s0", "0.01"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("s0"));
    let out = bin().args(["simulate", "--out", "-", "--channels", "t,nonsense"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nonsense"));
}
