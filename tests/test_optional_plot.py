"""matplotlib is an optional extra (``pip install "beamslider[plot]"``): computing works without it,
and asking for a figure raises an ImportError that names the extra. matplotlib is hidden from a
fresh interpreter by a meta-path hook, so this runs whether or not it is installed."""

from __future__ import annotations

import subprocess
import sys
import textwrap

HIDE = textwrap.dedent("""
    import sys
    class _NoMpl:
        def find_spec(self, name, path=None, target=None):
            if name == "matplotlib" or name.startswith("matplotlib."):
                raise ImportError("No module named 'matplotlib' (hidden by the test)")
            return None
    sys.meta_path.insert(0, _NoMpl())
""")


def _run(code: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", HIDE + textwrap.dedent(code), *args], capture_output=True,
                          text=True, timeout=300)


def test_compute_without_matplotlib_and_plot_names_the_extra():
    r = _run("""
        import beamslider
        from beamslider.plotting import plot_manifold, plot_operating_point
        r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=0.5)
        assert r.completed and len(r.t) > 10
        assert "matplotlib" not in sys.modules
        for f, args in ((plot_operating_point, (r,)), (beamslider.plot_operating_map, ({},))):
            try:
                f(*args)
            except ImportError as e:
                assert 'pip install "beamslider[plot]"' in str(e), e
            else:
                raise SystemExit(f"{f.__name__} did not raise")
        print("ok")
    """)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ok"


def test_cli_skips_the_figure_with_a_note(tmp_path):
    code = "import sys; from beamslider.cli import main; sys.exit(main(sys.argv[1:]))"
    r = _run(code, "simulate", "--t-end", "0.5", "--no-manifold", "--no-progress", "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr
    assert "figure skipped" in r.stderr and 'beamslider[plot]' in r.stderr
    assert sorted(p.suffix for p in (tmp_path / "o").iterdir()) == [".json", ".npz"]
    r = _run(code, "plot", str(tmp_path / "o" / "fs_124Hz_14ms2_s0_0p3.json"), "--out", str(tmp_path / "p"))
    assert r.returncode == 1
    assert r.stderr.count("\n") == 1 and 'beamslider[plot]' in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "p").exists()
