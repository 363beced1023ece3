"""Co-simulation of the level-of-detail RTL (``rtl/lod.py``) against the golden model (``fxmodel/units/lod.py``), bit
for bit: random pixels of random triangles and the hard cases the model's bound is proven on -- grazing (``W`` tiny
with a large ``W_x``), magnified (increments of a few ulps), degenerate (zero increments: the flag), ``W`` at its far
end (a few ulps) and ``W <= 0``, saturation (the largest increments at the smallest ``W``). Every preset on its
hard cases and random vectors under stalls: ``cosim/test_stress.py``. ``SIM=verilator`` runs the same tests on
Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.core.unit import preset
from fxmodel.units.lod import FLAG_BAD_W, FLAG_SATURATED, FLAG_ZERO


def pixels(params, rng, k: int) -> np.ndarray:
    """``k`` pixels of each kind (codes ``(5 k, 9)``): uniform codes with a positive ``W``; grazing; magnified;
    degenerate; ``W`` at its far end."""
    u, w, du, dw = params.uv_fmt, params.w_fmt, params.duv_fmt, params.dw_fmt
    fu, fw, fdu, fdw = u.frac_bits, w.frac_bits, du.frac_bits, dw.frac_bits

    def ints(lo, hi):
        return rng.integers(lo, hi, size=k, endpoint=True)

    uniform = params.random_inputs(rng, k)
    uniform[:, 2] = ints(1, w.max_code)
    # grazing: a floor seen edge-on, W from 1 down to 2^-12 falling fast along y, U changing along x
    wv = 2.0 ** rng.uniform(-12, 0, k)
    slope = rng.uniform(-0.45, 0.45, k)
    grazing = np.stack([np.rint(rng.uniform(-2, 2, k) * wv * 2 ** fu), np.rint(0.3 * wv * 2 ** fu),
                        np.clip(np.rint(wv * 2 ** fw), 1, w.max_code), np.rint(rng.uniform(0.5, 3, k) * 2 ** (fdu - 6)),
                        np.rint(slope * 2 ** (fdu - 8)), np.zeros(k), np.full(k, np.rint(0.01 * 2 ** fdu)),
                        np.zeros(k), np.rint(-slope * wv * 2 ** fdw)], axis=1)
    # magnified: increments of a few ulps; degenerate: some or all of them zero
    magnified = np.concatenate([uniform[:, :3], rng.integers(-4, 5, size=(k, 6))], axis=1)
    degenerate = magnified.copy()
    degenerate[:, 3:] *= rng.integers(0, 2, size=(k, 6)) * (rng.random((k, 1)) < 0.5)
    far = uniform.copy()
    far[:, 2] = ints(1, 16)
    return np.concatenate([uniform, grazing.astype(np.int64), magnified, degenerate, far])


@pytest.mark.parametrize("name", ["default", "npot"])
def test_lod_random_and_hard_pixels(sim, name):
    params = preset("lod", name)
    rng = np.random.default_rng(list(map(ord, name)))
    vectors = np.concatenate([params.hard_cases(), pixels(params, rng, 600)])
    result = run(params, vectors, sim=sim, tag=name)
    assert_bit_exact(result)
    # the run reached every outcome: a level, each flag, both ends of the format
    lod, flags = result.rtl[:, 0], result.rtl[:, 1]
    for flag in (FLAG_ZERO, FLAG_BAD_W, FLAG_SATURATED):
        assert (flags & flag).any(), flag
    assert (flags == 0).sum() > len(vectors) // 3
    fmt = params.out_fmt
    assert (lod == fmt.max_code).any() and (lod[flags == 0] < 0).any() and (lod[flags == 0] > 0).any()


def test_lod_bias_and_narrow_formats(sim):
    """A positive bias, a 6-entry-bit table with no guard bits, narrow formats (no operand group wider than one
    multiplier block: no shift), a non-square map, and narrower shifted operands and ``D`` (12 and 10 bits)."""
    from fxmodel.core.fixed import Fmt
    params = preset("lod").replace(uv_fmt=Fmt(True, 3, 9), w_fmt=Fmt(True, 1, 12), duv_fmt=Fmt(True, 2, 14),
                                   dw_fmt=Fmt(True, 1, 15), size=(256, 8), table_bits=6, guard=0, lod_frac=4,
                                   lod_int=5, bias=9)
    assert params.latency == preset("lod").latency
    rng = np.random.default_rng(11)
    vectors = np.concatenate([params.hard_cases(), pixels(params, rng, 400)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="narrow"))
    short = preset("lod").replace(op_bits=12, sq_bits=10)
    vectors = np.concatenate([short.hard_cases(), pixels(short, rng, 400)])
    assert_bit_exact(run(short, vectors, sim=sim, tag="short"))


def scene_pixels(name: str, width: int, height: int):
    """``(LodParams, codes)`` of every fragment of a shipped scene drawn from triangles by the scan converter's
    model: ``Uc, Vc, W`` the fragment's, the increments the triangle record's ``Uc_dx ... W_dy`` (the
    interpolators' own, in their accumulator formats ``RasterParams.acc_fmt``) -- what the engine from the
    triangle hands the LOD unit when the scan converter passes a triangle's increments on with its fragments --
    and the LOD of the color texture's size."""
    from types import SimpleNamespace

    from fxmodel.units.lod import LodParams
    from fxmodel.units.raster import scan
    from host.bumpmap import bump_gain
    from host.frontend import triangle_records
    from host.render import prepare, raster_params
    from host.scene import load_scene, scene_path
    from host.shipped import scene_preset

    scene = load_scene(scene_path(name)).with_size(width, height)
    frame = prepare(scene, preset=scene_preset(name))
    raster = raster_params(frame.units)
    mi = int(frame.frags.material[0])
    gains = [frame.maps if i == mi else SimpleNamespace(a_gain=bump_gain(m)) for i, m in enumerate(scene.materials)]
    recs, _, mat = triangle_records(scene, raster, gains, frame.exponent)
    res = scan(raster, recs)
    keep = mat[res.record] == mi
    p = frame.params
    params = LodParams(uv_fmt=p.persp.uv_fmt, w_fmt=p.persp.recip.in_fmt, duv_fmt=raster.acc_fmt("Uc"),
                       dw_fmt=raster.acc_fmt("W"), size=(p.texture.width, p.texture.height))
    cols = [res.codes[n][keep] for n in ("Uc", "Vc", "W")]
    cols += [recs.codes[f"{n}_{d}"][res.record[keep]] for n in ("Uc", "Vc", "W") for d in ("dx", "dy")]
    return params, np.stack(cols, axis=1)             # U, V, W, Ux, Uy, Vx, Vy, Wx, Wy


@pytest.mark.parametrize("name", ["grazing-floor", "tin-plane"])
def test_lod_on_scene_fragments_from_triangles(sim, name):
    """The grazing floor (levels from magnified to a dozen levels down at the horizon) and the tin plane, every
    fragment of a reduced frame, with the increments as the triangle records hold them."""
    params, vectors = scene_pixels(name, 128, 96)
    assert len(vectors) > 1000
    result = run(params, vectors, sim=sim, tag=name)
    assert_bit_exact(result)
    flags = result.rtl[:, 1]
    assert (flags & FLAG_BAD_W == 0).all()                          # the front end never sends W <= 0
