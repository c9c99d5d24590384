"""beamslider.read_measurement (docs/model.md §7): the published data-set format, integration of the
velocity, and errors naming file and line."""

import numpy as np
import pytest

from beamslider import MeasurementFormatError, parse_operating_point, read_measurement
from beamslider.measurement import write_measurement

NAME = "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
DT = 1e-4


def _signal(duration=2.0, amp=5e-4, f=124.0):
    t = np.arange(0, duration, DT)
    w = amp * np.sin(2 * np.pi * f * t)
    v = amp * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
    s = 0.3 - 0.01 * t
    return t, v, s, w


def _movmean(x, k):
    """Centred moving average, shrinking at the ends (k/2 before, k - 1 - k/2 after)."""
    before, after = k // 2, k - 1 - k // 2
    c = np.concatenate([[0.0], np.cumsum(x)])
    i = np.arange(len(x))
    lo, hi = np.maximum(i - before, 0), np.minimum(i + after + 1, len(x))
    return (c[hi] - c[lo]) / (hi - lo)


def test_generated_file(tmp_path):
    t, v, s, w = _signal()
    path = tmp_path / NAME
    write_measurement(path, t, v, s)
    m = read_measurement(path)
    assert (m.f_ex, m.a_ex, m.s0) == (124.0, 14.0, 0.3)
    assert m.path == path and m.dt == pytest.approx(DT)
    np.testing.assert_allclose(m.t, t, atol=1e-12)
    np.testing.assert_allclose(m.velocity, v, rtol=1e-9)
    np.testing.assert_allclose(m.s, s, rtol=1e-9)
    # docs/model.md §7 exactly: cumulative sum of v*dt minus its 0.1 s moving average.
    x = np.cumsum(m.velocity) * DT
    np.testing.assert_allclose(m.w, x - _movmean(x, 1000), rtol=0, atol=1e-12)
    # ... which recovers the displacement away from the ends (up to the rectangle rule's lag).
    inner = slice(2000, -2000) if len(t) > 4000 else slice(1000, -1000)
    assert np.max(np.abs(m.w[inner] - w[inner])) < 0.05 * 5e-4
    env = m.envelope(window=0.2)
    assert np.median(env[inner]) == pytest.approx(5e-4, rel=0.05)


def test_header_comments_and_separators(tmp_path):
    t, v, s, _ = _signal(0.05)
    lines = ["% exported", "Time VelBeam RelSliderPos"] + [f"{a:.6f},{b:.8e};{c:.6f}" for a, b, c in zip(t, v, s)]
    path = tmp_path / "fex104_ExcLevel6_RelSliderPosStart025.csv"
    path.write_text("\n".join(lines) + "\n")
    m = read_measurement(path)
    assert len(m.t) == len(t)
    assert (m.f_ex, m.a_ex, m.s0) == (104.0, 6.0, 0.25)


@pytest.mark.parametrize(
    "name,expected",
    [
        (NAME, (124.0, 14.0, 0.3)),
        ("Time_VelBeam_RelSliderPos__fex126_ExcLevel10_RelSliderPosStart03.txt", (126.0, 10.0, 0.3)),
        ("x_fex100p5_ExcLevel4_RelSliderPosStart05.txt", (100.5, 4.0, 0.5)),
        ("/some/dir/FEX124_exclevel14_relsliderposstart02.txt", (124.0, 14.0, 0.2)),
        ("measurement.txt", (None, None, None)),
    ],
)
def test_operating_point_from_name(name, expected):
    assert parse_operating_point(name) == expected


def _write(tmp_path, body, name="bad.txt"):
    path = tmp_path / name
    path.write_text(body)
    return path


@pytest.mark.parametrize(
    "body,line,what",
    [
        ("0.0 1.0 0.3\n0.0001 1.0\n0.0002 1.0 0.3\n", 2, "3 columns"),
        ("0.0 1.0 0.3\n0.0001 1.0 0.3 7\n", 2, "3 columns"),
        ("# c\n0.0 1.0 0.3\n0.0001 1.0 0.3\n0.0002 abc 0.3\n", 4, "non-numeric"),
        ("0.0 1.0 0.3\nTime Vel Pos\n", 2, "non-numeric"),
        ("0.0 1.0 0.3\n0.0002 1.0 0.3\n0.0001 1.0 0.3\n", 3, "does not increase"),
        ("0.0 1.0 0.3\n0.0 1.0 0.3\n", 2, "does not increase"),
        ("0.0 1.0 0.3\n0.0001 nan 0.3\n", 2, "non-finite"),
    ],
)
def test_malformed_files_name_file_and_line(tmp_path, body, line, what):
    path = _write(tmp_path, body)
    with pytest.raises(MeasurementFormatError) as e:
        read_measurement(path)
    msg = str(e.value)
    assert f"{path}:{line}:" in msg and what in msg, msg
    assert isinstance(e.value, ValueError)


def test_empty_and_missing_files(tmp_path):
    with pytest.raises(MeasurementFormatError, match="fewer than two"):
        read_measurement(_write(tmp_path, "# nothing\n"))
    with pytest.raises(OSError):
        read_measurement(tmp_path / "missing.txt")


def test_the_cores_number_parser_rounds_as_python_does():
    """The plain reader's numbers (core ``measured::plain_numbers``) are bitwise Python's ``float``
    of each token, for numbers printed in many forms; a token that is not a number gives None."""
    from beamslider import _core

    rng = np.random.default_rng(11)
    x = np.concatenate([rng.normal(size=3000) * 10.0 ** rng.integers(-12, 12, 3000), [0.0, -0.0, 1e-308, 5e-324]])
    forms = [repr, "{:.17g}".format, "{:.6e}".format, "{:.10g}".format, "{:.3f}".format, "{:.25f}".format]
    toks = [f(float(v)) for v, f in zip(x, (forms[i % len(forms)] for i in range(len(x))))]
    text = "".join(t + (", ", "\t", "\n", " ; ")[i % 4] for i, t in enumerate(toks))
    got = _core.plain_numbers(text)
    assert got is not None and got.tobytes() == np.array([float(t) for t in toks]).tobytes()
    for bad in ("1 2 x", "1_000 2", "0x10", "1e"):
        assert _core.plain_numbers(bad) is None


def test_the_plain_reader_gives_the_line_readers_rows(tmp_path):
    """read_measurement parses a file of the usual form at once (measurement._plain_rows): the same
    values, bitwise, as the line-by-line reader that names errors; a file with a header, a comment,
    a blank line or a bad value goes to that reader (and its error)."""
    from beamslider import measurement as M

    rng = np.random.default_rng(5)
    t = np.arange(2000) * 1e-4
    v, s = rng.normal(size=t.size) * 0.3, 0.3 + 0.01 * rng.random(t.size)
    lines = [f"{a:.10g}\t{b:.10g}\t{c:.10g}" for a, b, c in zip(t, v, s)]
    lines[7] = lines[7].replace("\t", " ; ")   # mixed separators
    text = "\n".join(lines) + "\n"
    plain = M._plain_rows(text)
    checked, linenos = M._rows_checked(text, tmp_path / "x.txt")
    assert plain is not None and plain.tobytes() == checked.tobytes()
    assert list(linenos[:3]) == [1, 2, 3]
    for other in ("time\tvel\ts\n" + text, "# note\n" + text, text.replace("\n", "\n\n", 1),
                  text.replace(lines[5], lines[5] + "\t1"), text.replace(lines[9], lines[9].replace("\t", "\tnan\t", 1))):
        assert M._plain_rows(other) is None
    p = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    p.write_text("# note\n" + text.replace(lines[5], lines[5] + "\t1"))
    with pytest.raises(M.MeasurementFormatError, match=r":7: expected 3 columns"):
        M.read_measurement(p)
    p.write_text("time\tvel\ts\n" + text)
    assert M.read_measurement(p).t.tobytes() == plain[:, 0].tobytes()
