"""Pictures of the design-space sweep (:mod:`tools.sweep`): the reciprocal's Pareto plot (:func:`plot`) and the
per-unit and pipeline panels (:func:`plot_units`), with labels moved apart (:func:`declutter`).
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

from host.atomic import atomic_savefig

__all__ = ["ANCHORS", "unit_points", "declutter", "plot", "plot_units"]

#: Published reference points: ``(label, table_bits, multipliers, correct_bits)``.
ANCHORS = [("NVIDIA SFU (Oberman & Siu 2005)", 6656, 2, 23.0)]


def unit_points(result: dict, unit: str) -> list[dict]:
    """The sweep points of ``unit`` (``recip`` for points that name none)."""
    return [r for r in result["points"] if r.get("unit", "recip") == unit]


def declutter(fig, texts, step: float = 3.0, rounds: int = 80) -> None:
    """Move overlapping annotations (offsets in points) apart vertically, the lower one down and the upper one
    up, until no two boxes overlap or ``rounds`` passes are spent: matplotlib places no labels by itself, and the
    sweep's points crowd where the front is steep."""
    renderer = fig.canvas.get_renderer()
    for _ in range(rounds):
        moved = False
        boxes = [t.get_window_extent(renderer) for t in texts]
        for i in range(len(texts)):
            for j in range(i + 1, len(texts)):
                if boxes[i].overlaps(boxes[j]):
                    lo, hi = (i, j) if boxes[i].y0 <= boxes[j].y0 else (j, i)
                    for k, d in ((lo, -step), (hi, step)):
                        x, y = texts[k].xyann
                        texts[k].xyann = (x, y + d)
                        boxes[k] = texts[k].get_window_extent(renderer)
                    moved = True
        if not moved:
            return


def plot(result: dict, path: Path) -> None:
    """Pareto plot of the reciprocal (PNG): worst-case correct bits against the cost proxy, and against LUT4 where
    the FPGA flow ran."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    recs = unit_points(result, "recip")
    w = result["meta"]["dsp_weight"]
    has_fpga = any(r["fpga"] and r["fpga"].get("LUT4") for r in recs)
    fig, axes = plt.subplots(1, 2 if has_fpga else 1, figsize=(13 if has_fpga else 8, 5.5), squeeze=False)
    ax = axes[0][0]
    colors = {"round": "tab:blue", "midpoint": "tab:orange"}
    markers = {1: "v", 2: "s", 3: "o", 4: "D"}
    for r in recs:
        if r["correct_bits_worst"] is None:
            continue
        ax.scatter(r["cost"], r["correct_bits_worst"], c=colors.get(r["params"]["table"], "gray"),
                   marker=markers[r["params"]["t"]], s=30, alpha=0.75, zorder=2)
    front = [r for r in recs if r.get("pareto") and r["correct_bits_worst"] is not None]
    front.sort(key=lambda r: r["cost"])
    ax.step([r["cost"] for r in front], [r["correct_bits_worst"] for r in front], where="post", c="k", lw=1.2,
            zorder=1, label="Pareto front")
    labels = []
    for k, r in enumerate(front):          # labels alternate right-below / left-above to limit overlaps
        named = r["family"] in ("paper", "preset")
        labels.append(ax.annotate(r["name"], (r["cost"], r["correct_bits_worst"]), fontsize=6.5,
                                  color="red" if named else "k", xytext=(5, -9) if k % 2 else (-6, 5),
                                  ha="left" if k % 2 else "right", textcoords="offset points"))
    for r in recs:
        if r["family"] in ("paper", "preset"):
            ax.scatter(r["cost"], r["correct_bits_worst"], s=140, facecolors="none", edgecolors="red", zorder=3)
            if not r.get("pareto"):
                labels.append(ax.annotate(r["name"], (r["cost"], r["correct_bits_worst"]), fontsize=7.5,
                                          color="red", xytext=(6, -3), textcoords="offset points"))
    for name, tb, mu, cb in ANCHORS:
        ax.scatter(tb + w * mu, cb, marker="*", s=220, c="green", zorder=4)
        labels.append(ax.annotate(name, (tb + w * mu, cb), fontsize=7.5, color="green", xytext=(-8, 6),
                                  ha="right", textcoords="offset points"))
    for t, mk in markers.items():
        ax.scatter([], [], marker=mk, c="gray", label=f"t = {t}")
    for k, c in colors.items():
        ax.scatter([], [], marker="o", c=c, label=f"{k} table")
    ax.scatter([], [], marker="*", c="green", s=120, label="published anchor")
    ax.set_xscale("log")
    ax.set_xlabel(f"cost: table bits + {w:g} × MULT18X18D blocks (estimated)")
    ax.set_ylabel("correct bits (worst case, measured)")
    ax.set_title("Reciprocal: correct bits against cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    if has_fpga:
        ax = axes[0][1]
        placed = sorted((r for r in recs if (r["fpga"] or {}).get("LUT4") and r["correct_bits_worst"] is not None),
                        key=lambda r: r["correct_bits_worst"])
        for k, r in enumerate(placed):      # labels alternate sides (neighbours in bits are often close)
            f = r["fpga"]
            ax.scatter(f["LUT4"], r["correct_bits_worst"], s=40 + 12 * f["DSP"], c="tab:purple", alpha=0.7)
            labels.append(ax.annotate(f"{r['name']}\n{f['DSP']} DSP, {f['fmax_mhz']:.0f} MHz",
                                      (f["LUT4"], r["correct_bits_worst"]), fontsize=7,
                                      xytext=(7, -4) if k % 2 == 0 else (-7, -4),
                                      ha="left" if k % 2 == 0 else "right", textcoords="offset points"))
        ax.set_xlabel("ECP5 LUT4 (marker size: MULT18X18D blocks)")
        ax.set_ylabel("correct bits (worst case, measured)")
        ax.set_title("Placed and routed (ECP5-85, speed 8)")
        ax.grid(True, alpha=0.3)
        ax.margins(x=0.3, y=0.15)
    fig.tight_layout()
    declutter(fig, labels)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_savefig(path, fig, dpi=130)
    plt.close(fig)


def plot_units(result: dict, path: Path) -> None:
    """Per-unit plots (PNG): worst-case correct bits against cost for each non-reciprocal unit (families by
    marker, Pareto front as a step line, presets circled, ECP5 LUT4 / Fmax beside the points placed), and the
    pipeline points' PSNR against reference (a) over cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .sweep_units import UNIT_ERRORS

    w = result["meta"]["dsp_weight"]
    units = [u for u in UNIT_ERRORS if unit_points(result, u)]
    pipe = (result.get("pipeline") or {}).get("points") or []
    n = len(units) + bool(pipe)
    if n == 0:
        return
    cols = min(3, n)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.4 * rows), squeeze=False)
    labels = []
    for k, unit in enumerate(units):
        _unit_panel(axes[k // cols][k % cols], result, unit, w, labels)
    if pipe:
        _pipeline_panel(axes[(n - 1) // cols][(n - 1) % cols], pipe, w, labels)
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.tight_layout()
    declutter(fig, labels)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_savefig(path, fig, dpi=120)
    plt.close(fig)


def _unit_panel(ax, result: dict, unit: str, w: float, labels: list) -> None:
    """One unit's panel of :func:`plot_units`: its families, Pareto front, presets and placed points (their
    annotations appended to ``labels``)."""
    from .sweep_units import UNIT_ERRORS

    markers = ["o", "s", "D", "^", "v"]
    recs = [r for r in unit_points(result, unit) if r["correct_bits_worst"] is not None]
    mid = (min(r["cost"] for r in recs) + max(r["cost"] for r in recs)) / 2 if recs else 0
    fams = list(dict.fromkeys(r["family"] for r in recs if r["family"] != "preset"))
    for j, fam in enumerate(fams):
        pts = [r for r in recs if r["family"] == fam]
        ax.scatter([r["cost"] for r in pts], [r["correct_bits_worst"] for r in pts], marker=markers[j % 5],
                   s=28, alpha=0.8, label=f"{fam} family")
    for r in recs:
        if r["family"] == "preset":
            ax.scatter(r["cost"], r["correct_bits_worst"], s=120, facecolors="none", edgecolors="red", zorder=3)
            labels.append(ax.annotate(r["name"].replace(f"{unit} ", ""), (r["cost"], r["correct_bits_worst"]),
                                      fontsize=7, color="red", xytext=(6, -10), textcoords="offset points"))
        f = r["fpga"] or {}
        if f.get("LUT4"):
            left = r["cost"] <= mid
            labels.append(ax.annotate(f"ECP5: {f['LUT4']} LUT4, {f['DSP']} DSP, {f['fmax_mhz']:.0f} MHz",
                                      (r["cost"], r["correct_bits_worst"]), fontsize=6.5, color="tab:purple",
                                      xytext=(6, 6) if left else (-6, -14), ha="left" if left else "right",
                                      textcoords="offset points"))
    front = sorted((r for r in recs if r.get("pareto")), key=lambda r: r["cost"])
    ax.step([r["cost"] for r in front], [r["correct_bits_worst"] for r in front], where="post", c="k", lw=1,
            zorder=1, label="Pareto front")
    if len({r["cost"] for r in recs}) == 1:
        ax.text(0.03, 0.03, f"every point: {recs[0]['dsp_blocks_est']} MULT18X18D, {recs[0]['table_bits']} table "
                "bits\n(the cost proxy does not see the narrower adders)", transform=ax.transAxes, fontsize=7)
    ax.set_title(textwrap.fill(f"{unit}: {UNIT_ERRORS[unit]['what']}", 60), fontsize=8.5)   # titles of a row
                                                                                            # must not overlap
    ax.set_xlabel(f"cost: table bits + {w:g} × MULT18X18D (est.)", fontsize=8)
    ax.set_ylabel("correct bits, worst case (−log2 error)", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.margins(x=0.12, y=0.12)
    ax.legend(fontsize=7, loc="lower right")


def _pipeline_panel(ax, pipe: list, w: float, labels: list) -> None:
    """The pipeline panel of :func:`plot_units`: each point's PSNR against reference (a) over cost."""
    right = max(r["cost"] for r in pipe)
    def db(r):                          # an exact match (None) is drawn at the top of the axis
        return 99.0 if r["psnr_db_vs_float"] is None else min(r["psnr_db_vs_float"], 99.0)
    for k, r in enumerate(sorted(pipe, key=lambda r: (db(r), r["cost"]))):
        y = db(r)
        c = "grey" if r.get("refused") else "red" if r["preset"] else "tab:blue"
        ax.scatter(r["cost"], y, c=c, s=40, zorder=3, marker="x" if r.get("refused") else "o")
        near_edge = r["cost"] > 0.9 * right          # labels alternate above / below, inward at the right edge
        refused = ", refused" if r.get("refused") else ""
        labels.append(ax.annotate(f"{r['name']} ({r['max_lsb_vs_float']} LSB{refused})", (r["cost"], y),
                                  fontsize=6.5, color=c, xytext=(-6 if near_edge else 6, 5 if k % 2 == 0 else -11),
                                  ha="right" if near_edge else "left", textcoords="offset points"))
    front = sorted((r for r in pipe if r.get("pareto")), key=lambda r: r["cost"])
    ax.step([r["cost"] for r in front], [db(r) for r in front], where="post",
            c="k", lw=1, zorder=1)
    ax.set_title(f"pipeline, {pipe[0]['scene']} {pipe[0]['width']}×{pipe[0]['height']} (bit-exact model)",
                 fontsize=8.5)
    ax.set_xlabel(f"cost: table bits + {w:g} × MULT18X18D (est.)", fontsize=8)
    ax.set_ylabel("PSNR against float reference (a), dB", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.margins(x=0.35, y=0.12)
