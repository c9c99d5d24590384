"""``beamslider hb-manifold``: the super-slow manifold by harmonic balance (docs/model.md §6.4)
written as CSV + JSON + figure.

Compute the super-slow manifold by N-mode harmonic balance (single-term by default) with the slider
rigidly attached (pseudo-arclength continuation, folds, stability) and write
hb_manifold_<f>Hz_<a>ms2_N<n>.csv/.json/.png (plus _Deff<D>, _H<H>, _sag for those options)."""

from __future__ import annotations

import argparse
import time
from typing import Any


from ..superslow import hb_manifold
from ._files import hb_manifold_file_stem, write_hb_manifold_csv
from ._manifold import add_operating_point
from ._common import add_common, doc_body, figure, fmt, out_dir, params_from_args, plan_outputs, positive, print_written, write_json


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    sp = sub.add_parser(
        "hb-manifold", help="super-slow manifold by harmonic balance (milliseconds; slider rigidly attached)",
        description=doc_body(__doc__))
    add_operating_point(sp, positive_level=True)
    sp.add_argument("--n-modes", type=positive(int), default=5, metavar="N", help="retained beam modes (5)")
    sp.add_argument("--d-eff", type=float, metavar="D", help="equivalent damping ratio of all modes (default: params)")
    sp.add_argument("--harmonics", type=int, default=1, choices=(1, 3, 5, 7), metavar="H",
                    help="odd harmonics 1..H of the ansatz: 1, 3, 5 or 7 (1 = single-term HB)")
    sp.add_argument("--static-sag", action="store_true",
                    help="include the static sag under the slider's weight (zeroth harmonic; off by default)")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_hb_manifold)


def cmd_hb_manifold(args: argparse.Namespace) -> int:
    p = params_from_args(args)
    stem = hb_manifold_file_stem(args.f_ex, args.a_ex, args.n_modes) + (
        f"_Deff{fmt(args.d_eff)}" if args.d_eff is not None else "") + (
        f"_H{args.harmonics}" if args.harmonics != 1 else "") + ("_sag" if args.static_sag else "")
    plan_outputs(args, [f"{stem}.{ext}" for ext in ("csv", "json", "png")])
    t0 = time.perf_counter()
    m = hb_manifold(p, f_ex=args.f_ex, a_ex=args.a_ex, n_modes=args.n_modes, d_eff=args.d_eff,
                    harmonics=args.harmonics, static_sag=args.static_sag)
    wall = time.perf_counter() - t0
    out = out_dir(args)
    write_hb_manifold_csv(out / f"{stem}.csv", m)
    write_json(out / f"{stem}.json", {
        "kind": "hb_manifold", "f_ex_hz": m.f_ex, "a_ex_m_s2": m.a_ex, "n_modes": m.n_modes, "harmonics": m.harmonics,
        "d_eff": m.d_eff, "static_sag": m.static_sag, "harmonic_orders": list(m.harmonic_orders), "s_up": m.s_up, "s_dn": m.s_dn, "s_res": m.s_res.tolist(), "folds_s": m.folds_s.tolist(),
        "folds_amplitude_h": m.folds_amplitude.tolist(), "steps": m.steps, "warnings": m.warnings,
        "wall_time_s": wall, "params_toml": p.toml_text(),
    })
    drew = figure(_draw, m, out / f"{stem}.png")
    s_up = "none" if m.s_up is None else f"{m.s_up:.4f}"
    s_dn = "none" if m.s_dn is None else f"{m.s_dn:.4f}"
    opt = (f" H={m.harmonics}" if m.harmonics != 1 else "") + (" +sag" if m.static_sag else "")
    print(f"HB N={m.n_modes}{opt} {m.f_ex:g} Hz, {m.a_ex:g} m/s²: s_up = {s_up}, s_dn = {s_dn} ({1e3 * wall:.1f} ms)")
    return print_written(out, stem, drew)


def _draw(m: Any, path: Any) -> None:
    """The manifold figure (needs the ``plot`` extra)."""
    from .._mpl import require_matplotlib

    require_matplotlib("the hb-manifold figure")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name, style in (("high", "-"), ("low", "-"), ("middle", ":")):
        b = getattr(m, name)
        ax.plot(b.s, b.amplitude, style, color={"high": "tab:red", "low": "tab:blue", "middle": "0.4"}[name], label=name)
    for s in m.folds_s:
        ax.axvline(s, color="0.7", lw=0.8)
    ax.set_xlim(0, 0.5)
    ax.set_xlabel("slider position s = x/L")
    ax.set_ylabel("amplitude |w(4L/7)| / h")
    ax.set_title(f"HB manifold, N = {m.n_modes}: {m.f_ex:g} Hz, {m.a_ex:g} m/s²"
                 + (f", D_eff = {m.d_eff:g}" if m.d_eff is not None else "")
                 + (f", H = {m.harmonics}" if m.harmonics != 1 else "") + (", static sag" if m.static_sag else ""))
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
