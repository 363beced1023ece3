"""Property sets of the AXI4 read managers with stream ports (the texel caches): one generic harness, and one
:class:`ReadManager` entry per design in :data:`READ_MANAGERS` (a new cache is checked by adding its entry).

The harness (:func:`read_manager_set`) drives every input of the design freely and checks:

- the AXI4 read-channel properties of :class:`formal.axiread.AxiReadCheck` on the design's port (asserted of the
  design: ``AR`` held until ready, legal bursts inside 4 KB, the declared length/size/type, at most ``max_out``
  bursts outstanding, no write; assumed of the memory: ``R`` held, only for an accepted ``AR``, ``RLAST`` on
  the last beat, bounded stalls of :data:`STALL` cycles);
- the stream rules: rule 2 assumed on ``i``, asserted on ``o``; requests and answers counted: never an answer
  without a request (``o_no_dup``), at most ``capacity`` requests inside (``o_capacity``);
- the entry's own white-box invariants (what ties the design's state to the counters: what makes k-induction
  close), and its reachability covers (``Cover``): a burst finished, an answer after the longest stall.
"""

from __future__ import annotations

from amaranth.hdl import Mux, Signal, Value
from amaranth.lib import wiring

from fxmodel.units.texcache import TexCacheParams
from rtl.texcache import TexCache

from . import whitebox
from .axiread import AxiReadCheck
from .fetch import ENTRIES as DECOUPLED_ENTRIES
from .manager import STALL, ReadManager
from .props import Harness, bits_for

__all__ = ["ReadManager", "READ_MANAGERS", "read_manager_set", "drive_inputs", "state_value", "STALL"]

def drive_inputs(h: Harness, dut, prefix: str = ""):
    """Every input of ``dut`` (its own ports and its interfaces' members) from a free input of the harness."""
    for name, member in dut.signature.members.items():
        if member.is_port:
            if member.flow == wiring.In:
                h.m.d.comb += getattr(dut, name).eq(h.free(member.shape, f"{prefix}{name}"))
            continue
        sub = getattr(dut, name)
        for part, m2 in member.signature.members.items():
            if m2.is_port and m2.flow == wiring.In:
                h.m.d.comb += getattr(sub, part).eq(h.free(m2.shape, f"{prefix}{name}_{part}"))


def state_value(fsm_state, name: str) -> int:
    """The encoding of FSM state ``name`` (Amaranth names a state ``NAME/value`` in the state signal's decoder)."""
    for v in range(1 << len(fsm_state)):
        if fsm_state.decoder(v).rpartition("/")[0] == name:
            return v
    raise LookupError(f"no FSM state {name!r}")


def read_manager_set(entry: ReadManager, *, kind: str = "proof", wrap=None) -> Harness:
    h = Harness(kind)
    m = h.m
    inner = entry.make()
    dut = wrap(inner) if wrap else inner
    frag = whitebox.elaborate(dut)
    m.submodules.dut = frag
    top = whitebox.subfragment(frag, "dut" if wrap else "")
    sig = lambda name, path="": whitebox.signal(top, name, path)        # noqa: E731
    drive_inputs(h, dut)
    h.stream_hold(dut.i.valid, dut.i.ready, Value.cast(dut.i.payload), "i", assume=True)
    h.stream_hold(dut.o.valid, dut.o.ready, Value.cast(dut.o.payload), "o")
    x_in, x_out = dut.i.valid & dut.i.ready, dut.o.valid & dut.o.ready
    inside = Signal(bits_for(entry.capacity + 2), name="f_inside")
    m.d.sync += inside.eq(inside + x_in - x_out)
    h.check(~x_out | (inside != 0), "o_no_dup")
    h.check(inside <= entry.capacity, "o_capacity")
    axi = getattr(dut, entry.port)
    rd = AxiReadCheck(h, axi, max_out=entry.max_out, stall=STALL, arlen=entry.arlen, arsize=entry.arsize,
                      arburst=entry.arburst, read_only=True)
    rd.invariants(entry.arlen)
    if entry.invariants is not None:
        entry.invariants(h, sig, rd, inside, inner=inner, top=top)
    run = Signal(bits_for(STALL + 2), name="f_o_stall")
    with m.If(dut.o.valid & ~dut.o.ready):
        m.d.sync += run.eq(Mux(run > STALL, run, run + 1))
    with m.Else():
        m.d.sync += run.eq(0)
    h.cover(axi.rvalid & axi.rready & axi.rlast, "burst_reach")
    h.cover((rd.stall_run == STALL - 1) & axi.arvalid & axi.arready, "ar_longest_stall_reach")
    h.cover((rd.r_wait == STALL - 1) & axi.rvalid & axi.rready, "r_longest_wait_reach")
    h.cover(x_out & (run >= STALL), "o_stalled_reach")
    h.cover(dut.i.valid & ~dut.i.ready & (inside == entry.capacity), "full_reach")
    return h


# ------------------------------------------------------------------------------------------------------------
# the entries
# ------------------------------------------------------------------------------------------------------------
_TC_PARAMS = TexCacheParams(block=2, sets=2, ways=2, index="linear", texel_bits=4)


def small_texcache() -> TexCache:
    """The blocking cache the proofs use: 2 x 2 texel lines (4-beat bursts), 2 sets of 2 ways, 4-bit texels, an
    8 x 8 map placed across a 4 KB boundary (16-bit addresses). The control (the FSM, the burst, the handshakes) is
    that of any size: only the widths of tags, counters and banks change."""
    p = _TC_PARAMS
    return TexCache(p, 8, 8, base=4096 - 4 * p.line_bytes, addr_bits=16)


def _texcache_invariants(h: Harness, sig, rd, inside, **_):
    """The blocking cache: filling iff a burst is outstanding; a request inside iff the FSM is not idle."""
    state = sig("fsm_state")
    idle, fill = (state_value(state, s) for s in ("IDLE", "FILL"))
    h.check((state == fill) == (rd.ar_pend != 0), "fill_is_outstanding")
    h.check((state != idle) == (inside != 0), "busy_is_inside")
    h.check(state < 6, "fsm_range")


#: The read managers ``make formal`` checks (add one entry per new design).
READ_MANAGERS = [
    ReadManager("texcache_axi", "TexCache blocking (block 2, 2 sets x 2 ways, 8x8 map across 4 KB, memory stalls "
                f"<= {STALL})", small_texcache, arlen=_TC_PARAMS.beats_per_line - 1, invariants=_texcache_invariants),
]
READ_MANAGERS += DECOUPLED_ENTRIES            # the decoupled cache and the texture fetch (formal/fetch.py)
