"""Property set of the engine with its depth test (``rtl/engine.py``, :class:`~rtl.engine.Engine`, the paper's
figure 5): the scan converter -> the pixel pipeline's stream unit -> the ROP behind its AXI4 port, composed.

The design is :class:`~rtl.engine.Engine` itself (its wiring, its sideband), with the pixel pipeline's datapath
abstracted (:mod:`formal.abstract`: the same :class:`~rtl.streams.StreamUnit` around a delay line of the
pipeline's latency and an opaque token; the pipeline's own stream version is proven whole beside it). Each part
brings the properties of its own proof, now with its neighbour's guarantee in place of an assumption (the
scan converter's rule 2 on ``o`` is the pipeline's input, the pipeline's rule 2 on ``o`` is the ROP's input):

- the triangle records: rule 2 assumed on ``i``; the memory: free within the AXI4 rules (stalls of at most
  :data:`formal.rop.STALL` cycles);
- ``raster_*``: the scan converter's (:func:`formal.raster.raster_props`); ``pipe_*``: rule 2 on the pipeline's
  ``o`` and its counts (:func:`formal.streamunit.stream_counts`); ``rop_*``: the AXI4 manager rules, the hazard
  rule and the slot accounting (:func:`formal.rop.rop_props`);
- conservation of fragments: the ROP's fragments accepted less those finished (dropped outside the frame, failed
  the depth test, or written and acknowledged) are those held (the accept register and the busy slots); the
  fragments the scan converter produced less those finished are those in the pipeline and in the ROP.

Proven by k-induction (the parts' invariants together are inductive). Sizes: the smallest that builds: the
default pipeline preset's ports and latency (74), a 16-pixel viewport, a 4 x 4 frame, 3 slots.
"""

from __future__ import annotations

import copy

from amaranth.hdl import Signal, Value

from fxmodel.core.unit import preset
from fxmodel.pipeline.engine import EngineParams
from fxmodel.units.raster import RasterParams
from fxmodel.units.rop import RopParams
from rtl.engine import Engine
from rtl.raster import Raster
from rtl.streams import StreamUnit, buffer_depth

from . import whitebox
from .abstract import Abstract
from .props import Harness, bits_for
from .raster import raster_props
from .readers import drive_inputs
from .rop import rop_props
from .streamunit import stream_counts

__all__ = ["small_engine", "engine_set"]


def small_engine() -> EngineParams:
    """The engine of the proof: the default pipeline's ports and latency (its datapath abstracted), the scan
    converter of its attributes on a 16-pixel viewport, a ROP of a 4 x 4 frame with 3 slots."""
    pipe = preset("pipeline", "default")
    raster = RasterParams.for_pipeline({"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect},
                                       max_size=16, subpixel_bits=2, guard_pixels=16, extra_guard=0)
    rop = RopParams(width=4, height=4, max_size=16, z_in=raster.out_fmt("Z"), outstanding=3, addr_bits=12)
    params = copy.copy(EngineParams(raster=raster, pipeline=pipe, rop=rop))
    object.__setattr__(params, "pipeline", Abstract.of(pipe))     # checked above with the real pipeline
    return params


def engine_set(*, kind: str = "proof", wrap=None) -> Harness:
    ep = small_engine()
    h = Harness(kind)
    m = h.m
    inner = Engine(ep)
    dut = wrap(inner) if wrap else inner
    pre = "dut/" if wrap else ""
    frag = whitebox.elaborate(dut)
    m.submodules.dut = frag
    drive_inputs(h, dut)
    h.stream_hold(dut.i.valid, dut.i.ready, Value.cast(dut.i.payload), "i", assume=True)
    ras = whitebox.origin(frag, pre + "raster", Raster)
    pix = whitebox.origin(frag, pre + "pipeline", StreamUnit)
    rop = inner._rop
    with h.scope("raster_", covers=False):
        raster_props(h, ep.raster, ras, frag, pre + "raster")
    with h.scope("pipe_", covers=False):
        h.stream_hold(pix.o.valid, pix.o.ready, pix.o.payload.as_value(), "o")
        c = stream_counts(h, ep.pipeline, pix, frag, pre + "pipeline/")
    with h.scope("rop_", covers=False):
        r = rop_props(h, ep.rop, rop, whitebox.subfragment(frag, pre + "rop"))
    # conservation of fragments
    R = ep.rop
    w = bits_for(4 * (buffer_depth(ep.pipeline, pix.in_stages) + R.outstanding + 4))
    take = rop.i.valid & rop.i.ready
    f = rop.i.payload
    drop = take & ~((f.x < R.width) & (f.y < R.height))
    finished = drop + r.fail + r.b_x
    held = r.s_valid + sum(r.busy[k] for k in range(r.N))
    in_rop = Signal(w, name="f_in_rop")
    m.d.sync += in_rop.eq(in_rop + take - finished)
    h.check(in_rop == held, "rop_fragments_conserved")
    ras_x = ras.o.valid & ras.o.ready
    in_engine = Signal(w, name="f_in_engine")
    m.d.sync += in_engine.eq(in_engine + ras_x - finished)
    h.check(in_engine == (c.out + in_rop)[:w], "fragments_conserved")
    # reachability (the assumptions leave runs: not a vacuous proof): fragments from the scan converter into the
    # pipeline, with the records' input stalled; a fragment reaches the ROP only after the pipeline's latency
    # (74 steps and more), each part's own covers show the rest
    h.cover(ras_x & (c.out >= 2), "fragments_in_pipeline_reach")
    h.cover(dut.i.valid & ~dut.i.ready & (c.out != 0), "records_stalled_reach")
    return h
