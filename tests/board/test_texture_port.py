"""The texel caches' read channels across clocks (``board/texture_port.py``), in Amaranth's simulator with two
unrelated clocks (each faster than the other in turn): every ``AR`` transfer and every ``R`` beat arrives once, in
order, unchanged but for the address's base (the maps' half of the SDRAM), under random ``valid`` and ``ready`` on
both sides; an offered transfer stays offered with the same
payload until taken (AXI's rule); the ID is widened with zeros and narrowed back; a beat with an error response or
an ID the manager did not send raises ``error``, and clean traffic does not."""

from __future__ import annotations

import random

import pytest
from amaranth.sim import Simulator

from board.litedram import ADDR_BITS, ID_BITS
from board.texture_port import TEXTURE_ADDR_BITS, TEXTURE_BASE, TextureReadCrossing

AR_FIELDS = ("araddr", "arlen", "arsize", "arburst")
R_FIELDS = ("rdata", "rresp", "rlast")


def _send(port, fields, prefix, items, domain, rng, p):
    """A source on ``port``'s channel ``prefix`` in ``domain``: ``items`` (dicts of ``fields``) offered with
    probability ``p`` a clock, each held until taken."""
    async def process(ctx):
        for item in items:
            while rng.random() >= p:
                ctx.set(getattr(port, f"{prefix}valid"), 0)
                await ctx.tick(domain)
            ctx.set(getattr(port, f"{prefix}valid"), 1)
            for f in fields:
                ctx.set(getattr(port, f), item[f])
            await ctx.tick(domain).until(getattr(port, f"{prefix}ready"))
        ctx.set(getattr(port, f"{prefix}valid"), 0)
    return process


def _receive(port, fields, prefix, out, domain, rng, p, held):
    """A sink on ``port``'s channel ``prefix`` in ``domain``: ``ready`` with probability ``p`` a clock; each
    transfer appended to ``out``; an offer not taken must stay offered with the same payload (else ``held`` gets
    the clock's note)."""
    async def process(ctx):
        waiting = None
        while True:
            ready = int(rng.random() < p)
            ctx.set(getattr(port, f"{prefix}ready"), ready)
            valid = ctx.get(getattr(port, f"{prefix}valid"))
            item = {f: ctx.get(getattr(port, f)) for f in fields}
            if waiting is not None and (not valid or item != waiting):
                held.append((prefix, waiting, valid, item))
            if valid and ready:
                out.append(item)
            waiting = item if valid and not ready else None
            await ctx.tick(domain)
    return process


def _run(ar, r, periods, seed, p=(0.6, 0.6), port=False, **kw):
    """The crossing with ``ar`` sent up and ``r`` sent down; ``(ARs at the core, beats at the caches, held
    violations, error, the core side's ID bits above the caches')``."""
    if port:                                                 # the same through the board's whole texture port
        from board.texture_port import TexturePort
        dut = TexturePort(1, i_domain="sync", o_domain="dram")
    else:
        dut = TextureReadCrossing(1, **kw)
    rng = random.Random(seed)
    sim = Simulator(dut)
    sim.add_clock(periods[0], domain="sync")
    sim.add_clock(periods[1], domain="dram")
    got_ar, got_r, held, upper = [], [], [], []
    sim.add_testbench(_send(dut.up, ("arid",) + AR_FIELDS, "ar", ar, "sync", rng, p[0]), background=True)
    sim.add_testbench(_receive(dut.down, ("arid",) + AR_FIELDS, "ar", got_ar, "dram", random.Random(seed + 1), p[1],
                               held), background=True)
    sim.add_testbench(_send(dut.down, ("rid",) + R_FIELDS, "r", r, "dram", random.Random(seed + 2), p[0]),
                      background=True)
    sim.add_testbench(_receive(dut.up, ("rid",) + R_FIELDS, "r", got_r, "sync", random.Random(seed + 3), p[1],
                               held), background=True)
    result = {}

    async def bench(ctx):
        result["error"] = 0
        limit = 40 * (len(ar) + len(r)) + 200
        for _ in range(limit):
            await ctx.tick("sync")
            if len(got_ar) == len(ar) and len(got_r) == len(r):
                break
        for _ in range(10):
            await ctx.tick("sync")
        result["error"] = ctx.get(dut.read_error if port else dut.error)

    sim.add_testbench(bench)
    sim.run()
    upper += [a["arid"] >> 1 for a in got_ar]
    return got_ar, got_r, held, result["error"], upper


def _traffic(rng, n, addr_bits=TEXTURE_ADDR_BITS):
    ar = [{"arid": rng.randrange(2), "araddr": rng.randrange(1 << addr_bits), "arlen": rng.randrange(256),
           "arsize": 2, "arburst": 1} for _ in range(n)]
    r = [{"rid": rng.randrange(2), "rdata": rng.randrange(1 << 32), "rresp": 0, "rlast": int(k % 4 == 3)}
         for k in range(4 * n)]
    return ar, r


@pytest.mark.parametrize("port", [False, True])
@pytest.mark.parametrize("periods", [(10e-9, 17e-9), (17e-9, 10e-9), (10e-9, 20e-9)])
def test_every_transfer_crosses_once_in_order(periods, port):
    """The crossing alone and inside the board's texture port (which also carries the uploads' writes)."""
    rng = random.Random(int(periods[1] * 1e9))
    ar, r = _traffic(rng, 40)
    got_ar, got_r, held, error, upper = _run(ar, r, periods, seed=int(periods[0] * 1e9), port=port)
    assert got_ar == [{**a, "araddr": TEXTURE_BASE + a["araddr"]} for a in ar] and got_r == r
    assert held == [] and error == 0 and set(upper) == {0}


def test_the_whole_sdram_with_base_zero():
    rng = random.Random(3)
    ar, r = _traffic(rng, 20, ADDR_BITS)
    got_ar, got_r, held, error, _ = _run(ar, r, (10e-9, 13e-9), seed=3, up_addr_bits=ADDR_BITS, base=0)
    assert got_ar == ar and got_r == r and held == [] and error == 0


@pytest.mark.parametrize("kw", [{"base": TEXTURE_BASE // 2}, {"base": TEXTURE_BASE, "up_addr_bits": ADDR_BITS},
                                {"up_addr_bits": 0}, {"up_addr_bits": ADDR_BITS + 1, "base": 0}])
def test_a_base_that_would_overlap_or_leave_the_sdram_is_refused(kw):
    with pytest.raises(ValueError, match="base|up_addr_bits"):
        TextureReadCrossing(1, **kw)


@pytest.mark.parametrize("bad", [{"rresp": 2}, {"rresp": 3}, {"rid": 2}, {"rid": 1 << (ID_BITS - 1)}])
def test_an_error_response_or_a_stray_id_raises_error(bad):
    rng = random.Random(5)
    ar, r = _traffic(rng, 6)
    r[9] = {**r[9], **bad}
    got_ar, got_r, held, error, _ = _run(ar, r, (10e-9, 17e-9), seed=5)
    assert error == 1 and len(got_r) == len(r) and held == []


def test_a_okay_exclusive_response_is_not_an_error():
    """``EXOKAY`` (1) is a success; only ``SLVERR`` and ``DECERR`` (bit 1 set) are errors."""
    rng = random.Random(6)
    ar, r = _traffic(rng, 6)
    r[3] = {**r[3], "rresp": 1}
    assert _run(ar, r, (10e-9, 17e-9), seed=6)[3] == 0


def _writes(words, gap, seed, bresp=0, ar_during=False):
    """:class:`TexturePort` with ``words`` ``(addr, data)`` handed over from the 10 ns clock a ``gap`` clocks apart
    (holding registers and a toggle, as the board's uploads), a memory on the 17 ns clock taking ``AW`` and ``W``
    at random and answering each write after a random wait with ``bresp``; with ``ar_during`` an ``AR`` offered
    while the first write is in flight. ``(writes seen: (awaddr, awlen, awsize, awburst, wdata, wstrb, wlast),
    error)``."""
    from board.texture_port import TexturePort
    dut = TexturePort(1)
    rng = random.Random(seed)
    sim = Simulator(dut)
    sim.add_clock(10e-9, domain="sync")
    sim.add_clock(17e-9, domain="dram")
    seen, aws, ws = [], [], []

    async def host(ctx):
        req = 0
        for addr, data in words:
            ctx.set(dut.addr, addr)
            ctx.set(dut.data, data)
            req ^= 1
            ctx.set(dut.req, req)
            await ctx.tick("sync").repeat(gap)

    async def memory(ctx):
        d = dut.down
        while True:
            ctx.set(d.awready, int(rng.random() < 0.5))
            ctx.set(d.wready, int(rng.random() < 0.5))
            if ctx.get(d.awvalid) and ctx.get(d.awready):
                aws.append(tuple(ctx.get(getattr(d, f)) for f in ("awaddr", "awlen", "awsize", "awburst")))
            if ctx.get(d.wvalid) and ctx.get(d.wready):
                ws.append(tuple(ctx.get(getattr(d, f)) for f in ("wdata", "wstrb", "wlast")))
            if len(aws) > len(seen) and len(ws) > len(seen):
                seen.append(aws[len(seen)] + ws[len(seen)])
                for _ in range(40 if ar_during else rng.randrange(1, 6)):   # the AR comes meanwhile
                    await ctx.tick("dram")
                ctx.set(d.bresp, bresp)
                ctx.set(d.bvalid, 1)
                await ctx.tick("dram").until(d.bready)
                ctx.set(d.bvalid, 0)
            await ctx.tick("dram")

    async def reader(ctx):                                   # one AR from the caches' side, during the first write
        await ctx.tick("sync").repeat(6)
        ctx.set(dut.up.arvalid, 1)
        ctx.set(dut.down.arready, 0)
        await ctx.tick("sync").until(dut.up.arready)
        ctx.set(dut.up.arvalid, 0)

    result = {}

    async def bench(ctx):
        await ctx.tick("sync").repeat(gap * len(words) + 400)
        result["error"] = ctx.get(dut.error)

    sim.add_testbench(host)
    sim.add_testbench(memory, background=True)
    if ar_during:
        sim.add_testbench(reader)
    sim.add_testbench(bench)
    sim.run()
    return seen, result["error"]


def _words(n, seed):
    rng = random.Random(seed)
    return [(TEXTURE_BASE + 4 * rng.randrange(1 << 20), rng.randrange(1 << 32)) for _ in range(n)]


def test_upload_words_are_written_once_each_in_order():
    """Words a UART byte's time apart (here 60 engine clocks) are each one single-beat write at their address,
    every byte enabled; no error."""
    words = _words(12, 1)
    seen, error = _writes(words, 60, seed=1)
    assert seen == [(a, 0, 2, 1, d, 0xF, 1) for a, d in words] and error == 0


def test_a_word_during_a_write_or_an_error_response_raises_error():
    words = _words(6, 2)
    seen, error = _writes(words, 2, seed=2)                 # faster than a write: some are lost, and said so
    assert error == 1 and len(seen) < len(words)
    assert _writes(_words(3, 3), 60, seed=3, bresp=2)[1] == 1


def test_a_lookup_during_an_upload_write_raises_error():
    """LiteDRAM would not order a read after a write still in flight on the port: the board never makes one, and
    one made is flagged (the same write without it is not)."""
    assert _writes(_words(1, 4), 200, seed=4, ar_during=True)[1] == 1
    assert _writes(_words(1, 4), 200, seed=4)[1] == 0


def test_the_maps_in_sdram_need_the_frame_in_sdram():
    from board.frame import EngineSystem, board_engine, board_textures
    from board.video import VGA_640x480
    params = board_engine("tin-plane", size=16)[0]
    with pytest.raises(ValueError, match="frame"):
        board_textures(params, True, "chip")
    with pytest.raises(ValueError, match="frame in SDRAM"):
        EngineSystem(board_textures(params, True, "sdram"), VGA_640x480, 25, frame="chip")
    system = EngineSystem(board_textures(params, True, "sdram"), VGA_640x480, 25, frame="sdram")
    assert system.textures and "tex" in system.signature.members
    assert "tex" not in EngineSystem(params, VGA_640x480, 25, frame="sdram").signature.members
