"""``bumpmap filtering``: every shipped scene against the true image, and the filtering study.

For each shipped scene: the bit-exact model frame (today's pipeline, no filtering) and float reference (a) against
reference (c) (:mod:`host.truth`, ``--samples`` per pixel along each axis) on the fully covered pixels, and apart
on the edge pixels: PSNR, RMSE, largest and 99th-percentile difference, mean FLIP (:mod:`host.metrics`); and the
same for the chosen filter (:data:`CHOSEN`). Then the study (paper section 6, "artifact reduced MIP mapping for
bump textures"): each filtering choice of :func:`study_choices`, in float (:mod:`host.filtered`), against (c) on
the study scenes; the convergence of (c) itself (``--samples`` against ``--check-samples``); and the flicker of a
slow camera pan over the grazing floor (:func:`flicker`). Writes the JSON record (``--record``) and the picture
none | ours | truth of the grazing floor (``--picture``), both atomically.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import ROOT, SCENES, shipped_scenes
from host.atomic import atomic_save_png, atomic_write_text
from host.shipped import scene_preset

__all__ = ["add_arguments", "add_truth_options", "run", "study_choices", "CHOSEN", "flicker", "measure_scene", "pan"]

#: Scenes of the study and of the flicker measure.
STUDY_SCENES = ("grazing-floor", "tin-plane")


def _choice(**kw):
    from host.filtered import Choice
    return Choice(**kw)


#: The filter this study chooses: anisotropic color and LEAN bump lookups (at most 4 trilinear taps along the
#: footprint's major axis), per-texel slope covariance, four specular cubes a factor 4 apart in exponent whose
#: faces shrink by 4 per lobe (64, 16, 8, 8 texels for a 64-texel cube: about 1.1 times one cube's memory).
CHOSEN = dict(color="anisotropic", bump="lean", bump_footprint="anisotropic", lean="covariance", spec="cubes",
              lobes=4, ratio=4.0, taps=4, shrink=2)


def study_choices() -> list:
    """The filtering choices measured, cheapest first (:class:`host.filtered.Choice` arguments)."""
    iso = dict(color="trilinear")
    aniso = dict(color="anisotropic", bump_footprint="anisotropic")
    lean = dict(bump="lean", lean="covariance")
    rows = [dict(), dict(color="nearest-level"), iso, dict(iso, bias=-0.5), dict(iso, bias=0.5),
            dict(iso, kernel="tent"), dict(iso, bump="mean"), dict(iso, bump="lean"), dict(iso, **lean),
            dict(iso, **lean, spec="cubes"), dict(color="anisotropic"), dict(aniso, bump="mean"),
            dict(aniso, bump="lean"), dict(aniso, **lean)]
    rows += [dict(aniso, **lean, spec="cubes", lobes=lobes, taps=taps)
             for lobes, taps in ((4, 2), (4, 4), (4, 8), (4, 16), (3, 4), (2, 4))]
    rows += [dict(aniso, **lean, spec="cubes", lobes=4, taps=4, shrink=shrink) for shrink in (1, 2)]
    rows += [dict(aniso, **lean, spec="cubes", lobes=2, taps=4, shrink=2), dict(aniso, **lean, spec="cubes",
                                                                              taps=4, shrink=2, bias=-0.25)]
    return rows


def add_truth_options(ap, pan_degrees: str) -> None:
    """The options ``bumpmap filtering`` and ``bumpmap mip`` share: the scenes, the samples of reference (c) and the
    flicker pan (``pan_degrees`` ends the pan's help: what the default yaw is)."""
    ap.add_argument("--scenes", nargs="*", default=None, help="scene names in scenes/ (default: every shipped scene)")
    ap.add_argument("--samples", type=int, default=8, help="samples per pixel along each axis of reference (c) "
                    "(default: %(default)s)")
    ap.add_argument("--pan-frames", type=int, default=8, help="frames of the flicker pan; 0: none "
                    "(default: %(default)s)")
    ap.add_argument("--pan-degrees", type=float, default=0.1, help="camera yaw per frame of the pan "
                    f"(default: %(default)s, {pan_degrees})")


def add_arguments(ap) -> None:
    add_truth_options(ap, "about a fifth of a pixel")
    ap.add_argument("--check-samples", type=int, default=16, help="the convergence check of (c) on the study "
                    "scenes at this many samples per axis; 0: none (default: %(default)s)")
    ap.add_argument("--reference-samples", type=int, default=32, help="the sample-pattern study on the grazing "
                    "floor: regular and jittered truths at --samples and --check-samples against a jittered truth "
                    "at this many samples per axis; 0: none (default: %(default)s)")
    ap.add_argument("--size", type=int, default=None, help="render every scene at this width (aspect kept) "
                    "instead of its own size (quick runs)")
    ap.add_argument("--record", type=Path, default=ROOT / "docs" / "records" / "filtering.json",
                    help="JSON record to write (default: docs/records/filtering.json)")
    ap.add_argument("--picture", type=Path, default=ROOT / "docs" / "img" / "grazing-floor.png",
                    help="picture none | ours | truth of the grazing floor (default: docs/img/grazing-floor.png)")


def _load(name: str, size):
    from host.scene import load_scene
    return load_scene(SCENES / f"{name}.toml", size=size or None)


def _frame(scene, name: str):
    from host.render import prepare
    return prepare(scene, preset=scene_preset(name))


def measure_scene(name: str, samples: int, size=None) -> tuple[dict, dict]:
    """Figures of one shipped scene against (c): the model frame, reference (a) and the chosen filter, on the
    fully covered and the edge pixels; and the images ``{"none", "ours", "truth"}`` (for the picture)."""
    from host.filtered import Choice, render_filtered
    from host.metrics import compare
    from host.render import render
    from host.truth import true_image
    scene = _load(name, size)
    t0 = time.perf_counter()
    truth = true_image(scene, samples)
    t1 = time.perf_counter()
    frame = _frame(scene, name)
    model = frame.image(render(frame, references=False)["_model_bytes"])
    a, _ = frame.references()
    ours = frame.image(render_filtered(frame, Choice(**CHOSEN)))
    out = {"preset": scene_preset(name), "width": scene.width, "height": scene.height,
           "full_pixels": int(truth.full.sum()), "edge_pixels": int(truth.edge.sum()),
           "seconds_truth": round(t1 - t0, 1)}
    for key, img in (("model", model), ("float_a", frame.image(a)), ("filtered", ours)):
        out[key] = {"full": compare(img, truth.image, truth.full), "edge": compare(img, truth.image, truth.edge),
                    "flip_mean_whole_frame": round(float(_flip_whole(img, truth.image)), 4)}
    return out, {"none": model, "ours": ours, "truth": truth.image}


def _flip_whole(img, ref) -> float:
    from host.metrics import flip_map
    return flip_map(ref, img).mean()


def study(name: str, samples: int, check: int, size=None) -> dict:
    """Each choice of :func:`study_choices` against (c) on scene ``name``, and (c)'s convergence."""
    from host.filtered import Choice, lookups_per_pixel, render_filtered
    from host.metrics import compare
    from host.render import render
    from host.truth import true_image
    scene = _load(name, size)
    frame = _frame(scene, name)
    truth = true_image(scene, samples)
    model = frame.image(render(frame, references=False)["_model_bytes"])
    rows = [{"choice": "model (bit-exact, no filtering)", "params": None,
             "full": compare(model, truth.image, truth.full)}]
    images = {}
    for kw in study_choices():
        c = Choice(**kw)
        img = frame.image(render_filtered(frame, c))
        images[c.label()] = img
        rows.append({"choice": c.label(), "params": dataclasses.asdict(c), "chosen": c == Choice(**CHOSEN),
                     "bilinear_lookups_per_pixel": lookups_per_pixel(frame, c),
                     "full": compare(img, truth.image, truth.full)})
    out = {"samples": samples, "rows": rows}
    if check:
        fine = true_image(scene, check)
        both = truth.full & fine.full
        for row in rows:
            img = model if row["params"] is None else images[row["choice"]]
            row[f"full_vs_{check}x{check}"] = compare(img, fine.image, both)
        conv = {"truth_vs_truth": compare(truth.image, fine.image, both)}
        for label, img in (("model", model), ("chosen", images[Choice(**CHOSEN).label()])):
            conv[label] = {str(samples): compare(img, truth.image, truth.full & fine.full),
                           str(check): compare(img, fine.image, truth.full & fine.full)}
        out["convergence"] = {"samples": [samples, check], **conv}
    return out


def pattern_study(name: str, samples: int, check: int, reference: int, size=None) -> dict:
    """Regular grid against jittered sampling of (c): each pattern at ``samples`` and ``check`` samples per axis
    against a jittered truth at ``reference``, and the model's and the chosen filter's figures against each."""
    from host.filtered import Choice, render_filtered
    from host.metrics import compare
    from host.render import render
    from host.truth import true_image
    scene = _load(name, size)
    frame = _frame(scene, name)
    model = frame.image(render(frame, references=False)["_model_bytes"])
    ours = frame.image(render_filtered(frame, Choice(**CHOSEN)))
    ref = true_image(scene, reference, "jittered", seed=1)          # another seed than the truths it judges
    out = {"reference": f"jittered {reference}x{reference}, seed 1", "rows": []}
    for k in sorted({samples, check} - {0}):
        for pattern in ("grid", "jittered"):
            t0 = time.perf_counter()
            t = true_image(scene, k, pattern)
            mask = ref.full & t.full
            out["rows"].append({"pattern": pattern, "samples": k, "seconds": round(time.perf_counter() - t0, 1),
                                "truth_vs_reference": compare(t.image, ref.image, mask, flip=False),
                                "model": compare(model, t.image, mask), "chosen": compare(ours, t.image, mask)})
    mask = ref.full
    out["rows"].append({"pattern": "jittered", "samples": reference, "seed": 1,
                        "model": compare(model, ref.image, mask), "chosen": compare(ours, ref.image, mask)})
    return out


def pan(scene, degrees: float):
    """``scene`` with its camera turned by ``degrees`` about the world's y axis (a yaw pan)."""
    cam = scene.camera
    d = np.subtract(cam.target, cam.position)
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    d = (c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2])
    target = tuple(float(p + q) for p, q in zip(cam.position, d))
    return dataclasses.replace(scene, camera=dataclasses.replace(cam, target=target))


def flicker(name: str, samples: int, frames: int, degrees: float, size=None) -> dict:
    """Temporal stability on a slow yaw pan: per frame the model (no filtering), trilinear color alone, the chosen
    filter and (c); the flicker of a sequence is the RMS, over the pixels fully covered in both frames and the
    frame pairs, of its frame-to-frame change minus (c)'s own (``Delta test - Delta truth``, 8-bit steps)."""
    from host.filtered import Choice, render_filtered
    from host.render import render
    from host.truth import true_image
    base = _load(name, size)
    trilinear = Choice(color="trilinear")
    seq = {"none": [], "trilinear": [], "ours": [], "truth": [], "full": []}
    for i in range(frames):
        scene = pan(base, i * degrees)
        frame = _frame(scene, name)
        truth = true_image(scene, samples)
        seq["none"].append(frame.image(render(frame, references=False)["_model_bytes"]).astype(np.float64))
        seq["ours"].append(frame.image(render_filtered(frame, Choice(**CHOSEN))).astype(np.float64))
        seq["trilinear"].append(frame.image(render_filtered(frame, trilinear)).astype(np.float64))
        seq["truth"].append(truth.image.astype(np.float64))
        seq["full"].append(truth.full)
    out = {"frames": frames, "degrees_per_frame": degrees, "samples": samples, "none": "the model frame",
           "trilinear": trilinear.label(), "ours": Choice(**CHOSEN).label()}
    sq = {"none": 0.0, "trilinear": 0.0, "ours": 0.0, "truth": 0.0}
    n = 0
    for i in range(frames - 1):
        m = seq["full"][i] & seq["full"][i + 1]
        dt = (seq["truth"][i + 1] - seq["truth"][i])[m]
        for key in ("none", "trilinear", "ours"):
            sq[key] += float((((seq[key][i + 1] - seq[key][i])[m] - dt) ** 2).sum())
        sq["truth"] += float((dt ** 2).sum())
        n += dt.size
    for key in sq:
        out[f"rms_{key}" if key == "truth" else f"flicker_{key}"] = round(math.sqrt(sq[key] / max(n, 1)), 3)
    out["reduction"] = round(out["flicker_none"] / out["flicker_ours"], 2) if out["flicker_ours"] else None
    out["reduction_trilinear"] = (round(out["flicker_none"] / out["flicker_trilinear"], 2)
                                  if out["flicker_trilinear"] else None)
    return out


def lod_check(name: str, size=None) -> dict:
    """The fixed-point level of detail (:class:`fxmodel.units.lod.LodParams`) on every fragment of scene
    ``name``, for its color texture and its bump map: ``U, V, W`` are the fragment's pipeline input codes, the
    increments each triangle's exact ``U_x = k (rep u_x - tile (1/w)_x)``, ``W_x = k (1/w)_x`` rounded to
    ``duv_fmt`` and ``dw_fmt``. Records the largest distance from the exact level of the same codes (the unit's
    documented bound) and from the float level of :func:`host.mipmap.level_of_detail` (which adds the
    rounding of the inputs)."""
    from fxmodel.core.fixed import Fmt
    from fxmodel.units.lod import LodParams
    from host.frontend import clip_space
    from host.mipmap import level_of_detail, screen_derivatives, texel_derivatives
    scene = _load(name, size)
    frame = _frame(scene, name)
    f, maps, p = frame.frags, frame.maps, frame.params
    names = [q.name for q in p.inputs]
    tris = scene.triangles()
    coef = np.linalg.solve(clip_space(scene, tris.positions),
                           np.concatenate([tris.uvs, np.ones(tris.uvs.shape[:2] + (1,))], -1))[np.asarray(f.tri)]
    px = np.array([2.0 / scene.width, -2.0 / scene.height])
    k = np.asarray(f.wscale)
    duv_fmt, dw_fmt = Fmt(True, 4, 36), Fmt(True, 2, 38)
    out = {"duv_fmt": str(duv_fmt), "dw_fmt": str(dw_fmt), "fragments": len(f)}
    duv = screen_derivatives(scene, f)
    for label, (nu, nv), rep, tile, shape in (
            ("color", ("Uc", "Vc"), maps.color_repeat, f.tile_c, maps.color.shape[:2]),
            ("bump", ("U", "V"), maps.bump_repeat, f.tile, frame.bump_float().shape[:2])):
        lp = LodParams(uv_fmt=p.persp.uv_fmt, w_fmt=p.persp.recip.in_fmt, duv_fmt=duv_fmt, dw_fmt=dw_fmt,
                       size=(int(shape[1]), int(shape[0])))
        inc = {}
        for ax, axn in ((0, "x"), (1, "y")):
            w1 = k * coef[:, ax, 2] * px[ax]
            inc["W" + axn] = np.rint(w1 * 2.0 ** dw_fmt.frac_bits)
            for i, n in enumerate((nu, nv)):
                v = k * (rep[i] * coef[:, ax, i] - tile[:, i] * coef[:, ax, 2]) * px[ax]
                inc[n + axn] = np.rint(v * 2.0 ** duv_fmt.frac_bits)
        cols = [frame.codes[:, names.index(nu)], frame.codes[:, names.index(nv)], frame.codes[:, names.index("W")],
                inc[nu + "x"], inc[nu + "y"], inc[nv + "x"], inc[nv + "y"], inc["Wx"], inc["Wy"]]
        cols = [np.asarray(c, dtype=np.int64) for c in cols]
        lam, flags = lp.compute(*cols)
        ok = flags == 0
        got = lam / (1 << lp.lod_frac)
        exact = np.array([lp.exact(*[c[i] for c in cols]) for i in np.flatnonzero(ok)])
        flt = level_of_detail(texel_derivatives(duv, rep, shape))[ok]
        worst = np.abs(got[ok] - exact)
        # the bound at each fragment's conditioning kappa (its domain kappa <= 2^kappa_bits: fxmodel/units/lod.py)
        kappa = np.array([lp.conditioning(*[c[i] for c in cols]) for i in np.flatnonzero(ok)])
        bounds = np.array([lp.error_bound(max(k * (1 + 1e-9), 2.0 ** lp.kappa_bits)) for k in kappa])
        out[label] = {"size": list(lp.size), "bound_levels": round(lp.error_bound(), 5),
                      "max_error_vs_exact_levels": round(float(worst.max(initial=0)), 5),
                      "within_bound": bool((worst <= bounds + 1e-12).all()),
                      "kappa_max": round(float(kappa.max(initial=0.0)), 1),
                      "max_error_vs_float_levels": round(float(np.abs(got[ok] - flt).max(initial=0)), 5),
                      "flagged": int((~ok).sum()), "level_range": [round(float(got[ok].min()), 3),
                                                                   round(float(got[ok].max()), 3)],
                      "table_entries": 1 << lp.table_bits, "products_per_pixel": lp.products_per_pixel()}
    return out


def _picture(path: Path, images: dict) -> None:

    from host.render import compose
    img = compose(images["none"], images["ours"], images["truth"])
    atomic_save_png(path, img)


def run(args) -> int:
    """Every shipped scene against the true image (reference (c)), and the filtering study (MIP maps, LEAN bump
    maps, level of detail)."""
    t0 = time.perf_counter()
    names = args.scenes if args.scenes is not None else shipped_scenes()
    for name in names:
        if not (SCENES / f"{name}.toml").is_file():
            print(f"error: --scenes: no scene {name!r} in {SCENES}", file=sys.stderr)
            return 2
    powers = [args.samples] + [k for k in (args.check_samples, args.reference_samples) if k]
    if any(k < 1 or k > 128 or k & (k - 1) for k in powers) or args.pan_frames < 0 or args.pan_frames == 1:
        print("error: --samples, --check-samples and --reference-samples must be powers of two up to 128 (or 0 for "
              "the last two), --pan-frames 0 or >= 2", file=sys.stderr)
        return 2
    argv = sys.argv[sys.argv.index("filtering") + 1:] if "filtering" in sys.argv else []
    record = {"command": " ".join(["bumpmap", "filtering", *argv]),
              "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
              "machine": {"nproc": os.cpu_count(), "load_average": [round(x, 2) for x in os.getloadavg()]},
              "samples": args.samples, "sample_pattern": "stratified (jittered): one uniform random point per "
              "cell of a K x K grid, seed 0 (host.truth; pattern_study measures it against the regular grid)",
              "chosen": _choice(**CHOSEN).label(), "scenes": {}, "study": {}}
    for name in names:
        print(f"filtering: {name}", file=sys.stderr)
        record["scenes"][name], images = measure_scene(name, args.samples, args.size)
        if name == "grazing-floor":
            _picture(args.picture, images)
    for name in STUDY_SCENES:
        if name in names:
            print(f"filtering: study on {name}", file=sys.stderr)
            record["study"][name] = study(name, args.samples, args.check_samples, args.size)
    if args.reference_samples and "grazing-floor" in names:
        print("filtering: sample patterns", file=sys.stderr)
        record["pattern_study"] = pattern_study("grazing-floor", args.samples, args.check_samples,
                                                args.reference_samples, args.size)
    for name in STUDY_SCENES:
        if name in names:
            print(f"filtering: level of detail on {name}", file=sys.stderr)
            record.setdefault("lod", {})[name] = lod_check(name, args.size)
    if args.pan_frames and "grazing-floor" in names:
        print("filtering: flicker pan", file=sys.stderr)
        record["flicker"] = flicker("grazing-floor", args.samples, args.pan_frames, args.pan_degrees, args.size)
    record["seconds"] = round(time.perf_counter() - t0, 1)
    text = json.dumps(record, indent=1, allow_nan=False) + "\n"
    atomic_write_text(args.record, text)
    print(json.dumps({k: record[k] for k in ("chosen", "seconds")}, indent=1))
    return 0
