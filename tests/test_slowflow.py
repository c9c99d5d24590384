"""Layer (b), docs/model.md §6.3: PCS drift tables (resume, mirror symmetry), the slow flow on the HB
manifold with synthetic drift, the fitted law's constraints, the predict CLI."""

import json
import os

import numpy as np
import pytest

from beamslider import Parameters
from beamslider.params import native
from beamslider.maps import rows_to_table
from beamslider.superslow import predicted_map
from beamslider.superslow import (DriftTable, drift_table, features, fit_drift_law, hb_manifold, load_drift_law, predict,
                                  read_drift_table, save_drift_law)

SHORT = dict(settle_periods=5, first_settle_periods=20, window_s=0.1, sub_windows=2)


def _synthetic_table(f_ex, a_ex, v_low, v_high):
    s = np.linspace(0.036, 0.5, 30)
    return DriftTable(f_ex=f_ex, a_ex=a_ex, s=np.concatenate([s, s]), branch=np.array(["L"] * 30 + ["H"] * 30),
                      v=np.concatenate([v_low(s), v_high(s)]), v_se=np.zeros(60),
                      amplitude=np.concatenate([np.zeros(30), np.full(30, 5.0)]),  # up sweep on the high branch
                      jump=np.zeros(60, bool), sweep=np.array(["down"] * 30 + ["up"] * 30))


def test_drift_table_resumes_bitwise(tmp_path):
    out = tmp_path / "d.jsonl"
    full = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32, 0.34], out=out, **SHORT)
    lines = out.read_text().splitlines()
    assert len(lines) == 1 + len(full.s)
    # A killed run: keep the header, one row of each sweep, and half a line.
    rows = [json.loads(x) for x in lines[1:]]
    keep = [lines[0]] + [lines[1 + i] for i, r in enumerate(rows) if r["index"] == 0] + [lines[-1][:40]]
    out.write_text("\n".join(keep))
    with pytest.raises(ValueError, match="exists"):
        drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32, 0.34], out=out, **SHORT)
    with pytest.raises(ValueError, match="other parameters"):
        drift_table(f_ex=124, a_ex=12, s=[0.3, 0.32, 0.34], out=out, resume=True, **SHORT)
    again = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32, 0.34], out=out, resume=True, **SHORT)
    assert again.computed == len(full.s) - 2
    np.testing.assert_array_equal(again.v, full.v)
    np.testing.assert_array_equal(again.s, full.s)
    back = read_drift_table(out)
    np.testing.assert_array_equal(back.v, full.v)
    assert set(back.branch) <= {"L", "H"}


def test_drift_table_mirror_symmetry():
    """V(1 − s) = −V(s) (docs/model.md §6.3) on generated tables: the far half is an independent PCS run."""
    near = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.4], settle_periods=10, first_settle_periods=40, window_s=0.2, sub_windows=4)
    far = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.4], settle_periods=10, first_settle_periods=40, window_s=0.2, sub_windows=4,
                      mirror=True)
    assert np.all(far.s > 0.5)
    for br in ("L", "H"):
        s1, v1, e1 = near.branch_rows(br)
        s2, v2, e2 = far.branch_rows(br)  # half coordinate: far-half V negated
        np.testing.assert_allclose(s1, s2, atol=1e-12)
        assert np.all(np.abs(v1 - v2) <= 3 * (e1 + e2) + 1e-3 * np.abs(v1) + 1e-9), (br, v1, v2, e1, e2)
    assert np.any(np.abs(near.v) > 1e-4)  # the test compares non-trivial drift


def test_drift_table_bad_input(tmp_path):
    with pytest.raises(ValueError, match="s_values"):
        drift_table(f_ex=124, a_ex=14, s=[0.3, 0.2], **SHORT)
    with pytest.raises(ValueError, match="s_values"):
        drift_table(f_ex=124, a_ex=14, s=[0.01, 0.3], **SHORT)
    with pytest.raises(ValueError, match="sub_windows"):
        drift_table(f_ex=124, a_ex=14, s=[0.3], settle_periods=5, first_settle_periods=5, window_s=0.1, sub_windows=1)


def test_predict_signature_move_on_the_hb_manifold():
    """Synthetic drift on the real HB manifold: V_L < 0 drives to the HB fold s_up, V_H has a stable
    zero at 0.42 → a signature move that jumps exactly at the manifold's s_up."""
    t = _synthetic_table(124, 14, lambda s: -0.005 + 0 * s, lambda s: 0.05 * (0.42 - s))
    m = hb_manifold(f_ex=124, a_ex=14)
    r = predict(f_ex=124, a_ex=14, s0=0.3, drift=t, build_up=0)
    assert r.behaviour == "signature_move", r.classification["reason"]
    # Default: the build-up from rest lasts 3 envelope time constants 3/(D Ω); the slider drifts
    # from t = 0 and reaches the fold after it (6.2 s > 3.85 s), so the jump time is unchanged.
    r2 = predict(f_ex=124, a_ex=14, s0=0.3, drift=t)
    t_b = 3 / (0.001 * 2 * np.pi * 124)
    assert r2.build_up_s == pytest.approx(t_b)
    assert r2.events[0][1] == pytest.approx((0.3 - m.s_up) / 0.005, rel=1e-9)
    # Held (the rule before): s stays at s0 until the build-up is over.
    r3 = predict(f_ex=124, a_ex=14, s0=0.3, drift=t, build_up_drift=False)
    assert r3.events[0][1] == pytest.approx((0.3 - m.s_up) / 0.005 + t_b, rel=1e-9)
    # A fold reached within the build-up: the jump waits for its end.
    t_fast = _synthetic_table(124, 14, lambda s: -0.02 + 0 * s, lambda s: 0.05 * (0.42 - s))
    r4 = predict(f_ex=124, a_ex=14, s0=0.3, drift=t_fast)
    assert r4.events[0][0] == "jump_up" and r4.events[0][1] == pytest.approx(t_b, rel=1e-9)
    kinds = [e[0] for e in r.events]
    assert kinds[0] == "jump_up"
    assert abs(r.events[0][2] - m.s_up) < 1e-9
    assert abs(r.events[0][1] - (0.3 - m.s_up) / 0.005) < 1e-6
    assert abs(r.s_final - 0.42) < 2e-3
    assert r.amplitude_final == pytest.approx(float(m.high.amplitude_at([r.s_final])[0]), rel=1e-3)
    assert r.s_dn is None and r.s_dn_source == "none"


def test_predict_rejects_bad_input():
    t = _synthetic_table(124, 14, lambda s: -0.005 + 0 * s, lambda s: 0.05 * (0.42 - s))
    with pytest.raises(ValueError, match="s0"):
        predict(f_ex=124, a_ex=14, s0=0.01, drift=t)
    with pytest.raises(ValueError, match="drift"):
        predict(f_ex=124, a_ex=12, s0=0.3, drift=t)
    with pytest.raises(ValueError, match="drift"):
        predict(f_ex=124, a_ex=14, s0=0.3, drift="law.json")  # a path is not a law (None: the built-in law)
    with pytest.raises(ValueError, match="s_dn"):
        predict(f_ex=124, a_ex=14, s0=0.3, drift=t, s_dn="pcs")


def test_features_and_law_constraints(tmp_path):
    """Λ_g from the closed form; a law fitted on synthetic tables is 0 where Λ_g < 1, is
    reported outside its training range, and round-trips through JSON."""
    m = hb_manifold(f_ex=124, a_ex=14)
    s = np.array([0.3, 0.4, 0.45])
    f = features(m, "H", s)
    assert np.all(f["lift_off"] > 1) and np.all(f["slope_gap"] > 0)
    # Λ_g at the high amplitude: Ω²|ŵ_abs|/g with |ŵ_abs| ≥ |w(s)| ~ Â h.
    assert np.all(f["lift_off"] > (2 * np.pi * 124) ** 2 * 0.5e-3 / 9.81)
    tables = [_synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s)) for f_, a_ in ((124, 14), (120, 12), (126, 10))]
    law = fit_drift_law(tables, k=3, monostable_vote=False)
    assert np.isfinite(law.loo["ratio"])
    feat = dict(f)
    feat["lift_off"] = np.array([0.5, 2.0, 0.9])
    v, _ = law.evaluate("H", feat)
    assert v[0] == 0.0 and v[2] == 0.0
    far = {k_: np.asarray(v_) * 10 for k_, v_ in f.items()}
    _, outside = law.evaluate("H", far)
    assert outside.all()
    r = predict(f_ex=104, a_ex=4, drift=law)
    assert r.extrapolated and "outside its training range" in r.warnings[0]
    save_drift_law(law, tmp_path / "law.json")
    back = load_drift_law(tmp_path / "law.json")
    np.testing.assert_array_equal(back.evaluate("H", f)[0], law.evaluate("H", f)[0])
    # s_dn learnt from the tables: none when no table's high branch ends; where the training
    # tables' high branches end at 0.33, the in-sample s_dn lies between HB s_up and 0.5.
    assert law.s_dn(m) is None and all(r["s_dn_law"] is None for r in law.loo_s_dn)
    for tb in tables:
        tb.s_dn_pcs = 0.33
    law2 = fit_drift_law(tables, k=3, monostable_vote=False)
    sdn = law2.s_dn(m)
    assert sdn is not None and m.s_up < sdn < 0.5
    r3 = predict(f_ex=124, a_ex=14, drift=law2, s_dn="law")
    assert r3.s_dn == pytest.approx(sdn) and r3.s_dn_source == "law"
    rows = predicted_map(drift=law, f_ex=[122, 124], a_ex=[14], out=tmp_path / "pm")
    from beamslider import read_map

    tab = read_map(tmp_path / "pm")
    assert len(rows) == 2 and len(tab["behaviour"]) == 2
    with pytest.raises(FileExistsError):
        predicted_map(drift=law, f_ex=[122], a_ex=[14], out=tmp_path / "pm")
    om = rows_to_table(predicted_map(drift=law, f_ex=[122, 124], a_ex=[14]))
    assert list(om["behaviour"]) == [r["behaviour"] for r in rows]


def test_predict_cli(tmp_path):
    from beamslider.cli import main

    t = drift_table(f_ex=124, a_ex=14, s=[0.25, 0.3, 0.4, 0.5], out=tmp_path / "d.jsonl", **SHORT)
    assert len(t.s) >= 4
    args = ["predict", "--f-ex", "124", "--a-ex", "14", "--drift", str(tmp_path / "d.jsonl"), "--out", str(tmp_path / "o")]
    assert main(args) == 0
    js = json.loads((tmp_path / "o" / "predict_124Hz_14ms2_s0_0p3.json").read_text())
    assert js["behaviour"] and js["timings_s"]["slow_flow"] < 1.0
    assert main(args) != 0  # refuses to overwrite
    assert main(args + ["--force"]) == 0
    assert js["robust"] is None  # a table (b1) has no resolution
    # The committed default law: the JSON says whether V ± its resolution changes the prediction.
    from pathlib import Path

    law = Path(__file__).resolve().parents[1] / "python" / "beamslider" / "data" / "default_law.json"
    for f_, want in (("124", True), ("112", False)):
        assert main(["predict", "--f-ex", f_, "--a-ex", "14" if f_ == "124" else "10", "--law", str(law), "--out", str(tmp_path / "l")]) == 0
    js = {f_: json.loads((tmp_path / "l" / name).read_text()) for f_, name in (("124", "predict_124Hz_14ms2_s0_0p3.json"), ("112", "predict_112Hz_10ms2_s0_0p3.json"))}
    assert js["124"]["robust"] is True and js["112"]["robust"] is False
    sh = js["112"]["shifted"]  # not robust: V ± its resolution changes the behaviour or moves the final s by > 0.02
    assert len(sh) == 2 and any(d["behaviour"] != js["112"]["behaviour"] or abs(d["s_final"] - js["112"]["s_final"]) > 0.02
                                for d in sh)


def test_builtin_default_law_is_the_committed_law_and_needs_no_file(tmp_path, capsys):
    """The package ships python/beamslider/data/default_law.json; predict and `beamslider predict` use it when no
    drift is given, and say so when the parameters are not the ones it was fitted at."""
    from pathlib import Path

    from beamslider.cli import main
    from beamslider.superslow import predicted_map
    from beamslider.superslow import DEFAULT_LAW_PATH, default_drift_law, load_drift_law, predict

    committed = Path(__file__).resolve().parents[1] / "python" / "beamslider" / "data" / "default_law.json"
    assert DEFAULT_LAW_PATH.read_bytes() == committed.read_bytes()  # the installed copy (a wheel) or the file itself
    assert default_drift_law().points == load_drift_law(committed).points
    a = predict(f_ex=124, a_ex=14)
    b = predict(f_ex=124, a_ex=14, drift=load_drift_law(committed))
    assert (a.behaviour, a.s_final, a.events) == (b.behaviour, b.s_final, b.events) and a.warnings == b.warnings == []
    c = predict(Parameters(friction_coefficient=0.3), f_ex=124, a_ex=14)  # inside the design box: blended, no warning
    assert c.warnings == [] and not c.extrapolated
    c = predict(Parameters(friction_coefficient=0.5), f_ex=124, a_ex=14)  # outside it: said, and extrapolated
    assert any("does not cover these parameters" in w and "friction_coefficient" in w for w in c.warnings) and c.extrapolated
    assert main(["predict", "--f-ex", "124", "--a-ex", "14", "--out", str(tmp_path)]) == 0
    js = json.loads((tmp_path / "predict_124Hz_14ms2_s0_0p3.json").read_text())
    assert js["drift"] == "built-in default law" and js["behaviour"] == a.behaviour and js["s_final"] == a.s_final
    (tmp_path / "p.toml").write_text("friction_coefficient = 0.5\n")
    capsys.readouterr()
    assert main(["predict", "--params", str(tmp_path / "p.toml"), "--out", str(tmp_path / "mu"), "--no-progress"]) == 0
    assert "does not cover these parameters" in capsys.readouterr().err
    rows = predicted_map(f_ex=[124.0], a_ex=[14.0])
    assert rows[0]["behaviour"] == a.behaviour and rows[0]["s_final"] == pytest.approx(a.s_final, abs=1e-9)
    with pytest.warns(UserWarning, match="does not cover these parameters"):
        predicted_map(Parameters(friction_coefficient=0.5), f_ex=[124.0], a_ex=[14.0])


def test_fit_law_cli_and_predicted_map_cli(tmp_path, capsys):
    """`beamslider fit-law` computes the tables, narrows the jump-down bracket, fits and writes a
    law that `predict --law` and `map --predictor` use; it refuses to overwrite, resumes bitwise,
    and refuses bad points. Cheap table settings: this checks the plumbing, not the law."""
    from beamslider.cli import main

    out = tmp_path / "fit"
    args = ["fit-law", "--points", "124:14,126:10,104:14", "--ds", "0.05", "--settle-periods", "10",
            "--first-settle-periods", "50", "--window-s", "0.1", "--jump-down-n", "1", "--candidates-f-ex", "120:126:2",
            "--candidates-a-ex", "8:12:2", "--out", str(out), "--no-progress"]
    assert main(args) == 0
    law = load_drift_law(out / "law.json")
    assert law.points == [(124.0, 14.0), (126.0, 10.0), (104.0, 14.0)]
    assert len(list((out / "drift").glob("drift_*.jsonl"))) == 3 and len(list((out / "drift" / "jump_down").glob("*.jsonl"))) == 1
    from beamslider.cli.predict import _law_content

    first = _law_content(out / "law.json")
    capsys.readouterr()
    assert main(args) != 0 and "--resume continues it" in capsys.readouterr().err
    assert main(args + ["--resume"]) == 0 and _law_content(out / "law.json") == first  # nothing recomputed differs
    assert main(args[:-3] + ["--out", str(tmp_path / "bad"), "--points", "124:x"]) != 0
    assert main(["fit-law", "--points", "124:14", "--out", str(tmp_path / "one")]) != 0
    assert main(["predict", "--law", str(out / "law.json"), "--out", str(tmp_path / "p")]) == 0
    # The map by the predictor: the fitted law, and the built-in one (= the core's predicted map).
    assert main(["map", "--predictor", str(out / "law.json"), "--f-ex", "120,126", "--a-ex", "8,12",
                 "--out", str(tmp_path / "m1"), "--no-progress"]) == 0
    from beamslider import read_map

    m1 = read_map(tmp_path / "m1")
    assert list(m1["status"]) == ["predicted"] * 4 and "predicted, t_end = 120 s" in (tmp_path / "m1" / "map.txt").read_text()
    assert main(["map", "--predictor", "default", "--f-ex", "124", "--a-ex", "14", "--out", str(tmp_path / "m2")]) == 0
    assert read_map(tmp_path / "m2")["behaviour"][0] == predict(f_ex=124, a_ex=14).behaviour
    capsys.readouterr()
    assert main(["map", "--predictor", "default", "--f-ex", "124", "--a-ex", "14", "--out", str(tmp_path / "m2")]) != 0
    err = capsys.readouterr().err
    assert "--resume to continue it" in err and "--force to start over" in err
    assert main(["map", "--predictor", "default", "--s0", "0.3,0.4", "--out", str(tmp_path / "m3")]) != 0
    assert main(["map", "--predictor", str(tmp_path / "missing.json"), "--out", str(tmp_path / "m4")]) != 0


def test_drift_table_cli(tmp_path):
    from beamslider.cli import main

    args = ["drift-table", "--f-ex", "124", "--a-ex", "14", "--ds", "0.2", "--window-s", "0.1", "--settle-periods", "5",
            "--out", str(tmp_path), "--no-progress"]
    assert main(args) == 0
    path = tmp_path / "drift_124Hz_14ms2.jsonl"
    t = read_drift_table(path)
    assert len(t.s) >= 4 and set(t.branch) <= {"L", "H"}
    assert main(args) != 0  # exists: refused without --resume / --force
    assert main(args + ["--resume"]) == 0  # complete: nothing recomputed
    np.testing.assert_array_equal(read_drift_table(path).v, t.v)


def _realistic_law(monostable_vote=False):
    """A law on synthetic tables at three points (V < 0 on L, a zero of V_H near 0.42). The
    synthetic tables have no jumps, so with ``monostable_vote`` every point is voted monostable."""
    tables = [_synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s)) for f_, a_ in ((124, 14), (120, 12), (126, 10))]
    return fit_drift_law(tables, k=3, monostable_vote=monostable_vote)


def _map_row(law_text, f_ex, a_ex, s0):
    """The core's predicted-map row of one point (the map writer's path, beside predict's)."""
    from beamslider import _core

    cfg = f"duration_s = 120.0\n[grid]\nf_ex_hz = [{float(f_ex)}]\na_ex_m_s2 = [{float(a_ex)}]\ns0 = [{float(s0)}]\n"
    return json.loads(_core.predicted_map(_core.MapConfig(cfg), _core.DriftLaw(law_text), threads=1)[0][0])


def test_core_law_and_features_against_independent_references(tmp_path):
    """The core's kNN law against a brute-force kNN in numpy (inverse-distance weights, V = 0
    below Λ_c, the extrapolation flag); the core's features against the formulas of docs/model.md
    §6.3 evaluated here from the manifold's Q and the mode shapes of ``beam_properties`` (slope by
    a central difference); the predicted map's rows against predict (the same core, two paths)."""
    from beamslider import _core
    from beamslider.superslow import law_json

    law = _realistic_law()
    text = law_json(law)
    rng = np.random.default_rng(1)
    for br in ("L", "H"):
        x = law.lo + (law.hi - law.lo) * rng.uniform(-0.2, 1.2, size=(200, len(law.lo)))
        lift = np.exp(rng.uniform(-0.5, 1.0, size=200))  # Λ_g on both sides of 1
        z = (law.x[br] - law.mean) / law.std
        d = np.sqrt(((((x - law.mean) / law.std)[:, None, :] - z[None, :, :]) ** 2).sum(axis=2))
        idx = np.argsort(d, axis=1, kind="stable")[:, :law.k]
        w = 1.0 / np.maximum(np.take_along_axis(d, idx, axis=1), 1e-6)
        v_ref = np.where(lift < law.lift_c, 0.0, (w * law.v[br][idx]).sum(axis=1) / w.sum(axis=1))
        out_ref = np.any((x < law.lo - 1e-9) | (x > law.hi + 1e-9), axis=1)
        v_rs, out_rs = _core.DriftLaw(text).evaluate(high=br == "H", x=x.tolist(), lift_off=lift.tolist())
        np.testing.assert_allclose(v_rs, v_ref, rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(out_rs, out_ref)
        v_py, _ = law.evaluate(br, {"amp_rel": x[:, 0], "s": x[:, 1], "lift_off": lift})
        np.testing.assert_array_equal(v_py, v_rs)
    p = Parameters()
    m = hb_manifold(f_ex=124, a_ex=14)
    omega, g, h = 2 * np.pi * 124, p.gravity_m_s2, 1e-6
    theta_gap = (p.gap_ratio - 1) * p.thickness_m / p.contact_spacing_m
    for br, b in (("H", m.high), ("L", m.low)):
        s = np.linspace(b.s.min(), b.s.max(), 17)
        f = features(m, br, s)
        o = np.argsort(b.s)
        q = np.stack([np.interp(s, b.s[o], b.q[o][:, k].real) + 1j * np.interp(s, b.s[o], b.q[o][:, k].imag)
                      for k in range(b.q.shape[1])], axis=1)
        phi = np.asarray(_core.beam_properties(native(p), s.tolist())["phi"])[: b.q.shape[1]].T
        dphi = (np.asarray(_core.beam_properties(native(p), (s + h).tolist())["phi"])
                - np.asarray(_core.beam_properties(native(p), (s - h).tolist())["phi"]))[: b.q.shape[1]].T / (2 * h * p.length_m)
        w_abs = 14.0 / omega**2 + np.sum(phi * q, axis=1)
        theta = np.sum(dphi * q, axis=1)
        ref = {"lift_off": omega**2 * np.abs(w_abs) / g, "slope_gap": np.abs(theta) / theta_gap,
               "f_slope": -(omega**2 / (2 * g)) * np.real(w_abs * np.conj(theta)), "s": s,
               "amp_rel": np.interp(s, b.s[o], b.amplitude[o]) / np.max(m.high.amplitude)}
        for key, want in ref.items():
            scale = float(np.max(np.abs(want)))
            np.testing.assert_allclose(f[key], want, rtol=1e-5, atol=1e-6 * scale, err_msg=f"{br} {key}")
    shifted = _realistic_law()
    shifted.s_up_shift = -0.015  # the learnt s_up correction moves the low branch's fold
    for lw in (law, shifted):
        text = law_json(lw)
        for f_, a_, s0 in ((124, 14, 0.3), (106, 10, 0.4), (126, 10, 0.3), (114, 14, 0.3)):
            r_py = predict(f_ex=f_, a_ex=a_, s0=s0, drift=lw)
            r_rs = _map_row(text, float(f_), float(a_), s0)
            assert r_rs["behaviour"] == r_py.behaviour, (f_, a_, s0, lw.s_up_shift)
            assert r_rs["s_final"] == pytest.approx(r_py.classification["s_final"], abs=1e-3)
            assert r_rs["extrapolated"] == r_py.extrapolated
            ups_py = [e[2] for e in r_py.events if e[0] == "jump_up"]
            ups_rs = [e[2] for e in r_rs["events"] if e[0] == "jump_up"]
            assert ups_rs == pytest.approx(ups_py, abs=1e-6)
    r = predict(f_ex=124, a_ex=14, drift=shifted)
    assert r.s_up == pytest.approx(hb_manifold(f_ex=124, a_ex=14).s_up - 0.015, abs=1e-3)
    # A monostable law (every training point voted single-branch): the core and Python agree,
    # and the slider follows the low branch through the HB fold towards the clamping.
    mono = _realistic_law(monostable_vote=True)
    text = law_json(mono)
    for f_, a_, s0 in ((124, 14, 0.3), (126, 10, 0.3)):
        r_py = predict(f_ex=f_, a_ex=a_, s0=s0, drift=mono)
        r_rs = _map_row(text, float(f_), float(a_), s0)
        assert r_py.monostable and r_rs["monostable"]
        assert r_rs["behaviour"] == r_py.behaviour == "self_damping", (f_, a_, r_py.behaviour)
        assert r_rs["s_final"] == pytest.approx(r_py.classification["s_final"], abs=1e-3)
        assert not [e for e in r_py.events if e[0] == "jump_up"] and not [e for e in r_rs["events"] if e[0] == "jump_up"]
        assert r_py.s_final < hb_manifold(f_ex=f_, a_ex=a_).s_up


def test_monostable_vote_is_the_nearest_training_point():
    """The vote (ln Â_L(s_up), s_up): a law whose tables are labelled bistable (a PCS s_up) except
    one monostable point answers each training point's own label in sample, and leave one out the
    label of the nearest other point; monostable_vote=False or a manifold without fold: False."""
    from beamslider.superslow import monostable_inputs as _mono_x

    pts = ((124, 14), (124, 6), (110, 8))
    tables = []
    for f_, a_ in pts:
        t = _synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s))
        t.s_up_pcs = None if (f_, a_) == (124, 6) else hb_manifold(f_ex=f_, a_ex=a_).s_up
        tables.append(t)
    law = fit_drift_law(tables, k=3)
    assert list(law.mono_y) == [0.0, 1.0, 0.0]
    for gi, (f_, a_) in enumerate(pts):
        m = hb_manifold(f_ex=f_, a_ex=a_)
        assert law.monostable(m) == ((f_, a_) == (124, 6))
        x = _mono_x(m)
        d = [np.sum(((law.mono_x[j] - x) / law.mono_std) ** 2) if j != gi else np.inf for j in range(3)]
        assert law.monostable(m, exclude_group=gi) == bool(law.mono_y[int(np.argmin(d))])
    assert not fit_drift_law(tables, k=3, monostable_vote=False).monostable(hb_manifold(f_ex=124, a_ex=6))
    back = load_drift_law_text(law)
    np.testing.assert_array_equal(back.mono_x, law.mono_x)
    assert back.monostable(hb_manifold(f_ex=124, a_ex=6))


def test_predicted_map_written_by_the_core(tmp_path):
    """predicted_map writes through the core's map writer: predictor in the header, resume keeps
    the rows, another law is refused on resume, bad law files are clear errors."""
    from beamslider import _core, read_map

    law = _realistic_law()
    out = tmp_path / "pm"
    rows = predicted_map(drift=law, f_ex=[122, 124], a_ex=[14], out=out)
    header = json.loads((out / "map.jsonl").read_text().splitlines()[0])
    assert header["predictor"]["kind"] == "drift_law_knn" and header["predictor"]["law_points"]
    assert [r["status"] for r in rows] == ["predicted", "predicted"]
    again = predicted_map(drift=law, f_ex=[122, 124, 126], a_ex=[14], out=out, resume=True)
    assert [json.dumps(r, sort_keys=True) for r in again[:2]] == [json.dumps(r, sort_keys=True) for r in rows]
    assert len(read_map(out)["behaviour"]) == 3
    other = fit_drift_law([_synthetic_table(f_, a_, lambda s: -0.002 + 0 * s, lambda s: 0.01 * (0.45 - s)) for f_, a_ in ((124, 14), (120, 12))], k=2, monostable_vote=False)
    with pytest.raises(ValueError, match="another drift law"):
        predicted_map(drift=other, f_ex=[122], a_ex=[14], out=out, resume=True)
    # In memory, the same rows as written (but the wall time).
    mem = predicted_map(drift=law, f_ex=[122, 124], a_ex=[14])
    strip = lambda r: {k: v for k, v in r.items() if k != "wall_time_s"}  # noqa: E731
    assert [strip(r) for r in mem] == [strip(r) for r in rows]
    for bad, match in (("{", "not a beamslider drift law"), ('{"kind": "x"}', "not a beamslider drift law"),
                       (law_json_text(law).replace('"amp_rel"', '"slope_mu"'), "features")):
        with pytest.raises(ValueError, match=match):
            _core.DriftLaw(bad)
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="not a beamslider drift law"):
        load_drift_law(tmp_path / "bad.json")
    # Out-of-range scalars are refused by Python and core alike.
    for key, value in (("jump_down_s", 0.7), ("rho_c", -1.0), ("lift_c", 0.0)):
        d = json.loads(law_json_text(law))
        d[key] = value
        (tmp_path / "bad.json").write_text(json.dumps(d))
        with pytest.raises(ValueError, match=key):
            load_drift_law(tmp_path / "bad.json")
        with pytest.raises(ValueError, match=key):
            _core.DriftLaw(json.dumps(d))


def load_drift_law_text(law):
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        save_drift_law(law, os.path.join(d, "law.json"))
        return load_drift_law(os.path.join(d, "law.json"))


def law_json_text(law):
    from beamslider.superslow import law_json

    return law_json(law)


def test_jump_down_from_the_forcing_ratio():
    """s_dn="law": the high branch ends where ρ(s) = a_ex/(Ω² Â_H(s) h) falls below the law's ρ_c,
    checked against ρ recomputed by hand from the manifold's own arrays; none below min ρ; the
    core (predict_point) and Python agree on the jump-down position and the behaviour."""
    from beamslider.superslow import forcing_ratio, law_json, s_dn_forcing_ratio

    m = hb_manifold(f_ex=124, a_ex=8)
    h = Parameters().thickness_m
    o = np.argsort(m.high.s)
    s_h, a_h = m.high.s[o], m.high.amplitude[o]
    rho_hand = 8.0 / ((2 * np.pi * 124) ** 2 * a_h * h)
    rho_c = float(np.interp(0.32, s_h, rho_hand))
    s_dn = s_dn_forcing_ratio(m, rho_c)
    assert s_dn == pytest.approx(0.32, abs=2e-3)
    assert float(forcing_ratio(m, [s_dn])[0]) == pytest.approx(rho_c, rel=2e-3)
    assert s_dn_forcing_ratio(m, 0.5 * float(np.nanmin(rho_hand))) is None  # never that low: reaches the centre
    assert s_dn_forcing_ratio(m, 0.0) is None
    law = _realistic_law()
    law.rho_c = rho_c
    text = law_json(law)
    for f_, a_, s0 in ((124, 8, 0.3), (126, 10, 0.3), (124, 14, 0.3)):
        r_py = predict(f_ex=f_, a_ex=a_, s0=s0, drift=law)
        r_rs = _map_row(text, float(f_), float(a_), s0)
        expect = s_dn_forcing_ratio(hb_manifold(f_ex=f_, a_ex=a_), rho_c)
        assert (r_py.s_dn is None) == (expect is None)
        if expect is not None:
            assert r_py.s_dn == pytest.approx(expect, abs=1e-9) and r_py.s_dn_source == "law"
        assert r_rs["behaviour"] == r_py.behaviour, (f_, a_)
        assert r_rs["s_final"] == pytest.approx(r_py.classification["s_final"], abs=1e-3)
        dn_py = [e[2] for e in r_py.events if e[0] == "jump_down"]
        dn_rs = [e[2] for e in r_rs["events"] if e[0] == "jump_down"]
        assert dn_rs == pytest.approx(dn_py, abs=1e-6)
    # 'hb' ignores the law's rule (single-term HB has no jump-down here)
    assert predict(f_ex=124, a_ex=8, drift=law, s_dn="hb").s_dn is None


def test_learnt_lift_off_threshold_and_monostable_label():
    """Λ_c: where a table's drift towards the clamping ends (two or more rows at rest below it),
    in Λ_g of the HB branch reaching the clamping; the law is zero below Λ_c. The monostable label
    needs a down sweep that stays below MONO_RISE_H on the clamping side of the HB fold."""
    from beamslider.superslow import MONO_RISE_H, learn_lift_off_threshold

    s_stop = 0.15
    t = _synthetic_table(124, 6, lambda s: np.where(s < s_stop, 0.0, -0.006), lambda s: np.where(s < s_stop, 0.0, -0.006))
    m = hb_manifold(f_ex=124, a_ex=6)
    lc = learn_lift_off_threshold(t, m)
    s_rows = np.unique(t.s[t.s < 0.3])
    i = int(np.searchsorted(s_rows, s_stop))
    expect = float(np.mean(features(m, "H", s_rows[[i - 1, i]])["lift_off"]))
    assert lc == pytest.approx(expect, rel=1e-12)
    moving = _synthetic_table(124, 6, lambda s: -0.006 + 0 * s, lambda s: -0.006 + 0 * s)  # drifts down to the clamp
    assert learn_lift_off_threshold(moving, m) is None
    others = [_synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s)) for f_, a_ in ((124, 14), (120, 12))]
    law = fit_drift_law([t] + others, k=3)
    assert law.lift_c == pytest.approx(lc) and law.lift_c_per_point == [{"f_ex": 124, "a_ex": 6, "lift_c": lc}]
    assert fit_drift_law([t] + others, k=3, lift_off_threshold=1.0).lift_c == 1.0
    f = features(m, "H", np.array([0.06, 0.12, 0.2]))
    v, _ = law.evaluate("H", f)
    assert np.all(v[f["lift_off"] < lc] == 0.0) and np.any(f["lift_off"] < lc)
    assert load_drift_law_text(law).lift_c == law.lift_c
    with pytest.raises(ValueError, match="lift_off_threshold"):
        fit_drift_law([t] + others, lift_off_threshold=-1)
    # monostable label: no PCS jump-up and the down sweep stays low -> 1; rising beyond MONO_RISE_H -> 0
    s_fold = hb_manifold(f_ex=124, a_ex=14).s_up
    for rise, label in ((0.5 * MONO_RISE_H, 1.0), (1.5 * MONO_RISE_H, 0.0)):
        tabs = [_synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s)) for f_, a_ in ((124, 14), (120, 12))]
        tabs[0].s_up_pcs = None
        tabs[0].amplitude = np.where((tabs[0].s < s_fold) & (tabs[0].sweep == "down"), rise, 0.03)
        tabs[1].s_up_pcs = hb_manifold(f_ex=120, a_ex=12).s_up
        assert fit_drift_law(tabs, k=3).mono_y[0] == label


def test_jump_down_bracket_locates_the_boundary_between_ending_and_passing_branches(tmp_path):
    """The bracket rule of the jump-down (fit_drift_law's default): s_p is the median PCS
    jump-down position; lo is the largest ρ(s_p) of the tables whose high branch ends there, hi
    the smallest of those whose high branch passes it, ρ_c = √(lo·hi), all recomputed by hand
    from forcing_ratio; the high branch then ends at s_p exactly where ρ(s_p) ≤ ρ_c (Python and
    core alike); jump_down_tables move the bracket without entering V; 'median' is the old rule."""
    from beamslider.superslow import forcing_ratio, jump_down_bracket, law_json, refine_jump_down

    ends = [(124, 8), (126, 10)]
    passes = [(124, 14), (120, 12)]
    tables = []
    for f_, a_ in ends + passes:
        t = _synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s))
        t.s_dn_pcs = 0.32 if (f_, a_) in ends else None
        tables.append(t)
    rho = {fa: float(forcing_ratio(hb_manifold(f_ex=fa[0], a_ex=fa[1]), [0.32])[0]) for fa in ends + passes}
    lo, hi = max(rho[fa] for fa in ends), min(rho[fa] for fa in passes)
    assert lo < hi
    law = fit_drift_law(tables, k=3, monostable_vote=False)
    assert law.jump_down_s == pytest.approx(0.32)
    assert law.rho_bracket["lo"] == pytest.approx(lo, rel=1e-12) and law.rho_bracket["hi"] == pytest.approx(hi, rel=1e-12)
    assert law.rho_c == pytest.approx(np.sqrt(lo * hi), rel=1e-12)
    assert [r["side"] for r in law.rho_bracket["tables"]] == ["ends", "ends", "passes", "passes"]
    # Leave one out: without (126, 10) the bracket's lower end is (124, 8)'s ρ.
    loo = {(r["f_ex"], r["a_ex"]): r for r in law.loo_s_dn}
    assert loo[(126, 10)]["rho_c_loo"] == pytest.approx(np.sqrt(min(rho[fa] for fa in ends) * hi), rel=1e-12)
    text = law_json(law)
    for (f_, a_), r in rho.items():
        m = hb_manifold(f_ex=f_, a_ex=a_)
        expect = 0.32 if r <= law.rho_c else None
        assert law.s_dn(m) == (pytest.approx(0.32) if expect else None)
        r_py = predict(f_ex=f_, a_ex=a_, drift=law)
        r_rs = _map_row(text, float(f_), float(a_), 0.3)
        assert r_rs["behaviour"] == r_py.behaviour and r_rs["s_final"] == pytest.approx(r_py.classification["s_final"], abs=1e-3)
        dn_py = [e[2] for e in r_py.events if e[0] == "jump_down"]
        dn_rs = [e[2] for e in r_rs["events"] if e[0] == "jump_down"]
        assert dn_rs == pytest.approx(dn_py, abs=1e-6)
        if expect is not None:
            assert dn_py and dn_py[0] == pytest.approx(0.32, abs=1e-9)
    # The law file keeps the position: a law read back predicts the same.
    save_drift_law(law, tmp_path / "law.json")
    assert load_drift_law(tmp_path / "law.json").jump_down_s == law.jump_down_s
    # An extra table inside the bracket whose high branch ends raises the bracket's lower end;
    # its V does not enter the law.
    mid = (122, 10)
    r_mid = float(forcing_ratio(hb_manifold(f_ex=mid[0], a_ex=mid[1]), [0.32])[0])
    extra = _synthetic_table(*mid, lambda s: 0.05 + 0 * s, lambda s: 0.05 + 0 * s)
    extra.s_dn_pcs = 0.32
    law2 = fit_drift_law(tables, k=3, monostable_vote=False, jump_down_tables=[extra])
    assert lo < r_mid < hi
    assert law2.rho_bracket["lo"] == pytest.approx(r_mid, rel=1e-12)
    np.testing.assert_array_equal(law2.v["H"], law.v["H"])
    assert fit_drift_law(tables, k=3, monostable_vote=False, jump_down="median").jump_down_s == 0.0
    with pytest.raises(ValueError, match="jump_down"):
        fit_drift_law(tables, jump_down="max")
    assert refine_jump_down(tables, candidates=[(122, 10)], n=0) == []
    with pytest.raises(ValueError, match="`n`"):
        refine_jump_down(tables, candidates=[(122, 10)], n=-1)
    with pytest.raises(ValueError, match="candidates"):
        refine_jump_down(tables, candidates=[(122,)], n=1)
    with pytest.raises(ValueError, match="jump_down_tables"):
        fit_drift_law(tables, jump_down_tables=[1])
    # No jump-down anywhere: no bracket, no learnt jump-down.
    for t in tables:
        t.s_dn_pcs = None
    assert jump_down_bracket(tables, [hb_manifold(f_ex=t.f_ex, a_ex=t.a_ex) for t in tables], [False] * 4)["rho_c"] == 0.0


def test_high_branch_samples_must_be_on_the_high_branch():
    """A row of a PCS up sweep trains V_H only where its amplitude is on the HB high branch:
    synthetic rows with a low-branch amplitude are dropped, whatever their V; on the committed
    tables, the monostable point (114, 4) (its up sweep stays at a few hundredths of h) gives no
    high-branch sample where HB's high branch is high, while (110, 8) keeps every row in range."""
    from pathlib import Path

    from beamslider.superslow import ON_BRANCH_RATIO
    from beamslider.superslow.fit import _training_samples

    m = hb_manifold(f_ex=124, a_ex=14)
    hs, ha = np.asarray(m.high.s), np.asarray(m.high.amplitude)
    tab = _synthetic_table(124, 14, lambda s: -0.004 + 0 * s, lambda s: 0.03 * (0.42 - s))
    up = tab.branch == "H"
    a_hb = np.interp(tab.s[up], hs[np.argsort(hs)], ha[np.argsort(hs)])
    low = (tab.s[up] > 0.3) & (tab.s[up] < 0.4)
    amp = np.where(low, 0.3 * ON_BRANCH_RATIO * a_hb, 0.95 * a_hb)
    tab.amplitude = tab.amplitude.copy()
    tab.amplitude[up] = amp
    v = tab.v.copy()
    v[np.where(up)[0][low]] = -0.5  # a marker no kept row has
    tab.v = v
    x, vh, _, _ = _training_samples(tab, m)["H"]
    in_range = (tab.s[up] >= hs.min()) & (tab.s[up] <= hs.max())
    assert vh.size == int(np.sum(in_range & ~low)) and not np.any(vh == -0.5)
    assert np.all((x[:, 1] <= 0.3) | (x[:, 1] >= 0.4))
    drift = Path(__file__).resolve().parents[1] / "docs" / "results" / "superslow" / "drift"
    mono = read_drift_table(drift / "drift_114Hz_4ms2.jsonl")
    mm = hb_manifold(f_ex=114, a_ex=4)
    xs, _, _, _ = _training_samples(mono, mm)["H"]
    s_mono = xs[:, 1]
    assert s_mono.size > 0 and s_mono.max() < 0.27
    ok = read_drift_table(drift / "drift_110Hz_8ms2.jsonl")
    mo = hb_manifold(f_ex=110, a_ex=8)
    s_ok, _, _ = ok.branch_rows("H")
    hs2 = np.asarray(mo.high.s)
    assert _training_samples(ok, mo)["H"][1].size == int(np.sum((s_ok >= hs2.min()) & (s_ok <= hs2.max())))


def test_robustness_flag_from_the_law_resolution(tmp_path):
    """A prediction is robust when V ± the law's v_resolution changes neither the behaviour nor
    the final s by more than 0.02: a steep zero of V_H (the stop moves by v_resolution / slope)
    is robust, a nearly flat drift that a shift of V reverses is not; Python and core agree; a
    law without a resolution gives None, and the resolution is the median standard error of the
    training rows and survives the JSON round trip."""
    from beamslider.superslow import law_json

    def law_with(v_high, se):
        tables = [_synthetic_table(f_, a_, lambda s: -0.004 + 0 * s, v_high) for f_, a_ in ((124, 14), (120, 12), (126, 10))]
        for t in tables:
            t.v_se = np.full(t.v.size, se)
        return fit_drift_law(tables, k=3, monostable_vote=False)

    steep = law_with(lambda s: 0.03 * (0.42 - s), 3e-4)
    assert steep.v_resolution == pytest.approx(3e-4)
    assert load_drift_law_text(steep).v_resolution == pytest.approx(3e-4)
    r = predict(f_ex=124, a_ex=14, drift=steep)
    assert r.robust is True and len(r.shifted) == 2
    assert all(b == r.behaviour and abs(s - r.s_final) <= 0.02 for b, s in r.shifted)
    # The stop moves by v_resolution / |dV/ds| = 3e-4 / 0.03 = 0.01 either way.
    assert sorted(s for _, s in r.shifted) == pytest.approx([r.s_final - 0.01, r.s_final + 0.01], abs=3e-3)
    flat = law_with(lambda s: 2e-4 + 0 * s, 3e-4)  # V_H > 0 everywhere, but within its resolution
    r2 = predict(f_ex=124, a_ex=14, drift=flat)
    assert r2.robust is False and {b for b, _ in r2.shifted} | {r2.behaviour} != {r2.behaviour}
    for lw, want in ((steep, True), (flat, False)):
        row = _map_row(law_json(lw), 124.0, 14.0, 0.3)
        assert row["robust"] is want
        assert [b for b, _ in row["shifted"]] == [b for b, _ in predict(f_ex=124, a_ex=14, drift=lw).shifted]
    unknown = law_with(lambda s: 0.03 * (0.42 - s), 0.0)
    assert unknown.v_resolution == 0.0
    assert predict(f_ex=124, a_ex=14, drift=unknown).robust is None
    row = _map_row(law_json(unknown), 124.0, 14.0, 0.3)
    assert row["robust"] is None and "shifted" not in row
    assert predict(f_ex=124, a_ex=14, drift=steep, robustness=False).robust is None
    d = json.loads(law_json(steep))
    d["v_resolution"] = -1.0
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(ValueError, match="v_resolution"):
        load_drift_law(tmp_path / "bad.json")


@pytest.mark.parametrize("f_ex, a_ex", [(60.0, 1.0), (80.0, 0.5)])
def test_no_lift_off_anywhere_is_inactivity_without_a_hang(f_ex, a_ex):
    """Λ_g < 1 everywhere (a weak excitation) with the built-in law: the slider stays at
    s0, no event, the classifier says inactivity; the law's extrapolation is reported. (Below the
    first resonance: with the hardening high branch, 100 Hz has Λ_g up to 7 even at 0.05 m/s².)"""
    r = predict(f_ex=f_ex, a_ex=a_ex, s0=0.3)
    lift = np.concatenate([r.features[b]["lift_off"] for b in r.features])
    assert lift.size and np.all(lift < 1.0), lift.max()
    assert r.behaviour == "inactivity" and r.events == [] and np.all(r.s == 0.3)
    assert r.extrapolated and any("outside its training range" in w for w in r.warnings)


def test_low_branch_rows_are_paired_as_the_slow_flow_stretches_the_branch():
    """A low-branch row of a table whose down sweep jumps up at s_up(PCS) below the HB fold takes
    the features of the HB position that the slow flow's stretch (fold moved onto s_up(PCS)) moves
    to its s; rows between the two folds (where the PCS drift slows before the jump) are kept."""
    from beamslider.superslow import FEATURES, move_fold
    from beamslider.superslow.fit import _training_samples

    mf = hb_manifold(f_ex=124, a_ex=14)
    su, z = mf.s_up, float(np.max(mf.low.s))
    t = _synthetic_table(124, 14, lambda s: -0.01 + 0 * s, lambda s: 0.01 + 0 * s)
    t.s_up_pcs = su - 0.015
    x = _training_samples(t, mf)["L"][0]
    s_feat = x[:, FEATURES.index("s")]
    s_rows = t.branch_rows("L")[0]
    s_rows = s_rows[s_rows >= t.s_up_pcs]
    assert np.any(s_rows < su)  # rows below the HB fold, dropped by the pairing before
    assert np.allclose(s_feat, move_fold(s_rows, z, t.s_up_pcs, su)) and np.all(s_feat >= su - 1e-12)
    # The stretch of beamslider.superslow.slow_model / the core (fold onto s_up(PCS)) maps them back.
    assert np.allclose(z - (z - s_feat) * (z - t.s_up_pcs) / (z - su), s_rows)
    # Without a PCS jump-up the rows keep their own s (the pairing before).
    t.s_up_pcs = None
    s_all = t.branch_rows("L")[0]
    assert np.allclose(_training_samples(t, mf)["L"][0][:, FEATURES.index("s")], s_all[s_all >= np.min(mf.low.s)])


@pytest.mark.parametrize("kw, text", [
    (dict(s_dn="fold"), "invalid parameter `s_dn` = \"fold\": one of 'law', 'hb', 'table', 'none'"),
    (dict(source="pcs"), "invalid parameter `source` = \"pcs\": 'hb' or 'table'"),
])
def test_predict_option_names_are_checked_by_the_core(kw, text):
    """An unknown jump-down rule or branch source is a one-line ValueError naming the option
    (the core reads the names, docs/model.md §6.4), before the drift is even looked at."""
    from beamslider import _core
    with pytest.raises(ValueError) as e:
        _core.predict(native(Parameters()), f_ex_hz=124.0, a_ex_m_s2=14.0, s0=0.3, t_end_s=1.0, **kw)
    assert str(e.value) == text
