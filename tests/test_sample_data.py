"""The sample measured file of examples/data/ and gzip support of read_measurement."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider.measurement import MeasurementFormatError, write_measurement

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = ROOT / "examples" / "data" / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt.gz"


def test_sample_file_reads_with_its_operating_point():
    m = beamslider.read_measurement(SAMPLE)
    assert (m.f_ex, m.a_ex, m.s0) == (124.0, 14.0, 0.3)
    assert m.dt == pytest.approx(1e-4, rel=1e-9) and m.t[-1] == pytest.approx(20.0)
    assert abs(m.s[0] - 0.3) < 0.005 and np.all(np.isfinite(m.w))
    assert SAMPLE.stat().st_size < 4e6


def test_sample_readme_states_the_hidden_parameter():
    text = (ROOT / "examples" / "data" / "README.md").read_text(encoding="utf-8")
    assert "friction_coefficient` = 0.26" in text and "10.18419/darus-2883" in text
    script = (ROOT / "scripts" / "tooling" / "make_sample_data.py").read_text(encoding="utf-8")
    assert "Parameters(friction_coefficient=0.26)" in script


def test_gz_reads_like_plain(tmp_path):
    t = np.arange(2000) * 1e-4
    v = 0.01 * np.sin(2 * np.pi * 124 * t)
    s = 0.3 + 0.0 * t
    plain = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    write_measurement(plain, t, v, s)
    gz = plain.with_name(plain.name + ".gz")
    gz.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = beamslider.read_measurement(plain), beamslider.read_measurement(gz)
    assert (b.f_ex, b.a_ex, b.s0) == (a.f_ex, a.a_ex, a.s0)
    assert np.array_equal(a.w, b.w) and np.array_equal(a.s, b.s)


def test_corrupt_or_truncated_gz_is_a_format_error(tmp_path):
    bad = tmp_path / "x.txt.gz"
    bad.write_bytes(b"not gzip at all\n")
    with pytest.raises((MeasurementFormatError, OSError)) as e:
        beamslider.read_measurement(bad)
    assert "x.txt.gz" in str(e.value)
    trunc = tmp_path / "y.txt.gz"
    trunc.write_bytes(gzip.compress(b"0 1 0.3\n0.0001 1 0.3\n" * 100)[:-20])
    with pytest.raises(MeasurementFormatError, match="y.txt.gz"):
        beamslider.read_measurement(trunc)
