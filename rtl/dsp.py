"""Products in the ECP5's multiplier blocks with their registers inside the block.

Why: Yosys maps a product onto a ``MULT18X18D`` but never moves registers into it (``synth_ecp5`` has no register
packing for this block), so every product of the pipeline ran from a fabric register through a route into the
block, through the whole multiplier, and through a route out to a fabric register; with most of the device's blocks
in use, those paths were most of the engine's endpoints that missed 100 MHz (``bumpmap bitstream --misses``
counts them and gives nextpnr's delays). The block has registers of its own on both operands and on the product
(nextpnr times the block by them): with them the multiplier lies between two registers inside the block, and the
fabric sees only a setup at the block's input and the block's clock-to-out at its output.

What: :class:`rtl.unit.Pipe` asks :func:`registered_product` for each expression it registers. When the platform is
an ECP5 (``platform.family == "ecp5"``: amaranth-boards' ULX3S, or :data:`ECP5` for the Verilog that ``bumpmap
fpga`` places) and the expression is a product (or a slice of one) of two operands of at most :data:`DSP_BITS`
bits, the stage register is the block's output register, and when both operands are registers the same ``Pipe``
made (or slices or sign casts of them) they are replaced by the block's input registers fed from those registers'
own inputs: the same values at the same clock edge (one operand alone is left in the fabric: nextpnr times a block
with one input register as if it had none). A product with an operand of at most :data:`LOGIC_PRODUCT_BITS` bits
(the narrow top piece of a cut operand, ``fxmodel.core.cost.pieces``) takes no block: :func:`logic_product` writes
it as one adder of the other operand's copies, which Yosys keeps in logic (``synth_ecp5``'s ``mul2dsp`` maps
operands of 2 bits or more to a block, so a ``*`` would still take one). The blocks are most of what the engine's
placement has to spread over the die (``docs/board.md``). Anything else stays as it was (Yosys infers the block
without registers). The function is the same as the fabric's registers, clock for clock, reset included (the
block's registers reset synchronously with the domain, as Amaranth's registers do; global set/reset off);
``tests/rtl/test_dsp.py`` runs each unit both ways in Icarus, :data:`MODEL` standing in for the block, and compares
every output on every clock. The block itself has no simulation model in Yosys' library: :data:`MODEL` is written
from Lattice's sysDSP usage guide (TN1267) for the one configuration used here, and refuses any other.

Outside an ECP5 build (simulation, co-simulation, ``make verilog``) nothing changes: the Verilog is the same.

Uses Amaranth's private expression classes (``Slice``, ``Operator``) to recognise a product; the project pins
Amaranth (``pyproject.toml``).
"""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.hdl import ClockSignal, Const, Instance, Module, Mux, ResetSignal, Shape, Signal, Value, signed, unsigned
from amaranth.hdl._ast import Operator, Slice

from fxmodel.core.cost import DSP_BITS, LOGIC_PRODUCT_BITS

from .fixed import extend

__all__ = ["DSP_BITS", "LOGIC_PRODUCT_BITS", "ECP5", "MODEL", "uses_blocks", "Product", "registered_product",
           "logic_product", "RegisterSources"]


class _Ecp5Target:
    """Stand-in platform for Verilog written for an ECP5 without a board (``bumpmap fpga``): it has the family and
    nothing else, so every other elaboration is the platform-free one."""

    family = "ecp5"

    def __repr__(self):
        return "ECP5"


#: The platform argument for Verilog placed on an ECP5 by ``bumpmap fpga`` (:func:`rtl.verilog.verilog_text`).
ECP5 = _Ecp5Target()

#: Product width of the block (two 18-bit operands).
P_BITS = 2 * DSP_BITS


def uses_blocks(platform) -> bool:
    """Whether products registered by :class:`rtl.unit.Pipe` go into ``MULT18X18D`` blocks with their registers."""
    return getattr(platform, "family", None) == "ecp5"


@dataclass
class Product:
    """A product ``a * b`` to register, and the bits ``[lo:hi]`` of it that are kept (the whole product unless the
    expression was a slice of it)."""

    a: Value
    b: Value
    shape: Shape        # the product's (signed when either operand is)
    lo: int
    hi: int


def _product(expr) -> Product | None:
    """``expr`` as a :class:`Product` if it is ``a * b``, or a slice of it or of it shifted right by a constant
    (either perhaps read as signed or unsigned: the same bits, as ``rtl.fixed.narrow`` truncating with a proven
    range gives them), with neither operand a constant or empty; else ``None``."""
    lo = hi = None
    if isinstance(expr, Operator) and expr.operator in ("s", "u") and len(expr.operands) == 1:
        expr = expr.operands[0]
    if isinstance(expr, Slice) and isinstance(expr.value, Operator):
        lo, hi, expr = expr.start, expr.stop, expr.value
    shift = 0
    if isinstance(expr, Operator) and expr.operator == ">>" and isinstance(expr.operands[1], Const):
        # a right shift by a constant (``rtl.fixed.shift_round`` truncating): the product's bits from k up, read
        # with its own extension above its top bit (Amaranth keeps the shifted value as wide as the product)
        lo, hi = (0, len(expr)) if lo is None else (lo, hi)
        expr, shift = expr.operands[0], expr.operands[1].value
    if not (isinstance(expr, Operator) and expr.operator == "*" and len(expr.operands) == 2):
        return None
    a, b = expr.operands
    if any(isinstance(x, Const) or len(x) == 0 for x in (a, b)):
        return None
    return Product(a, b, expr.shape(), shift + (0 if lo is None else lo), len(expr) if hi is None else shift + hi)


def registered_product(expr) -> Product | None:
    """``expr`` as a :class:`Product` for one block: a product (:func:`_product`) with both operands at most
    :data:`DSP_BITS` bits wide and neither at most :data:`LOGIC_PRODUCT_BITS` (:func:`logic_product` builds
    those); else ``None``."""
    p = _product(expr)
    if p is None or any(len(x) > DSP_BITS or len(x) <= LOGIC_PRODUCT_BITS for x in (p.a, p.b)):
        return None
    return p


def logic_product(expr) -> Value | None:
    """``expr``, a product (:func:`_product`) with an operand of at most :data:`LOGIC_PRODUCT_BITS` bits, as
    the sum of the other operand's copies those bits select (the sign bit's copy subtracted when that operand is
    signed): one adder, exact, the same bits as ``expr`` (the sum is Amaranth's exact arithmetic, as wide as the
    product or wider, so its bits ``[lo:hi]`` are the product's); else ``None``."""
    p = _product(expr)
    if p is None:
        return None
    a, b = sorted((p.a, p.b), key=len, reverse=True)         # b the narrower
    if len(b) > LOGIC_PRODUCT_BITS:
        return None
    total = 0
    for i in range(len(b)):
        copy = Mux(b[i], a, 0) << i
        total = total - copy if b.shape().signed and i == len(b) - 1 else total + copy
    out = extend(total, p.hi)[p.lo:p.hi]        # the product's bits (the sum's own extension above its top)
    return out.as_signed() if expr.shape().signed else out.as_unsigned()


class RegisterSources:
    """The input of each register a :class:`rtl.unit.Pipe` made (only for ECP5 builds): an operand that is such a
    register can be the block's own input register, fed from the same input."""

    def __init__(self):
        self._regs: dict[int, tuple[Signal, Value]] = {}

    def add(self, reg: Signal, d: Value) -> None:
        self._regs[id(reg)] = (reg, d)

    def source(self, v: Value) -> Value | None:
        """The value ``v`` takes one clock after now, if ``v`` is such a register or a slice or sign cast of one."""
        if isinstance(v, Signal):
            hit = self._regs.get(id(v))
            return hit[1] if hit is not None and hit[0] is v else None
        if isinstance(v, Slice):
            s = self.source(v.value)
            return None if s is None else Value.cast(s)[v.start:v.stop]
        if isinstance(v, Operator) and v.operator in ("s", "u") and len(v.operands) == 1:
            s = self.source(v.operands[0])
            if s is None:
                return None
            return Value.cast(s).as_signed() if v.operator == "s" else Value.cast(s).as_unsigned()
        return None


def block(m: Module, p: Product, sources: RegisterSources, name: str) -> Value:
    """One ``MULT18X18D`` computing ``p`` with its output register (and its input registers when
    :meth:`RegisterSources.source` knows both operands); returns the registered product's bits ``[p.lo:p.hi]``,
    exact (every product of two 18-bit operands fits the block's 36 bits: at most ``2**34`` in magnitude when both
    are signed, below ``2**36`` when both unsigned, below ``2**35`` in magnitude when mixed)."""
    ports, params = {}, {}
    srcs = [sources.source(x) for x in (p.a, p.b)]
    if any(s is None for s in srcs):    # both operand registers or neither: nextpnr times a block with one input
        srcs = [None, None]             # register as if it had none, and the fabric register is as fast
    for (port, x), src in zip((("A", p.a), ("B", p.b)), srcs):
        wide = Signal(signed(DSP_BITS) if x.shape().signed else unsigned(DSP_BITS), name=f"{name}_{port.lower()}")
        m.d.comb += wide.eq(x if src is None else src)        # sign or zero extension, by the operand's shape
        for i in range(DSP_BITS):
            ports[f"i_{port}{i}"] = wide[i]
        ports[f"i_SIGNED{port}"] = Const(int(x.shape().signed), 1)
        params.update({f"p_REG_INPUT{port}_CLK": "NONE" if src is None else "CLK0",
                       f"p_REG_INPUT{port}_CE": "CE0", f"p_REG_INPUT{port}_RST": "RST0"})
    out = Signal(P_BITS, name=f"{name}_p")
    ports.update({f"o_P{i}": out[i] for i in range(P_BITS)})
    ports.update(i_SOURCEA=Const(0, 1), i_SOURCEB=Const(0, 1), i_CLK0=ClockSignal("sync"), i_CE0=Const(1, 1),
                 i_RST0=ResetSignal("sync", allow_reset_less=True))
    params.update(p_REG_OUTPUT_CLK="CLK0", p_REG_OUTPUT_CE="CE0", p_REG_OUTPUT_RST="RST0",
                  p_REG_PIPELINE_CLK="NONE", p_REG_PIPELINE_CE="CE0", p_REG_PIPELINE_RST="RST0",
                  p_GSR="DISABLED", p_RESETMODE="SYNC", p_CLK0_DIV="ENABLED", p_CLK1_DIV="ENABLED",
                  p_CLK2_DIV="ENABLED", p_CLK3_DIV="ENABLED", p_SOURCEB_MODE="B_SHIFT")
    m.submodules[f"{name}_mult"] = Instance("MULT18X18D", **params, **ports)
    full = Signal(Shape(max(p.shape.width, p.hi), p.shape.signed), name=f"{name}_full")   # extended to bit hi
    m.d.comb += full.eq(out.as_signed() if p.shape.signed else out)
    return full[p.lo:p.hi]


#: Behavioural Verilog of ``MULT18X18D`` in the one configuration :func:`block` instantiates (operand registers
#: on ``CLK0`` or none, the output register on ``CLK0``, ``CE0``, synchronous ``RST0``, no pipeline register, no
#: shift or cascade inputs), for simulating ECP5 builds: any other configuration stops the simulation.
MODEL = r"""
module MULT18X18D #(
  parameter REG_INPUTA_CLK = "NONE", parameter REG_INPUTA_CE = "CE0", parameter REG_INPUTA_RST = "RST0",
  parameter REG_INPUTB_CLK = "NONE", parameter REG_INPUTB_CE = "CE0", parameter REG_INPUTB_RST = "RST0",
  parameter REG_INPUTC_CLK = "NONE", parameter REG_INPUTC_CE = "CE0", parameter REG_INPUTC_RST = "RST0",
  parameter REG_PIPELINE_CLK = "NONE", parameter REG_PIPELINE_CE = "CE0", parameter REG_PIPELINE_RST = "RST0",
  parameter REG_OUTPUT_CLK = "NONE", parameter REG_OUTPUT_CE = "CE0", parameter REG_OUTPUT_RST = "RST0",
  parameter CLK0_DIV = "ENABLED", parameter CLK1_DIV = "ENABLED", parameter CLK2_DIV = "ENABLED",
  parameter CLK3_DIV = "ENABLED", parameter HIGHSPEED_CLK = "NONE", parameter GSR = "ENABLED",
  parameter CAS_MATCH_REG = "FALSE", parameter SOURCEB_MODE = "B_SHIFT", parameter MULT_BYPASS = "DISABLED",
  parameter RESETMODE = "SYNC"
) (
  input A0, A1, A2, A3, A4, A5, A6, A7, A8, A9, A10, A11, A12, A13, A14, A15, A16, A17,
  input B0, B1, B2, B3, B4, B5, B6, B7, B8, B9, B10, B11, B12, B13, B14, B15, B16, B17,
  input SIGNEDA, SIGNEDB, SOURCEA, SOURCEB, CLK0, CE0, RST0,
  output P0, P1, P2, P3, P4, P5, P6, P7, P8, P9, P10, P11, P12, P13, P14, P15, P16, P17,
  output P18, P19, P20, P21, P22, P23, P24, P25, P26, P27, P28, P29, P30, P31, P32, P33, P34, P35
);
  wire [17:0] a = {A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0};
  wire [17:0] b = {B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0};
  reg [17:0] ar = 0, br = 0;
  reg [35:0] p = 0;
  wire [17:0] ai = (REG_INPUTA_CLK == "CLK0") ? ar : a;
  wire [17:0] bi = (REG_INPUTB_CLK == "CLK0") ? br : b;
  wire signed [36:0] ax = SIGNEDA ? {{19{ai[17]}}, ai} : {19'b0, ai};
  wire signed [36:0] bx = SIGNEDB ? {{19{bi[17]}}, bi} : {19'b0, bi};
  wire signed [73:0] prod = ax * bx;
  initial begin
    if (!((REG_INPUTA_CLK == "NONE" || REG_INPUTA_CLK == "CLK0") && (REG_INPUTB_CLK == "NONE" ||
          REG_INPUTB_CLK == "CLK0") && REG_OUTPUT_CLK == "CLK0" && REG_PIPELINE_CLK == "NONE" &&
          REG_INPUTA_CE == "CE0" && REG_INPUTB_CE == "CE0" && REG_OUTPUT_CE == "CE0" &&
          REG_INPUTA_RST == "RST0" && REG_INPUTB_RST == "RST0" && REG_OUTPUT_RST == "RST0" &&
          RESETMODE == "SYNC" && GSR == "DISABLED")) begin
      $display("MULT18X18D model: configuration not modelled");
      $finish;
    end
  end
  always @(posedge CLK0) begin
    if (RST0) begin
      ar <= 0; br <= 0; p <= 0;
    end else if (CE0) begin
      ar <= a; br <= b; p <= prod[35:0];
    end
  end
  assign {P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18,
          P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0} = p;
endmodule
"""
