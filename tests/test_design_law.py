"""The drift law over the design box (docs/model.md §6.5): blending, coverage, files, refit."""

import json
import math

import numpy as np
import pytest

import beamslider as bs
from beamslider.superslow import predicted_map
from beamslider.superslow import (DESIGN_BOX, DesignLaw, JAM_GAP_RATIO, default_drift_law, default_law, design_coordinates,
                                  design_params, design_sample, drift_table, fit_design_law, fit_drift_law, load_law,
                                  predict, save_design_law)
from beamslider.superslow.design_law import design_law_dict


@pytest.fixture(scope="module")
def shipped():
    return default_law()


def test_coordinates_round_trip():
    for x in design_sample(4, seed=3):
        c = design_coordinates(design_params(x))
        for k, v in x.items():
            assert math.isclose(c[k], v, rel_tol=1e-9, abs_tol=1e-12), k
    assert design_params(design_coordinates(bs.Parameters())) == bs.Parameters()


def test_prototype_uses_the_default_law_unchanged(shipped):
    """At the prototype the design law is the default law itself: predictions bitwise as before."""
    law, note = shipped.law_for(bs.Parameters())
    d0 = default_drift_law()
    assert note is None and not law.outside_design
    for br in ("L", "H"):
        assert np.array_equal(law.x[br], d0.x[br]) and np.array_equal(law.v[br], d0.v[br])
    a = predict(f_ex=124, a_ex=14, s0=0.3)
    b = predict(f_ex=124, a_ex=14, s0=0.3, drift=d0)
    assert a.behaviour == b.behaviour and np.array_equal(a.s, b.s)


def test_reproduces_its_training_designs(shipped):
    """At each training design the blended law is that design's own law: V of its training rows."""
    for i in (1, 7, 30):
        law, note = shipped.law_for(design_params(shipped.x[i], shipped.base))
        own = shipped.laws[i]
        for br in ("L", "H"):
            x = own.x[br]
            if x.shape[0] == 0:
                continue
            free = np.full(x.shape[0], np.inf)
            v, _ = law._evaluate_x(br, x, free)
            assert np.array_equal(v, own._evaluate_x(br, x, free)[0])
            # the k-nearest mean reproduces its rows up to its 1e-6 distance floor and averages rows at nearly one input (within twice the law.s V resolution, the spread of repeated PCS windows)
            np.testing.assert_allclose(v, own.v[br], rtol=1e-3, atol=2 * own.v_resolution)


def test_blend_equals_the_stored_numbers(shipped):
    """The core's blend (docs/model.md §6.5) against numbers stored from the Python blend it
    replaced (tests/data/design_law_blend.json: two designs drawn over the box and one outside it;
    each neighbour law evaluated by the core's kNN): V on the 26 × 51 grid within 1e-12, the
    scalars and the coverage notes; the handle parses the file once."""
    from pathlib import Path

    ref = json.loads((Path(__file__).parent / "data" / "design_law_blend.json").read_text())
    assert len(ref["cases"]) == 3
    for c in ref["cases"]:
        law, note = shipped.law_for(bs.Parameters.from_dict(c["params"]))
        for br in ("L", "H"):
            want = np.asarray(c["v"][br])
            assert law.v[br].shape == want.shape == (26 * 51,) and law.x[br].shape == (26 * 51, 2)
            assert np.max(np.abs(law.v[br] - want)) <= 1e-12, (c["name"], br)
        for key in ("mean", "std", "lo", "hi", "mono_std"):
            np.testing.assert_allclose(getattr(law, key), c[key], rtol=0, atol=1e-12, err_msg=key)
        for key in ("lift_c", "rho_c", "jump_down_s", "s_up_shift", "v_resolution"):
            assert getattr(law, key) == pytest.approx(c[key], abs=1e-12), key
        assert [list(q) for q in law.points] == c["points"]
        assert law.outside_design == c["outside_design"] and (note is None) == (not c["outside_design"])
    assert shipped.core() is shipped.core()


def test_blend_between_designs_is_a_weighted_mean(shipped):
    """Midway between two training designs (one coordinate apart) V lies between theirs."""
    x = dict(shipped.x[5])
    x["restitution"] = min(max(x["restitution"] + 0.01, 0.2), 0.8)
    law, note = shipped.law_for(design_params(x, shipped.base))
    assert note is None
    vs = [q.v for q in (law,)]
    assert all(np.all(np.isfinite(v[b])) for v in vs for b in v)
    assert 0 < law.lift_c <= 2 and abs(law.s_up_shift) < 0.5


@pytest.mark.parametrize("change, word", [
    ({"gap_ratio": 1.025}, "barely move"),
    ({"gap_ratio": 1.4}, "gap_ratio"),
    ({"friction_coefficient": 0.5}, "friction_coefficient"),
    ({"length_m": 0.15}, "length_m"),
    ({"slider_mass_kg": 0.1}, "slider_mass_kg"),
])
def test_outside_the_box_is_extrapolated(shipped, change, word):
    p = bs.Parameters(**{**bs.Parameters().to_dict(), **change})
    law, note = shipped.law_for(p)
    assert note and word in note and "\n" not in note
    with pytest.warns(UserWarning, match="does not cover|outside"):
        rows = predicted_map(p, f_ex=[110, 124], a_ex=[10])
    assert all(r["extrapolated"] for r in rows)
    r = predict(p, f_ex=124, a_ex=10, drift=shipped)
    assert r.extrapolated and any(word in w for w in r.warnings)


def test_inside_the_box_not_extrapolated(shipped):
    p = design_params(design_sample(1, seed=11)[0])
    if design_coordinates(p)["gap_ratio"] < JAM_GAP_RATIO:
        pytest.skip("drawn in the jam zone")
    law, note = shipped.law_for(p)
    assert note is None
    rows = predicted_map(p, drift=shipped, f_ex=[110, 124], a_ex=[10, 14])
    assert not any(r["extrapolated"] for r in rows)


@pytest.mark.heavy
def test_refit_reproduces_the_shipped_law(shipped):
    """The shipped file is the fit of its own designs and laws (length scales by leave-one-design-out)."""
    again = fit_design_law(shipped.x, shipped.laws, base=shipped.base)
    assert np.array_equal(again.scales, shipped.scales)
    assert json.dumps(design_law_dict(again), sort_keys=True) == json.dumps(design_law_dict(shipped), sort_keys=True)


def test_small_box_fit_from_tables(tmp_path):
    """A design law fitted on PCS tables of three designs of a small box: at each design, its own
    law's V at the table rows; saved and read back unchanged; in between, inside the box."""
    designs = [dict(design_coordinates(bs.Parameters()), friction_coefficient=mu) for mu in (0.18, 0.2, 0.22)]
    laws = []
    for x in designs:
        p = design_params(x)
        tabs = [drift_table(p, f_ex=f, a_ex=14, ds=0.05, settle_periods=40, window_s=1.0) for f in (120, 126)]
        laws.append(fit_drift_law(tabs, params=p))
    law = fit_design_law(designs, laws, k_sets=2, scales=np.ones(len(DESIGN_BOX)))
    path = tmp_path / "small.json"
    save_design_law(law, path)
    back = load_law(path)
    assert isinstance(back, DesignLaw) and back.k_sets == 2
    for x, own in zip(designs, laws):
        blended, _ = back.law_for(design_params(x))
        for br in ("L", "H"):
            if own.x[br].shape[0]:
                free = np.full(own.x[br].shape[0], np.inf)
                v, _ = blended._evaluate_x(br, own.x[br], free)
                np.testing.assert_allclose(v, own._evaluate_x(br, own.x[br], free)[0], rtol=1e-12, atol=1e-15)
                np.testing.assert_allclose(v, own.v[br], rtol=1e-3, atol=2 * own.v_resolution)


@pytest.mark.parametrize("edit, word", [
    (lambda d: d.pop("designs"), "designs"),
    (lambda d: d.pop("scales"), "scales"),
    (lambda d: d.update(version=99), "version"),
    (lambda d: d.update(kind="something else"), "not a"),
    (lambda d: d["designs"][0].pop("x"), "designs[0]"),
    (lambda d: d["designs"][0]["x"].pop("gap_ratio"), "gap_ratio"),
    (lambda d: d["designs"][1]["law"].pop("x"), "`x`"),
    (lambda d: d.update(scales=[1.0]), "scales"),
    (lambda d: d.update(k_sets=0), "k_sets"),
])
def test_bad_design_law_files(tmp_path, shipped, edit, word):
    d = design_law_dict(shipped)
    edit(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError) as e:
        load_law(path)
    msg = str(e.value)
    assert word in msg and str(path) in msg and "\n" not in msg


def test_not_json(tmp_path):
    path = tmp_path / "x.json"
    path.write_bytes(b"\x00\xff garbage")
    with pytest.raises(ValueError, match="not a beamslider law file"):
        load_law(path)


def test_fit_law_design_cli(tmp_path, capsys):
    """`beamslider fit-law --design N`: the prototype's law and N designs' laws, blended into
    design_law.json that predict --law reads; a second fit is refused, --resume refits from the
    stored laws to the same file. Cheap table settings: this checks the plumbing, not the law."""
    from beamslider.cli import main

    out = tmp_path / "dl"
    cheap = ["--points", "124:14,126:10", "--ds", "0.1", "--settle-periods", "40", "--first-settle-periods", "40",
             "--window-s", "0.5", "--jump-down-n", "0", "--no-progress"]
    assert main(["fit-law", "--design", "4", "--out", str(out), *cheap]) == 0
    text = (out / "design_law.json").read_text()
    law = load_law(out / "design_law.json")
    assert isinstance(law, DesignLaw) and len(law.laws) == 5 and law.x[0] == design_coordinates(bs.Parameters())
    assert sorted(p.name for p in (out / "designs").iterdir()) == ["design_000", "design_001", "design_002",
                                                                    "design_003", "prototype"]
    capsys.readouterr()
    assert main(["fit-law", "--design", "4", "--out", str(out), *cheap]) == 1
    assert "--resume" in capsys.readouterr().err
    assert main(["fit-law", "--design", "4", "--out", str(out), "--resume", *cheap]) == 0
    assert (out / "design_law.json").read_text() == text
    assert main(["predict", "--law", str(out / "design_law.json"), "--f-ex", "124", "--a-ex", "14",
                 "--out", str(tmp_path / "p"), "--no-progress"]) == 0
    assert main(["fit-law", "--design", "1", "--out", str(tmp_path / "x"), *cheap]) == 1
