//! Bad input to `beamslider-batch`, tried on purpose (docs/guide/reliability.md): every case
//! must exit non-zero with a message naming the field, file or line, print no panic or
//! backtrace, and overwrite nothing. Faults: a blow-up stops with a status and the time, solver
//! cap hits are reported, a map with failing points finishes the others and lists the failures,
//! and SIGTERM / SIGINT during a map leave a results file that `--resume` completes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::{bin, rows};

fn tmp(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bsb-bad-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SENTINEL: &str = "KEEP: an earlier result that bad input must not overwrite\n";

/// One bad input: a parameter file body (None: no --params), the extra arguments, and the words
/// the one-line error must contain.
struct Case {
    params: Option<&'static [u8]>,
    args: &'static [&'static str],
    words: &'static [&'static str],
}

fn check(out: &Output, words: &[&str], what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{what}: exit status 0\n{err}");
    assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "{what}: panic\n{err}");
    for w in words {
        assert!(err.contains(w), "{what}: message does not name {w:?}:\n{err}");
    }
}

const SIMULATE_CASES: &[Case] = &[
    // excitation, initial state, run options: NaN / inf / out of range / wrong type
    Case { params: None, args: &["--f-ex", "nan"], words: &["f_ex_hz"] },
    Case { params: None, args: &["--f-ex", "inf"], words: &["f_ex_hz"] },
    Case { params: None, args: &["--f-ex", "-5"], words: &["f_ex_hz"] },
    Case { params: None, args: &["--f-ex", "0"], words: &["f_ex_hz"] },
    Case { params: None, args: &["--f-ex", "1e6"], words: &["f_ex_hz", "dt_s"] },
    Case { params: None, args: &["--f-ex", "abc"], words: &["--f-ex"] },
    Case { params: None, args: &["--a-ex", "-1"], words: &["a_ex_m_s2"] },
    Case { params: None, args: &["--a-ex", "nan"], words: &["a_ex_m_s2"] },
    Case { params: None, args: &["--a-ex", "inf"], words: &["a_ex_m_s2"] },
    Case { params: None, args: &["--s0", "0.99"], words: &["s0"] },
    Case { params: None, args: &["--s0", "-0.3"], words: &["s0"] },
    Case { params: None, args: &["--s0", "nan"], words: &["s0"] },
    Case { params: None, args: &["--duration", "-1"], words: &["duration_s"] },
    Case { params: None, args: &["--duration", "nan"], words: &["duration_s"] },
    Case { params: None, args: &["--duration", "inf"], words: &["duration_s"] },
    Case { params: None, args: &["--record-every", "0"], words: &["record_every"] },
    Case { params: None, args: &["--record-every", "-3"], words: &["record-every"] },
    Case { params: None, args: &["--record-every", "2.5"], words: &["record-every"] },
    Case { params: None, args: &["--channels", "t,nonsense"], words: &["nonsense"] },
    Case { params: None, args: &["--channels", "t,w@1.0"], words: &["w@x"] },
    Case { params: None, args: &["--channels", "t,w@abc"], words: &["w@abc"] },
    Case { params: None, args: &["--model", "pcs"], words: &["--s-pcs"] },
    Case { params: None, args: &["--model", "pcs", "--s-pcs", "5"], words: &["s_pcs"] },
    Case { params: None, args: &["--model", "pcs", "--s-pcs", "nan"], words: &["s_pcs"] },
    Case { params: None, args: &["--model", "xyz"], words: &["--model"] },
    Case { params: None, args: &["--solver", "magic"], words: &["--solver"] },
    Case { params: None, args: &["--no-such-flag"], words: &["--no-such-flag"] },
    Case { params: None, args: &["--params", "/nonexistent/p.toml"], words: &["/nonexistent/p.toml"] },
    // parameter files: out of range, physically impossible, wrong types, unknown / garbled keys
    Case { params: Some(b"gap_ratio = 0.9\n"), args: &[], words: &["gap_ratio"] },
    Case { params: Some(b"gap_ratio = 1.0\n"), args: &[], words: &["gap_ratio"] },
    Case { params: Some(b"length_m = 0.0\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"length_m = -0.14\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"length_m = nan\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"length_m = inf\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"thickness_m = 0.2\n"), args: &[], words: &["gap_ratio", "length_m"] },
    Case { params: Some(b"contact_spacing_m = 0.5\n"), args: &[], words: &["contact_spacing_m"] },
    Case { params: Some(b"youngs_modulus_pa = inf\n"), args: &[], words: &["youngs_modulus_pa"] },
    Case { params: Some(b"slider_mass_kg = 0\n"), args: &[], words: &["slider_mass_kg"] },
    Case { params: Some(b"slider_inertia_kg_m2 = -1e-6\n"), args: &[], words: &["slider_inertia_kg_m2"] },
    Case { params: Some(b"density_kg_m3 = 0.0\n"), args: &[], words: &["density_kg_m3"] },
    Case { params: Some(b"k_r_nm_per_rad = -1.0\n"), args: &[], words: &["k_r_nm_per_rad"] },
    Case { params: Some(b"k_t_n_per_m = nan\n"), args: &[], words: &["k_t_n_per_m"] },
    Case { params: Some(b"k_r_nm_per_rad = 1255e-324\n"), args: &[], words: &["k_r_nm_per_rad", "too small"] },
    Case { params: Some(b"damping_ratio = -1e-3\n"), args: &[], words: &["damping_ratio"] },
    Case { params: Some(b"friction_coefficient = -0.2\n"), args: &[], words: &["friction_coefficient"] },
    Case { params: Some(b"restitution = 1.5\n"), args: &[], words: &["restitution"] },
    Case { params: Some(b"gravity_m_s2 = -9.81\n"), args: &[], words: &["gravity_m_s2"] },
    Case { params: Some(b"axial_preload_n = inf\n"), args: &[], words: &["axial_preload_n"] },
    Case { params: Some(b"n_modes = 0\n"), args: &[], words: &["n_modes"] },
    Case { params: Some(b"n_modes = 21\n"), args: &[], words: &["n_modes"] },
    Case { params: Some(b"n_modes = -1\n"), args: &[], words: &["n_modes"] },
    Case { params: Some(b"n_modes = 2.5\n"), args: &[], words: &["n_modes"] },
    Case { params: Some(b"n_modes = \"five\"\n"), args: &[], words: &["n_modes"] },
    Case { params: Some(b"dt_s = 1e-3\n"), args: &[], words: &["dt_s", "highest"] },
    Case { params: Some(b"dt_s = 0.0\n"), args: &[], words: &["dt_s"] },
    Case { params: Some(b"dt_s = nan\n"), args: &[], words: &["dt_s"] },
    Case { params: Some(b"solver_max_iter = 0\n"), args: &[], words: &["solver_max_iter"] },
    Case { params: Some(b"solver_tol_rel = 0.0\n"), args: &[], words: &["solver_tol_rel"] },
    Case { params: Some(b"contact_solver = \"magic\"\n"), args: &[], words: &["contact_solver"] },
    Case { params: Some(b"contact_solver = 1\n"), args: &[], words: &["contact_solver"] },
    Case { params: Some(b"length_m = \"long\"\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"length_m = [0.14]\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"lenght_m = 0.14\n"), args: &[], words: &["lenght_m"] },
    Case { params: Some(b"[params]\nlength_m = 0.14\n"), args: &[], words: &["params"] },
    Case { params: Some(b"length_m = 0.14\nlength_m = 0.15\n"), args: &[], words: &["length_m"] },
    Case { params: Some(b"length_m = = 0.14\n"), args: &[], words: &["line 1"] },
    Case { params: Some(b"n_modes = 5\nlength_m = 0."), args: &[], words: &["line 2"] },
    Case { params: Some(b"length_m 0.14\n"), args: &[], words: &["line 1"] },
    Case { params: Some(b"\xff\xfe\x00garbage\x00"), args: &[], words: &["p.toml"] },
];

#[test]
fn simulate_bad_input_names_the_field_and_overwrites_nothing() {
    let d = tmp("simulate");
    let out = d.join("run.csv");
    let pfile = d.join("p.toml");
    for (i, case) in SIMULATE_CASES.iter().enumerate() {
        std::fs::write(&out, SENTINEL).unwrap();
        let mut cmd = bin();
        cmd.args(["simulate", "-q"]).args(case.args).arg("--out").arg(&out);
        if !case.args.contains(&"--duration") {
            cmd.args(["--duration", "0.01"]);
        }
        if let Some(body) = case.params {
            std::fs::write(&pfile, body).unwrap();
            cmd.arg("--params").arg(&pfile);
        }
        let o = cmd.output().unwrap();
        check(&o, case.words, &format!("simulate case {i} {:?}", case.args));
        assert_eq!(std::fs::read_to_string(&out).unwrap(), SENTINEL, "case {i}: output overwritten");
    }
    // The parameter file is a folder.
    let o = bin().args(["simulate", "-q", "--out"]).arg(&out).arg("--params").arg(&d).output().unwrap();
    check(&o, &[d.to_str().unwrap()], "params is a folder");
    // The output folder does not exist.
    let o = bin().args(["simulate", "-q", "--duration", "0.01", "--out"]).arg(d.join("no/such/dir/x.csv")).output().unwrap();
    check(&o, &["no/such/dir"], "output folder missing");
    // Manifold options.
    for (args, word) in [
        (&["--periods", "0"][..], "record_periods"),
        (&["--record", "0"][..], "record_periods"),
        (&["--periods", "10", "--record", "20"][..], "record_periods"),
        (&["--f-ex", "nan"][..], "f_ex_hz"),
    ] {
        std::fs::write(&out, SENTINEL).unwrap();
        let o = bin().args(["manifold", "-q"]).args(args).arg("--out").arg(&out).output().unwrap();
        check(&o, &[word], &format!("manifold {args:?}"));
        assert_eq!(std::fs::read_to_string(&out).unwrap(), SENTINEL, "manifold {args:?}: output overwritten");
    }
}

/// Map configurations: (TOML, words of the message).
const MAP_CASES: &[(&str, &[&str])] = &[
    ("duration_s = 1.0\n", &["grid"]),
    ("[grid]\na_ex_m_s2 = [6.0]\n", &["f_ex_hz"]),
    ("[grid]\nf_ex_hz = []\na_ex_m_s2 = [6.0]\n", &["grid.f_ex_hz"]),
    ("[grid]\nf_ex_hz = { start = 130.0, stop = 100.0, step = 2.0 }\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz"]),
    ("[grid]\nf_ex_hz = { start = 100.0, stop = 130.0, step = 0.0 }\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz"]),
    ("[grid]\nf_ex_hz = { start = 100.0, stop = 130.0, step = 1e-12 }\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz", "at most"]),
    ("[grid]\nf_ex_hz = { start = 100.0, stop = nan, step = 2.0 }\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz"]),
    ("[grid]\nf_ex_hz = [120.0, 120.0]\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz", "twice"]),
    ("[grid]\nf_ex_hz = [120.0, nan]\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz"]),
    ("[grid]\nf_ex_hz = [-120.0]\na_ex_m_s2 = 6.0\n", &["f_ex_hz"]),
    ("[grid]\nf_ex_hz = [1e6]\na_ex_m_s2 = 6.0\n", &["grid.f_ex_hz", "dt_s"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = [-6.0]\n", &["a_ex_m_s2"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = [inf]\n", &["a_ex_m_s2"]),
    ("[grid]\nf_ex_hz = [\"120\"]\na_ex_m_s2 = 6.0\n", &["f_ex_hz"]),
    ("[grid]\nf_ex_hz = { begin = 100.0, stop = 130.0, step = 2.0 }\na_ex_m_s2 = 6.0\n", &["f_ex_hz"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\ns0 = 0.99\n", &["grid.s0"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\ns0 = [0.3, 0.01]\n", &["grid.s0"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\nfrequency = 1.0\n", &["frequency"]),
    ("duration_s = 0.0\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["duration_s"]),
    ("duration_s = nan\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["duration_s"]),
    ("duration_s = -3.0\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["duration_s"]),
    ("record_every = 0\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["record_every"]),
    ("dt_s = 1e-3\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["dt_s"]),
    ("bogus = 1\n[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n", &["bogus"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n[params]\ngap_ratio = 0.5\n", &["gap_ratio"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n[params]\nlenght_m = 0.1\n", &["lenght_m"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n[params]\ndt_s = 1e-3\n", &["dt_s"]),
    ("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n[criteria]\nbogus = 1.0\n", &["bogus"]),
    ("[grid\nf_ex_hz = 120.0\n", &["line 1"]),
];

#[test]
fn map_bad_config_names_the_field_and_writes_nothing() {
    let d = tmp("mapcfg");
    let cfg = d.join("map-config.toml");
    for (i, (text, words)) in MAP_CASES.iter().enumerate() {
        std::fs::write(&cfg, text).unwrap();
        let out = d.join(format!("out{i}"));
        let o = bin().args(["map", "-q", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
        check(&o, words, &format!("map case {i} {text:?}"));
        assert!(!out.exists(), "map case {i}: output folder created");
    }
    let o = bin().args(["map", "-q", "-c"]).arg(d.join("missing.toml")).arg("-o").arg(d.join("o")).output().unwrap();
    check(&o, &["missing.toml"], "missing map config");
}

fn small_map(d: &Path, grid: &str) -> PathBuf {
    let cfg = d.join("map-config.toml");
    std::fs::write(&cfg, format!("duration_s = 0.3\nrecord_every = 10\n[grid]\n{grid}\n")).unwrap();
    cfg
}

#[test]
fn map_results_file_bad_input_overwrites_nothing() {
    let d = tmp("mapres");
    let cfg = small_map(&d, "f_ex_hz = [120.0, 124.0]\na_ex_m_s2 = 6.0");
    let out = d.join("out");
    let o = bin().args(["map", "-q", "-j", "1", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let results = out.join("map.jsonl");
    let good = std::fs::read_to_string(&results).unwrap();
    let toml = std::fs::read_to_string(out.join("map.toml")).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    assert_eq!(lines.len(), 3);
    // (results file body, extra args, config, words)
    let other = d.join("other.toml");
    std::fs::write(&other, "duration_s = 0.3\nrecord_every = 10\n[grid]\nf_ex_hz = [120.0, 124.0]\na_ex_m_s2 = 6.0\n[params]\nfriction_coefficient = 0.3\n")
        .unwrap();
    let garbled_middle = format!("{}\n{{\"index\":0,\"f_ex\n{}\n", lines[0], lines[2]);
    let garbled_last = format!("{}\n{}\nnot json at all\n", lines[0], lines[1]);
    let bad_header = format!("{{\"beamslider_map\":99,\"settings\":{{}}}}\n{}\n", lines[1]);
    let not_a_map = "hello\n".to_string();
    let cases: Vec<(String, Vec<&str>, &Path, Vec<&str>)> = vec![
        (good.clone(), vec![], &cfg, vec!["exists", "resume"]),
        (good.clone(), vec!["--resume"], other.as_path(), vec!["other settings"]),
        (garbled_middle, vec!["--resume"], &cfg, vec!["map.jsonl:2"]),
        (garbled_last, vec!["--resume"], &cfg, vec!["map.jsonl:3"]),
        (bad_header, vec!["--resume"], &cfg, vec!["format version 99"]),
        (not_a_map, vec!["--resume"], &cfg, vec!["map.jsonl:1"]),
    ];
    for (i, (body, args, config, words)) in cases.iter().enumerate() {
        std::fs::write(&results, body).unwrap();
        std::fs::write(out.join("map.toml"), &toml).unwrap();
        let o = bin().args(["map", "-q", "-c"]).arg(config).arg("-o").arg(&out).args(args).output().unwrap();
        check(&o, words, &format!("results case {i}"));
        assert_eq!(&std::fs::read_to_string(&results).unwrap(), body, "results case {i}: results file changed");
        assert_eq!(std::fs::read_to_string(out.join("map.toml")).unwrap(), toml, "results case {i}: map.toml overwritten");
    }
}

#[test]
fn blow_up_stops_with_status_and_time() {
    let d = tmp("blowup");
    let out = d.join("run.csv");
    let o = bin().args(["simulate", "-q", "--a-ex", "1e6", "--duration", "0.5", "--out"]).arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("stopped at t = "), "{err}");
    assert!(err.contains("left the") || err.contains("blew up"), "{err}");
    // The trajectory up to the fault is kept, and it is finite.
    let text = std::fs::read_to_string(&out).unwrap();
    let rows = text.lines().skip(1).count();
    assert!(rows > 1 && rows < 2501, "{rows} rows");
    assert!(!text.contains("NaN") && !text.contains("inf"));
}

#[test]
fn solver_cap_hits_are_reported_per_run() {
    let d = tmp("cap");
    let p = d.join("p.toml");
    std::fs::write(&p, "contact_solver = \"reference\"\nsolver_max_iter = 1\n").unwrap();
    let o = bin().args(["simulate", "-q", "--duration", "0.2", "--out"]).arg(d.join("r.csv")).arg("--params").arg(&p).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let hits: u64 = err.split(" cap hits").next().unwrap().rsplit(' ').next().unwrap().parse().unwrap();
    assert!(hits > 0, "{err}");
    // Map rows carry the counters of their run.
    let cfg = d.join("map.toml");
    std::fs::write(
        &cfg,
        "duration_s = 0.2\nrecord_every = 10\n[grid]\nf_ex_hz = 124.0\na_ex_m_s2 = 14.0\n[params]\ncontact_solver = \"reference\"\nsolver_max_iter = 1\n",
    )
    .unwrap();
    let o = bin().args(["map", "-q", "-c"]).arg(&cfg).arg("-o").arg(d.join("m")).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let row = std::fs::read_to_string(d.join("m/map.jsonl")).unwrap().lines().nth(1).unwrap().to_string();
    assert!(!row.contains("\"cap_hits\":0,"), "{row}");
}

#[test]
fn map_with_failing_points_finishes_the_others_and_lists_failures() {
    let d = tmp("failing");
    let cfg = small_map(&d, "f_ex_hz = [120.0, 124.0]\na_ex_m_s2 = [6.0, 1e6]");
    let out = d.join("out");
    let o = bin().args(["map", "-q", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("2 of 4 points failed"), "{err}");
    assert!(err.contains("#2 f_ex = 120 Hz, a_ex = 1000000") && err.contains("#3 f_ex = 124 Hz"), "{err}");
    let text = std::fs::read_to_string(out.join("map.jsonl")).unwrap();
    assert_eq!(text.lines().count(), 5);
    assert_eq!(text.matches("\"status\":\"completed\"").count(), 2, "{text}");
    // The failed rows read back (NaN features are null) and a resume computes nothing.
    let o = bin().args(["map", "-q", "--resume", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("0 computed") && err.contains("4 from the results file"), "{err}");
    assert_eq!(std::fs::read_to_string(out.join("map.jsonl")).unwrap(), text);
}

#[cfg(unix)]
#[test]
fn sigterm_and_sigint_during_a_map_then_resume_loses_nothing() {
    let d = tmp("signals");
    let cfg = d.join("map-config.toml");
    std::fs::write(&cfg, "duration_s = 10.0\nrecord_every = 10\n[grid]\nf_ex_hz = { start = 110.0, stop = 130.0, step = 2.0 }\na_ex_m_s2 = [6.0, 14.0]\n")
        .unwrap();
    let n_points = 22; // 10 s a point: long enough (about 1 s in all on one thread) for the signal to land mid-map on an idle machine
    let full = d.join("full");
    let st = bin().args(["map", "-q", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(&full).stdout(Stdio::null()).status().unwrap();
    assert!(st.success());
    let reference = rows(&full.join("map.jsonl"));
    assert_eq!(reference.len(), n_points);
    for signal in ["TERM", "INT"] {
        let out = d.join(signal);
        let mut cmd = bin();
        cmd.args(["map", "-q", "-j", "1", "-c"]).arg(&cfg).arg("-o").arg(&out).stdout(Stdio::null()).stderr(Stdio::null());
        // A test runner started in the background (or under nohup) passes SIGINT/SIGHUP on
        // ignored, and the binary rightly keeps an ignored signal ignored: give the child the
        // default dispositions, as a terminal would.
        use std::os::unix::process::CommandExt;
        unsafe {
            cmd.pre_exec(|| {
                libc::signal(libc::SIGINT, libc::SIG_DFL);
                libc::signal(libc::SIGTERM, libc::SIG_DFL);
                Ok(())
            });
        }
        let mut child = cmd.spawn().unwrap();
        let results = out.join("map.jsonl");
        let t0 = Instant::now();
        while std::fs::read_to_string(&results).map(|t| t.lines().count()).unwrap_or(0) < 4 && t0.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(5));
        }
        let st = Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap();
        assert!(st.success());
        let status = child.wait().unwrap();
        assert!(!status.success(), "SIG{signal}: the map finished before the signal");
        let before = rows(&results);
        assert!(!before.is_empty() && before.len() < n_points, "SIG{signal}: {} rows", before.len());
        let o = bin().args(["map", "-q", "--resume", "-j", "2", "-c"]).arg(&cfg).arg("-o").arg(&out).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(rows(&results), reference, "SIG{signal}: resumed map differs (lost or duplicated points)");
    }
}
