"""The one hardware cost model: ECP5 multiplier blocks, table / memory bits and block RAMs of a parameter object.

Every unit's parameter object declares what its RTL builds (:meth:`fxmodel.core.unit.Unit.products`,
:meth:`~fxmodel.core.unit.Unit.memories`): each product's operand widths and signedness, and whether the RTL cuts it
into registered 18 x 18 partial products (:func:`pieces`, which ``rtl.recip.pieces`` also uses, so the
splitting and its cost cannot drift apart); each memory's words, bits and read ports. :func:`estimate` turns
that into the resources ``synth_ecp5`` (Yosys) maps it to on an ECP5 (the paper's section 4 counts multipliers
and table sizes; this is the same count for one FPGA family):

* ``MULT18X18D`` blocks (:func:`mult_blocks`). Amaranth widens the operands of a product to the full result
  width; Yosys' ``wreduce`` turns a product of a signed and an unsigned operand into a signed one, so the
  unsigned operand grows by one bit; ``mul2dsp`` then cuts each operand into 18-bit slices (the top slice
  keeps the rest) and gives each pair of slices one block, except a one-bit slice, which becomes logic. A
  product with an operand of at most :data:`LOGIC_PRODUCT_BITS` bits is logic too: the RTL writes it so.
* ``DP16KD`` block RAMs (:func:`bram_blocks`): for each memory the cheapest block shape for its depth and word
  width, one copy per two read ports (a DP16KD has two), or none when Yosys keeps the memory in logic: a ROM
  of at most :data:`LOGIC_ROM_BITS_PER_BLOCK` bits per block it would need, as Yosys' ``memory_libmap`` weighs
  a block (cost 128) against logic (1/16 per ROM bit).
* table bits (the reciprocal tables) and memory bits (texel memories), as declared.

``tests/fxmodel/core/test_cost.py`` checks the declared products and memories against what the RTL instantiates, and the
estimate against the counts ``bumpmap fpga --synth-only --record`` measured (``docs/fpga/resources.json``).

This module is in the core layer: it imports only from :mod:`fxmodel.core.fixed`, ``rounding`` and ``unit``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

__all__ = ["DSP_BITS", "LOGIC_PRODUCT_BITS", "DP16KD_SHAPES", "REGISTERED_PORTS", "LOGIC_ROM_BITS_PER_BLOCK",
           "MEMORY_KINDS", "Product", "Memory", "pieces", "piece_pairs", "mult_blocks", "registered_shape",
           "blocks_in_bram", "in_logic", "bram_blocks", "estimate"]

#: Widest operand of one ECP5 multiplier block (MULT18X18D, signed or unsigned operands).
DSP_BITS = 18

#: A product with an operand of at most this many bits takes no multiplier block: the RTL writes it as one adder
#: of the other operand's copies (``rtl.dsp.logic_product``; the narrow top piece of a cut operand, :func:`pieces`).
LOGIC_PRODUCT_BITS = 2

#: What a :class:`Memory` holds.
MEMORY_KINDS = ("table", "texels", "frame")

#: ECP5 DP16KD block RAM shapes (words x bits) of one read port.
DP16KD_SHAPES = ((16384, 1), (8192, 2), (4096, 4), (2048, 9), (1024, 18), (512, 36))

#: The DP16KD ports of a memory read through its blocks' own output registers (``rtl/bram.py``), ``(words,
#: bits)``: a memory is columns of one port's bits, and when deeper than the port, groups of such columns, each
#: group the port's words (:func:`registered_shape`). The 36-bit port needs the pseudo-dual-port block, and the
#: narrower ones a layout of the blocks' initial contents not checked against Yosys' (``tests/rtl/test_bram.py``).
REGISTERED_PORTS = ((1024, 18), (2048, 9))

#: A ROM stays in logic (LUTs) when it has at most this many bits per block RAM it would take: Yosys'
#: ``memory_libmap`` costs a DP16KD 128 and a ROM bit in logic 1/16.
LOGIC_ROM_BITS_PER_BLOCK = 128 * 16


def _positive(value, what: str):
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise ValueError(f"{what}={value!r}: must be a positive int")


@dataclass(frozen=True)
class Product:
    """One kind of product the RTL computes.

    Parameters
    ----------
    a_bits, b_bits : int
        Operand widths, as the RTL's signals have them.
    a_signed, b_signed : bool
        Operand signedness.
    count : int
        How many such products.
    split : bool
        The RTL cuts the operands into :func:`pieces` and registers each partial product (one block each),
        summing them in the next stage (``rtl.recip.split_products``); else one product that Yosys maps
        (splitting it itself when an operand is wider than :data:`DSP_BITS`).
    square : bool
        Both operands are the same signal (``q * q``): see :func:`piece_pairs`.
    name : str
        What it computes (for reports).
    """

    a_bits: int
    b_bits: int
    a_signed: bool = True
    b_signed: bool = True
    count: int = 1
    split: bool = False
    square: bool = False
    name: str = ""

    def __post_init__(self):
        _positive(self.a_bits, "Product.a_bits")
        _positive(self.b_bits, "Product.b_bits")
        if self.square and (self.a_bits, self.a_signed) != (self.b_bits, self.b_signed):
            raise ValueError(f"Product {self.name!r}: a square needs equal operands, got "
                             f"{self.a_bits} and {self.b_bits} bits")
        if self.count < 0 or not isinstance(self.count, int):
            raise ValueError(f"Product.count={self.count!r}: must be an int >= 0")

    def times(self, k: int) -> Product:
        """The same product ``k`` times as often."""
        return Product(self.a_bits, self.b_bits, self.a_signed, self.b_signed, self.count * k, self.split,
                       self.square, self.name)


@dataclass(frozen=True)
class Memory:
    """One kind of memory the RTL instantiates.

    Parameters
    ----------
    words, bits : int
        Depth and word width.
    read_ports : int
        Read ports on the one memory (a block RAM has two; more means copies).
    rom : bool
        Initialised and never written (every memory of this project).
    count : int
        How many such memories.
    kind : str
        ``table`` (a unit's own table, such as the reciprocal's, counted in ``table_bits``), ``texels`` (a
        scene's map, counted in ``memory_bits``) or ``frame`` (an on-chip frame buffer, ``frame_bits``).
    name : str
        What it holds (for reports).
    registered : bool
        Read through its blocks' own output registers (``rtl/bram.py``): on an ECP5, the groups of columns of
        :func:`registered_shape`.
    """

    words: int
    bits: int
    read_ports: int = 1
    rom: bool = True
    count: int = 1
    kind: str = "table"
    name: str = ""
    registered: bool = False

    def __post_init__(self):
        _positive(self.words, "Memory.words")
        _positive(self.bits, "Memory.bits")
        _positive(self.read_ports, "Memory.read_ports")
        if self.count < 0 or not isinstance(self.count, int):
            raise ValueError(f"Memory.count={self.count!r}: must be an int >= 0")
        if self.kind not in MEMORY_KINDS:
            raise ValueError(f"Memory.kind={self.kind!r}: must be one of {MEMORY_KINDS}")

    def times(self, k: int) -> Memory:
        """The same memory ``k`` times as often."""
        return replace(self, count=self.count * k)


def pieces(width: int, signed: bool, limit: int = DSP_BITS) -> list[tuple[int, int, bool]]:
    """How the RTL cuts a ``width``-bit operand for registered partial products: ``[(low bit, bits, signed)]``.

    Unchanged (one piece) if ``width <= limit``; else ``limit - 1``-bit unsigned pieces from the bottom (an
    unsigned 17-bit piece is an 18-bit signed block operand) and a top piece of at most ``limit`` bits that keeps
    the sign. Every product of two pieces fits one ``limit x limit`` block. ``rtl.recip.pieces`` cuts signals
    by this list.
    """
    if width <= limit:
        return [(0, width, signed)]
    out, lo = [], 0
    while width - lo > limit:
        out.append((lo, limit - 1, False))
        lo += limit - 1
    out.append((lo, width - lo, signed))
    return out


def piece_pairs(p: Product) -> list[tuple[int, bool, int, bool]]:
    """The block-level products of one product ``p``: ``(a_bits, a_signed, b_bits, b_signed)`` of each pair of
    :func:`pieces` when ``p.split``, else ``p``'s own operands.

    A split square (``p.square``) computes the cross products ``x_i x_j`` and ``x_j x_i`` twice; Yosys merges the
    two (``opt_merge``) when one of the pieces is signed (a signed Verilog product, which its front end builds
    with both operands at the result width), not for two unsigned pieces (measured with ``synth_ecp5``).
    """
    if not p.split:
        return [(p.a_bits, p.a_signed, p.b_bits, p.b_signed)]
    cut_a, cut_b = pieces(p.a_bits, p.a_signed), pieces(p.b_bits, p.b_signed)
    out = []
    for i, (_, wa, sa) in enumerate(cut_a):
        for j, (_, wb, sb) in enumerate(cut_b):
            if p.square and j < i and (sa or sb):
                continue                                    # merged with (j, i)
            out.append((wa, sa, wb, sb))
    return out


def _slices(width: int) -> int:
    """Blocks along one operand of ``mul2dsp``'s cut: 18-bit slices, a one-bit top slice left to logic."""
    n = math.ceil(width / DSP_BITS)
    return n - 1 if n > 1 and width % DSP_BITS == 1 else n


def _yosys_blocks(a: int, a_signed: bool, b: int, b_signed: bool) -> int:
    """MULT18X18D blocks of one product as ``synth_ecp5`` maps it (module docstring), none for a product the RTL
    builds in logic (:data:`LOGIC_PRODUCT_BITS`)."""
    if min(a, b) <= LOGIC_PRODUCT_BITS:
        return 0
    if a_signed != b_signed:                         # wreduce: mixed signedness becomes signed x signed
        a, b = (a + (not a_signed), b + (not b_signed))
    return _slices(a) * _slices(b)


def mult_blocks(products) -> int:
    """Estimated ECP5 MULT18X18D blocks of ``products`` (an iterable of :class:`Product`)."""
    return sum(p.count * sum(_yosys_blocks(*pair) for pair in piece_pairs(p)) for p in products)


def registered_shape(words: int, bits: int) -> tuple[int, int, int, int]:
    """How ``rtl/bram.py`` builds a memory of ``words`` words of ``bits`` bits read through its blocks' output
    registers: ``(port words, port bits, groups, columns)``, the :data:`REGISTERED_PORTS` port with the fewest
    blocks (``groups`` of ``columns = ceil(bits / port bits)`` blocks, each group ``port words`` of the words), on a
    tie the fewer groups (a smaller multiplexer after the blocks)."""
    def shape(port):
        depth, width = port
        return depth, width, math.ceil(words / depth), math.ceil(bits / width)
    return min((shape(port) for port in REGISTERED_PORTS), key=lambda s: (s[2] * s[3], s[2]))


def blocks_in_bram(mem: Memory) -> int:
    """DP16KD blocks of one memory (``count`` 1) put in block RAM: the cheapest shape, or for a
    :attr:`~Memory.registered` one its :func:`registered_shape`'s groups of columns; one copy per two read
    ports."""
    if mem.registered:
        _, _, groups, columns = registered_shape(mem.words, mem.bits)
        return groups * columns * math.ceil(mem.read_ports / 2)
    return min(math.ceil(mem.words / d) * math.ceil(mem.bits / w) for d, w in DP16KD_SHAPES) \
        * math.ceil(mem.read_ports / 2)


def in_logic(mem: Memory) -> bool:
    """Whether Yosys keeps ``mem`` in logic instead of block RAM (:data:`LOGIC_ROM_BITS_PER_BLOCK`, weighed
    against the cheapest shape Yosys would map it to, for a :attr:`~Memory.registered` memory too: the RTL
    builds the blocks only where Yosys would use block RAM, ``rtl/bram.py``)."""
    return mem.rom and mem.words * mem.bits * math.ceil(mem.read_ports / 2) <= \
        LOGIC_ROM_BITS_PER_BLOCK * blocks_in_bram(replace(mem, registered=False))


def bram_blocks(memories) -> int:
    """Estimated ECP5 DP16KD blocks of ``memories`` (an iterable of :class:`Memory`)."""
    return sum(m.count * (0 if in_logic(m) else blocks_in_bram(m)) for m in memories)


def estimate(params) -> dict:
    """The cost of a parameter object (anything with ``products()`` and ``memories()``).

    Returns
    -------
    dict
        ``dsp`` (MULT18X18D blocks), ``bram`` (DP16KD blocks), ``multipliers`` (products, each counted once
        however it is split), ``multiplier_bit_products`` (sum of operand-width products), ``table_bits``
        (bits of the ``table`` memories: the reciprocal tables), ``memory_bits`` (the texel
        memories' bits, each stored once), ``frame_bits`` (on-chip frame buffers), ``logic_rom_bits`` (memory
        bits Yosys keeps in logic).
    """
    products = tuple(params.products())
    memories = tuple(params.memories())
    tables = [m for m in memories if m.kind == "table"]
    texels = [m for m in memories if m.kind == "texels"]
    return {
        "dsp": mult_blocks(products),
        "bram": bram_blocks(memories),
        "multipliers": sum(p.count for p in products),
        "multiplier_bit_products": sum(p.count * p.a_bits * p.b_bits for p in products),
        "table_bits": sum(m.count * m.words * m.bits for m in tables),
        "memory_bits": sum(m.count * m.words * m.bits for m in texels),
        "frame_bits": sum(m.count * m.words * m.bits for m in memories if m.kind == "frame"),
        "logic_rom_bits": sum(m.count * m.words * m.bits for m in memories if in_logic(m)),
    }
