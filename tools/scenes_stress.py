"""``bumpmap scenes-stress [--count 200] [--seed 0] [--size 32] [--preset default]``: random scenes.

Renders ``--count`` random valid scenes (:func:`host.scenegen.random_scene`, seeds ``seed .. seed + count -
1``) through the bit-exact model and reference (a) with ``--preset``, and prints the figures the README quotes:
how many scenes the preset accepts and refuses (and why), the share of accepted frames within 1 LSB
of (a) on every well-conditioned pixel, how many are within the documented bound, the worst frames, and the
ill-conditioned pixels (:data:`host.render.ILL_CONDITIONED`). Frames without a visible fragment are counted
apart. Writes every scene's result to ``build/scenes_stress/report.json``; ``--keep DIR`` also writes the TOML
of each frame over 1 LSB into DIR (to keep as a named regression scene).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import build_dir
from host.args import int_range, size_arg
from host.atomic import atomic_json, atomic_write_text
from host.render import SCENE_BOUND_LSB, ClampError, judge, prepare, render
from host.scene import parse_scene
from host.scenegen import random_scene
from tools.record import add_record_option, machine, write_if_asked


def run_one(seed: int, size: int, preset: str = "default") -> dict:
    """Render random scene ``seed``; a dict: ``seed``, ``status`` (``refused``, ``empty`` or ``drawn``) and the
    figures (``max_lsb``, ``max_lsb_well``, ``ill``, ``pixels``, ``verdict``; or ``refused`` names)."""
    text = random_scene(np.random.default_rng(seed), size=size, name=f"random-{seed}")
    scene = parse_scene(text, source=f"random scene {seed}")
    try:
        frame = prepare(scene, preset=preset)
    except ClampError as exc:
        return {"seed": seed, "status": "refused", "refused": sorted(exc.clamped) + sorted(exc.imprecise)}
    if not len(frame.codes):
        return {"seed": seed, "status": "empty"}
    rep = render(frame)
    rep.pop("_model_bytes")
    judge(rep)
    return {"seed": seed, "status": "drawn", "pixels": rep["pixels"], "max_lsb": rep["max_lsb_vs_float"],
            "max_lsb_well": rep["max_lsb_vs_float_well_conditioned"], "ill": rep["ill_conditioned_pixels"],
            "max_lsb_ill": rep["max_lsb_vs_float_ill_conditioned"], "pass": rep["verdict"]["pass"],
            "pixels_by_lsb": rep["pixels_by_lsb_vs_float"], "text": text}


def summary(results: list) -> dict:
    """The figures over ``results`` of :func:`run_one`."""
    drawn = [r for r in results if r["status"] == "drawn"]
    refused = [r for r in results if r["status"] == "refused"]
    why = {}
    for r in refused:
        for name in r["refused"]:
            why[name] = why.get(name, 0) + 1
    within1 = sum(r["max_lsb_well"] <= 1 for r in drawn)
    return {"scenes": len(results), "drawn": len(drawn), "refused": len(refused),
            "empty": sum(r["status"] == "empty" for r in results), "refused_because": why,
            "drawn_within_1_lsb_well_conditioned": within1,
            "share_within_1_lsb": round(within1 / len(drawn), 4) if drawn else None,
            "drawn_within_bound": sum(r["pass"] for r in drawn), "bound_lsb": SCENE_BOUND_LSB,
            "worst_lsb_well_conditioned": max((r["max_lsb_well"] for r in drawn), default=0),
            "worst_seeds": [r["seed"] for r in sorted(drawn, key=lambda r: -r["max_lsb_well"])[:5]],
            "median_pixels": float(np.median([r["pixels"] for r in drawn])) if drawn else 0,
            "frames_with_ill_conditioned_pixels": sum(r["ill"] > 0 for r in drawn),
            "ill_conditioned_pixels": sum(r["ill"] for r in drawn),
            "worst_lsb_ill_conditioned": max((r["max_lsb_ill"] for r in drawn), default=0),
            "seeds_over_1_lsb_ill_conditioned": [r["seed"] for r in drawn if r["max_lsb_ill"] > 1],
            "seconds_per_scene": None}


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap scenes-stress``, :mod:`tools.main`)."""
    ap.add_argument("--count", type=int_range(1, 10**6), default=200, help="scenes (default: %(default)s)")
    ap.add_argument("--seed", type=int_range(0, 2**63 - 1), default=0, help="first seed (default: %(default)s)")
    ap.add_argument("--size", type=size_arg(), default=32, help="image width and height (default: %(default)s)")
    ap.add_argument("--preset", default="default")
    ap.add_argument("--out", default=str(build_dir("scenes_stress")), help="report folder")
    ap.add_argument("--keep", help="write the scenes of frames over 1 LSB here")

    add_record_option(ap, "the summary")


def run(args: argparse.Namespace) -> int:
    before = machine()
    t0 = time.perf_counter()
    results = []
    from tqdm import tqdm
    for seed in tqdm(range(args.seed, args.seed + args.count), unit="scene", desc="random scenes"):
        results.append(run_one(seed, args.size, args.preset))
    summ = summary(results)
    summ["command"] = (f"bumpmap scenes-stress --count {args.count} --seed {args.seed} --size {args.size} "
                       f"--preset {args.preset}")
    summ["seconds"] = round(time.perf_counter() - t0, 1)
    summ["seconds_per_scene"] = round(summ["seconds"] / max(1, args.count), 2)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_json(out / "report.json", {"summary": summ, "scenes": [
        {k: v for k, v in r.items() if k != "text"} for r in results]}, indent=1)
    if args.keep:
        for r in results:
            if r["status"] == "drawn" and r["max_lsb_well"] > 1:
                Path(args.keep).mkdir(parents=True, exist_ok=True)
                atomic_write_text(Path(args.keep) / f"random-{r['seed']}.toml", r["text"])
    print(json.dumps(summ, indent=1))
    write_if_asked(args, summ, before)
    return 0 if summ["drawn_within_bound"] == summ["drawn"] else 1
