r"""Design-space sweep of the reciprocal: speed against error (issue 7, item 2).

``python -m cosim.sweep [--no-fpga] [--fpga-points N] [--jobs J] [--docs]`` (second phase of ``make bench``)
measures a grid of about 45 reciprocal configurations that spans cheap to precise: table index bits ``m``, table
word bits ``b``, Taylor terms ``t`` (1 to 4), output precision ``p`` and table mode (``round``, the paper's
``round(1/w_h)``, against ``midpoint``, the expansion about each interval's centre; ``fxmodel/recip.py``). The grid
(:func:`default_grid`) holds

* the presets ``default``, ``small`` and ``rcp24``, and the paper's configuration (``paper``: 128 entries
  (``m = 8``), ``t = 3``, ``round`` table, no centring constant, ``p = 17`` on the 24-bit input, ``b = 17``,
  ``guard = 2``);
* ``faithful`` points: for ``t`` in 1 to 4, ``m`` in 5 to 8 (``t = 1``: 6 to 12) and both modes, the widest
  ``p <= 24`` whose documented bound (``error_bound_ulp``) is below one ulp, with ``b = p + 3``, ``guard = 4``;
* ``p17`` points: ``p = 17``, ``b = 20``, ``guard = 4`` for ``t`` in 2 to 4, ``m`` in 6 and 8, both modes (the
  error a fixed output width gets from each table and term count, faithful or not).

Every point but ``rcp24`` has the 24-bit input ``s8.16`` (``small``: ``s4.12``). For each point the bit-exact model
(:meth:`RecipParams.compute`) runs over **every** input when the input space is at most ``--exhaustive-limit``
(default ``2**24``), else over ``--samples`` uniform random inputs plus the unit's hard cases; the error of each
output against the exact ``1/w`` comes from :func:`fxmodel.exact.recip_error_ulp` (exact integers). Recorded:
worst and mean error in ulps of the result, correct bits ``p - 1 - log2(error)`` (relative error of a mantissa in
``[1, 2)``; worst and mean), the documented bound, table bits, multipliers, estimated MULT18X18D blocks
(:func:`dsp_blocks`), latency, model throughput (one timing of the whole ``compute`` call, one core), and, for at
most ``--fpga-points`` points (the four named ones first, then Pareto points spread evenly inside the front), the
ECP5 results of :func:`rtl.fpga.run_designs` (LUT4, FF, DSP, block RAM, Fmax; cached under ``build/fpga``).

Cost and Pareto front. Without place and route for every point, the cost is a proxy:
``table_bits + dsp_weight * dsp_blocks`` (``--dsp-weight``, default 1024 ROM bits per 18x18 multiplier block).
A point is on the front when no other point has at least as many worst-case correct bits at no more cost
(and is better in one). Published anchors on the plot: NVIDIA's SFU reciprocal (Oberman & Siu 2005: 128 entries
of quadratic-interpolation coefficients, about 6.5 Kbit, two multipliers, at most 1 ulp at 24 bits, drawn at 23
correct bits) and the paper's configuration (measured here).

Writes ``build/bench/speed_vs_error.json``, ``build/bench/speed_vs_error.md`` and ``build/bench/pareto.png``
(with ``--docs`` also ``docs/img/pareto.png``).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

from fxmodel.exact import recip_error_ulp
from fxmodel.fixed import Fmt
from fxmodel.recip import RecipParams
from fxmodel.unit import preset

__all__ = ["PAPER", "ANCHORS", "dsp_blocks", "faithful_p", "default_grid", "measure_point", "pareto_front",
           "sweep", "markdown", "plot", "write_outputs", "main"]

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "build" / "bench"
DOCS_IMG = ROOT / "docs" / "img"

#: Input format of the sweep (the default preset's 24-bit ``s8.16``).
IN24 = Fmt(True, 8, 16)

#: The paper's configuration (section 4.1): 128 entries, three terms, ``round(1/w_h)``, no centring constant.
PAPER = RecipParams(in_fmt=IN24, m=8, b=17, t=3, p=17, guard=2, table="round", center=False)

#: Published reference points: ``(label, table_bits, multipliers, correct_bits)``.
ANCHORS = [("NVIDIA SFU (Oberman & Siu 2005)", 6656, 2, 23.0)]

#: Chunk of inputs measured at once (bounds the memory of the exact error arithmetic).
CHUNK = 1 << 22


def dsp_blocks(params: RecipParams) -> int:
    """Estimated MULT18X18D blocks: one per product whose operands fit 18 bits, else the number of partial
    products of ``rtl.recip.pieces`` (17-bit pieces and a top piece of at most 18 bits per operand)."""
    def npieces(w):
        return 1 if w <= params.DSP_BITS else 1 + math.ceil((w - params.DSP_BITS) / (params.DSP_BITS - 1))
    return sum(npieces(a) * npieces(b) for _, a, b in params.product_operands())


def _params(m, t, p, table, b=None, guard=4, in_fmt=IN24):
    try:
        return RecipParams(in_fmt=in_fmt, m=m, b=p + 3 if b is None else b, t=t, p=p, guard=guard, table=table)
    except ValueError:
        return None


def faithful_p(m: int, t: int, table: str, p_max: int = 24, in_fmt: Fmt = IN24) -> RecipParams | None:
    """The configuration with the widest ``p <= p_max`` whose documented bound is below one ulp (``b = p + 3``,
    ``guard = 4``), by bisection (the bound in ulps grows with ``p``); ``None`` if no ``p >= 4`` is faithful."""
    def ok(p):
        P = _params(m, t, p, table, in_fmt=in_fmt)
        return P is not None and P.error_bound_ulp < 1

    lo = next((p for p in range(4, p_max + 1) if _params(m, t, p, table, in_fmt=in_fmt)), None)
    if lo is None or not ok(lo):
        return None
    if ok(p_max):
        return _params(m, t, p_max, table, in_fmt=in_fmt)
    hi = p_max
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return _params(m, t, lo, table, in_fmt=in_fmt)


def default_grid() -> list[tuple[str, str, RecipParams]]:
    """``(name, family, params)`` of the sweep (module docstring), duplicates removed (first name kept)."""
    grid = [(f"preset {n}", "preset", preset("recip", n)) for n in ("default", "small", "rcp24")]
    grid.append(("paper", "paper", PAPER))
    for m in (6, 8, 10, 12):
        P = faithful_p(m, 1, "round")
        if P is not None:
            grid.append((f"t1 m{m} round p{P.p}", "faithful", P))
    for t in (2, 3, 4):
        for m in (5, 6, 7, 8):
            for table in ("round", "midpoint"):
                P = faithful_p(m, t, table)
                if P is not None:
                    grid.append((f"t{t} m{m} {table} p{P.p}", "faithful", P))
    for t in (2, 3, 4):
        for m in (6, 8):
            for table in ("round", "midpoint"):
                P = _params(m, t, 17, table, b=20)
                if P is not None:
                    grid.append((f"t{t} m{m} {table} p17", "p17", P))
    seen, out = set(), []
    for name, family, P in grid:
        if P not in seen:
            seen.add(P)
            out.append((name, family, P))
    return out


def _inputs(params: RecipParams, exhaustive_limit: int, samples: int, rng) -> tuple[np.ndarray, bool]:
    if params.input_space() <= exhaustive_limit:
        return params.all_inputs()[:, 0], True
    w = np.concatenate([params.random_inputs(rng, samples)[:, 0], params.hard_cases()[:, 0]])
    return w, False


def measure_point(name: str, family: str, params: RecipParams, *, exhaustive_limit: int = 1 << 24,
                  samples: int = 10 ** 6, dsp_weight: float = 1024.0, seed: int = 1) -> dict:
    """Error, cost and model throughput of one configuration (one JSON record; fields in the module docstring)."""
    rng = np.random.default_rng(seed)
    w, exhaustive = _inputs(params, exhaustive_limit, samples, rng)
    params.compute(w[:1000, None])                     # tables and cached formats outside the timing
    t0 = time.perf_counter()
    out = params.compute(w[:, None])
    rate = len(w) / (time.perf_counter() - t0)
    worst, worst_w, total = Fraction(0), None, 0.0
    for lo in range(0, len(w), CHUNK):
        num, den = recip_error_ulp(w[lo:lo + CHUNK], out[lo:lo + CHUNK, 0], out[lo:lo + CHUNK, 1],
                                   params.in_fmt.frac_bits, params.fo)
        err = np.asarray(num, dtype=np.float64) / np.asarray(den, dtype=np.float64)
        total += float(err.sum())
        i = int(np.argmax(err))
        cand = Fraction(int(num[i]), int(den[i]))       # exact worst of the chunk (float argmax, exact value)
        if cand > worst:
            worst, worst_w = cand, int(w[lo + i])
    mean = total / len(w)
    bound = params.error_bound_ulp
    dsp = dsp_blocks(params)

    def bits(e):
        return round(params.p - 1 - math.log2(e), 3) if e > 0 else None

    return {
        "name": name, "family": family,
        "params": {"in_fmt": str(params.in_fmt), "m": params.m, "b": params.b, "t": params.t, "p": params.p,
                   "guard": params.guard, "table": params.table, "center": params.center},
        "entries": params.entries, "table_bits": params.table_bits, "multipliers": params.multipliers,
        "dsp_blocks_est": dsp, "latency": params.latency,
        "bound_ulp": float(bound), "worst_ulp": float(worst), "mean_ulp": mean,
        "worst_input_code": worst_w, "within_bound": bool(worst <= bound), "faithful": bool(worst < 1),
        "correct_bits_worst": bits(float(worst)), "correct_bits_mean": bits(mean),
        "vectors": int(len(w)), "exhaustive": exhaustive, "model_per_second": rate,
        "cost": params.table_bits + dsp_weight * dsp, "fpga": None,
    }


def pareto_front(records, cost_key: str = "cost", bits_key: str = "correct_bits_worst") -> list[int]:
    """Indices of the non-dominated records: no other record has ``>=`` bits at ``<=`` cost, better in one."""
    pts = [(r[cost_key], r[bits_key] if r[bits_key] is not None else math.inf) for r in records]
    front = []
    for i, (c, b) in enumerate(pts):
        if not any((c2 <= c and b2 >= b) and (c2 < c or b2 > b) for j, (c2, b2) in enumerate(pts) if j != i):
            front.append(i)
    return sorted(front, key=lambda i: pts[i][0])


def _fpga_subset(records, front, limit: int) -> list[int]:
    """The named points (presets, paper), then interior Pareto points spread evenly by cost, ``limit`` in all."""
    chosen = [i for i, r in enumerate(records) if r["family"] in ("preset", "paper")][:limit]
    rest = [i for i in front if i not in chosen]
    k = limit - len(chosen)
    if k > 0 and rest:
        picks = sorted({rest[round((j + 1) * (len(rest) - 1) / (k + 1))] for j in range(min(k, len(rest)))})
        chosen += picks
    return chosen


def _run_fpga(records, grid, idx, jobs: int, progress: bool) -> None:
    try:
        from rtl.fpga import run_designs
        results = run_designs([({"unit": "recip", "preset": records[i]["name"]}, grid[i][2]) for i in idx],
                              jobs=jobs, progress=progress)
    except Exception as exc:                       # a broken tool or RTL must not lose the model results
        print(f"sweep: FPGA flow failed: {exc!r}", file=sys.stderr)
        for i in idx:
            records[i]["fpga"] = {"error": repr(exc)}
        return
    for i, res in zip(idx, results):
        records[i]["fpga"] = {k: res.get(k) for k in ("LUT4", "FF", "DSP", "BRAM", "fmax_mhz", "target_mhz",
                                                      "met", "cached", "run", "error") if k in res}


def sweep(grid=None, *, exhaustive_limit: int = 1 << 24, samples: int = 10 ** 6, dsp_weight: float = 1024.0,
          fpga_points: int = 0, jobs: int = 1, progress: bool = True) -> dict:
    """Measure every ``(name, family, params)`` of ``grid`` (:func:`default_grid` if ``None``).

    Returns ``{"meta", "points", "pareto"}``: ``points`` the records of :func:`measure_point` (``pareto`` true on
    the front, ``fpga`` filled for at most ``fpga_points`` of them), ``pareto`` the front's names by cost.
    """
    from tqdm import tqdm

    t0 = time.perf_counter()
    grid = default_grid() if grid is None else list(grid)
    if not grid:
        raise ValueError("sweep: the grid is empty")
    records = []
    bar = tqdm(grid, desc="sweep", unit="point", disable=not progress)
    for name, family, params in bar:
        bar.set_postfix_str(name)
        records.append(measure_point(name, family, params, exhaustive_limit=exhaustive_limit, samples=samples,
                                     dsp_weight=dsp_weight))
    front = pareto_front(records)
    for i, r in enumerate(records):
        r["pareto"] = i in front
    if fpga_points > 0:
        _run_fpga(records, grid, _fpga_subset(records, front, min(fpga_points, len(records))), jobs, progress)
    meta = {"machine": platform.platform(), "python": platform.python_version(), "dsp_weight": dsp_weight,
            "exhaustive_limit": exhaustive_limit, "samples": samples, "seconds": round(time.perf_counter() - t0, 1),
            "cost": "table_bits + dsp_weight * dsp_blocks_est",
            "anchors": [{"name": a, "table_bits": tb, "multipliers": mu, "correct_bits": cb}
                        for a, tb, mu, cb in ANCHORS]}
    return {"meta": meta, "points": records, "pareto": [records[i]["name"] for i in front]}


def _fmt(v, spec):
    return "" if v is None else format(v, spec)


def markdown(result: dict) -> str:
    """The sweep as a Markdown table (front points in bold names), sorted by cost."""
    lines = ["| point | mode | m | entries | b | t | p | table bits | mult. (DSP est.) | latency | bound ulp "
             "| worst ulp | mean ulp | correct bits worst / mean | model M/s | LUT4 | DSP | Fmax MHz |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(result["points"], key=lambda r: (r["cost"], r["name"])):
        P, f = r["params"], r["fpga"] or {}
        name = f"**{r['name']}**" if r.get("pareto") else r["name"]
        mode = P["table"] + ("" if P["center"] else ", no centring")
        ex = "" if r["exhaustive"] else "*"
        lines.append(
            f"| {name} | {mode} | {P['m']} | {r['entries']} | {P['b']} | {P['t']} | {P['p']} | {r['table_bits']} "
            f"| {r['multipliers']} ({r['dsp_blocks_est']}) | {r['latency']} | {r['bound_ulp']:.3f} "
            f"| {r['worst_ulp']:.3f}{ex} | {r['mean_ulp']:.3f} | {_fmt(r['correct_bits_worst'], '.2f')} / "
            f"{_fmt(r['correct_bits_mean'], '.2f')} | {r['model_per_second'] / 1e6:.0f} | {_fmt(f.get('LUT4'), 'd')} "
            f"| {_fmt(f.get('DSP'), 'd')} | {_fmt(f.get('fmax_mhz'), '.1f')} |")
    meta = result["meta"]
    lines += ["", f"Bold: Pareto front of worst-case correct bits against cost = table bits + {meta['dsp_weight']:g} "
              "× estimated MULT18X18D blocks. Errors over every input (24-bit `s8.16` input; `small`: `s4.12`); "
              f"`*`: {meta['samples']:,} random inputs plus the hard cases. FPGA: ECP5-85 speed 8 (`rtl.fpga`)."]
    return "\n".join(lines)


def plot(result: dict, path: Path) -> None:
    """Pareto plot (PNG): worst-case correct bits against the cost proxy, and against LUT4 where the FPGA flow ran."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    recs = result["points"]
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
    for k, r in enumerate(front):          # labels alternate right-below / left-above to limit overlaps
        named = r["family"] in ("paper", "preset")
        ax.annotate(r["name"], (r["cost"], r["correct_bits_worst"]), fontsize=6.5, color="red" if named else "k",
                    xytext=(5, -9) if k % 2 else (-6, 5), ha="left" if k % 2 else "right",
                    textcoords="offset points")
    for r in recs:
        if r["family"] in ("paper", "preset"):
            ax.scatter(r["cost"], r["correct_bits_worst"], s=140, facecolors="none", edgecolors="red", zorder=3)
            if not r.get("pareto"):
                ax.annotate(r["name"], (r["cost"], r["correct_bits_worst"]), fontsize=7.5, color="red",
                            xytext=(6, -3), textcoords="offset points")
    for name, tb, mu, cb in ANCHORS:
        ax.scatter(tb + w * mu, cb, marker="*", s=220, c="green", zorder=4)
        ax.annotate(name, (tb + w * mu, cb), fontsize=7.5, color="green", xytext=(-8, 6), ha="right",
                    textcoords="offset points")
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
            ax.annotate(f"{r['name']}\n{f['DSP']} DSP, {f['fmax_mhz']:.0f} MHz", (f["LUT4"], r["correct_bits_worst"]),
                        fontsize=7, xytext=(7, -4) if k % 2 == 0 else (-7, -4), ha="left" if k % 2 == 0 else "right",
                        textcoords="offset points")
        ax.set_xlabel("ECP5 LUT4 (marker size: MULT18X18D blocks)")
        ax.set_ylabel("correct bits (worst case, measured)")
        ax.set_title("Placed and routed (ECP5-85, speed 8)")
        ax.grid(True, alpha=0.3)
        ax.margins(x=0.3, y=0.15)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def write_outputs(result: dict, out: Path = OUT, docs: bool = False) -> list[Path]:
    """Write the JSON, Markdown and PNG under ``out`` (and ``docs/img/pareto.png`` with ``docs``)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "speed_vs_error.json", out / "speed_vs_error.md", out / "pareto.png"]
    paths[0].write_text(json.dumps(result, indent=2))
    paths[1].write_text("Reciprocal design-space sweep, `python -m cosim.sweep`.\n\n" + markdown(result) + "\n")
    plot(result, paths[2])
    if docs:
        plot(result, DOCS_IMG / "pareto.png")
        paths.append(DOCS_IMG / "pareto.png")
    return paths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m cosim.sweep", description=__doc__.split("\n")[0])
    ap.add_argument("--no-fpga", action="store_true", help="skip the ECP5 flow")
    ap.add_argument("--fpga-points", type=int, default=6,
                    help="points placed and routed (cached; at most 6, default %(default)s)")
    ap.add_argument("--jobs", type=int, default=2, help="FPGA designs placed and routed in parallel")
    ap.add_argument("--exhaustive-limit", type=int, default=1 << 24,
                    help="measure every input when the input space is at most this (default 2**24)")
    ap.add_argument("--samples", type=int, default=10 ** 6, help="random inputs otherwise (plus the hard cases)")
    ap.add_argument("--dsp-weight", type=float, default=1024.0, help="ROM bits per multiplier block in the cost")
    ap.add_argument("--out", default=str(OUT), help="output folder (default: build/bench)")
    ap.add_argument("--docs", action="store_true", help="also write docs/img/pareto.png")
    args = ap.parse_args(argv)
    if not 0 <= args.fpga_points <= 6:
        print("error: --fpga-points must be 0 to 6 (each new design takes 1-2 minutes)", file=sys.stderr)
        return 2
    if args.samples < 1 or args.exhaustive_limit < 1 or args.dsp_weight < 0:
        print("error: --samples and --exhaustive-limit must be positive, --dsp-weight >= 0", file=sys.stderr)
        return 2
    result = sweep(exhaustive_limit=args.exhaustive_limit, samples=args.samples, dsp_weight=args.dsp_weight,
                   fpga_points=0 if args.no_fpga else args.fpga_points, jobs=args.jobs)
    paths = write_outputs(result, Path(args.out), docs=args.docs)
    print(markdown(result))
    print(f"\nPareto front: {', '.join(result['pareto'])}")
    print(f"({result['meta']['seconds']} s; written to {', '.join(str(p) for p in paths)})")
    bad = [r["name"] for r in result["points"] if not r["within_bound"]]
    if bad:
        print(f"error: measured error above the documented bound: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
