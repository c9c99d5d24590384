"""Outputs are never overwritten silently: file names carry the settings that distinguish them,
an existing file is refused without --force, and a refused run creates nothing. One column name
(``branch``) for the manifold in both front ends; the old ``sweep`` still reads."""

from __future__ import annotations

import json

import numpy as np

import beamslider
from beamslider.cli import manifold_file_stem, read_manifold_csv
from conftest import is_png, run_cli

FAST = ["--manifold-s", "0.2,0.3", "--manifold-periods", "4", "--manifold-record", "2", "--no-progress"]


def test_manifold_names_carry_the_settings():
    assert manifold_file_stem(124, 14, 100) == "manifold_124Hz_14ms2_100periods"
    assert manifold_file_stem(124, 14, 300) == "manifold_124Hz_14ms2_300periods"
    assert manifold_file_stem(124, 14, 100, 50) == "manifold_124Hz_14ms2_100periods_avg50"
    a = manifold_file_stem(124, 14, 100, 25, [0.2, 0.3])
    b = manifold_file_stem(124, 14, 100, 25, [0.2, 0.35])
    assert a != b and a.startswith("manifold_124Hz_14ms2_100periods_s")


def test_other_periods_do_not_touch_the_main_jobs_manifold(tmp_path):
    """The issue: `beamslider manifold` replaced the main job's manifold, so `beamslider plot` of
    the main job showed the other one."""
    r = run_cli("simulate", "--t-end", "0.2", *FAST, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "beamslider-out"
    meta = json.loads((out / "fs_124Hz_14ms2_s0_0p3.json").read_text())
    main_csv = out / meta["manifold_csv"]
    before = main_csv.read_bytes()
    r = run_cli("manifold", *FAST[:-5], "--manifold-periods", "6", "--manifold-record", "2", "--no-progress", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert main_csv.read_bytes() == before
    assert len(list(out.glob("manifold_124Hz_14ms2_6periods_avg2_s*.csv"))) == 1


def test_refuses_to_overwrite_without_force(tmp_path):
    args = ["simulate", "--t-end", "0.2", "--no-manifold", "--no-progress", "--out", "o"]
    assert run_cli(*args, cwd=tmp_path).returncode == 0
    csv = tmp_path / "o" / "fs_124Hz_14ms2_s0_0p3.npz"
    before = csv.read_bytes()
    r = run_cli(*args[:2], "0.3", *args[3:], cwd=tmp_path)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "exists" in r.stderr and "--force" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert csv.read_bytes() == before
    r = run_cli(*args[:2], "0.3", *args[3:], "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert csv.read_bytes() != before


def test_refused_runs_create_nothing(tmp_path):
    for args in (["simulate", "--s0", "0.99", "--t-end", "0.1"], ["simulate", "--dt", "1e-3"],
                 ["manifold", "--manifold-s", "a:b"], ["manifold", "--manifold-periods", "2", "--manifold-record", "5"],
                 ["compare", "missing.txt"], ["plot", "missing.json"]):
        r = run_cli(*args, "--out", "never", cwd=tmp_path)
        assert r.returncode != 0, args
        assert not (tmp_path / "never").exists(), args


def test_old_sweep_column_still_reads(tmp_path):
    old = tmp_path / "manifold_124Hz_14ms2.csv"
    old.write_text("sweep,s,amplitude_m\nup,0.2,1e-4\nup,0.3,2e-4\ndown,0.3,3e-4\ndown,0.2,4e-4\n")
    m = read_manifold_csv(old, f_ex=124, a_ex=14, params=beamslider.Parameters())
    assert list(m.up_s) == [0.2, 0.3] and list(m.down_amplitude) == [3e-4, 4e-4]
    new = tmp_path / "manifold_124Hz_14ms2_100periods.csv"
    new.write_text(old.read_text().replace("sweep,", "branch,"))
    m = read_manifold_csv(new, f_ex=124, a_ex=14, params=beamslider.Parameters())
    assert m.periods == 100 and list(m.up_amplitude) == [1e-4, 2e-4]


def test_figure_of_a_diverged_run_says_so(tmp_path):
    from beamslider.plotting import plot_operating_point

    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = beamslider.simulate(f_ex=124, a_ex=1e6, s0=0.3, t_end=0.05)
    assert not r.completed
    fig = plot_operating_point(r, path=tmp_path / "d.png")
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any(r.status in t and "no super-slow amplitude" in t for t in texts), texts
    assert is_png(tmp_path / "d.png")
    ax_a = fig.axes[0]
    assert ax_a.get_xlabel() == "time t [s]"
    assert "h = beam thickness" in fig._supxlabel.get_text()
    assert np.isfinite(r.t[-1])


def test_default_overlay_is_the_hb_manifold_and_plot_reads_it_back(tmp_path):
    """The default overlay of panel (c) is the harmonic-balance manifold (milliseconds),
    written as hb_manifold_<f>Hz_<a>ms2_N5.csv; `beamslider plot` draws it again from that file."""
    r = run_cli("simulate", "--t-end", "0.2", "--no-progress", "--out", "o", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "o"
    meta = json.loads((out / "fs_124Hz_14ms2_s0_0p3.json").read_text())
    assert meta["manifold_csv"] == "hb_manifold_124Hz_14ms2_N5.csv"
    m = read_manifold_csv(out / meta["manifold_csv"], f_ex=124, a_ex=14, params=beamslider.Parameters())
    hb = beamslider.superslow.hb_manifold(f_ex=124, a_ex=14)
    assert m.n_modes == 5 and len(m.high.s) == len(hb.high.s) and len(m.low.s) == len(hb.low.s) > 0
    np.testing.assert_allclose(m.high.amplitude, hb.high.amplitude, rtol=1e-9)  # independent recomputation
    assert not list(out.glob("manifold_*"))  # no PCS sweep was run
    r = run_cli("plot", str(out / "fs_124Hz_14ms2_s0_0p3.json"), "--out", "p", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert is_png(tmp_path / "p" / "fs_124Hz_14ms2_s0_0p3.png")


def test_manifold_kind_options(tmp_path):
    """--manifold pcs|none, PCS options imply pcs, a PCS option with --manifold hb is refused in one line."""
    r = run_cli("simulate", "--t-end", "0.1", "--manifold", "none", "--no-progress", "--out", "n", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(p.suffix for p in (tmp_path / "n").iterdir()) == [".json", ".npz", ".png"]
    r = run_cli("simulate", "--t-end", "0.1", *FAST, "--out", "p", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert len(list((tmp_path / "p").glob("manifold_124Hz_14ms2_4periods_avg2_s*.csv"))) == 1
    r = run_cli("simulate", "--t-end", "0.1", "--manifold", "hb", "--manifold-periods", "4", "--out", "x", cwd=tmp_path)
    assert r.returncode != 0 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "--manifold-periods" in r.stderr and "--manifold pcs" in r.stderr
    assert not (tmp_path / "x").exists()
    r = run_cli("simulate", "--t-end", "0.1", "--a-ex", "0", "--manifold", "hb", "--out", "z", cwd=tmp_path)
    assert r.returncode != 0 and "a_ex > 0" in r.stderr and "Traceback" not in r.stderr
