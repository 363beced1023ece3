"""``bumpmap mip``: the bit-exact pipeline with MIP mapping of the color texture against the true image, on every
shipped scene (paper section 6, "artifact reduced MIP mapping"; ``docs/filtering.md``).

For each scene: the bit-exact model frame with the scene's preset (no filtering) and with the same preset plus
MIP mapping (``mip_levels``, ``lod_bias``, ``level_bits``: trilinear color texture at the fixed-point LOD unit's
level, the bump map unfiltered), each against reference (c) (:mod:`host.truth`, ``--samples`` per pixel along each
axis) on the fully covered pixels: PSNR, mean FLIP, 99th percentile and largest difference; the MIP frame's
distance from its own reference (a) on the well-conditioned pixels (the 1-LSB bound); and the LOD unit's largest
error on every fragment against the exact level of the same codes, beside its proven bound
(:meth:`fxmodel.units.lod.LodParams.error_bound`). Writes the JSON record (``--record``); ``bumpmap docs`` renders
it (:func:`table`).
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from fxmodel.core.paths import SCENES, shipped_scenes
from tools.record import add_record_option, machine, write_if_asked

__all__ = ["add_arguments", "run", "table", "mip_units", "lod_worst"]


def add_arguments(ap) -> None:
    from tools.filtering import add_truth_options
    add_truth_options(ap, "as bumpmap filtering")
    ap.add_argument("--levels", type=int, default=16, help="MIP levels, capped at the 1 x 1 level "
                    "(default: %(default)s)")
    ap.add_argument("--bias", type=int, default=-128, help="LOD bias, a code of 8 fraction bits "
                    "(default: %(default)s, -0.5 level)")
    ap.add_argument("--level-bits", type=int, default=8, help="bits of the blend between two levels "
                    "(default: %(default)s)")
    add_record_option(ap, "the rows")


def mip_units(preset: str, levels: int, bias: int, level_bits: int):
    """The units of ``preset`` with MIP mapping turned on (a validated preset)."""
    from fxmodel.pipeline.presets import PipelinePreset, preset_units
    return PipelinePreset.from_mapping({**preset_units(preset), "mip_levels": levels, "lod_bias": bias,
                                        "level_bits": level_bits})


def lod_worst(frame) -> dict:
    """The LOD unit on every fragment of ``frame`` against the exact level of the same codes (Fractions)."""
    from fxmodel.pipeline.pixel import LOD_INPUTS
    p = frame.params
    if p.lod is None:                                        # a one-texel texture: nothing to filter
        return {"bound_levels": None, "worst_levels": None, "within_bound": True, "flagged": 0, "level_range": None,
                "levels": 1}
    names = [q.name for q in p.inputs]
    cols = [np.asarray(frame.codes[:, names.index(n)], np.int64) for n in ("Uc", "Vc", "W", *LOD_INPUTS)]
    lam, flags = p.lod.compute(*cols)
    ok = np.flatnonzero(flags == 0)
    got = lam[ok] / (1 << p.lod.lod_frac)
    exact = np.array([p.lod.exact(*[c[i] for c in cols]) for i in ok])
    # the bound's domain: conditioning kappa <= 2^kappa_bits (fxmodel/units/lod.py); beyond, the bound at kappa
    kappa = np.array([p.lod.conditioning(*[c[i] for c in cols]) for i in ok])
    err = np.abs(got - exact)
    inside = kappa <= 2.0 ** p.lod.kappa_bits
    worst = float(err[inside].max(initial=0.0))
    own = all(e <= p.lod.error_bound(k * (1 + 1e-9)) + 1e-12 for e, k in zip(err[~inside], kappa[~inside]))
    return {"bound_levels": round(p.lod.error_bound(), 5), "worst_levels": round(worst, 5),
            "within_bound": bool(worst <= p.lod.error_bound() + 1e-12 and own), "flagged": int(len(lam) - len(ok)),
            "kappa_max": round(float(kappa.max(initial=0.0)), 1), "beyond_domain": int((~inside).sum()),
            "level_range": [round(float(got.min(initial=0)), 3), round(float(got.max(initial=0)), 3)],
            "levels": p.texture.levels}


def flicker(args, name: str = "grazing-floor") -> dict:
    """The pan of ``bumpmap filtering`` (``tools.filtering.flicker``: a slow yaw, the RMS over the pixels fully
    covered in both frames of each frame-to-frame change less (c)'s own) with the bit-exact frames, without and
    with MIP mapping."""
    from host.render import prepare, render
    from host.scene import load_scene
    from host.shipped import scene_preset
    from host.truth import true_image
    from tools.filtering import pan
    base, preset = load_scene(SCENES / f"{name}.toml"), scene_preset(name)
    units = {"none": preset, "mip": mip_units(preset, args.levels, args.bias, args.level_bits)}
    seq = {"none": [], "mip": [], "truth": [], "full": []}
    for i in range(args.pan_frames):
        scene = pan(base, i * args.pan_degrees)
        for key, u in units.items():
            frame = prepare(scene, preset=u)
            seq[key].append(frame.image(render(frame, references=False)["_model_bytes"]).astype(np.float64))
        truth = true_image(scene, args.samples)
        seq["truth"].append(truth.image.astype(np.float64))
        seq["full"].append(truth.full)
    sq, n = {"none": 0.0, "mip": 0.0}, 0
    for i in range(args.pan_frames - 1):
        m = seq["full"][i] & seq["full"][i + 1]
        dt = (seq["truth"][i + 1] - seq["truth"][i])[m]
        for key in sq:
            sq[key] += float((((seq[key][i + 1] - seq[key][i])[m] - dt) ** 2).sum())
        n += dt.size
    out = {"scene": name, "frames": args.pan_frames, "degrees_per_frame": args.pan_degrees,
           **{f"flicker_{k}": round(math.sqrt(v / max(n, 1)), 3) for k, v in sq.items()}}
    out["reduction"] = round(out["flicker_none"] / out["flicker_mip"], 2) if out["flicker_mip"] else None
    return out


def _scene(name: str, args) -> dict:
    from host.render import prepare, render
    from host.shipped import scene_preset
    from host.truth import against_truth
    path = SCENES / f"{name}.toml"
    preset = scene_preset(name)
    plain = prepare(path, preset=preset)
    mip = prepare(path, preset=mip_units(preset, args.levels, args.bias, args.level_bits))
    r0, r1 = render(plain), render(mip)
    a = mip.references()[0]
    images = {"none": plain.image(r0["_model_bytes"]), "mip": mip.image(r1["_model_bytes"]), "mip_float": mip.image(a)}
    vs, _ = against_truth(plain.scene, images, args.samples)
    return {"preset": preset, "vs_truth": {k: vs[k]["full"] for k in images}, "full_pixels": vs["full_pixels"],
            "max_lsb_vs_float_well_conditioned": r1["max_lsb_vs_float_well_conditioned"],
            "max_lsb_vs_float_well_conditioned_unfiltered": r0["max_lsb_vs_float_well_conditioned"],
            "clamped_fragment_inputs": r1["clamped_fragment_inputs"], "lod": lod_worst(mip),
            "texture_levels": [list(s) for s in mip.params.texture.level_sizes]}


def run(args) -> int:
    """Every shipped scene with and without MIP mapping against the true image."""
    names = args.scenes if args.scenes is not None else shipped_scenes()
    for name in names:
        if not (SCENES / f"{name}.toml").is_file():
            print(f"error: --scenes: no scene {name!r} in {SCENES}", file=sys.stderr)
            return 2
    if not 1 <= args.samples <= 128 or not 1 <= args.levels <= 16 or not 1 <= args.level_bits <= 8 \
            or args.pan_frames < 0 or args.pan_frames == 1:
        print("error: --samples must be 1..128, --levels 1..16, --level-bits 1..8, --pan-frames 0 or >= 2",
              file=sys.stderr)
        return 2
    before, t0 = machine(), time.perf_counter()
    rows = {}
    for name in names:
        print(f"mip: {name}", file=sys.stderr)
        rows[name] = _scene(name, args)
    data = {"samples": args.samples, "levels": args.levels, "bias": args.bias, "level_bits": args.level_bits,
            "scenes": rows}
    if args.pan_frames >= 2 and "grazing-floor" in names:
        print("mip: flicker pan", file=sys.stderr)
        data["flicker"] = flicker(args)
    data["seconds"] = round(time.perf_counter() - t0, 1)
    print(table(data))
    write_if_asked(args, data, before)
    return 0


def _db(v) -> str:
    return "exact" if v is None or (isinstance(v, float) and math.isinf(v)) else f"{v:.2f} dB"


def table(data: dict) -> str:
    """Markdown tables of a ``bumpmap mip`` result: each scene without and with MIP mapping against (c), the
    distance from (a), and the LOD's worst case against its bound."""
    head = ["scene", "frame", "PSNR vs (c)", "mean FLIP", "p99 (LSB)", "max (LSB)", "max vs (a) (LSB)"]
    rows = []
    for name, s in data["scenes"].items():
        for key, label, lsb in (("none", f"no filtering (`{s['preset']}`)",
                                 s["max_lsb_vs_float_well_conditioned_unfiltered"]),
                                ("mip", "MIP mapping (bit-exact)", s["max_lsb_vs_float_well_conditioned"]),
                                ("mip_float", "MIP mapping, float (a)", "")):
            m = s["vs_truth"][key]
            rows.append([f"`{name}`" if key == "none" else "", label, _db(m["psnr_db"]), f"{m['flip_mean']:.4f}",
                         f"{m['p99_lsb']:g}", str(m["max_lsb"]), str(lsb)])
    out = ["| " + " | ".join(head) + " |", "|---|---|---:|---:|---:|---:|---:|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    lod = ["| scene | levels | LOD range (levels) | bound (levels) | worst (levels) | within | largest kappa |",
           "|---|---:|---|---:|---:|---|---:|"]
    for name, s in data["scenes"].items():
        v = s["lod"]
        if v["levels"] == 1:
            lod.append(f"| `{name}` | 1 | one-texel texture: no MIP mapping | | | | |")
            continue
        lod.append(f"| `{name}` | {v['levels']} | {v['level_range'][0]} .. {v['level_range'][1]} | "
                   f"{v['bound_levels']:.4f} | {v['worst_levels']:.4f} | {'yes' if v['within_bound'] else '**no**'} | "
                   f"{v.get('kappa_max', '')} |")
    fl = data.get("flicker")
    pan = ("" if not fl else f"\n\nFlicker of the bit-exact frames on a pan of the `{fl['scene']}`, {fl['frames']} "
           f"frames, {fl['degrees_per_frame']} degrees a frame (RMS of each frame-to-frame change less the truth's "
           "own, as `bumpmap filtering`):\n\n| no filtering | MIP mapping | reduction |\n|---:|---:|---:|\n"
           f"| {fl['flicker_none']} | {fl['flicker_mip']} | {fl['reduction']}x |")
    return "\n".join(out) + (f"\n\nReference (c): {data['samples']} x {data['samples']} samples per pixel, fully "
                             f"covered pixels. MIP mapping: up to {data['levels']} levels, LOD bias code "
                             f"{data['bias']} (8 fraction bits), {data['level_bits']}-bit blend between levels. The "
                             "largest distance from (a) is on the well-conditioned pixels.\n\nThe LOD unit on every "
                             "fragment against "
                             "the exact level of the same codes (the bound holds on the fragments of conditioning "
                             "kappa up to the LOD unit's domain, any beyond held to the bound at their own kappa: "
                             "`fxmodel/units/lod.py`):\n\n") + "\n".join(lod) + pan
