"""The cost model (``fxmodel/core/cost.py``): the declared products and memories are the ones the RTL builds, the
tiling reassembles every operand exactly, and the estimate matches the recorded ECP5 counts."""

from __future__ import annotations

import sys
from collections import Counter
from contextlib import contextmanager

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core import cost
from fxmodel.core.cost import Memory, Product
from fxmodel.core.unit import preset, preset_names, units

UNIT_PRESETS = [(u, n) for u in units() if u != "pipeline" for n in preset_names(u)]


@contextmanager
def census():
    """Record the operand shapes of every Amaranth product and every memory built inside the block."""
    from amaranth.hdl import Value
    from amaranth.lib import memory

    seen = {"products": [], "memories": []}
    mul, rmul = Value.__mul__, Value.__rmul__
    mem_init, read_port = memory.Memory.__init__, memory.Memory.read_port

    def key(a, b):
        sa, sb = Value.cast(a).shape(), Value.cast(b).shape()
        return tuple(sorted([(sa.width, sa.signed), (sb.width, sb.signed)]))

    def mul_(self, other):
        if isinstance(other, Value):
            seen["products"].append(key(self, other))
        return mul(self, other)

    def rmul_(self, other):
        if isinstance(other, Value):
            seen["products"].append(key(other, self))
        return rmul(self, other)

    def init_(self, *args, **kwargs):
        # the output FIFO of a stream interface (rtl/streams.py, amaranth.lib.fifo) and the scan converter's
        # FIFOs (rtl.streams.CreditFIFO) are plumbing, not a unit's memory: an asynchronous read port, so LUT RAM
        # (no DP16KD: the synthesized counts of the engine's pipeline confirm it), outside the cost model's DSP
        # and block-RAM counts
        if sys._getframe(1).f_globals.get("__name__") not in ("amaranth.lib.fifo", "rtl.streams"):
            seen["memories"].append(self)
        self._census_ports = 0
        mem_init(self, *args, **kwargs)

    def read_port_(self, *args, **kwargs):
        self._census_ports += 1
        return read_port(self, *args, **kwargs)

    Value.__mul__, Value.__rmul__ = mul_, rmul_
    memory.Memory.__init__, memory.Memory.read_port = init_, read_port_
    try:
        yield seen
    finally:
        Value.__mul__, Value.__rmul__ = mul, rmul
        memory.Memory.__init__, memory.Memory.read_port = mem_init, read_port


def built(params):
    """``(products, memories)`` the RTL of ``params`` builds: Counters of operand-shape pairs and of
    ``(words, bits, read ports)``."""
    from amaranth.hdl import Fragment, Shape

    from rtl.unit import build

    with census() as seen:
        Fragment.get(build(params), None)
    mems = Counter((m.depth, Shape.cast(m.shape).width, m._census_ports) for m in seen["memories"])
    return Counter(seen["products"]), mems


def declared(params):
    """The same Counters from the parameter object's declarations (every piece product the RTL writes, the
    cross products of a split square twice)."""
    prods = Counter()
    for p in params.products():
        pairs = ([(wa, sa, wb, sb) for _, wa, sa in cost.pieces(p.a_bits, p.a_signed)
                  for _, wb, sb in cost.pieces(p.b_bits, p.b_signed)] if p.split
                 else [(p.a_bits, p.a_signed, p.b_bits, p.b_signed)])
        for wa, sa, wb, sb in pairs:
            prods[tuple(sorted([(wa, sa), (wb, sb)]))] += p.count
    mems = Counter()
    for m in params.memories():
        mems[(m.words, m.bits, m.read_ports)] += m.count
    return prods, mems


@pytest.mark.parametrize("unit, name", UNIT_PRESETS)
def test_declared_products_and_memories_are_what_the_rtl_builds(unit, name):
    params = preset(unit, name)
    assert built(params) == declared(params)


def test_pipeline_declares_every_stage_sampler_blends_included():
    P = preset("pipeline")
    assert built(P) == declared(P)
    stages = [P.persp, P.bump_map, P.texture, P.bump, P.reflect, P.cube, P.cube, P.diffuse, P.specular, P.shade]
    assert P.cost()["dsp"] == sum(s.cost()["dsp"] for s in stages)
    assert any(p.name.startswith("f*") for p in P.products())           # the blends are in


def test_pipeline_with_mip_mapping_declares_its_lod_unit_and_trilinear_texture():
    """MIP mapping (``lod``): the RTL's LOD unit and trilinear color sampler are what the pipeline declares, and the
    cost is the stages' own, the LOD unit's included."""
    from host.render import pipeline_params
    P = pipeline_params("grazing-floor", "grazing-floor-mip")
    assert P.lod is not None and P.texture.trilinear
    assert built(P) == declared(P)
    stages = [P.persp, P.lod, P.bump_map, P.texture, P.bump, P.reflect, P.cube, P.cube, P.diffuse, P.specular,
              P.shade]
    assert P.cost()["dsp"] == sum(s.cost()["dsp"] for s in stages) > P.replace(
        lod=None, texture=P.texture.replace(filter="bilinear", mips=(), lod_fmt=None)).cost()["dsp"]


@given(st.integers(1, 80), st.booleans(), st.data())
def test_pieces_reassemble_every_operand(width, signed, data):
    """Exact integers: the pieces of any code sum back to it; each fits an 18-bit operand, and all but the top
    one are 17-bit unsigned (18-bit signed operands)."""
    lo_code = -(1 << (width - 1)) if signed else 0
    hi_code = (1 << (width - 1)) - 1 if signed else (1 << width) - 1
    x = data.draw(st.integers(lo_code, hi_code))
    total = 0
    cut = cost.pieces(width, signed)
    for lo, bits, piece_signed in cut:
        value = (x >> lo) & ((1 << bits) - 1)
        if piece_signed and value >> (bits - 1):
            value -= 1 << bits
        total += value << lo
        assert bits <= cost.DSP_BITS
        if lo + bits < width:
            assert bits == cost.DSP_BITS - 1 and not piece_signed
    assert total == x
    assert sum(bits for _, bits, _ in cut) == width


@pytest.mark.parametrize("a, b, blocks", [
    ((18, True), (18, True), 1), ((17, False), (18, True), 1),          # 17u becomes 18s: one block
    ((18, False), (18, True), 1),                                       # 19s: its top bit a one-bit slice (logic)
    ((20, True), (18, True), 2), ((36, True), (36, True), 4), ((37, True), (36, True), 4),
    ((1, True), (9, True), 0), ((8, False), (1, False), 0), ((4, True), (4, True), 1),
    ((2, True), (11, False), 0), ((17, False), (2, True), 0), ((3, True), (11, False), 1)])     # 2 bits: logic
def test_yosys_mapping_of_one_product(a, b, blocks):
    assert cost.mult_blocks([Product(a[0], b[0], a[1], b[1])]) == blocks


def test_split_square_merges_signed_cross_products_only():
    signed = Product(21, 21, True, True, split=True, square=True)
    unsigned = Product(20, 20, False, False, split=True, square=True)
    assert cost.mult_blocks([signed]) == 3 and cost.mult_blocks([unsigned]) == 4


def test_memories_in_logic_or_block_ram():
    assert cost.bram_blocks([Memory(64, 19)]) == 0                     # a reciprocal table: logic
    assert cost.bram_blocks([Memory(1024, 18)]) == 1
    assert cost.bram_blocks([Memory(1024, 18, read_ports=4)]) == 2     # two copies of two read ports
    assert cost.bram_blocks([Memory(4096, 36, count=4)]) == 4 * 8


@pytest.mark.parametrize("field, value", [("a_bits", 0), ("count", -1)])
def test_bad_product_is_refused(field, value):
    args = {"a_bits": 4, "b_bits": 4, field: value}
    with pytest.raises(ValueError, match=field):
        Product(**args)


def test_bad_memory_is_refused():
    with pytest.raises(ValueError, match="kind"):
        Memory(4, 4, kind="rom")
    with pytest.raises(ValueError, match="read_ports"):
        Memory(4, 4, read_ports=0)


def test_info_shows_the_estimate():
    info = preset("recip", "rcp24").info()
    assert info["cost"]["dsp"] == 13 and info["cost"]["table_bits"] == preset("recip", "rcp24").table_bits


def test_bram_estimate_counts_blocks_copies_and_memories_in_logic():
    """DP16KD estimate against hand counts. A bordered 64-texel cube map is banked by texel parity: four banks of 6 x
    33 x 33 = 6534 words of 36 bits read through their blocks' output registers (``rtl/bram.py``), seven groups of
    two 1024 x 18 columns each (Yosys' cheapest shape would be 13 blocks of 512 x 36); nearest filtering, one memory
    of 26136 words, 52 blocks. A 41 x 40 two-channel 12-bit repeat map (odd width: not banked) is 1640 words of 24
    bits, 3 blocks of 2048 x 9 per copy, two copies for four read ports; at 40 x 40 it is banked, four banks of 400
    words read through their blocks' output registers (``rtl/bram.py``), two 1024 x 18 columns each. An 8 x 8 map,
    four banks of 16 words, stays in logic."""
    import dataclasses

    import numpy as np

    from fxmodel.core.fixed import Fmt
    from fxmodel.units.sampler import SamplerParams, Texels

    def blocks(sampler):
        return cost.bram_blocks(sampler.memories())

    u2 = Fmt(False, 2, 10)
    cube = SamplerParams(texels=Texels(np.zeros((6, 66, 66, 3), np.int64)), channels=(u2,) * 3,
                         coord_fmt=Fmt(False, 1, 16), edge="border")
    assert cube.banked and blocks(cube) == 4 * 7 * 2
    assert blocks(dataclasses.replace(cube, filter="nearest")) == 52
    s12 = Fmt(True, 1, 11)
    odd = SamplerParams(texels=Texels(np.zeros((1, 40, 41, 2), np.int64)), channels=(s12,) * 2)
    assert not odd.banked and blocks(odd) == 3 * 2
    even = SamplerParams(texels=Texels(np.zeros((1, 40, 40, 2), np.int64)), channels=(s12,) * 2)
    assert even.banked and blocks(even) == 4 * 2
    tiny = SamplerParams(texels=Texels(np.zeros((1, 8, 8, 2), np.int64)), channels=(s12,) * 2)
    assert blocks(tiny) == 0


# -- the estimate against the recorded ECP5 counts (docs/fpga/resources.json, `bumpmap fpga --record`) --
#: Largest relative difference allowed when the record states a reason.
TOLERANCE = 0.10


def recorded_designs():
    """Every unit preset (``make fpga``), and the pipeline and the engine from the triangle that ``make fpga``
    places with a scene."""
    from tools.fpga import design_list
    return design_list() + design_list(["pipeline", "engine"], ["tin-plane-fit"], scene="tin-plane")


@pytest.fixture(scope="module")
def resources():
    import json

    from tools.fpga import RESOURCES, design_key
    return {design_key(d): d for d in json.loads(RESOURCES.read_text())["designs"]}


@pytest.mark.parametrize("label, params", recorded_designs(),
                         ids=lambda x: "/".join(str(v) for v in x.values()) if isinstance(x, dict) else "")
def test_estimate_matches_the_synthesized_count(label, params, resources):
    from tools.fpga import design_key, params_digest

    rerun = ("re-record: bumpmap fpga --synth-only --record docs/fpga/resources.json"
             + (f" --scene {label['scene']} --preset {label['preset']}" if "scene" in label else ""))
    rec = resources.get(design_key(label))
    assert rec is not None, f"{label}: no recorded count; {rerun}"
    assert rec["params_digest"] == params_digest(params), f"{label}: the parameters changed since the record; {rerun}"
    est = params.cost()
    for kind, key in (("DSP", "dsp"), ("BRAM", "bram")):
        if est[key] != rec[kind]:
            assert rec.get("reason"), f"{label}: {kind} estimate {est[key]} != recorded {rec[kind]}, no reason given"
            assert abs(est[key] - rec[kind]) <= TOLERANCE * rec[kind], \
                f"{label}: {kind} estimate {est[key]} is more than 10 % from recorded {rec[kind]} ({rec['reason']})"


@pytest.mark.parametrize("name", ["default", "on_chip", "small"])
def test_rop_declares_what_its_rtl_builds(name):
    """The raster-operations unit: no product (the pixel address is shifted copies of ``y``); on chip, the frame
    buffer memory."""
    from fxmodel.units.rop import RopParams
    P = RopParams.PRESETS[name]
    assert built(P) == declared(P)
    assert bool(P.memories()) == P.on_chip


def test_scan_converter_and_engine_declare_what_the_rtl_builds():
    """The scan converter's span-start products (one per attribute), and the engine from the triangle's whole
    count (scan converter plus pixel pipeline), through the same census as every unit."""
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.units.raster import RasterParams
    for name in RasterParams.PRESETS:
        R = RasterParams.PRESETS[name]
        assert built(R) == declared(R) and (R.cost()["dsp"] > 0) == R.span_dsp and R.cost()["bram"] == 0
    P = preset("pipeline")
    E = EngineParams(raster=RasterParams.for_pipeline(
        {"persp": P.persp, "bump": P.bump, "reflect": P.reflect}), pipeline=P)
    assert built(E) == declared(E)
    assert E.cost()["dsp"] == E.raster.cost()["dsp"] + P.cost()["dsp"]
