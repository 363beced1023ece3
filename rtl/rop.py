"""RTL of the raster-operations unit (``fxmodel/units/rop.py``): per fragment read the pixel's stored depth, compare,
and on pass write depth and color; the frame buffer behind an AXI4 master port or in block RAM (paper, section 4
and Fig. 5: the engine's colors go to a frame buffer). Bit-exact with :func:`fxmodel.units.rop.draw`.

Why AXI4 and not Wishbone B4: AXI4 is what FPGA memory controllers (DDR, HBM) and interconnects speak, and its
independent read and write channels let depth reads of later fragments run while earlier writes are in flight,
several transactions outstanding on each, which a one-fragment-per-clock read-modify-write needs when the memory
takes tens of cycles. Wishbone's pipelined mode has one request channel for reads and writes. cocotbext-axi's
``AxiRam`` is the memory model in co-simulation.

Memory port (:class:`Rop`, ``on_chip=False``). Three stages, all transfers with ID 0 (in order):

1. **Accept**: the fragment's depth narrowed (``z_in`` -> ``z_fmt``: TRUNC, SATURATE, as the model), the pixel
   index ``y width + x`` (shifted copies of ``y``, no multiplier) into a register; a fragment outside the frame
   is dropped there (``status`` bit ``outside``): no address outside the frame is formed, and the largest index,
   ``width height - 1``, gives ``base + 8 (width height - 1)``, inside ``2**addr_bits`` (checked by
   ``RopParams``).
2. **Read**: ``AR`` (4 bytes, ``ARSIZE = 2``) is issued from that register into a free **slot** of the
   scoreboard (``outstanding`` slots, allocated in a ring). A slot holds the fragment (pixel index, depth,
   color) from its read until its fate is sealed: until the compare if it fails, until the write's ``B``
   response if it passes (AXI4 orders a read after a write to the same address only once the write is
   acknowledged).
3. **Compare and write**: ``R`` beats return in order, so the next slot of the ring owns each beat; the beat's
   stored depth and its slot are registered (the slot read out of the ring by a multiplexer, in its own cycle:
   with the compare in the same one it was a 35-level path, 95 MHz on ECP5), and the next cycle the fragment
   passes iff its depth is strictly greater than the stored one (ties: the first drawn wins) and then enters a
   :data:`WRITE_QUEUE`-entry write queue that issues ``AW`` and ``W`` (8 bytes, ``AWSIZE = 3``); the queue's
   slot numbers wait in a ring for the ``B`` responses, which free the slots.

**Hazard**: two fragments of one pixel in flight would read the same stored depth and both write. The
scoreboard compares the accepted fragment's pixel index with every busy slot's and holds ``AR`` (and so ``i``)
while one matches, so a fragment's read is issued only after the earlier fragment of its pixel failed or had its
write acknowledged: the result is the model's sequential one. It costs a stall only when a pixel recurs within
the round-trip time (small or overlapping triangles drawn back to back). ``hazard=False`` removes the check (for
the test that shows the test can fail).

Throughput: one fragment per clock while a slot is free and the memory keeps up; ``outstanding`` slots cover a
round trip of that many clocks (:data:`SLOT_OVERHEAD`). ``AR``/``AW``/``W`` valid never wait for their
ready; ``R.ready`` and ``B.ready`` come from registers (``B`` is always taken).

On chip (:class:`Rop`, ``on_chip=True``): the same read-compare-write on a memory of ``width height`` words
(``z_fmt`` depth, r, g, b, flags, from the low bits), initialised to the clear value, built as Amaranth
``Memory`` slices of ``RopParams.slice_bits`` bits each one block RAM deep (no multiplexer from the blocks' slow
outputs across the device's block-RAM rows: it was the board's critical path at 66 MHz, speed grade 6). The
slices' block RAMs spread over the device, so every net to or from all of them crosses it in a cycle of its own
between flip-flops: each slice has its own registers beside its block RAM (**Fan-out**): the read address, the
word read, and the write's enable, address and data. A net from one flip-flop to the address pins of every
block RAM (through the read-out's address multiplexer and the comparators Yosys added while the read port was
transparent) was the board's engine clock's next critical path. Yosys's ``opt_merge`` merges flip-flops with one
input, so the copies are :func:`rtl.unit.kept_copy` registers, which the board's synthesis marks ``keep``
(:data:`rtl.unit.KEEP_COPIES`). Eight stages (``RopParams.latency``): the fragment registered as the stream
delivers it (nothing else: the pixel pipeline's output FIFO is LUT RAM read through a multiplexer, and with the
accept's logic behind it in one cycle it was the board's slowest engine path, into ``status`` and the depth,
at every placement tried); the accepted fragment registered (its pixel index and depth computed from the first
stage's registers); its address in the registers beside the block RAMs;
the read; the word in the registers beside the block RAMs; the stored depth registered (the block RAM's slow
output never meets logic in the cycle it leaves the block); the compare; the write's central registers; the
write from the registers beside the block RAMs. A fragment's read sees every write up to the one of the
fragment six ahead of it (the read port is not transparent: Yosys builds a transparent one's bypass as a
multiplexer after the block RAM's output, in the cycle it leaves the block, and comparators on its address); the
five just ahead of it are forwarded (the nearer first: its depth replaces the stored one when the pixel is the
same): whether each has the same pixel is registered a cycle early, the two to five ahead (their writes decided)
replace the stored depth as it is registered, the one just ahead in the compare. ``i.ready`` is always 1, except while
the frame is read out through ``fb`` (``fb.read``: the read port takes ``fb.addr``; ``fb.data`` holds its word
``RopParams.readout_latency`` cycles later; accepted fragments wait in the first two stages). With ``fb.clear`` as
well, the word read is also overwritten with the clear value, through the write's registers (a read-out that
clears, or a clear of the frame: the next frame's depth test starts from the cleared frame).
"""

from __future__ import annotations

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal
from amaranth.lib import memory, stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.units.rop import DEPTH_BYTES, PIXEL_BYTES, STATUS_BITS, Z_OVERFLOW, Z_ROUNDING, RopParams, clear_word

from .fixed import const_mul, narrow
from .streams import payload_layout
from .unit import COPY_SUFFIX, kept_copy, register

__all__ = ["Rop", "axi_signature", "readout_signature", "pixel_index", "ring_next", "SLOT_OVERHEAD", "WRITE_QUEUE"]

#: Entries of the write queue between the compare and the ``AW``/``W`` channels: one being issued, one arriving,
#: one for the beat in the compare stage, so that ``R.ready`` is one logic level from registers and one fragment
#: per clock passes.
WRITE_QUEUE = 3

#: Cycles a slot is busy beyond the memory's read and write latencies ``L`` (added to ``AxiRam``'s own in the
#: co-simulation): a slot lives ``2 L + SLOT_OVERHEAD`` cycles when its fragment passes, so ``outstanding`` slots
#: keep one fragment per clock while ``2 L + SLOT_OVERHEAD <= outstanding`` (``cosim/test_rtl_rop.py`` checks both
#: sides of that bound).
SLOT_OVERHEAD = 7


def axi_signature(addr_bits: int, data_bits: int, id_bits: int = 1) -> wiring.Signature:
    """An AXI4 manager port (the AMBA names, lower case, without the ``m_axi_`` prefix): ``AW``, ``W``, ``B``,
    ``AR``, ``R`` with ID, length, size and burst; no lock, cache, prot, QoS, region or user signals (the
    defaults). Out members are driven by the manager."""
    return wiring.Signature({
        "awid": Out(id_bits), "awaddr": Out(addr_bits), "awlen": Out(8), "awsize": Out(3), "awburst": Out(2),
        "awvalid": Out(1), "awready": In(1),
        "wdata": Out(data_bits), "wstrb": Out(data_bits // 8), "wlast": Out(1), "wvalid": Out(1), "wready": In(1),
        "bid": In(id_bits), "bresp": In(2), "bvalid": In(1), "bready": Out(1),
        "arid": Out(id_bits), "araddr": Out(addr_bits), "arlen": Out(8), "arsize": Out(3), "arburst": Out(2),
        "arvalid": Out(1), "arready": In(1),
        "rid": In(id_bits), "rdata": In(data_bits), "rresp": In(2), "rlast": In(1), "rvalid": In(1),
        "rready": Out(1)})


def readout_signature(params: RopParams) -> wiring.Signature:
    """The on-chip frame's read-out port (``Rop.fb``, :class:`board.frame.TileCopy` drives it)."""
    return wiring.Signature({"read": In(1), "clear": In(1), "addr": In(range(params.pixels)),
                             "data": Out(params.word_bits)})


def pixel_index(params: RopParams, x, y):
    """``(inside, y width + x)``: the pixel index of an inside fragment (shifted copies of ``y``)."""
    inside = (x < params.width) & (y < params.height)
    return inside, (const_mul(y, params.width) + x)[:_index_bits(params)]


def _index_bits(params: RopParams) -> int:
    return max(1, (params.pixels - 1).bit_length())


def ring_next(ptr, n: int):
    """The pointer after ``ptr`` in a ring of ``n`` slots (any ``n``)."""
    return Mux(ptr == n - 1, 0, ptr + 1)


class _Ring:
    """A pointer over ``n`` slots, stepping with wrap-around."""

    def __init__(self, n: int, name: str):
        self.n = n
        self.ptr = Signal(range(n), name=name)

    def next(self):
        return ring_next(self.ptr, self.n)


@register(RopParams)
class Rop(wiring.Component):
    """Raster operations: depth test and frame buffer.

    Ports
    -----
    i : In(stream.Signature(payload_layout(params.inputs))) -- fragments ``x, y`` (``pixel_fmt``), ``z``
        (``z_in``), ``r, g, b`` (bytes), ``flags`` (``flags_fmt``)
    axi : Out(axi_signature(addr_bits, data_bits)) -- the AXI4 manager port (``on_chip=False`` only)
    fb : the frame read-out (``on_chip=True`` only): ``read`` In(1), ``addr`` In (pixel index ``y width + x``),
        ``clear`` In(1) (with ``read``: the word at ``addr`` is overwritten with the clear value), ``data``
        Out(``word_bits``): the word of the address given ``readout_latency`` cycles earlier
    busy : Out(1) -- a fragment accepted and not yet finished (its write not acknowledged, or it failed)
    status : Out(3) -- sticky (a clock after the event): bit 0 a fragment outside the frame was dropped, bit 1 a
        depth saturated (the narrowing to ``z_fmt``), bit 2 an AXI error response
        (``fxmodel.units.rop.STATUS_BITS``); on chip,
        a read-out that clears the frame (``fb.read`` and ``fb.clear``) clears them too: they are the frame's
    """

    def __init__(self, params: RopParams):
        self.params = params
        members = {"i": In(stream.Signature(payload_layout(params.inputs))), "busy": Out(1),
                   "status": Out(len(STATUS_BITS))}
        if params.on_chip:
            members["fb"] = Out(readout_signature(params))
        else:
            members["axi"] = Out(axi_signature(params.addr_bits, params.data_bits))
        super().__init__(members)

    # -- shared: the accepted fragment --------------------------------------------------------------------
    def _accept(self, m, f):
        """The fragment ``f`` (a payload of ``params.inputs``): its depth narrowed, whether it is inside the frame,
        its pixel index and its color word."""
        P = self.params
        zc, zsat = narrow(f.z, P.z_in.frac_bits, P.z_fmt, Z_ROUNDING, Z_OVERFLOW)
        inside, index = pixel_index(P, f.x, f.y)
        color = Cat(f.r, f.g, f.b, f.flags)
        return zc, zsat, inside, index, color

    def elaborate(self, platform):
        return self._on_chip() if self.params.on_chip else self._port()

    # -- on chip ------------------------------------------------------------------------------------------
    def _on_chip(self):
        P = self.params
        m = Module()
        clear = clear_word(P)
        m.d.comb += self.i.ready.eq(~self.fb.read)
        # stage I: the fragment as the stream delivers it, registered; then stage A: the accepted fragment (both
        # held while the read-out has the read port)
        i_valid, i_frag = Signal(name="in_valid"), Signal(payload_layout(P.inputs), name="in_frag")
        with m.If(~self.fb.read):
            m.d.sync += [i_valid.eq(self.i.valid), i_frag.eq(self.i.payload)]
        zc, zsat, inside, index, color = self._accept(m, i_frag)
        take = i_valid & ~self.fb.read
        a_valid = Signal(name="acc_valid")
        a_z, a_color, a_index = Signal(P.z_fmt.width, name="acc_z"), Signal(24 + P.flag_bits, name="acc_color"), \
            Signal(range(P.pixels), name="acc_index")
        with m.If(~self.fb.read):
            m.d.sync += [a_valid.eq(take & inside), a_z.eq(zc), a_color.eq(color), a_index.eq(index)]
        # stages R1..R3: its read (the address registered beside each block RAM, the block RAM, the word registered
        # beside it); the fragment's own fields follow in central registers
        rd = [(a_valid & ~self.fb.read, a_z, a_color, a_index)]
        for n in (1, 2, 3):
            st = (Signal(name=f"rd{n}_valid"), Signal.like(a_z, name=f"rd{n}_z"),
                  Signal.like(a_color, name=f"rd{n}_color"), Signal.like(a_index, name=f"rd{n}_index"))
            m.d.sync += [x.eq(y) for x, y in zip(st, rd[-1])]
            rd.append(st)
        (_, _, _, r2_index), (r3_valid, r3_z, r3_color, r3_index) = rd[2], rd[3]
        c_valid = Signal(name="cmp_valid")
        c_z, c_color, c_index = Signal.like(a_z, name="cmp_z"), Signal.like(a_color, name="cmp_color"), \
            Signal.like(a_index, name="cmp_index")
        w_en, w_z, w_color, w_index = Signal(name="write"), Signal.like(a_z, name="write_z"), \
            Signal.like(a_color, name="write_color"), Signal.like(a_index, name="write_index")
        # the write's copy in the cycle its registers beside the block RAMs write, and the one after (forwarding)
        h1_en, h1_z, h1_index = (kept_copy(m, w_en, "wrote1"), kept_copy(m, w_z, "wrote1_z"),
                                 kept_copy(m, w_index, "wrote1_index"))
        h2_en, h2_z, h2_index = Signal(name="wrote2"), Signal.like(a_z, name="wrote2_z"), \
            Signal.like(a_index, name="wrote2_index")
        h3_en, h3_z = Signal(name="wrote3"), Signal.like(a_z, name="wrote3_z")
        m.d.sync += [h2_en.eq(h1_en), h2_z.eq(h1_z), h2_index.eq(h1_index), h3_en.eq(h2_en), h3_z.eq(h2_z)]
        rdata = self._frame(m, clear, Mux(self.fb.read, self.fb.addr, a_index), w_en, w_index, Cat(w_z, w_color))
        m.d.comb += self.fb.data.eq(rdata)
        # forwarding: a fragment's read sees every write up to the one of the fragment six ahead (the read port
        # is not transparent: a transparent one puts a multiplexer after the block RAM's slow output, in the
        # cycle it leaves the block, and comparators on its address); the five just ahead are forwarded, the
        # nearer first. Whether each has the same pixel is registered while the fragment is in R2 (then: one
        # ahead in R3, two in the compare, three writing, four in wrote1, five in wrote2); in R3 the two to five
        # ahead, whose writes are decided, replace the stored depth as it is registered; in the compare the one
        # just ahead
        same = [Signal(name=f"same{k}") for k in (1, 2, 3, 4, 5)]
        m.d.sync += [s.eq(i == r2_index) for s, i in zip(same, (r3_index, c_index, w_index, h1_index, h2_index))]
        stored_in = rdata[:P.z_fmt.width]
        if P.hazard:
            for hit, z in reversed(((same[1] & w_en, w_z), (same[2] & h1_en, h1_z), (same[3] & h2_en, h2_z),
                                    (same[4] & h3_en, h3_z))):
                stored_in = Mux(hit, z, stored_in)
        c_stored, c_same1 = Signal(P.z_fmt.width, name="cmp_stored"), Signal(name="cmp_same1")
        m.d.sync += [c_valid.eq(r3_valid), c_z.eq(r3_z), c_color.eq(r3_color), c_index.eq(r3_index),
                     c_stored.eq(stored_in), c_same1.eq(c_valid & same[0])]
        # compare, then the write's central registers (``w_*``) and its registers beside each block RAM
        stored = Mux(c_same1 & w_en, w_z, c_stored) if P.hazard else c_stored
        with m.If(self.fb.read & self.fb.clear):     # the read-out clears: the clear word written behind it
            m.d.sync += [w_en.eq(1), w_z.eq(clear & ((1 << P.z_fmt.width) - 1)),
                         w_color.eq(clear >> P.z_fmt.width), w_index.eq(self.fb.addr)]
        with m.Else():
            m.d.sync += [w_en.eq(c_valid & (c_z > stored)), w_z.eq(c_z), w_color.eq(c_color),
                         w_index.eq(c_index)]
        m.d.comb += self.busy.eq(Cat(i_valid, a_valid, *(st[0] for st in rd[1:]), c_valid, w_en, h1_en).any())
        self._sticky(m, take & ~inside, take & inside & zsat, Const(0), self.fb.read & self.fb.clear)
        return m

    def _frame(self, m, clear: int, raddr, w_en, w_index, wdata):
        """The frame's memory in slices of ``slice_bits`` (``RopParams.slice_bits``: each slice one block RAM
        deep, no read multiplexer between blocks), each read port not transparent (the forwarding covers it).
        Beside each slice its own registers: the read address, the word read, the write's enable, address and
        data (:func:`~rtl.unit.kept_copy` registers, kept by synthesis). Returns the registered words (``Cat``)."""
        P = self.params
        words = []
        for k, lo in enumerate(range(0, P.word_bits, P.slice_bits)):
            hi = min(lo + P.slice_bits, P.word_bits)
            init = clear >> lo & ((1 << (hi - lo)) - 1)
            m.submodules[f"frame{k}"] = mem = memory.Memory(shape=hi - lo, depth=P.pixels, init=[init] * P.pixels)
            wp = mem.write_port()
            rp = mem.read_port()
            ra = Signal.like(w_index, name=f"frame{k}_raddr{COPY_SUFFIX}")     # (the read-out's address: its width)
            m.d.sync += ra.eq(raddr)
            we, wa = kept_copy(m, w_en, f"frame{k}_wen"), kept_copy(m, w_index, f"frame{k}_waddr")
            wd = kept_copy(m, wdata[lo:hi], f"frame{k}_wdata")                  # (bits of wrote1_z's input too: kept)
            word = Signal(hi - lo, name=f"frame{k}_word")
            m.d.sync += word.eq(rp.data)
            m.d.comb += [wp.addr.eq(wa), wp.data.eq(wd), wp.en.eq(we), rp.addr.eq(ra), rp.en.eq(1)]
            words.append(word)
        return Cat(*words)

    def _sticky(self, m, outside, zsat, bus_error, clear=None):
        """``status``: each flag set a clock after its condition, kept until ``clear`` (on chip: a read-out that
        clears the frame, during which no fragment is accepted). The conditions and ``clear`` reach ``status``
        through registers of their own (the accepted fragment's compares, from the pipeline's output FIFO, and
        the read-out's control, far away, were among the board's slowest paths into ``status``), and a flag set
        in the clock the clear acts wins, so no flag of a fragment is lost."""
        bits = [None] * len(STATUS_BITS)
        bits[STATUS_BITS["outside"]], bits[STATUS_BITS["z_saturated"]] = outside, zsat
        bits[STATUS_BITS["bus_error"]] = bus_error
        raised, cleared = Signal(len(STATUS_BITS), name="status_raised"), Signal(name="status_clear")
        m.d.sync += [raised.eq(Cat(*bits)), cleared.eq(Const(0) if clear is None else clear),
                     self.status.eq(Mux(cleared, 0, self.status) | raised)]

    # -- behind the AXI4 port -----------------------------------------------------------------------------
    def _port(self):
        P = self.params
        m = Module()
        axi = self.axi
        N = P.outstanding
        zc, zsat, inside, index, color = self._accept(m, self.i.payload)

        # stage 1: the accepted fragment
        s_valid = Signal()
        s_index = Signal(_index_bits(P))
        s_z = Signal(P.z_fmt.width)
        s_color = Signal(24 + P.flag_bits)

        # the scoreboard: slots in a ring
        busy = Signal(N, name="slot_busy")
        slot_index = Array(Signal.like(s_index, name=f"slot{k}_index") for k in range(N))
        slot_z = Array(Signal.like(s_z, name=f"slot{k}_z") for k in range(N))
        slot_color = Array(Signal.like(s_color, name=f"slot{k}_color") for k in range(N))
        tail, rd = _Ring(N, "alloc"), _Ring(N, "rd")

        conflict = Signal()
        if P.hazard:
            m.d.comb += conflict.eq(Cat(busy[k] & (slot_index[k] == s_index) for k in range(N)).any())
        free = ~busy.bit_select(tail.ptr, 1)
        ar_go = Signal()

        address = self._address

        m.d.comb += [axi.arvalid.eq(s_valid & free & ~conflict), axi.araddr.eq(address(s_index)),
                     axi.arsize.eq((DEPTH_BYTES - 1).bit_length()), axi.arlen.eq(0), axi.arburst.eq(1),
                     axi.arid.eq(0), ar_go.eq(axi.arvalid & axi.arready)]
        m.d.comb += self.i.ready.eq(~s_valid | ar_go)
        take = self.i.valid & self.i.ready
        with m.If(take):
            m.d.sync += [s_valid.eq(inside), s_index.eq(index), s_z.eq(zc), s_color.eq(color)]
        with m.Elif(ar_go):
            m.d.sync += s_valid.eq(0)
        self._sticky(m, take & ~inside, take & inside & zsat, (axi.rvalid & axi.rready & axi.rresp.any())
                     | (axi.bvalid & axi.bready & axi.bresp.any()))
        slots = (busy, slot_index, slot_z, slot_color, tail, rd)
        q, c_valid, c_slot, passes, r_go = self._compare(m, s_index, s_z, s_color, slots)
        head, issued = self._write_issue(m, q, c_valid, passes, address)
        self._slots(m, slots, q[3], s_valid, s_index, s_z, s_color, ar_go, r_go, c_valid, c_slot, passes, head,
                    issued)
        return m


    def _address(self, index):
        """The byte address of pixel ``index``."""
        return Const(self.params.base, self.params.addr_bits) + (index << 3)

    def _compare(self, m, s_index, s_z, s_color, slots):
        """The write queue's registers, and the compare in two stages: the R beat belongs to slot ``rd``; its
        stored depth and the slot are registered (``c_*``), the next cycle compares (one carry chain). Returns
        ``((q_index, q_z, q_color, q_slot, q_count, aw_done, w_done, c_index, c_z, c_color, c_slot), c_valid,
        c_slot, passes, r_go)``."""
        P = self.params
        axi = self.axi
        N = P.outstanding
        lanes = P.data_bits // 64                        # 64-bit pixel words per bus beat
        _, slot_index, slot_z, slot_color, _, rd = slots
        # write queue: index, depth, color, slot
        q_index = [Signal.like(s_index, name=f"wq{k}_index") for k in range(WRITE_QUEUE)]
        q_z = [Signal.like(s_z, name=f"wq{k}_z") for k in range(WRITE_QUEUE)]
        q_color = [Signal.like(s_color, name=f"wq{k}_color") for k in range(WRITE_QUEUE)]
        q_slot = [Signal(range(N), name=f"wq{k}_slot") for k in range(WRITE_QUEUE)]
        q_count = Signal(range(WRITE_QUEUE + 1))
        aw_done, w_done = Signal(name="aw_done"), Signal()       # a tuple names only its last signal

        # compare, in two stages: the R beat belongs to slot rd; its stored depth and the slot are registered
        # (``c_*``), the next cycle compares (one carry chain) and pushes a passing fragment into the queue
        r_go = Signal()
        c_valid = Signal(name="cmp_valid")
        c_index, c_z, c_color = Signal.like(s_index, name="cmp_index"), Signal.like(s_z, name="cmp_z"), \
            Signal.like(s_color, name="cmp_color")
        c_stored = Signal(8 * DEPTH_BYTES, name="cmp_stored")
        c_slot = Signal(range(N), name="cmp_slot")
        m.d.comb += [axi.rready.eq(q_count + c_valid < WRITE_QUEUE), r_go.eq(axi.rvalid & axi.rready)]
        r_index = slot_index[rd.ptr]
        if lanes > 1:
            lane = (r_index + P.base // PIXEL_BYTES)[:(lanes - 1).bit_length()]
            word = axi.rdata.word_select(lane, 64)
        else:
            word = axi.rdata
        m.d.sync += c_valid.eq(r_go)
        with m.If(r_go):
            m.d.sync += [c_index.eq(r_index), c_z.eq(slot_z[rd.ptr]), c_color.eq(slot_color[rd.ptr]),
                         c_stored.eq(word[:8 * DEPTH_BYTES]), c_slot.eq(rd.ptr)]
        passes = c_z > c_stored

        return ((q_index, q_z, q_color, q_slot, q_count, aw_done, w_done, c_index, c_z, c_color, c_slot), c_valid,
                c_slot, passes, r_go)

    def _write_issue(self, m, q, c_valid, passes, address):
        """Write issue from the queue's head (``AW`` and ``W``), and the queue's shift and push of a passing
        fragment. Returns ``(head, issued)``."""
        P = self.params
        axi = self.axi
        lanes = P.data_bits // 64
        q_index, q_z, q_color, q_slot, q_count, aw_done, w_done, c_index, c_z, c_color, c_slot = q
        # write issue from the queue's head
        head = Signal()
        m.d.comb += head.eq(q_count != 0)
        data = Cat(q_z[0], Const(0, 8 * DEPTH_BYTES - P.z_fmt.width), q_color[0],
                   Const(0, 8 - P.flag_bits))
        m.d.comb += [axi.awvalid.eq(head & ~aw_done), axi.awaddr.eq(address(q_index[0])),
                     axi.awsize.eq((PIXEL_BYTES - 1).bit_length()), axi.awlen.eq(0), axi.awburst.eq(1),
                     axi.awid.eq(0),
                     axi.wvalid.eq(head & ~w_done), axi.wdata.eq(data.replicate(lanes)), axi.wlast.eq(1)]
        if lanes > 1:
            wlane = (q_index[0] + P.base // PIXEL_BYTES)[:(lanes - 1).bit_length()]
            m.d.comb += axi.wstrb.eq(Const(0xFF, P.data_bits // 8) << (wlane << 3))
        else:
            m.d.comb += axi.wstrb.eq(0xFF)
        aw_now = axi.awvalid & axi.awready
        w_now = axi.wvalid & axi.wready
        issued = head & (aw_done | aw_now) & (w_done | w_now)
        with m.If(issued):
            m.d.sync += [aw_done.eq(0), w_done.eq(0)]
        with m.Else():
            m.d.sync += [aw_done.eq(aw_done | aw_now), w_done.eq(w_done | w_now)]
        push = c_valid & passes
        m.d.sync += q_count.eq(q_count + push - issued)
        with m.If(issued):
            m.d.sync += [q[k].eq(q[k + 1]) for q in (q_index, q_z, q_color, q_slot) for k in range(WRITE_QUEUE - 1)]
        with m.If(push):
            at = q_count - issued
            for k in range(WRITE_QUEUE):
                with m.If(at == k):
                    m.d.sync += [q_index[k].eq(c_index), q_z[k].eq(c_z), q_color[k].eq(c_color),
                                 q_slot[k].eq(c_slot)]

        return head, issued

    def _slots(self, m, slots, q_slot, s_valid, s_index, s_z, s_color, ar_go, r_go, c_valid, c_slot, passes, head,
               issued):
        """The slots waiting for ``B`` (in issue order) and the slot bookkeeping: allocate at ``AR``, free at a
        failed compare or at ``B``; ``busy``."""
        axi = self.axi
        N = self.params.outstanding
        busy, slot_index, slot_z, slot_color, tail, rd = slots
        # slots waiting for B, in issue order
        b_slot = Array(Signal(range(N), name=f"b{k}_slot") for k in range(N))
        b_head, b_tail = _Ring(N, "b_head"), _Ring(N, "b_tail")
        b_go = Signal()
        m.d.comb += [axi.bready.eq(1), b_go.eq(axi.bvalid)]
        with m.If(issued):
            m.d.sync += [b_slot[b_tail.ptr].eq(q_slot[0]), b_tail.ptr.eq(b_tail.next())]
        with m.If(b_go):
            m.d.sync += b_head.ptr.eq(b_head.next())

        # slot bookkeeping: allocate at AR, free at a failed compare or at B
        with m.If(ar_go):
            m.d.sync += [slot_index[tail.ptr].eq(s_index), slot_z[tail.ptr].eq(s_z),
                         slot_color[tail.ptr].eq(s_color), tail.ptr.eq(tail.next())]
        with m.If(r_go):
            m.d.sync += rd.ptr.eq(rd.next())
        set_ = Signal(N)
        clr = Signal(N)
        m.d.comb += set_.eq(Mux(ar_go, Const(1, N) << tail.ptr, 0))
        m.d.comb += clr.eq(Mux(c_valid & ~passes, Const(1, N) << c_slot, 0)
                           | Mux(b_go, Const(1, N) << b_slot[b_head.ptr], 0))
        m.d.sync += busy.eq((busy & ~clr) | set_)
        m.d.comb += self.busy.eq(s_valid | busy.any() | c_valid | head)
