r"""Triangle set-up, scan conversion and attribute interpolation in fixed point (paper, section 4 and Fig. 5).

"Given the triangle's start coordinate with its start attributes and slope increments, the Scan Line Initializer
computes the relevant data at the start point of every new scanline, while the Pixel Calculator interpolates the
coordinates and attributes within a scanline" (section 4). The host does the set-up once per triangle, in exact
arithmetic on its float64 vertex data, and quantizes it once into a **triangle record** (:attr:`RasterParams.record`);
the hardware (``rtl/raster.py``) turns records into fragments with adders, comparators and one small multiplier per
attribute (cut into registered partial products), one fragment per clock. This module is the bit-exact model of
that hardware, clock count included.

Coverage (the edge traverser)
-----------------------------
Vertices are snapped to ``S = 2**subpixel_bits`` steps per pixel (:func:`edge_setup` gives the integer edge
functions and the top-left bias, exactly as the float front end uses them). Pixel ``(x, y)`` (centre
``(x + 1/2, y + 1/2)``) is covered when ``a_e x + b_e y + c_e >= 0`` for the three edges, with ``a_e = S A_e``,
``b_e = S B_e`` and ``c_e = C_e + S (A_e + B_e) / 2 - bias_e`` (integers): the top-left rule of the front end, so
coverage is bit-identical to :func:`host.frontend.scan_triangle` and a mesh without T-junctions has each pixel
visited exactly once. For row ``y`` an edge with ``a_e > 0`` (a *left* edge) admits ``x >= -p_e(y)``, one with
``a_e < 0`` (a *right* edge) ``x <= p_e(y)``, where ``p_e(y) = floor((b_e y + c_e) / |a_e|)``; a horizontal edge
(``a_e = 0``) only removes whole rows and is folded into the row range by the set-up. The span of row ``y`` is
``[L, R] = [max(x0, -p_left...), min(x1, p_right...)]`` clamped to the triangle's bounding box within the viewport
``[x0, x1]``. The hardware steps ``p_e`` from row to row without dividing (Bresenham): with ``q_e = floor(b_e /
|a_e|)``, ``m_e = b_e - q_e |a_e|`` and the remainder ``r_e`` in ``[0, |a_e|)``: ``r_e += m_e; p_e += q_e``, and
if ``r_e >= |a_e|``: ``r_e -= |a_e|; p_e += 1``. The model uses the closed form ``p_e(y0 + i) = p_e(y0) + i q_e +
floor((r_e(y0) + i m_e) / |a_e|)``, the same integers.

**Traversal**: rows ``y0 .. y0 + rows`` in order, each span left to right; a row costs ``max(1, span length)``
clocks of the Pixel Calculator (an empty row one clock), so a triangle costs exactly ``sum over its rows of
max(1, n_row)`` clocks (:func:`scan` counts them; the RTL's ``busy`` clocks are checked against the count). In
the RTL only the row step feeds back: a row generator issues one row per clock into a pipeline that forms the
span and the span starts (one carry chain or one product a stage) and a row FIFO in front of the Pixel
Calculator; the generator takes the next triangle in the clock it issues the previous one's last row and runs up
to :attr:`RasterParams.ROW_FIFO_DEPTH` rows ahead, so when the source never waits the rows follow one another
with no clock between them, within and across triangles, and the only cost beyond the count is the fill latency
(:attr:`RasterParams.latency`) once at the start. Triangles whose row or column range within the viewport is
empty are dropped by the set-up (they cover no pixel) and cost nothing.

Attributes (the interpolators)
------------------------------
Every attribute ``a`` is a plane in screen space, ``a(x, y) = a(x0, y0) + (x - x0) a_x + (y - y0) a_y``, exact
for the attributes chosen (below). The set-up computes the three coefficients exactly (rationals from the float64
vertex values and the integer edge functions) and rounds each once, half-up, to ``f = out.frac_bits + g``
fraction bits (``g``: :attr:`RasterParams.guard_bits`). The Scan Line Initializer keeps ``a`` at ``(x0, y)`` (one
addition of ``a_y`` per row) and gives the span start ``a(x0, y) + (L - x0) a_x``; the Pixel Calculator adds
``a_x`` per pixel. All of it is two's-complement arithmetic modulo ``2**N`` (``N``: the accumulator width): values
outside the triangle (the bounding-box corner of a sliver may extrapolate the plane far out of range) may wrap, but
modular sums are exact, and at a covered pixel the true value lies in the output range (proof below), so the
wrapped word is the true word. This is the one deliberate wrap of the project, proven rather than silent.

**Error bound (the proof)**. The quantized plane at a covered pixel differs from the exact plane by
``e_0 + n_x e_x + n_y e_y`` where ``e_0, e_x, e_y <= 2**-(f+1)`` are the rounding errors of the start value and of
the two increments and ``n_x = x - x0``, ``n_y = y - y0`` count the additions of each increment (with exact
integer accumulation, the incremental result *is* the quantized plane). The viewport is at most ``max_size``
pixels wide and high, so ``n_x, n_y <= max_size - 1`` and the accumulated error is at most ``(2 max_size - 1)
2**-(f+1)``. ``g = ceil(log2(2 max_size - 1)) + extra_guard`` makes this at most ``2**-(out.frac_bits + 1 +
extra_guard)``: a quarter of an output ulp for ``extra_guard = 1``; the final half-up rounding to the output format
adds at most half an ulp. Bound: ``(1/2 + 2**-(1 + extra_guard))`` output ulps from the exact plane
(:meth:`RasterParams.error_bound`). Range: a covered pixel centre has barycentrics in ``[0, 1]``, so the exact
value is a convex combination of the vertex values; the set-up refuses a vertex value outside the output format
(naming the triangle and the attribute), so with one more integer bit in the accumulator the quantized value
cannot wrap; the output rounding saturates (and flags) the at most ``3/4`` ulp by which it may pass the format's end.

The attributes (:data:`ATTRIBUTES`; formats are the pixel pipeline's input formats)
------------------------------------------------------------------------------------
``U, V, W`` and ``Uc, Vc``: the front end's homogeneous texture coordinates ``k u_b / w_c``, ``k v_b / w_c``,
``k / w_c`` (screen-linear, exact), with a per-triangle integer **tile offset**: the set-up subtracts
``floor`` of the mean vertex ``s`` (and ``t``, and the color texture's) from the vertex coordinates, which the
textures' repeat makes free, so ``|s|`` stays small wherever the triangle lies in texture space. ``Z = near / w_c``
in ``(0, 1]``, the depth the front end's z-buffer compares (``1/w`` is screen-linear; ``z/w`` would need the far
plane). ``N W`` and ``A W`` (the vertex normal and the triangle's bump matrix times ``W``) and ``E_h = c (eye -
P) / w_c``: the pipeline needs only the *directions* of ``N' = N + du A_0 + dv A_1`` and of the eye vector, so a
common positive factor per pixel is free, and with it these three are exactly screen-linear, i.e. the
perspective-correct directions with no divider. The factor must be common: scaling ``N`` alone by ``W`` would tilt
``N'`` (``du A_0`` keeps its size), so ``A`` is interpolated as ``A W`` beside it (six adder-only interpolators
instead of a per-pixel divide). ``E_h`` scales ``R = 2 N'(N'.E) - E (N'.N')`` by ``|E_h|``, harmless for the cube
lookup; ``c`` per triangle makes the largest vertex ``|E_h|`` equal to 1 (its smallest is ``cos`` of the view
angle). The price: ``N W`` and ``A W`` lose ``log2(1/W)`` bits of relative precision where ``W`` is small.

Depth: which quantity, and its precision
----------------------------------------
**Why ``Z = near / w_c``.** The depth test needs a quantity that orders the surfaces at a pixel and that the
interpolators produce exactly, i.e. one linear in screen space. ``1 / w_c`` is (the same reason ``W`` is), and it
is monotonic in the view distance (larger = nearer). OpenGL's ``z_c / w_c`` is screen-linear too, but it is the
affine map ``a + b / w_c`` with ``a`` and ``b`` set by the near **and** far planes: it orders exactly like ``1 /
w_c`` and only adds a dependence on ``far`` (and, in fixed point, spends its codes on the near range in the same
way). The scale ``near`` maps the visible range ``near <= w_c`` to ``Z`` in ``(0, 1]``, a fixed format for every
scene; ``Z`` needs no far plane and the far clip keeps ``Z >= near / far > 0``. The front end's float z-buffer
compares the same quantity (``1 / w_c``; ties: first drawn wins), so model and reference differ only by rounding.

**Precision (the proof above, applied to ``Z``).** At a covered pixel ``|code ulp - Z| <= b`` with ``b =``
:meth:`RasterParams.error_bound` ``("Z")`` (``(1/2 + (2 max_size - 1) 2**-(g + 1))`` ulp of ``Z``'s format: 0.74994
ulp for the default preset, whose ``Z`` (:meth:`RasterParams.for_pipeline`'s ``z_fmt``) has 22 fraction bits). For
two surfaces with exact depths ``Z_1 >
Z_2`` at one pixel:

* ``Z_1 - Z_2 > 2 b`` (:meth:`RasterParams.depth_precision`): ``code_1 ulp >= Z_1 - b > Z_2 + b >= code_2 ulp``,
  so ``code_1 > code_2`` and the depth test keeps the nearer surface whatever the drawing order. This is the
  **documented depth precision**: about 1.5 ulp of ``Z``, ``3.58e-7`` for the default preset;
* ``2 b - ulp < Z_1 - Z_2 <= 2 b`` (between 0.5 and 1.5 ulp): the codes may be equal, and then the fragment drawn
  first wins (a reversal needs ``code_2 >= code_1 + 1``, i.e. a gap of at most ``2 b - ulp``);
* ``Z_1 - Z_2 <= 2 b - ulp`` (below 0.5 ulp): the codes may order the two surfaces the other way.

In view distance: ``Z_1 - Z_2 = near (w_2 - w_1) / (w_1 w_2)``, so two surfaces at distance ``w`` are ordered
right when they are more than ``Δw = 2 b w**2 / near`` apart, a relative gap ``Δw / w = 2 b w / near``
(:meth:`RasterParams.depth_gap`): for ``near = 0.1`` and the default ``Z``, ``1.1e-5`` at ``w = 3`` (33 µ of a
unit), ``1.8e-4`` at ``w = 50``. The float reference compares float64 ``1 / w_c`` (relative rounding about
``1e-16``), so where the float z-buffer and the fixed-point depth test keep different surfaces at a pixel, the
two surfaces' float depths differ by at most ``2 b`` plus that rounding (:data:`FLOAT_DEPTH_SLACK`).

Per-triangle constants (:attr:`RasterParams.consts`)
-----------------------------------------------------
A value that is the same on every pixel of a triangle is not interpolated: the record carries it once and every
fragment of the triangle carries it unchanged. The engine has one, ``Ae``: the block exponent ``e`` of the bump
matrix (:func:`host.bumpmap.block_exponent`, the same per scene triangle as on the fragment path), so the
set-up sends ``A W 2**-e`` and the bump engine scales ``N W`` by ``2**-e`` (``fxmodel/units/bump.py``): a steep bump map
(``A`` beyond ``bump.a_fmt``) draws from triangles as it does from fragments.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction
from typing import ClassVar

import numpy as np

from fxmodel.core.cost import DSP_BITS, Product, estimate
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, require
from fxmodel.units.shapes import repr_without_defaults

from .raster_setup import (
    EDGE_LEFT,
    EDGE_OFF,
    EDGE_RIGHT,
    Records,
    area2,
    edge_setup,
    setup,
)

__all__ = ["RasterParams", "ATTRIBUTES", "ATTRIBUTE_FORMATS", "attribute_format", "FLOAT_DEPTH_SLACK", "edge_setup",
           "area2", "Records", "setup", "scan", "ScanResult", "EDGE_OFF", "EDGE_LEFT", "EDGE_RIGHT"]

#: Attribute names in record / fragment order.
ATTRIBUTES = ("U", "V", "Uc", "Vc", "W", "Z", "Nx", "Ny", "Nz", "Ex", "Ey", "Ez",
              "A00", "A01", "A10", "A11", "A20", "A21")

#: Where each interpolated attribute's format lives among a pipeline's units: ``unit.field`` (a field path of the
#: parameter objects, and of a pipeline preset file), read by :meth:`RasterParams.for_pipeline` and
#: :func:`attribute_format`. ``Z`` has none: its format is ``for_pipeline``'s ``z_fmt``.
ATTRIBUTE_FORMATS = {**{n: "persp.uv_fmt" for n in ("U", "V", "Uc", "Vc")}, "W": "persp.recip.in_fmt",
                     **{f"N{c}": "bump.n_fmt" for c in "xyz"}, **{f"E{c}": "reflect.e_fmt" for c in "xyz"},
                     **{f"A{i}{j}": "bump.a_fmt" for i in range(3) for j in range(2)}}


def attribute_format(pipeline_units: dict, name: str) -> Fmt:
    """The format of attribute ``name`` in a pipeline's units (``{"persp": ..., "bump": ..., "reflect": ...}``),
    by its path in :data:`ATTRIBUTE_FORMATS`."""
    unit, *fields = ATTRIBUTE_FORMATS[name].split(".")
    obj = pipeline_units[unit]
    for f in fields:
        obj = getattr(obj, f)
    return obj


#: The depth ``Z``'s default format (:meth:`RasterParams.for_pipeline`).
Z_FMT = Fmt(True, 2, 22)

#: Slack for the float reference's own rounding when comparing float depths with :meth:`RasterParams.depth_precision`
#: (relative, of ``Z``): the front end's float64 ``1 / w_c`` at a pixel is three products and a division away from
#: exact, a few units of ``2**-53``; this allows for 64 of them.
FLOAT_DEPTH_SLACK = 64 * 2.0 ** -53

@dataclass(frozen=True)
class RasterParams:
    """Parameters of the triangle set-up, scan converter and attribute interpolators.

    Parameters
    ----------
    attrs : tuple of (str, Fmt)
        The interpolated attributes and their **output** formats (the pixel pipeline's input formats), in
        :data:`ATTRIBUTES` order by default.
    max_size : int
        Largest viewport width and height: the longest span and the tallest triangle, the ``n`` of the error
        proof. At least 2048 for the default preset.
    subpixel_bits : int
        Fraction bits of snapped vertex coordinates (the front end's ``SUBPIXEL_BITS``).
    guard_pixels : int
        The front end's clipping guard band: vertices lie within ``guard_pixels`` outside the viewport.
    extra_guard : int
        Guard bits beyond the proof's minimum ``ceil(log2(2 max_size - 1))`` (each halves the accumulated error).
    consts : tuple of (str, Fmt)
        Per-triangle constants (integer formats): carried by the record and passed to every fragment of the
        triangle unchanged (the bump engine's block exponent ``Ae``).
    slopes : tuple of (str, str, str, Fmt)
        Per-triangle increments carried with every fragment like ``consts`` (the level of detail of MIP mapping
        needs them, ``fxmodel/units/lod.py``): ``(field, attribute, axis, fmt)``, the step of the exact plane of
        ``attribute`` per pixel along ``axis`` (``"x"`` or ``"y"``), rounded half-up once by the set-up to the
        signed ``fmt``; a triangle whose step lies outside ``fmt`` is refused, as a vertex value outside its format.
    """

    NAME: ClassVar[str] = "raster"
    PRESETS: ClassVar[dict]
    #: Rows the RTL's row FIFO holds between the span pipeline and the Pixel Calculator (LUT RAM): the row
    #: generator runs up to this many rows ahead, enough to cover the round trip of a row through the span
    #: pipeline, so one-clock rows follow one another without a gap.
    ROW_FIFO_DEPTH: ClassVar[int] = 16
    #: Stages of the RTL's span pipeline from the row generator's state to the row FIFO (``rtl/raster.py``):
    #: the edges' bounds, the span, its column and length (the offset fanned out to the products' copies), the
    #: offset products, two adder levels of the span start.
    SPAN_STAGES: ClassVar[int] = 6
    #: Registers (one beside each of the Pixel Calculator's control copies) through which a row written into the
    #: RTL's row FIFO reaches the copies' counts of rows (``rtl/raster.py``, "Fan-out"): from the span
    #: pipeline's last valid bit through every copy's count logic, that net held the scan converter alone with
    #: its span start in logic below 100 MHz (``bumpmap fpga --unit raster``) and was among the board's slowest.
    #: Each adds a clock of fill latency (:attr:`latency`), none between rows.
    ROW_SEEN_STAGES: ClassVar[int] = 1
    #: Registers between the consumer's read of the RTL's output FIFO and the Pixel Calculator's control copies,
    #: which count the FIFO's places (``rtl/raster.py``, "Output"): one beside the FIFO, one copy beside each
    #: control copy. Straight from the consumer's ``ready`` into every copy's count, that net was the board's
    #: slowest at 100 MHz once the record's valid no longer was.
    POP_STAGES: ClassVar[int] = 2
    #: Fragments the RTL's output FIFO holds (LUT RAM): with two in flight behind it and a read taking
    #: :attr:`POP_STAGES` clocks to free its place, one per clock flows while the consumer is ready.
    OUT_FIFO_DEPTH: ClassVar[int] = 4 + POP_STAGES
    #: Register bits one copy of a control state drives in the RTL (``rtl/raster.py``, "Fan-out"): the row
    #: generator's load/step enable and the Pixel Calculator's enables reach some 2 000 and 1 300 register
    #: bits; one net to all of them was the engine's critical path (7 ns of routing in its last net alone), so
    #: the control state is kept in as many identical copies as groups of this many bits need (groups of 384
    #: bits still left the enables among the board's slowest paths, ``bumpmap bitstream --misses``).
    ENABLE_FANOUT: ClassVar[int] = 128

    attrs: tuple = ()
    max_size: int = 2048
    subpixel_bits: int = 8
    guard_pixels: int = 4096
    extra_guard: int = 1
    consts: tuple = ()
    slopes: tuple = ()
    span_dsp: bool = True

    def __repr__(self):
        """The dataclass ``repr`` without ``slopes`` when there are none and without ``span_dsp`` at its default
        (as before they existed: build caches and recorded resource counts are keyed by it)."""
        return repr_without_defaults(self, ("slopes", "span_dsp"))

    def __post_init__(self):
        require(isinstance(self.attrs, tuple) and len(self.attrs) > 0, "attrs", self.attrs,
                "must be a non-empty tuple of (name, Fmt) pairs")
        names = []
        for item in self.attrs:
            require(isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)
                    and isinstance(item[1], Fmt) and item[1].signed, "attrs", item,
                    "each entry must be (name, signed Fmt)")
            names.append(item[0])
        require(isinstance(self.consts, tuple), "consts", self.consts, "must be a tuple of (name, Fmt) pairs")
        for item in self.consts:
            require(isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)
                    and isinstance(item[1], Fmt) and item[1].frac_bits == 0 and item[1].width <= 32, "consts",
                    item, "each entry must be (name, integer Fmt of at most 32 bits)")
            names.append(item[0])
        attrs = [n for n, _ in self.attrs]
        require(isinstance(self.slopes, tuple), "slopes", self.slopes, "must be a tuple of (field, attribute, axis, "
                "Fmt) entries")
        for item in self.slopes:
            require(isinstance(item, tuple) and len(item) == 4 and isinstance(item[0], str) and item[1] in attrs
                    and item[2] in ("x", "y") and isinstance(item[3], Fmt) and item[3].signed
                    and item[3].width <= 48, "slopes", item,
                    "each entry must be (field, an attribute's name, 'x' or 'y', signed Fmt of at most 48 bits)")
            names.append(item[0])
        require(len(set(names)) == len(names), "attrs", names, "names (attrs, consts, slopes) must be unique")
        require(isinstance(self.span_dsp, bool), "span_dsp", self.span_dsp, "must be a bool")
        for name in ("max_size", "subpixel_bits", "guard_pixels", "extra_guard"):
            value = getattr(self, name)
            require(isinstance(value, int) and not isinstance(value, bool), name, value, "must be an int")
        require(2 <= self.max_size <= 1 << 14, "max_size", self.max_size, "must be in 2..16384")
        require(1 <= self.subpixel_bits <= 10, "subpixel_bits", self.subpixel_bits, "must be in 1..10")
        require(0 <= self.guard_pixels <= 1 << 14, "guard_pixels", self.guard_pixels, "must be in 0..16384")
        require(0 <= self.extra_guard <= 8, "extra_guard", self.extra_guard, "must be in 0..8")
        for name, fmt in self.attrs:
            # the model's plane evaluation start + dx * nx + dy * ny stays below 2**62 in int64
            require(self.acc_fmt(name).width + self.offset_fmt.width + 1 <= 62, "attrs", (name, str(fmt)),
                    f"accumulator of {self.acc_fmt(name).width} bits is too wide for the int64 model")

    # -- derived formats -----------------------------------------------------------------------------------
    @property
    def S(self) -> int:
        """Sub-pixel steps per pixel."""
        return 1 << self.subpixel_bits

    @property
    def names(self) -> tuple:
        return tuple(n for n, _ in self.attrs)

    def out_fmt(self, name: str) -> Fmt:
        return dict(self.attrs)[name]

    @property
    def guard_bits(self) -> int:
        """``g = ceil(log2(2 max_size - 1)) + extra_guard`` (the proof in the module docstring)."""
        return (2 * self.max_size - 2).bit_length() + self.extra_guard

    def acc_fmt(self, name: str) -> Fmt:
        """Start value, increments and accumulators of attribute ``name``: one more integer bit than the output
        (headroom for the error bound) and ``guard_bits`` more fraction bits; arithmetic is modulo ``2**width``."""
        out = self.out_fmt(name)
        return Fmt(True, out.int_bits + 1, out.frac_bits + self.guard_bits)

    @property
    def pixel_fmt(self) -> Fmt:
        """Pixel coordinates ``x``, ``y`` in ``0 .. max_size - 1``."""
        return Fmt.integer(0, self.max_size - 1)

    @property
    def offset_fmt(self) -> Fmt:
        """``x - x0`` and the row count."""
        return self.pixel_fmt

    @property
    def coord_max(self) -> int:
        """Largest magnitude of a snapped vertex coordinate (sub-pixel steps): the guard band around the largest
        viewport, plus the snapping's half step."""
        return (self.max_size + self.guard_pixels + 1) * self.S

    @property
    def edge_bounds(self) -> dict:
        """Exact bounds on the magnitudes of the edge quantities (from :attr:`coord_max`)."""
        S, cmax = self.S, self.coord_max
        dmax = 2 * cmax                                   # |A_e|, |B_e| (coordinate differences)
        c = 2 * dmax * cmax + dmax * S + 1                # |c_e| = |C_e + S (A_e + B_e) / 2 - bias|
        row = dmax * S * self.max_size + c                # |b_e y + c_e| over the viewport's rows
        return {"d": dmax * S, "q": dmax + 1, "p": row // S + 1, "m": dmax * S}

    @property
    def edge_fmts(self) -> dict:
        """Record formats of one edge's fields: ``kind`` (0 off, 1 left, 2 right), ``p`` (bound at the row),
        ``r`` (remainder), ``q``, ``m`` (the row step ``b = q |a| + m``), ``d = |a|``."""
        b = self.edge_bounds
        return {"kind": Fmt(False, 2, 0), "p": Fmt.integer(-b["p"], b["p"]), "r": Fmt.integer(0, b["d"]),
                "q": Fmt.integer(-b["q"], b["q"]), "m": Fmt.integer(0, b["m"]),
                "d": Fmt.integer(0, b["d"])}

    @property
    def record(self) -> tuple:
        """The triangle record (the RTL's input payload), one :class:`~fxmodel.core.unit.Port` per field."""
        pf = self.pixel_fmt
        ports = [Port("y0", pf, "first row"), Port("rows", pf, "rows - 1"), Port("x0", pf, "first column of the "
                 "bounding box in the viewport (attribute origin)"), Port("x1", pf, "last column")]
        for e in range(3):
            ports += [Port(f"e{e}_{k}", f, f"edge {e}: {k}") for k, f in self.edge_fmts.items()]
        ports += [Port(name, f, "per-triangle constant") for name, f in self.consts]
        ports += [Port(name, f, f"d{a}/d{ax}, per-triangle") for name, a, ax, f in self.slopes]
        for name, _ in self.attrs:
            f = self.acc_fmt(name)
            ports += [Port(f"{name}_0", f, f"{name} at (x0, y0)"), Port(f"{name}_dx", f, f"d{name}/dx"),
                      Port(f"{name}_dy", f, f"d{name}/dy")]
        return tuple(ports)

    @property
    def fragment(self) -> tuple:
        """The fragment (the RTL's output payload): ``x``, ``y``, the attributes, the triangle's constants,
        ``flags`` (bit 0: an attribute saturated at the output rounding)."""
        return ((Port("x", self.pixel_fmt), Port("y", self.pixel_fmt))
                + tuple(Port(n, f) for n, f in self.attrs + self.carried) + (Port("flags", Fmt(False, 1, 0)),))

    @property
    def carried(self) -> tuple:
        """``(name, Fmt)`` of the record's fields every fragment of the triangle carries unchanged: :attr:`consts`,
        then the :attr:`slopes`."""
        return self.consts + tuple((n, f) for n, _, _, f in self.slopes)

    # the design's stream payloads under the names every streaming harness reads (cosim/stream.py)
    @property
    def inputs(self) -> tuple:
        """:attr:`record`."""
        return self.record

    @property
    def outputs(self) -> tuple:
        """:attr:`fragment`."""
        return self.fragment

    @property
    def latency(self) -> int:
        """Clocks from an idle scan converter accepting a record to the record's first fragment on the output
        (the fill latency): the row generator's load, the span pipeline (:attr:`SPAN_STAGES`, its last stage
        writing the row FIFO), the write reaching the Pixel Calculator's copies (:attr:`ROW_SEEN_STAGES`), the
        FIFO's read, the Pixel Calculator, the rounding, the saturation (writing the output FIFO, whose head is
        the output). It does not add to :func:`scan`'s clocks: the rows that follow come one per
        ``max(1, span)`` clocks with no gap."""
        return 1 + self.SPAN_STAGES + self.ROW_SEEN_STAGES + 3

    # -- cost (fxmodel/core/cost.py, the one cost model) ---------------------------------------------------------
    def dx_pieces(self, name: str) -> list:
        """How the RTL cuts the increment ``a_x`` of attribute ``name`` for the span start's partial products:
        ``[(low bit, bits, signed)]``, unsigned :data:`~fxmodel.core.cost.DSP_BITS`-bit pieces from the bottom and a
        signed top piece with the rest. The other operand, the column offset, is unsigned, so an unsigned
        18-bit piece fills one multiplier block (``fxmodel.core.cost.pieces`` cuts 17-bit pieces for a signed
        partner); a top piece of at most :data:`~fxmodel.core.cost.LOGIC_PRODUCT_BITS` bits is one adder in logic
        (``rtl.dsp.logic_product``), no block."""
        width, out, lo = self.acc_fmt(name).width, [], 0
        while width - lo > DSP_BITS:
            out.append((lo, DSP_BITS, False))
            lo += DSP_BITS
        return out + [(lo, width - lo, True)]

    def products(self) -> tuple:
        """Per attribute, the span start ``a(x0, y) + (L - x0) a_x``: the increment (``acc_fmt``, signed) cut
        into :meth:`dx_pieces`, each piece times the unsigned column offset (``pixel_fmt``), registered and
        summed by the next two adder stages: one product per piece. None with ``span_dsp`` off: the RTL then
        adds the increment's copies shifted by each bit of the offset in logic (a carry-save tree, the same sum
        modulo ``2**N``)."""
        if not self.span_dsp:
            return ()
        pw = self.pixel_fmt.width
        return tuple(Product(bits, pw, signed, False, name=f"{n}_dx[{lo}:{lo + bits}]*offset")
                     for n in self.names for lo, bits, signed in self.dx_pieces(n))

    def memories(self) -> tuple:
        """None: the scan converter holds registers and its row FIFO (:attr:`ROW_FIFO_DEPTH` rows in LUT RAM,
        ``amaranth.lib.fifo``: plumbing like the stream interface's FIFO, no block RAM)."""
        return ()

    def cost(self) -> dict:
        """:func:`fxmodel.core.cost.estimate` of :meth:`products` and :meth:`memories`."""
        return estimate(self)

    def error_bound(self, name: str) -> Fraction:
        """Largest distance of an output code from the exact plane at a covered pixel (real units)."""
        out = self.out_fmt(name)
        acc = Fraction(2 * self.max_size - 1, 1 << (self.acc_fmt(name).frac_bits + 1))
        return acc + Fraction(1, 1 << (out.frac_bits + 1))

    def depth_precision(self, name: str = "Z") -> Fraction:
        """The documented depth precision (module docstring, "Depth"): two surfaces whose exact depths at a covered
        pixel differ by more than this (``2 error_bound``, in units of ``Z``) get codes ordered the same way."""
        return 2 * self.error_bound(name)

    def depth_gap(self, w: float, near: float, name: str = "Z") -> float:
        """The relative view-distance gap ``Δw / w = depth_precision w / near`` above which two surfaces at view
        distance ``w`` (``Z = near / w``) are always ordered right by the fixed-point depth."""
        return float(self.depth_precision(name)) * w / near

    def accumulated_bound(self, name: str, nx: int, ny: int) -> Fraction:
        """Bound on the accumulator's distance from the exact plane after ``nx`` and ``ny`` increments."""
        return Fraction(1 + nx + ny, 1 << (self.acc_fmt(name).frac_bits + 1))

    def info(self) -> dict:
        return {"unit": self.NAME,
                "params": {"max_size": self.max_size, "subpixel_bits": self.subpixel_bits,
                           "guard_pixels": self.guard_pixels, "extra_guard": self.extra_guard,
                           "guard_bits": self.guard_bits},
                "consts": {n: str(f) for n, f in self.consts},
                "record": [p.fmt.describe(p.name) for p in self.record],
                "record_bits": sum(p.fmt.width for p in self.record),
                "fragment": [p.fmt.describe(p.name) for p in self.fragment],
                "attributes": {n: {"out": str(f), "start_and_increments": str(self.acc_fmt(n)),
                                   "max_error_out_ulp": float(self.error_bound(n) / f.ulp)}
                               for n, f in self.attrs},
                "clocks": "sum over rows of max(1, covered pixels in the row), per triangle",
                **({"depth_precision": float(self.depth_precision()),
                    "depth_precision_ulp": float(self.depth_precision() / self.out_fmt("Z").ulp)}
                   if "Z" in self.names else {}),
                "cost": self.cost()}

    @classmethod
    def for_pipeline(cls, pipeline_units: dict, z_fmt: Fmt = Z_FMT, **kw) -> RasterParams:
        """The attributes in the formats of a pipeline preset's units (``persp``, ``bump``, ``reflect``), and the
        bump engine's block exponent ``Ae`` as a per-triangle constant (if it has one)."""
        bump = pipeline_units["bump"]
        kw.setdefault("consts", (("Ae", bump.e_fmt),) if bump.exp_bits else ())
        fm = {n: attribute_format(pipeline_units, n) for n in ATTRIBUTE_FORMATS} | {"Z": z_fmt}
        return cls(attrs=tuple((n, fm[n]) for n in ATTRIBUTES), **kw)


# ------------------------------------------------------------------------------------------------------------
# scan conversion and interpolation (the hardware's model)
# ------------------------------------------------------------------------------------------------------------
@dataclass
class ScanResult:
    """Fragments in traversal order: ``codes[name]`` (``x``, ``y``, each attribute's output code, ``flags``) as
    int64 arrays ``(K,)``; ``record`` the index of each fragment's record; ``acc[name]`` the accumulator words
    (``acc_fmt``) before the output rounding; ``clocks`` per record (``sum max(1, n_row)``)."""

    codes: dict
    record: np.ndarray
    acc: dict
    clocks: np.ndarray

    def __len__(self) -> int:
        return int(self.record.shape[0])

    def matrix(self, params: RasterParams) -> np.ndarray:
        return np.stack([self.codes[p.name] for p in params.fragment], axis=1)


def spans(params: RasterParams, rec: dict):
    """Rows and spans of one record (a dict of ints): ``(y, L, R)`` int64 arrays, one entry per row (``L > R`` for
    an empty row), by the closed form of the hardware's row stepping."""
    i = np.arange(rec["rows"] + 1, dtype=np.int64)
    L = np.full(i.shape, rec["x0"], dtype=np.int64)
    R = np.full(i.shape, rec["x1"], dtype=np.int64)
    for e in range(3):
        kind = rec[f"e{e}_kind"]
        if kind == EDGE_OFF:
            continue
        d = rec[f"e{e}_d"]
        p = rec[f"e{e}_p"] + i * rec[f"e{e}_q"] + (rec[f"e{e}_r"] + i * rec[f"e{e}_m"]) // d
        if kind == EDGE_LEFT:
            L = np.maximum(L, -p)
        else:
            R = np.minimum(R, p)
    return rec["y0"] + i, L, R


def scan(params: RasterParams, records) -> ScanResult:
    """Fragments of triangle records (:class:`Records` or a codes matrix ``(T, fields)``), bit-exact with the RTL."""
    P = params
    mat = records.matrix() if isinstance(records, Records) else np.asarray(records, dtype=np.int64)
    names = [p.name for p in P.record]
    xs, ys, recs, clocks = [], [], [], np.zeros(mat.shape[0], dtype=np.int64)
    nxs, nys = [], []
    for t in range(mat.shape[0]):
        rec = dict(zip(names, (int(v) for v in mat[t])))
        y, L, R = spans(P, rec)
        n = np.maximum(R - L + 1, 0)
        clocks[t] = int(np.maximum(n, 1).sum())
        rows = np.repeat(np.arange(len(y)), n)
        start = np.cumsum(n) - n
        x = L[rows] + (np.arange(int(n.sum())) - start[rows])
        xs.append(x)
        ys.append(y[rows])
        nxs.append(x - rec["x0"])
        nys.append(y[rows] - rec["y0"])
        recs.append(np.full(x.shape, t, dtype=np.int64))
    def cat(a):
        return np.concatenate(a) if a else np.zeros(0, np.int64)
    x, y, rec_idx, nx, ny = (cat(a) for a in (xs, ys, recs, nxs, nys))
    codes = {"x": x, "y": y}
    acc = {}
    flags = np.zeros(x.shape, dtype=np.int64)
    for name in P.names:
        fa, fo = P.acc_fmt(name), P.out_fmt(name)
        col = {k: mat[:, names.index(f"{name}_{k}")] for k in ("0", "dx", "dy")}
        # Scan Line Initializer and Pixel Calculator: start + ny dy (per row) + nx dx (per pixel), modulo 2**N
        word = col["0"][rec_idx] + col["dy"][rec_idx] * ny + col["dx"][rec_idx] * nx
        mask = (1 << fa.width) - 1
        word = word & mask
        word = np.where(word >> (fa.width - 1) == 1, word - (1 << fa.width), word)
        acc[name] = word
        out, sat = narrow(word, fa.frac_bits, fo, Rounding.HALF_UP, Overflow.SATURATE, f"raster {name}")
        codes[name] = out
        flags |= sat.astype(np.int64)
    for name, _ in P.carried:                         # per triangle: every fragment carries the record's code
        codes[name] = mat[:, names.index(name)][rec_idx]
    codes["flags"] = flags
    return ScanResult(codes=codes, record=rec_idx, acc=acc, clocks=clocks)


def _pipeline_raster() -> RasterParams:
    from fxmodel.units.bump import BumpParams
    from fxmodel.units.persp import PerspParams
    from fxmodel.units.reflect import ReflectParams
    units = {"persp": PerspParams.PRESETS["color"], "bump": BumpParams.PRESETS["default"],
             "reflect": ReflectParams.PRESETS["default"]}
    return RasterParams.for_pipeline(units)


#: ``default``: the default pixel pipeline's input formats (its units' default presets), ``Z`` in the format
#: :meth:`RasterParams.for_pipeline` gives it, and the bump engine's block exponent ``Ae`` as a constant;
#: ``small``: two attributes for quick RTL tests; ``logic``: ``default`` with the span start's products in logic
#: (``span_dsp`` off, as the engines fitted to the ECP5-85's multiplier blocks build it).
RasterParams.PRESETS = {
    "default": _pipeline_raster(),
    "logic": replace(_pipeline_raster(), span_dsp=False),
    "small": RasterParams(attrs=(("U", Fmt(True, 4, 12)), ("W", Fmt(True, 2, 12))), max_size=256,
                          guard_pixels=256, extra_guard=0),
}
