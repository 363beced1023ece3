"""Block RAMs read through their own output registers: a memory whose read word is registered in the next
clock (:class:`RegisteredMemory`), on an ECP5 a column of ``DP16KD`` blocks with ``REGMODE_B = "OUTREG"``.

Why: in nextpnr's timing of the ULX3S's speed grade 6, a ``DP16KD`` without its output register gives its word
more than half of a 100 MHz cycle after the clock, before any route; with the output register, a small fraction of
it (the clock-to-out of a register). Yosys never uses the output register (its ``DP16KD`` mapping sets
``REGMODE`` to ``NOREG``), so the register after a read stays in the fabric, a route away from the block, and a
memory deeper than the widest port that holds it gets a multiplexer of Yosys' own between the blocks and that
register: the samplers' texel words into their bank registers were among the board's slowest paths (``bumpmap
bitstream --misses``), and the default 64-texel cubes' banks (6534 words, deeper than any port) among the routed
engines' (``docs/fpga/placement.json``).

What: :class:`RegisteredMemory` is ``depth`` words of ``width`` bits with one synchronous read port whose word is
registered once more (``r_data`` holds the word at ``r_addr`` of two clocks before) and one write port (``w_en``,
``w_addr``, ``w_data``: the word is there for reads from the next clock on; a read of the word being written gives
the word before the write). With ``enables``, the two registers advance only when told: ``r_en`` the read (the
word at ``r_addr`` into the read register), ``o_en`` the output register (the read register's word into it), so
the read and the output are a pipeline of two stages that a stream's handshake can hold (the blocks' ``CEB`` and
``OCEB``). On an ECP5 platform (:func:`rtl.dsp.uses_blocks`), when too large to stay in logic
(the cost model's rule, which Yosys' follows), it is built of ``DP16KD`` blocks of one port of :data:`PORTS`
(:func:`fxmodel.core.cost.registered_shape`): side by side, each holding every word of a column of the port's
bits, written through port A and read through port B with the block's output register as the register; a memory
deeper than the port is groups of such columns, each the port's words, written where the write address' top bits
select, and a multiplexer after the output registers picks the group the read address' top bits (registered
with the read) select: the word leaves a register, not a block's array. Otherwise (simulation, co-simulation)
it is an Amaranth ``Memory`` and a register: the same function, clock for clock.

The blocks' initial contents (``INITVAL_00`` to ``INITVAL_3F``) follow the layout Yosys' own ``DP16KD`` mapping
writes (``tests/rtl/test_bram.py`` checks them against Yosys' for the same contents), and :data:`MODEL`, a
behavioural ``DP16KD`` for the configurations built here (Yosys' library has none), lets Icarus run the ECP5 form
beside the other (``tests/rtl/test_bram.py``: every read word equal on every clock, writes included).
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import ClockSignal, Const, Instance, Module, Mux, ResetSignal, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from fxmodel.core.cost import REGISTERED_PORTS, in_logic, registered_shape
from fxmodel.core.cost import Memory as CostMemory

from .dsp import uses_blocks

__all__ = ["PORTS", "ROW_BITS", "blocks", "init_values", "RegisteredMemory", "MODEL"]

#: The ``DP16KD`` port shapes used, ``(words, bits)`` (:data:`fxmodel.core.cost.REGISTERED_PORTS`).
PORTS = REGISTERED_PORTS

#: Bits of one row of the block's initial contents (``INITVAL_xx``: 16 rows of 20 bits, 18 used, in each of 64).
ROW_BITS = 18

def blocks(depth: int, width: int) -> int:
    """``DP16KD`` blocks of a :class:`RegisteredMemory` on an ECP5 (its groups of columns)."""
    _, _, groups, columns = registered_shape(depth, width)
    return groups * columns


def init_values(init, width: int, depth: int) -> list[list[int]]:
    """For each block of a :class:`RegisteredMemory` (group ``g``, column ``j``, in that order: bits ``[j w, (j + 1)
    w)`` of words ``[g D, (g + 1) D)``, ``D`` the port's words), its 64 ``INITVAL_xx`` values: the group's word
    ``k``'s column at bit ``k w`` of the 18432-bit contents, which row ``r`` (18 bits) of ``INITVAL_{r // 16}``
    holds at bit ``20 (r % 16)``."""
    D, w, groups, columns = registered_shape(depth, width)
    init = list(init) + [0] * (groups * D - len(init))
    out = []
    for g in range(groups):
        for j in range(columns):
            flat = 0
            for k, word in enumerate(init[g * D:(g + 1) * D]):
                flat |= ((word >> (j * w)) & ((1 << w) - 1)) << (k * w)
            vals = []
            for idx in range(64):
                v = 0
                for i in range(16):
                    row = idx * 16 + i
                    v |= ((flat >> (row * ROW_BITS)) & ((1 << ROW_BITS) - 1)) << (20 * i)
                vals.append(v)
            out.append(vals)
    return out


class RegisteredMemory(wiring.Component):
    """``depth`` words of ``width`` bits (``init``: the first words' values, the rest 0), read through a register
    (module docstring).

    Ports
    -----
    r_addr : in, ``range(depth)`` -- the word read
    r_data : out, ``width`` -- the word at ``r_addr`` two clocks before
    w_en, w_addr, w_data : in -- a write (the word is read from the next clock on)
    r_en, o_en : in, with ``enables`` -- the read register's and the output register's enables (without, both
        always enabled: ``r_data`` is then the word at ``r_addr`` two clocks before)
    """

    def __init__(self, width: int, depth: int, init=(), name: str = "mem", enables: bool = False):
        if not (isinstance(width, int) and width >= 1 and isinstance(depth, int) and depth >= 1):
            raise ValueError(f"RegisteredMemory {name}: width={width!r}, depth={depth!r}: must be positive ints")
        if len(init) > depth:
            raise ValueError(f"RegisteredMemory {name}: {len(init)} initial words for a depth of {depth}")
        self.width, self.depth, self.init, self.name, self.enables = width, depth, list(init), name, enables
        abits = max(1, (depth - 1).bit_length())
        ports = {"r_addr": In(abits), "r_data": Out(width), "w_en": In(1), "w_addr": In(abits), "w_data": In(width)}
        if enables:
            ports |= {"r_en": In(1), "o_en": In(1)}
        super().__init__(ports)

    def _enables(self) -> tuple:
        """The read register's and the output register's enables (constants 1 without ``enables``)."""
        return (self.r_en, self.o_en) if self.enables else (Const(1, 1), Const(1, 1))

    @property
    def in_logic(self) -> bool:
        """Small enough for Yosys to keep in logic (:func:`fxmodel.core.cost.in_logic`): no blocks then."""
        return in_logic(CostMemory(self.depth, self.width, 1, registered=True))

    def write_port(self, domain: str = "sync") -> SimpleNamespace:
        """The write port's signals (``en``, ``addr``, ``data``), as a ``Memory``'s write port gives them."""
        assert domain == "sync", "RegisteredMemory: one write port, in the sync domain"
        return SimpleNamespace(en=self.w_en, addr=self.w_addr, data=self.w_data)

    def elaborate(self, platform):
        m = Module()
        if uses_blocks(platform) and not self.in_logic:
            self._blocks(m)
            return m
        m.submodules.mem = mem = Memory(shape=self.width, depth=self.depth, init=self.init)
        rd, wr = mem.read_port(domain="sync"), mem.write_port(domain="sync")
        r_en, o_en = self._enables()
        m.d.comb += [rd.addr.eq(self.r_addr), rd.en.eq(r_en), wr.en.eq(self.w_en), wr.addr.eq(self.w_addr),
                     wr.data.eq(self.w_data)]
        with m.If(o_en):
            m.d.sync += self.r_data.eq(rd.data)
        return m

    def _blocks(self, m: Module) -> None:
        D, w, groups, cols = registered_shape(self.depth, self.width)
        low = 4 if w == 18 else 3                       # the word's address on ADx13..ADx4 (x18), ADx13..ADx3 (x9)
        abits = (D - 1).bit_length()                    # the address within a group; the top bits pick the group
        vals = init_values(self.init, self.width, self.depth)
        words = []
        for g in range(groups):
            word = Signal(self.width, name=f"{self.name}_g{g}")
            words.append(word)
            w_en = self.w_en & (self.w_addr[abits:] == g) if groups > 1 else self.w_en
            for j in range(cols):
                self._block(m, f"g{g}c{j}" if groups > 1 else f"col{j}", w, low, w_en, j, vals[g * cols + j], word)
        out = words[-1]
        if groups > 1:
            # the group read, registered twice: with the read (as the block's own read register, not reset),
            # then with the output register
            sel = Signal(range(groups), name=f"{self.name}_sel", reset_less=True)
            sel_q = Signal(range(groups), name=f"{self.name}_sel_q")
            r_en, o_en = self._enables()
            with m.If(r_en):
                m.d.sync += sel.eq(self.r_addr[abits:])
            with m.If(o_en):
                m.d.sync += sel_q.eq(sel)
            for g in reversed(range(groups - 1)):   # every group's output register reset to 0: so is the word
                out = Mux(sel_q == g, words[g], out)
        m.d.comb += self.r_data.eq(out)

    def _block(self, m: Module, name: str, w: int, low: int, w_en, j: int, vals: list, word) -> None:
        """The block of column ``j`` of one group, its output register's word into ``word``."""
        lo, hi = j * w, min(self.width, (j + 1) * w)
        dob = Signal(w, name=f"{self.name}_{name}_do")
        r_en, o_en = self._enables()
        ports = {"i_CLKA": ClockSignal("sync"), "i_CLKB": ClockSignal("sync"),
                 "i_CEA": Const(1, 1), "i_CEB": r_en, "i_OCEA": Const(1, 1), "i_OCEB": o_en,
                 "i_RSTA": Const(0, 1), "i_RSTB": ResetSignal("sync", allow_reset_less=True),
                 "i_WEA": w_en, "i_WEB": Const(0, 1)}        # RSTB: the output register, as the domain's
        for c in "AB":
            for k in range(3):
                ports[f"i_CS{c}{k}"] = Const(0, 1)
        pins = min(len(self.r_addr), 14 - low)          # the address bits within the group the block holds
        for pin in range(14):
            ports[f"i_ADA{pin}"] = self.w_addr[pin - low] if low <= pin < low + pins else \
                Const(1 if w == 18 and pin < 2 else 0, 1)          # x18: ADA1..0 are the write's byte enables
            ports[f"i_ADB{pin}"] = self.r_addr[pin - low] if low <= pin < low + pins else Const(0, 1)
        for b in range(18):
            ports[f"i_DIA{b}"] = self.w_data[lo + b] if b < hi - lo else Const(0, 1)
            ports[f"i_DIB{b}"] = Const(0, 1)
            if b < w:
                ports[f"o_DOB{b}"] = dob[b]
        params = {"p_DATA_WIDTH_A": w, "p_DATA_WIDTH_B": w, "p_REGMODE_A": "NOREG", "p_REGMODE_B": "OUTREG",
                  "p_RESETMODE": "SYNC", "p_ASYNC_RESET_RELEASE": "SYNC", "p_CSDECODE_A": "0b000",
                  "p_CSDECODE_B": "0b000", "p_WRITEMODE_A": "NORMAL", "p_WRITEMODE_B": "NORMAL",
                  "p_GSR": "DISABLED"}
        params |= {f"p_INITVAL_{idx:02X}": Const(v, 320) for idx, v in enumerate(vals)}
        m.submodules[name] = Instance("DP16KD", **params, **ports)
        m.d.comb += word[lo:hi].eq(dob[:hi - lo])


def _model() -> str:
    inits = ",\n".join(f"  parameter [319:0] INITVAL_{i:02X} = 320'h0" for i in range(64))
    loads = "\n".join(f"    for (i = 0; i < 16; i = i + 1) rows[{i * 16} + i] = INITVAL_{i:02X}[i * 20 +: 18];"
                      for i in range(64))
    return MODEL_TEMPLATE.replace("@INITS@", inits).replace("@LOADS@", loads)


#: Behavioural Verilog of ``DP16KD`` in the configurations :class:`RegisteredMemory` builds (both ports of one
#: width of :data:`PORTS`, port A written, port B read, ``REGMODE_B`` ``OUTREG`` or ``NOREG``, no chip selects,
#: a synchronous reset of port B's output register only, no global set/reset); any other stops the simulation.
#: A read of the word port A writes in the same clock gives the word before the write (as Amaranth's ``Memory``
#: without transparency does); the device does not define that word, and the texel memories are written only
#: between frames (``docs/board.md``, "Uploads while the engine draws"), when no read is used.
MODEL_TEMPLATE = r"""
module DP16KD #(
  parameter DATA_WIDTH_A = 18, parameter DATA_WIDTH_B = 18, parameter REGMODE_A = "NOREG",
  parameter REGMODE_B = "NOREG", parameter RESETMODE = "SYNC", parameter ASYNC_RESET_RELEASE = "SYNC",
  parameter CSDECODE_A = "0b000", parameter CSDECODE_B = "0b000", parameter WRITEMODE_A = "NORMAL",
  parameter WRITEMODE_B = "NORMAL", parameter GSR = "ENABLED",
@INITS@
) (
  input DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4, DIA3, DIA2,
  input DIA1, DIA0, ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0,
  input CEA, OCEA, CLKA, WEA, RSTA, CSA2, CSA1, CSA0,
  output DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3,
  output DOA2, DOA1, DOA0,
  input DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4, DIB3, DIB2,
  input DIB1, DIB0, ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0,
  input CEB, OCEB, CLKB, WEB, RSTB, CSB2, CSB1, CSB0,
  output DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3,
  output DOB2, DOB1, DOB0
);
  reg [17:0] rows [0:1023];
  integer i;
  wire [17:0] dia = {DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4,
                     DIA3, DIA2, DIA1, DIA0};
  wire [13:0] ada = {ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0};
  wire [13:0] adb = {ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0};
  reg [17:0] rd = 0, rd_q = 0;
  initial begin
    if (!(DATA_WIDTH_A == DATA_WIDTH_B && (DATA_WIDTH_A == 18 || DATA_WIDTH_A == 9) &&
          (REGMODE_B == "OUTREG" || REGMODE_B == "NOREG") && RESETMODE == "SYNC" && GSR == "DISABLED" &&
          CSDECODE_A == "0b000" && CSDECODE_B == "0b000")) begin
      $display("DP16KD model: configuration not modelled");
      $finish;
    end
@LOADS@
  end
  // x18: word ADx13..ADx4 is row; x9: word ADx13..ADx3, its half of row ADx13..ADx4 by ADx3
  always @(posedge CLKA) begin
    if (CEA && WEA && !RSTA) begin
      if (DATA_WIDTH_A == 18) begin
        if (ada[0]) rows[ada[13:4]][8:0] <= dia[8:0];
        if (ada[1]) rows[ada[13:4]][17:9] <= dia[17:9];
      end else if (ada[3])
        rows[ada[13:4]][17:9] <= dia[8:0];
      else
        rows[ada[13:4]][8:0] <= dia[8:0];
    end
  end
  always @(posedge CLKB) begin
    if (CEB) rd <= (DATA_WIDTH_B == 18) ? rows[adb[13:4]] : {9'b0, adb[3] ? rows[adb[13:4]][17:9] :
                                                                    rows[adb[13:4]][8:0]};
    if (RSTB) rd_q <= 0;
    else if (OCEB) rd_q <= rd;
  end
  wire [17:0] dob = (REGMODE_B == "OUTREG") ? rd_q : rd;
  assign {DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3, DOB2,
          DOB1, DOB0} = dob;
  assign {DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3, DOA2,
          DOA1, DOA0} = 18'b0;
endmodule
"""

#: The behavioural ``DP16KD`` (:data:`MODEL_TEMPLATE` with its 64 ``INITVAL`` parameters and their loading).
MODEL = _model()
