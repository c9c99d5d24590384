"""One home per format and formula: the Python package writes and reads through the core's
letter table, manifold CSV, design results file, blocked envelope and backbone (docs/model.md §6–§9).
The expected texts are written out here by hand (independent references)."""

import json
import math

import numpy as np
import pytest

import beamslider
from beamslider import _core, enma, maps
from beamslider.cli._files import read_manifold_csv, write_manifold_csv
from beamslider.design import DesignConfig
from beamslider.design.results import DesignWriter, read_design_file, read_designs
from beamslider.simulate import blocked_envelope

HEAD = ("rows a_ex [m/s^2], columns f_ex [Hz]; I inactivity, T trivial adaption, S signature move, R relaxation "
        "oscillation, D self-damping, N not settled, ? undetermined, . not run; * reached, not yet settled")


def _table(status, t_end=(120.0, 120.0, 60.0)):
    return {"s0": np.array([0.3, 0.3, 0.3]), "f_ex_hz": np.array([120.0, 124.0, 120.0]),
            "a_ex_m_s2": np.array([6.0, 6.0, 14.0]), "t_end_s": np.array(t_end), "status": np.array(status),
            "behaviour": np.array(["trivial_adaption", "signature_move", "not_settled"]),
            "settled": np.array([False, True, False])}


def test_letter_table_is_the_cores():
    t = _table(["completed", "completed", "left_beam"])
    want = (f"s0 = 0.3, t_end = 120 s; {HEAD}\n"
            "   a\\f  120 124\n"
            "    14    N   .\n"
            "     6   T*   S\n")
    assert maps.text_table(t) == want
    assert maps.text_table(t, 0.4) == ""
    t = _table(["predicted"] * 3, t_end=(120.0, 120.0, 120.0))
    assert maps.t_end_text(t) == "predicted, t_end = 120 s"
    assert maps.text_table(t).startswith(f"s0 = 0.3, predicted, t_end = 120 s; {HEAD}\n")
    t = _table(["completed"] * 3)
    assert maps.t_end_text(t) == "t_end = 120 s (settled points kept from 60 s)"
    with pytest.raises(ValueError, match="same length"):
        _core.map_text_table(([0.3], [], [], [], [], [], []))


def test_manifold_csv_is_the_cores_and_reads_back_exactly(tmp_path):
    m = beamslider.ManifoldResult(up_s=np.array([0.1, 0.30000000000000004]), up_amplitude=np.array([1.2345678901234e-3, 2e-4]),
                                  down_s=np.array([0.5]), down_amplitude=np.array([3.1e-3]), counters={}, f_ex=124.0,
                                  a_ex=14.0, periods=100, record=25, params=beamslider.Parameters())
    path = tmp_path / "manifold_124Hz_14ms2_100periods.csv"
    write_manifold_csv(path, m)
    assert path.read_text() == ("branch,s,amplitude_m\nup,0.1,1.2345678901234e-3\nup,0.30000000000000004,2e-4\n"
                                "down,0.5,3.1e-3\n")
    back = read_manifold_csv(path, f_ex=124.0, a_ex=14.0, params=m.params)
    assert back.up_s.tolist() == m.up_s.tolist() and back.up_amplitude.tolist() == m.up_amplitude.tolist()


def test_backbone_is_the_single_mode_formula():
    a = np.linspace(0.0, 3.0, 7)
    w2, b = 3.1e5, 9.5e5
    np.testing.assert_array_equal(enma.backbone_hz(w2, b, a), np.sqrt(w2 + 0.75 * b * a * a) / (2 * math.pi))
    assert enma.backbone_hz(w2, -9.5e5, 2.0) == 0.0  # clamped at 0 where a softening backbone ends
    assert np.shape(enma.backbone_hz(w2, b, [[1.0, 2.0]])) == (1, 2)


def test_blocked_envelope_of_a_short_signal_is_the_whole_fft():
    t = np.arange(5000) * 1e-3
    w = (1 + 0.2 * np.sin(t)) * np.cos(2 * np.pi * 100 * t)
    np.testing.assert_array_equal(blocked_envelope(t, w, 0.1), beamslider.envelope(t, w, 0.1))
    long = blocked_envelope(t, w, 0.1, block=1024, margin=128)
    assert np.max(np.abs(long - beamslider.envelope(t, w, 0.1))) < 1e-2
    with pytest.raises(ValueError, match="window"):
        blocked_envelope(t, w, 0.0)


def test_design_file_through_the_core(tmp_path):
    cfg = DesignConfig(variables=[dict(name="gap_ratio", low=1.02, high=1.2)], f_lo_hz=120.0, f_hi_hz=124.0,
                       f_step_hz=4.0, a_ex_m_s2=[14.0], t_end_s=1.5)
    path = tmp_path / "run" / "design.jsonl"
    w = DesignWriter(cfg, path, False)
    w.add({"key": "a", "x": [0.1]})
    w.close()
    header = path.read_text().splitlines()[0]
    assert json.loads(header)["beamslider_design"] == 1
    # A file as the earlier Python writer left it after a kill: a torn last line.
    path.write_text(f'{header}\n{json.dumps({"key": "a", "x": [0.1]})}\n{{"key": "b", "x"')
    head, records, good = read_design_file(path.parent)
    assert [r["key"] for r in records] == ["a"] and good == len(header) + 1 + len(json.dumps({"key": "a", "x": [0.1]})) + 1
    w = DesignWriter(cfg, path, True)
    assert "a" in w and "b" not in w
    w.add({"key": "c"})
    w.close()
    assert path.read_text().splitlines()[1:] == ['{"key": "a", "x": [0.1]}', '{"key": "c"}']
    assert read_designs(path).header == head
    path.write_text(f'{header}\n{{"key": \n{{"key": "c"}}\n')
    with pytest.raises(ValueError, match=r"design.jsonl:2"):
        read_design_file(path)
    path.write_text('{"beamslider_map": 3}\n')
    with pytest.raises(ValueError, match="beamslider_design"):
        read_design_file(path)
    with pytest.raises(FileExistsError):
        DesignWriter(cfg, path, False)
