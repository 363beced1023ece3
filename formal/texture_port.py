"""AXI4 manager properties of the board's texture port (``board/texture_port.py`` :class:`TexturePort`: the texel
caches' reads across the clock crossing and the uploads' single-beat writes on one port of LiteDRAM's core): the
core's side checked with :class:`formal.axi.AxiManagerCheck` (``AW``/``W``/``AR`` held until ready, legal bursts
inside 4 KB, ``WLAST``, one ID, outstanding bounds; the memory's responses assumed well-formed with bounded
stalls), with the caches' side a read manager keeping the rules (assumed: ``AR`` held, ID 0, line bursts inside a
page, at most :data:`MAX_OUT` outstanding) and the uploads' words free (4-byte aligned, as the upload writer makes
them). Also: every ``R`` beat the caches take is the core's next beat, in order (a counter each side), and the
flags: an ``AR`` offered while an upload's write is in flight raises ``error``. A bounded check (both clocks one:
the crossing is Amaranth's ``AsyncFIFO``, its logic the same for any two clocks); covers: a line read through to
the caches, an upload's write answered.
"""

from __future__ import annotations

from amaranth.hdl import C, Cat, Signal

from board.texture_port import TexturePort

from .axi import AxiManagerCheck
from .props import Harness, bits_for

__all__ = ["texture_port_set", "MAX_OUT", "STALL", "DEPTH", "SETTLE"]

#: Bursts the caches' side has outstanding at most (assumed; the caches' miss registers), the memory's bounded
#: stalls (assumed) and the bounded check's depth (a line of four beats through both FIFOs and a write).
MAX_OUT, STALL, DEPTH = 2, 3, 24
#: Clocks from configuration before the caches or the uploads offer anything (assumed).
SETTLE = 4

_MEMORY = ("awready", "wready", "bid", "bresp", "bvalid", "arready", "rid", "rdata", "rresp", "rlast", "rvalid")


def texture_port_set(kind: str = "proof") -> Harness:
    """The harness (module docstring)."""
    h = Harness(kind)
    m = h.m
    dut = TexturePort(1, i_domain="sync", o_domain="sync")
    m.submodules.dut = dut
    # the FIFOs start empty, as the FPGA's configuration leaves them (every counter at its initial value, 0); the
    # solver would start the read counters anywhere (Amaranth's AsyncFIFO leaves them to its write domain's reset,
    # which the board's engine clock does not have)
    for name, fifo in (("ar", dut.crossing.ar_fifo), ("r", dut.crossing.r_fifo)):
        h.check(h.started | (fifo.r_level == 0), f"{name}_fifo_empty_at_start", assume=True)
    up, down = dut.up, dut.down
    # the caches' side: a read manager within the rules (assumed), lines of four beats of four bytes
    m.d.comb += [up.arid.eq(0), up.arsize.eq(2), up.arburst.eq(1), up.arlen.eq(3), up.awvalid.eq(0),
                 up.wvalid.eq(0), up.bready.eq(1), up.arvalid.eq(h.free(1, "up_arvalid")),
                 up.araddr.eq(Cat(C(0, 4), h.free(len(up.araddr) - 4, "up_line"))),      # 16-byte lines
                 up.rready.eq(h.free(1, "up_rready"))]
    h.stream_hold(up.arvalid, up.arready, up.araddr, "up_ar", assume=True)
    # nothing is offered while the reset settles the crossing (the board's engine waits for a record for far
    # longer after configuration)
    age = Signal(range(SETTLE + 1), name="f_age")
    with m.If(age < SETTLE):
        m.d.sync += age.eq(age + 1)
    settling = age < SETTLE
    h.check(~settling | ~up.arvalid, "up_idle_at_start", assume=True)
    h.check(~settling | ~dut.req, "req_idle_at_start", assume=True)
    up_ar, up_last = up.arvalid & up.arready, up.rvalid & up.rready & up.rlast
    owed = Signal(bits_for(MAX_OUT + 1), name="f_up_owed")
    m.d.sync += owed.eq(owed + up_ar - up_last)
    h.check(owed + up.arvalid <= MAX_OUT, "up_outstanding", assume=True)
    # the uploads' words: free, 4-byte aligned
    m.d.comb += [dut.req.eq(h.free(1, "req")), dut.data.eq(h.free(len(dut.data), "data")),
                 dut.addr.eq(Cat(C(0, 2), h.free(len(dut.addr) - 2, "word")))]
    # the core's side: the memory free within the rules (AxiManagerCheck's assumptions), the port checked
    for name in _MEMORY:
        sig = getattr(down, name)
        m.d.comb += sig.eq(h.free(len(sig), f"mem_{name}"))
    AxiManagerCheck(h, down, max_out=MAX_OUT, stall=STALL)
    # the beats in order: the caches take the core's beats, none lost, none made up, in the order they came
    beats_in, beats_out = (h.counter(x, 8, n) for x, n in ((down.rvalid & down.rready, "r_in"),
                                                          (up.rvalid & up.rready, "r_out")))
    h.check(beats_out <= beats_in, "r_no_beat_made_up", bounded=True)
    # an error response the caches take, and an AR at the core while an upload's write is in flight, are flagged
    # a clock later
    bad_beat = h.past(up.rvalid & up.rready & up.rresp[1], "error_beat")
    h.check(~h.started | ~bad_beat | dut.read_error, "error_beat_flagged", bounded=True)
    flight = h.past(down.arvalid & dut.write_busy, "ar_during_write")
    h.check(~h.started | ~flight | dut.error, "ar_during_write_flagged", bounded=True)
    h.cover(up.rvalid & up.rready & up.rlast, "line_read_reach")
    h.cover(down.bvalid & down.bready, "write_answered_reach")
    return h
