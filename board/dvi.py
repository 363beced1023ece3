"""DVI output in Amaranth (DVI 1.0 section 3.2): the video timing generator, the TMDS 8b/10b encoder of one lane, the
display (timing, pixel source, three encoders) and the 10:1 serializer (two bits a clock at five times the pixel
clock: the ECP5's ODDRX1F through the platform in the hardware build, a behavioural double-data-rate stand-in in
simulation).

Checked against the golden model ``board/video.py`` bit for bit (``tests/board/test_dvi.py`` in Amaranth's simulator,
``cosim/test_board_dvi.py`` decoding the lanes on Icarus).
"""

from __future__ import annotations

from amaranth import Cat, ClockSignal, Const, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .video import CTRL_TOKENS, VideoTiming

__all__ = ["TimingGenerator", "TmdsEncoder", "Display", "Serializer", "DisplayTest", "CLOCK_WORD", "pattern"]

#: The clock lane's 10-bit word: five ones then five zeros each pixel clock (bit 0 sent first).
CLOCK_WORD = 0b0000011111


class TimingGenerator(wiring.Component):
    """Line and frame counters of a :class:`~board.video.VideoTiming`: ``x``, ``y`` (the counters: the pixel's
    position while ``de``), ``de``, ``hsync``, ``vsync`` (wire levels, polarity applied), ``frame`` (high on the
    first clock of a frame, ``x = y = 0``). Out of reset the counters stand at the first blanking line (``y =
    v_active``), so a sink sees a whole vertical blanking before the first frame."""

    def __init__(self, timing: VideoTiming):
        self.timing = t = timing
        super().__init__({"x": Out(range(t.h_total)), "y": Out(range(t.v_total), init=t.v_active), "de": Out(1),
                          "hsync": Out(1),
                          "vsync": Out(1), "frame": Out(1)})

    def elaborate(self, platform):
        t = self.timing
        m = Module()
        h, v = self.x, self.y
        with m.If(h == t.h_total - 1):
            m.d.sync += h.eq(0)
            m.d.sync += v.eq(Mux(v == t.v_total - 1, 0, v + 1))
        with m.Else():
            m.d.sync += h.eq(h + 1)
        hs0, vs0 = t.h_active + t.h_front, t.v_active + t.v_front
        hs = (h >= hs0) & (h < hs0 + t.h_sync)
        vs = (v >= vs0) & (v < vs0 + t.v_sync)
        m.d.comb += [self.de.eq((h < t.h_active) & (v < t.v_active)),
                     self.hsync.eq(hs if t.h_sync_pos else ~hs),
                     self.vsync.eq(vs if t.v_sync_pos else ~vs),
                     self.frame.eq((h == 0) & (v == 0))]
        return m


class TmdsEncoder(wiring.Component):
    """One TMDS lane (DVI 1.0, 3.2.2): ``data`` while ``de``, else the control token of ``ctrl`` (``C1 C0``);
    ``word`` (bit 0 sent first) one clock later (a control token out of reset). The running disparity is kept in
    ``cnt`` and reset in blanking."""

    def __init__(self):
        super().__init__({"de": In(1), "data": In(8), "ctrl": In(2), "word": Out(10, init=CTRL_TOKENS[0])})
        self.cnt = Signal(signed(6))

    def elaborate(self, platform):
        m = Module()
        d, cnt = self.data, self.cnt
        n1 = sum(d[i] for i in range(8))
        xnor = (n1 > 4) | ((n1 == 4) & ~d[0])
        bits = [d[0]]
        for i in range(1, 8):
            bits.append(Mux(xnor, ~(bits[-1] ^ d[i]), bits[-1] ^ d[i]))
        qm = Signal(8)
        m.d.comb += qm.eq(Cat(*bits))
        q8 = ~xnor
        n1q = Signal(range(9))
        m.d.comb += n1q.eq(sum(qm[i] for i in range(8)))
        diff = Signal(signed(6))                       # n1q - n0q
        m.d.comb += diff.eq(2 * n1q - 8)
        with m.If(~self.de):
            m.d.sync += [self.word.eq(Mux(self.ctrl[1], Mux(self.ctrl[0], CTRL_TOKENS[3], CTRL_TOKENS[2]),
                                          Mux(self.ctrl[0], CTRL_TOKENS[1], CTRL_TOKENS[0]))),
                         cnt.eq(0)]
        with m.Elif((cnt == 0) | (diff == 0)):
            m.d.sync += [self.word.eq(Cat(Mux(q8, qm, ~qm), q8, ~q8)),
                         cnt.eq(Mux(q8, cnt + diff, cnt - diff))]
        with m.Elif(((cnt > 0) & (diff > 0)) | ((cnt < 0) & (diff < 0))):
            m.d.sync += [self.word.eq(Cat(~qm, q8, Const(1, 1))),
                         cnt.eq(cnt + Mux(q8, 2, 0) - diff)]
        with m.Else():
            m.d.sync += [self.word.eq(Cat(qm, q8, Const(0, 1))),
                         cnt.eq(cnt - Mux(q8, 0, 2) + diff)]
        return m


class Display(wiring.Component):
    """The timing generator and three encoders: the pixel source drives ``r``, ``g``, ``b`` for position ``x``,
    ``y`` ``latency`` clocks after they are shown (0: combinationally); the syncs and ``de`` are delayed to match.
    ``words``: lane 0 (blue, ``C0 = hsync``, ``C1 = vsync``), lane 1 (green), lane 2 (red), 10 bits each."""

    def __init__(self, timing: VideoTiming, latency: int = 0):
        self.timing, self.latency = timing, latency
        super().__init__({"x": Out(range(timing.h_total)), "y": Out(range(timing.v_total)), "de": Out(1),
                          "frame": Out(1), "r": In(8), "g": In(8), "b": In(8), "words": Out(30)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.timing = tg = TimingGenerator(self.timing)
        m.d.comb += [self.x.eq(tg.x), self.y.eq(tg.y), self.de.eq(tg.de), self.frame.eq(tg.frame)]
        ctl = Cat(tg.de, tg.hsync, tg.vsync)
        for k in range(self.latency):
            nxt = Signal(3, name=f"ctl_delay{k}")
            m.d.sync += nxt.eq(ctl)
            ctl = nxt
        for lane, (color, c) in enumerate(((self.b, ctl[1:3]), (self.g, 0), (self.r, 0))):
            enc = TmdsEncoder()
            m.submodules[f"lane{lane}"] = enc
            m.d.comb += [enc.de.eq(ctl[0]), enc.data.eq(color), enc.ctrl.eq(c),
                         self.words[10 * lane:10 * lane + 10].eq(enc.word)]
        return m


class Serializer(wiring.Component):
    """Four 10-bit words a pixel clock (``sync``) -> four serial lanes, two bits a clock of domain ``tmds`` (five
    times the pixel clock, from the same PLL). The ``tmds`` domain loads a word every fifth clock and shifts it out
    from bit 0: ``pairs`` holds each lane's two bits of the clock (lane ``k``: bit ``2k`` first, ``2k + 1`` second).
    ``hardware=True``: the board top hands ``pairs`` to the platform's double-data-rate output buffers (the ECP5's
    ODDRX1F, ``amaranth.lib.io.DDRBuffer``); otherwise ``pins`` is a behavioural double-data-rate output (the first
    bit while the ``tmds`` clock is high, the second while low), for simulation."""

    def __init__(self, lanes: int = 4, hardware: bool = False):
        self.lanes, self.hardware = lanes, hardware
        sig = {"words": In(10 * lanes), "pairs": Out(2 * lanes)}
        if not hardware:
            sig["pins"] = Out(lanes)
        super().__init__(sig)

    def elaborate(self, platform):
        m = Module()
        phase = Signal(range(5))
        m.d.tmds += phase.eq(Mux(phase == 4, 0, phase + 1))
        for k in range(self.lanes):
            sr = Signal(10, name=f"shift{k}")
            word = self.words[10 * k:10 * k + 10]
            with m.If(phase == 0):
                m.d.tmds += sr.eq(word)
            with m.Else():
                m.d.tmds += sr.eq(sr >> 2)
            m.d.comb += self.pairs[2 * k:2 * k + 2].eq(sr[:2])
            if not self.hardware:
                q0, q1 = Signal(name=f"ddr{k}_0"), Signal(name=f"ddr{k}_1")
                m.d.tmds += [q0.eq(sr[0]), q1.eq(sr[1])]
                m.d.comb += self.pins[k].eq(Mux(ClockSignal("tmds"), q0, q1))
        return m


def pattern(disp: Display) -> list:
    """Statements driving ``disp``'s colors with :func:`~board.video.pattern_rgb` of its position (the same
    formula)."""
    x, y = disp.x, disp.y
    return [disp.r.eq(x[:8]), disp.g.eq(y[:8] + x[8:]), disp.b.eq((x >> 1) ^ (y << 1))]


class DisplayTest(wiring.Component):
    """The display showing :func:`~board.video.pattern_rgb` (the same formula), serialized (behaviourally): the
    co-simulation's top. Ports: ``tmds_clk``/``tmds_rst`` (the five-times clock), ``serial`` (lanes 0-2, lane 3
    the clock), ``words`` (the three data lanes' words before the serializer, for the full-frame check)."""

    def __init__(self, timing: VideoTiming):
        self.timing = timing
        super().__init__({"tmds_clk": In(1), "tmds_rst": In(1), "serial": Out(4), "words": Out(30)})

    def elaborate(self, platform):
        from amaranth import ClockDomain, ResetSignal
        m = Module()
        m.domains.tmds = ClockDomain("tmds")
        m.d.comb += [ClockSignal("tmds").eq(self.tmds_clk), ResetSignal("tmds").eq(self.tmds_rst)]
        m.submodules.display = disp = Display(self.timing)
        m.submodules.serializer = ser = Serializer(4)
        m.d.comb += [*pattern(disp),
                     self.words.eq(disp.words), ser.words.eq(Cat(disp.words, Const(CLOCK_WORD, 10))),
                     self.serial.eq(ser.pins)]
        return m

