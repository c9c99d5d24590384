"""Validation of layer (a), docs/model.md §6.4 (the harmonic-balance super-slow manifold).

Produces, into docs/results/superslow/:
- validation_a.txt: the validation tables (HB against the project's PCS manifold, 100 periods
  per step, Δs = 0.0025) and §4.6 (ω₁ ± 5 % at (124 Hz, 14 m/s²)), the D_eff calibration;
- fig4_overlay.png: seed Fig. 4 (124 Hz, 14 and 8 m/s²) — PCS sweeps with HB N = 1, 2, 5 and
  N = 5 with D_eff overlaid;
- pcs_<f>Hz_<a>ms2_N<n>.csv: the PCS sweeps (cached: delete them to recompute).

Not part of the fast test suite; PCS sweeps take seconds to minutes each:
    nohup python scripts/repro/validate_superslow_a.py > /tmp/validate_a.log 2>&1 &

Subcommand ``options`` (multi-harmonic HB and static sag, docs/model.md §6.4; uses the cached PCS
CSVs, seconds): writes validation_a_options.txt (the §4.1 table for H = 1, 3, 5 and the static
sag, N = 5, with the cost per manifold) and fig4_overlay_options.png:
    python scripts/repro/validate_superslow_a.py options
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import beamslider
from beamslider import Parameters
from beamslider.superslow import closed_form_n1, hb_manifold

OUT = Path(__file__).resolve().parents[2] / "docs" / "results" / "superslow"
POINTS = [(124, 14), (124, 8), (126, 10), (124, 6), (104, 14), (106, 10)]
DS = 0.0025
S_TARGET_DN = 0.32  # seed §3.3: N = 5 PCS high branch at (124 Hz, 8 m/s²) ends near s = 0.32
LINES: list[str] = []


def say(text: str = "") -> None:
    print(text, flush=True)
    LINES.append(text)


def pcs(f: float, a: float, n_modes: int = 5):
    """PCS sweeps (MODEL.md §6, 100 periods per step, last 25 averaged) on a Δs = 0.0025 grid."""
    path = OUT / f"pcs_{f:g}Hz_{a:g}ms2_N{n_modes}.csv"
    if path.exists():
        d = np.loadtxt(path, delimiter=",", skiprows=1)
        n = len(d) // 2
        return d[:n, 1], d[:n, 2], d[n:, 1], d[n:, 2]
    p = Parameters(n_modes=n_modes)
    s_min = 0.5 * p.contact_spacing_m / p.length_m
    grid = np.round(np.arange(np.ceil(s_min / DS) * DS, 0.5 + 1e-9, DS), 10)
    t0 = time.time()
    m = beamslider.super_slow_manifold(p, f_ex=f, a_ex=a, s=grid, periods=100, record=25)
    h = p.thickness_m
    up_a, dn_a = m.up_amplitude / h, m.down_amplitude / h
    rows = np.vstack([np.column_stack([np.zeros_like(m.up_s), m.up_s, up_a]),
                      np.column_stack([np.ones_like(m.down_s), m.down_s, dn_a])])
    np.savetxt(path, rows, delimiter=",", header="sweep(0=up,1=down),s,amplitude_h", comments="", fmt="%.10g")
    print(f"  PCS ({f}, {a}) N={n_modes}: {time.time() - t0:.1f} s", flush=True)
    return m.up_s, up_a, m.down_s, dn_a


def jumps(up_s, up_a, dn_s, dn_a, high=0.3, ratio=2.0):
    """PCS jump positions: where a sweep leaves its branch. A jump changes the amplitude by more
    than a factor 2 between two consecutive s, with the high side above Â = 0.3 (the low branch
    rattles at Â ≈ 0.01–0.18 with scatter that must not count); the position is the midpoint of
    that step. s_dn from the upward sweep (jump down), s_up from the downward sweep (jump up)."""
    s_dn = None
    for k in range(len(up_s) - 1):
        if up_a[k] > high and up_a[k + 1] < up_a[k] / ratio:
            s_dn = 0.5 * (up_s[k] + up_s[k + 1])
            break
    s_up = None
    for k in range(len(dn_s) - 1):
        if dn_a[k + 1] > high and dn_a[k + 1] > dn_a[k] * ratio:
            s_up = 0.5 * (dn_s[k] + dn_s[k + 1])
            break
    return s_up, s_dn


def rms_high(m, up_s, up_a, s_dn_pcs):
    """RMS relative error of the HB high branch against the PCS upward sweep on s ∈ [0.35, 0.5]
    where the PCS sweep is still on its high branch."""
    sel = (up_s >= 0.35 - 1e-9) & (up_s <= 0.5 + 1e-9) & (up_a > 0.3)  # PCS on its high branch
    if s_dn_pcs is not None:
        sel &= up_s < s_dn_pcs
    if not sel.any():
        return float("nan"), 0
    hb = np.interp(up_s[sel], m.s_grid, m.high_on_grid, left=np.nan, right=np.nan)
    ok = np.isfinite(hb)
    if not ok.any():
        return float("nan"), 0
    err = (hb[ok] - up_a[sel][ok]) / up_a[sel][ok]
    return float(np.sqrt(np.mean(err**2))), int(ok.sum())


def fmt(x, digits=4):
    return "none" if x is None else (f"{x:.{digits}f}" if np.isfinite(x) else "nan")


def calibrate_d_eff():
    """D_eff (all modes) such that the N = 5 high branch at (124 Hz, 8 m/s²) ends at s = 0.32."""
    def s_dn(d):
        m = hb_manifold(f_ex=124, a_ex=8, n_modes=5, d_eff=d)
        return m.s_dn if m.s_dn is not None else 0.5

    # s_dn(D) is not monotone over the whole range (with a large D the coexistence vanishes and
    # the high branch reaches the centre again): bracket on a coarse scan, then bisect.
    scan = np.geomspace(1e-3, 0.1, 41)
    lo = hi = None
    for d0, d1 in zip(scan[:-1], scan[1:]):
        if s_dn(d0) > S_TARGET_DN >= s_dn(d1):
            lo, hi = d0, d1
            break
    if lo is None:
        return None
    for _ in range(60):
        mid = np.sqrt(lo * hi)
        if s_dn(mid) > S_TARGET_DN:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1 + 1e-6:
            break
    # s_dn jumps from 'none' to about 0.31 at D* (the high branch pinches off; its part near the
    # centre becomes an isola that continuation from the clamping does not reach): return the
    # side of the bracket where the high branch ends.
    return float(hi)


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    say("Harmonic-balance super-slow manifold against the PCS manifold")
    say(f"beamslider {beamslider.__version__}; PCS: 100 periods per step, last 25 averaged, Δs = {DS}, N = 5")
    say("")
    d_eff = calibrate_d_eff()
    say(f"D_eff calibration (all modes, N = 5, (124 Hz, 8 m/s²), high branch to end at s = {S_TARGET_DN}): "
        f"D_eff = {fmt(d_eff, 5)}")
    if d_eff is not None:
        for d in (d_eff / 1.01, d_eff, 1.25 * d_eff, 1.5 * d_eff, 2 * d_eff):
            m = hb_manifold(f_ex=124, a_ex=8, n_modes=5, d_eff=d)
            say(f"   D_eff = {d:.5f}: s_up = {fmt(m.s_up)}, s_dn = {fmt(m.s_dn)}, max Â on the high branch = "
                f"{np.max(m.high.amplitude):.3f}")
        say("   s_dn(D_eff) is discontinuous: just below D* ≈ 0.019 the high branch reaches the centre, just above "
            "it ends near s ≈ 0.32 (its centre part becomes an isola) and s_dn decreases with D_eff.")
    say("")

    # --- §4.1 -----------------------------------------------------------------------------------
    say("§4.1  HB against PCS (N = 5 PCS reference)")
    head = (f"{'point':>12} | {'PCS s_up':>8} {'PCS s_dn':>8} | {'opt':>10} {'s_up':>7} {'|Δs_up|':>7} "
            f"{'s_dn':>7} | {'RMS high [0.35,0.5]':>19} {'n':>3}")
    say(head)
    say("-" * len(head))
    cache = {}
    summary = []
    for f, a in POINTS:
        up_s, up_a, dn_s, dn_a = pcs(f, a)
        su_p, sd_p = jumps(up_s, up_a, dn_s, dn_a)
        cache[(f, a)] = (up_s, up_a, dn_s, dn_a, su_p, sd_p)
        for label, kw in [("N=1", dict(n_modes=1)), ("N=2", dict(n_modes=2)), ("N=5", dict(n_modes=5)),
                          ("N=5 D_eff", dict(n_modes=5, d_eff=d_eff))]:
            if kw.get("d_eff", 0) is None:
                continue
            m = hb_manifold(f_ex=f, a_ex=a, s=up_s, sample=True, **kw)
            err, n = rms_high(m, up_s, up_a, sd_p)
            dsu = abs(m.s_up - su_p) if (m.s_up is not None and su_p is not None) else None
            say(f"{f'({f}, {a})':>12} | {fmt(su_p):>8} {fmt(sd_p):>8} | {label:>10} {fmt(m.s_up):>7} "
                f"{fmt(dsu):>7} {fmt(m.s_dn):>7} | {100 * err:>18.2f}% {n:>3}")
            summary.append((f, a, label, m.s_up, su_p, dsu, m.s_dn, sd_p, err))
        say("")
    say("Targets: RMS ≤ 5 % with N = 5; |s_up(HB) − s_up(PCS)| ≤ 0.02 with N = 5.")
    n5 = [r for r in summary if r[2] == "N=5"]
    ok_rms = sum(1 for r in n5 if np.isfinite(r[8]) and r[8] <= 0.05)
    ok_sup = sum(1 for r in n5 if r[5] is not None and r[5] <= 0.02)
    say(f"N = 5: RMS target met at {ok_rms} of {sum(1 for r in n5 if np.isfinite(r[8]))} points with a PCS high branch "
        f"on [0.35, 0.5]; s_up target met at {ok_sup} of {sum(1 for r in n5 if r[5] is not None)} points "
        f"where both give a jump-up.")
    say("PCS s_up / s_dn: midpoint of the Δs = 0.0025 step where a sweep changes Â by a factor > 2 with the high side > 0.3 (±0.00125);")
    say("'none' for PCS s_up: the downward sweep never jumps up. RMS n = 0: the PCS upward sweep has no high branch")
    say("(Â > 0.3) on [0.35, 0.5] (it jumped down before 0.35, or never rose: self-damping at (124, 6)).")
    say("")

    # --- §4.6 -----------------------------------------------------------------------------------
    say("§4.6  Sensitivity to ω₁ ± 5 % at (124 Hz, 14 m/s²) (seed Fig. 10a: Δs ≈ ±0.013, ΔÂmax ≈ ∓0.088)")
    say(f"{'model':>14} {'factor':>6} | {'s_up':>7} {'Δs_up':>8} | {'Âmax':>7} {'ΔÂmax':>8} | {'s_res':>7} {'time ms':>8}")
    for label, kw in [("HB N=5", dict(n_modes=5)), ("HB N=1", dict(n_modes=1)), ("HB N=2", dict(n_modes=2))]:
        base = None
        for fac in (1.0, 1.05, 0.95):
            t0 = time.perf_counter()
            m = hb_manifold(f_ex=124, a_ex=14, omega1_factor=fac, **kw)
            dt = 1e3 * (time.perf_counter() - t0)
            amax = float(np.max(m.high.amplitude))
            sres = float(m.s_res[0]) if m.s_res.size else float("nan")
            if base is None:
                base = (m.s_up, amax)
            dsu = (m.s_up - base[0]) if (m.s_up is not None and base[0] is not None) else None
            say(f"{label:>14} {fac:>6.2f} | {fmt(m.s_up):>7} {('%+.4f' % dsu) if dsu is not None else 'none':>8} | "
                f"{amax:>7.4f} {amax - base[1]:>+8.4f} | {sres:>7.4f} {dt:>8.2f}")
    cf0 = closed_form_n1(f_ex=124, a_ex=14)
    for fac in (1.05, 0.95):
        cf = closed_form_n1(f_ex=124, a_ex=14, omega1_factor=fac)
        say(f"{'closed N=1':>14} {fac:>6.2f} | Δs_up = {cf.s_up - cf0.s_up:+.4f}")
    say("")

    # --- figure ---------------------------------------------------------------------------------
    plt = _pyplot()
    if plt is None:
        return 0
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6), sharey=False)
    for ax, a in zip(axes, (14, 8)):
        up_s, up_a, dn_s, dn_a, su_p, sd_p = cache[(124, a)]
        ax.plot(up_s, up_a, "o", ms=2.5, color="0.35", label="PCS N=5 up-sweep")
        ax.plot(dn_s, dn_a, "s", ms=2.5, mfc="none", color="0.55", label="PCS N=5 down-sweep")
        for n_pcs, col in ((1, "tab:olive"), (2, "tab:cyan")):
            try:
                u_s, u_a, d_s, d_a = pcs(124, a, n_modes=n_pcs)
                ax.plot(u_s, u_a, ".", ms=2, color=col, alpha=0.6, label=f"PCS N={n_pcs}")
                ax.plot(d_s, d_a, ".", ms=2, color=col, alpha=0.6)
            except Exception as e:  # noqa: BLE001 - figure extras are optional
                print(f"PCS N={n_pcs} skipped: {e}", file=sys.stderr)
        for label, kw, col, ls in [("HB N=1", dict(n_modes=1), "tab:green", "-"),
                                   ("HB N=2", dict(n_modes=2), "tab:blue", "-"),
                                   ("HB N=5", dict(n_modes=5), "tab:red", "-"),
                                   (f"HB N=5 D_eff={fmt(d_eff, 4)}", dict(n_modes=5, d_eff=d_eff), "tab:purple", "-")]:
            if kw.get("d_eff", 0) is None:
                continue
            m = hb_manifold(f_ex=124, a_ex=a, **kw)
            for run in (m.up_run, m.down_run):
                st = run.stable
                y = np.where(st, run.amplitude, np.nan)
                ax.plot(run.s, y, ls, color=col, lw=1.3)
                ax.plot(run.s, np.where(~st, run.amplitude, np.nan), ":", color=col, lw=1.0)
            ax.plot([], [], ls, color=col, label=label)
        _label_panel(ax, a, "amplitude |w(4L/7)| / h")
    _save_overlay(fig, axes, "Super-slow manifold: harmonic balance (lines; dotted = unstable) over PCS sweeps (markers)",
                  "fig4_overlay", "validation_a")
    return 0


def _pyplot():
    """matplotlib.pyplot on the Agg backend, or None (said) without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        say("matplotlib missing: no figure")
        return None
    return plt


def _label_panel(ax, a, ylabel: str) -> None:
    """Axes, title and grid of one excitation level's overlay panel."""
    ax.set_xlim(0, 0.5)
    ax.set_xlabel("slider position s = x/L")
    ax.set_ylabel(ylabel)
    ax.set_title(f"124 Hz, {a} m/s² (seed Fig. 4{'a' if a == 14 else 'b'})")
    ax.grid(alpha=0.3)


def _save_overlay(fig, axes, title: str, figure: str, text: str) -> None:
    """Legend and title, then the figure (``figure``.png) and the report lines (``text``.txt) into OUT."""
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(OUT / f"{figure}.png", dpi=130)
    say(f"Figure: docs/results/superslow/{figure}.png")
    (OUT / f"{text}.txt").write_text("\n".join(LINES) + "\n", encoding="utf-8")


OPTIONS = [("H=1", dict(harmonics=1)), ("H=3", dict(harmonics=3)), ("H=5", dict(harmonics=5)),
           ("H=1 sag", dict(static_sag=True)), ("H=3 sag", dict(harmonics=3, static_sag=True)),
           ("H=5 sag", dict(harmonics=5, static_sag=True))]


def timed(repeat=5, **kw):
    """Median wall time [ms] of hb_manifold (Python call included) and the last manifold."""
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        m = hb_manifold(**kw)
        ts.append(1e3 * (time.perf_counter() - t0))
    return float(np.median(ts)), m


def options() -> int:
    """§4.1 with the layer-(a) options multi-harmonic HB and static sag (N = 5)."""
    OUT.mkdir(parents=True, exist_ok=True)
    LINES.clear()
    say("Options of the harmonic-balance manifold, docs/model.md §6.4 (multi-harmonic HB: odd harmonics up to H) and static sag (")
    say("under the slider's weight; with it all harmonics 0..H), N = 5, against the PCS manifold (N = 5, 100 periods")
    say(f"per step, Δs = {DS}). beamslider {beamslider.__version__}. Command: python scripts/repro/validate_superslow_a.py options")
    say("")
    head = (f"{'point':>12} | {'PCS s_up':>8} {'PCS s_dn':>8} | {'option':>8} {'s_up':>7} {'|Δs_up|':>7} {'s_dn':>7} | "
            f"{'RMS high':>8} {'n':>3} | {'max a3/a1':>9} {'max a5/a1':>9} {'Â0(0.3)':>8} | {'ms':>6} {'steps':>5}")
    say(head)
    say("-" * len(head))
    rows = []
    for f, a in POINTS:
        up_s, up_a, dn_s, dn_a = pcs(f, a)
        su_p, sd_p = jumps(up_s, up_a, dn_s, dn_a)
        for label, kw in OPTIONS:
            ms, _ = timed(f_ex=f, a_ex=a, n_modes=5, **kw)
            m = hb_manifold(f_ex=f, a_ex=a, n_modes=5, s=up_s, sample=True, **kw)
            err, n = rms_high(m, up_s, up_a, sd_p)
            dsu = abs(m.s_up - su_p) if (m.s_up is not None and su_p is not None) else None
            orders = list(m.harmonic_orders)
            ha = m.high.harmonic_amplitude
            r3 = float(np.max(ha[:, orders.index(3)] / ha[:, 0])) if 3 in orders and len(ha) else float("nan")
            r5 = float(np.max(ha[:, orders.index(5)] / ha[:, 0])) if 5 in orders and len(ha) else float("nan")
            a0 = float("nan")
            if 0 in orders and len(ha):
                k = int(np.argmin(np.abs(m.high.s - 0.3)))
                a0 = float(ha[k, orders.index(0)])
            say(f"{f'({f}, {a})':>12} | {fmt(su_p):>8} {fmt(sd_p):>8} | {label:>8} {fmt(m.s_up):>7} {fmt(dsu):>7} "
                f"{fmt(m.s_dn):>7} | {100 * err:>7.2f}% {n:>3} | {r3:>9.2e} {r5:>9.2e} {a0:>8.4f} | {ms:>6.1f} {m.steps:>5}")
            rows.append((f, a, label, m.s_up, su_p, m.s_dn, sd_p, err, ms))
        say("")
    say("Columns: s_up/s_dn of the HB manifold ('none': the low branch reaches s_min / the high branch reaches 0.5);")
    say("RMS high: relative RMS error of the first-harmonic Â of the high branch against the PCS up-sweep on [0.35, 0.5];")
    say("max a_k/a1: largest ratio of the k-th to the first harmonic of w(4L/7) on the high branch; Â0(0.3): static")
    say("deflection w₀(4L/7)/h on the high branch at s ≈ 0.3 (negative: down); ms: median wall time of one manifold")
    say("(both branches, default grid 201 s, Python call included, 5 repeats, shared 2-core machine).")
    say("")
    base = {(r[0], r[1]): r for r in rows if r[2] == "H=1"}
    say("Effect of each option on s_up (s_up(option) − s_up(H=1)) and whether s_dn appears:")
    for label, _ in OPTIONS[1:]:
        parts = []
        for f, a in POINTS:
            r = next(x for x in rows if x[0] == f and x[1] == a and x[2] == label)
            b = base[(f, a)]
            d = (r[3] - b[3]) if (r[3] is not None and b[3] is not None) else None
            parts.append(f"({f},{a}): {('%+.2e' % d) if d is not None else 'n/a'}, s_dn {fmt(r[5])}")
        say(f"  {label:>8}: " + "; ".join(parts))
    say("")
    for label, _ in OPTIONS:
        ms = [r[8] for r in rows if r[2] == label]
        say(f"  cost {label:>8}: median {np.median(ms):.1f} ms per manifold (range {min(ms):.1f}–{max(ms):.1f}) over the 6 points")
    say("")
    plt = _pyplot()
    if plt is None:
        (OUT / "validation_a_options.txt").write_text("\n".join(LINES) + "\n", encoding="utf-8")
        return 0
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for ax, a in zip(axes, (14, 8)):
        up_s, up_a, dn_s, dn_a = pcs(124, a)
        ax.plot(up_s, up_a, "o", ms=2.5, color="0.35", label="PCS N=5 up-sweep")
        ax.plot(dn_s, dn_a, "s", ms=2.5, mfc="none", color="0.55", label="PCS N=5 down-sweep")
        for (label, kw), col, ls in zip(OPTIONS[:4], ("tab:red", "tab:orange", "tab:purple", "tab:green"),
                                        ("-", "--", ":", "-.")):
            m = hb_manifold(f_ex=124, a_ex=a, n_modes=5, **kw)
            for run in (m.up_run, m.down_run):
                st = run.stable
                ax.plot(run.s, np.where(st, run.amplitude, np.nan), ls, color=col, lw=1.3)
                ax.plot(run.s, np.where(~st, run.amplitude, np.nan), ls, color=col, lw=0.6, alpha=0.5)
            ax.plot([], [], ls, color=col, label=f"HB N=5 {label}")
        _label_panel(ax, a, "first-harmonic amplitude |w(4L/7)| / h")
    _save_overlay(fig, axes, "HB options (multi-harmonic H, static sag; thin = unstable) over PCS sweeps (markers)",
                  "fig4_overlay_options", "validation_a_options")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1:
        if sys.argv[1] != "options" or len(sys.argv) > 2:
            print("usage: validate_superslow_a.py [options]", file=sys.stderr)
            sys.exit(2)
        sys.exit(options())
    try:
        rc = main()
    finally:
        OUT.mkdir(parents=True, exist_ok=True)
        (OUT / "validation_a.txt").write_text("\n".join(LINES) + "\n", encoding="utf-8")
    sys.exit(rc)
