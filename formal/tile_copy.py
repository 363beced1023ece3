"""Property set of the tile's clear and copy (``board/frame.py``, :class:`~board.frame.TileCopy`): the unit that
reads the on-chip depth test's frame out (``fb``) between pictures, for both board builds.

Its commands (``swap``, ``copy``, ``start``, ``shown``), ``active`` (the engine's input, scan converter and depth
test), ``room`` and the read-out's words are free. Proven by k-induction:

- **the depth test's contract** (``formal/rop_chip.py`` assumes it): a walk over the tile (a copy's or a clear's)
  begins only after ``active`` has been low for ``quiet`` clocks; ``fb.clear`` only with ``fb.read``; while a walk
  reads, ``fb.addr`` steps through the tile once, in order, from 0;
- **the copy**: each word the walk reads (the read-out returns it ``readout_latency`` clocks later) is written into
  the frame store once, at its pixel's address in the back buffer, narrowed to RGB565 (the read-out's words are
  assumed to be their address's, so a write of the wrong word or to the wrong place is seen); a copy writes the
  whole tile (``pixels`` writes) and a clear writes nothing;
- ``copied`` toggles once per SWAP's copy, after its last write, and never for COPY's.
"""

from __future__ import annotations

from amaranth.hdl import Mux, Signal

from board.frame import TileCopy
from fxmodel.units.rop import RopParams
from rtl.rop import readout_signature

from . import whitebox
from .props import Harness, bits_for
from .readers import drive_inputs, state_value
from .rop_chip import small_rop_chip

__all__ = ["tile_copy_set", "small_tile", "QUIET", "DEPTH"]

#: The quiet the proof's copy waits for (any value: the board's is ``board.cdc.QUIET``).
QUIET = 3
#: k of the k-induction.
DEPTH = 12


def small_tile() -> RopParams:
    """The tile of the proof: 4 x 4 pixels on chip (the walk and its delay line are those of any size)."""
    return small_rop_chip()


def tile_copy_set(kind: str = "proof", *, wait_every_copy: bool = False, broken_latency: int = 0) -> Harness:
    """The harness; ``broken_latency`` (a bug for the test): the read-out's word arrives that many clocks later
    than the copy expects."""
    P = small_tile()
    h = Harness(kind)
    m = h.m
    fb = readout_signature(P)
    dut, _, top = whitebox.attach(h, TileCopy(P, fb, quiet=QUIET, place_bits=2,
                                                        wait_every_copy=wait_every_copy))
    sig = lambda name: whitebox.signal(top, name)        # noqa: E731
    drive_inputs(h, dut)
    n, L = P.pixels, P.readout_latency + broken_latency
    zb = P.z_fmt.width
    # the read-out's word is its address's: the address in the color bits, ``L`` clocks after it was given
    # (r, g, b bytes: the address in r's top bits, the ones RGB565 keeps)
    addr = h.pasts(dut.fb.addr, L, "addr")[-1]
    h.check(dut.fb.data[zb:zb + 24] == addr << 3, "readout_word_is_its_address", assume=True)
    # the contract the depth test's proof assumes
    reading, clearing = dut.fb.read, dut.clearing          # (the walk's own registers are unnamed)
    h.check(~dut.fb.clear | dut.fb.read, "clear_with_read")
    quiet = Signal(range(QUIET + 1), name="f_quiet")
    m.d.sync += quiet.eq(Mux(dut.active, 0, Mux(quiet == QUIET, QUIET, quiet + 1)))
    h.check(quiet == sig("quiet"), "quiet_counts")
    began = reading & ~h.past(reading, "reading")
    h.check(~h.started | ~began | (h.past(quiet, "quiet") == QUIET), "walk_begins_quiet")
    # the walk: the address from 0, once through the tile, in order
    walk_addr = sig("addr")
    h.check(~began | (walk_addr == 0), "walk_from_zero")
    # the copy's writes: each once, at its pixel, its own word
    index = dut.w_addr[:len(dut.w_addr) - 1]
    h.check(~dut.w_en | (dut.w_data == index << 11), "write_word_is_its_pixel")     # r's bits carry the index
    h.check(~dut.w_en | (index < n), "write_in_tile")
    writes = _walk_count(m, began, dut.w_en, n, "f_writes")
    h.check(~dut.w_en | (index == writes), "writes_in_order")
    # the invariants that close the induction: the walk's address counts the words it read (each step reads
    # one), and the writes are those reads less the ones still in the read-out and the write's registers
    read_one = reading & ~clearing & dut.room & (walk_addr < n)
    reads = _walk_count(m, began, read_one, n, "f_reads")
    h.check(~(reading & ~clearing & ~began) | (reads == walk_addr), "reads_are_the_walk")
    h.check(writes == reads - sum(h.pasts(read_one, P.readout_latency + 1, "read")), "writes_follow_reads")
    # and the walk's state machine: reading exactly in its walk, the address within the walk and the drain
    state = sig("fsm_state")
    walk, drain = state == state_value(state, "walk"), state == state_value(state, "drain")
    h.check(walk | drain | (state == state_value(state, "idle")), "fsm_states")
    h.check(reading == walk, "read_is_walk")
    h.check(~walk | (walk_addr <= n), "walk_in_tile")
    h.check(~drain | ((walk_addr >= n) & (walk_addr <= n + P.readout_latency + 1)), "drain_after_tile")
    h.check(~(dut.w_en & clearing), "clear_writes_nothing")
    toggled = h.started & (dut.copied != h.past(dut.copied, "copied"))
    h.check(~toggled | ((writes == n) & h.past(dut.copy_show, "show")), "copied_after_whole_swap_copy")
    # reachability: a SWAP's copy done, a clear begun, a copy stalled by room
    h.cover(toggled, "swap_copy_reach")
    h.cover(began & clearing, "clear_reach")
    h.cover(reading & ~clearing & ~dut.room & (walk_addr == 2), "room_stall_reach")
    return h


def _walk_count(m, began, event, n: int, name: str) -> Signal:
    """The ``event`` clocks of the walk under way (counted from the clock it ``began``, up to ``n``)."""
    count = Signal(bits_for(n + 1), name=name)
    m.d.sync += count.eq(Mux(began, event, count + event))
    return count
