r"""Cube-map address unit: face, s, t of a signed 3-vector (paper, sections 2 and 4).

The paper addresses a diffuse reflectance cube by the (perturbed) normal and a specular one by the unnormalized
reflection vector (section 2); "the vector's major axis determines the corresponding reflectance cube face.
Indexing this map is done by dividing the vector's minor axis values by the major axis value" (section 4), with
the divider of section 4.1 at a lower precision. The face orientation follows the OpenGL / Vulkan table
(``docs/design.md``, "Cube faces: table and tie rule") instead of the paper's, so cube maps authored for GL work
unchanged:

==========  ====  =======  =======
major axis  face  ``s_c``  ``t_c``
==========  ====  =======  =======
+x          0     -z       -y
-x          1     +z       -y
+y          2     +x       +z
-y          3     +x       -z
+z          4     +x       -y
-z          5     -x       -y
==========  ====  =======  =======

``s = (s_c / |ma| + 1) / 2``, ``t = (t_c / |ma| + 1) / 2``.

Algorithm (bit-exact; ``rtl/cube.py`` builds the same datapath from the same :class:`CubeParams`)
--------------------------------------------------------------------------------------------------
Input codes ``(x, y, z)`` in ``in_fmt`` (signed, ``n`` bits). Only the codes matter: a vector in any signed format
of at most ``n`` bits (the bump engine's ``N'``, the reflection unit's ``R``) is fed by wiring, whatever its
binary point, and the result is invariant under scaling the vector by a power of two (tested).

1. **Face.** ``|x|, |y|, |z|`` as ``n``-bit unsigned words (``|min_code| = 2**(n-1)`` fits). **Tie rule**: z wins
   if ``|z| >= |x|`` and ``|z| >= |y|``; else y wins if ``|y| >= |x|``; else x. The major component ``ma`` is
   negative only if ``ma < 0``; ``face = 2 axis + (ma < 0)``. Three magnitude comparators; the tie rule is
   only the choice of ``>=`` over ``>`` in them: it costs nothing.
2. **Quotients with the signed major.** ``q_s = a / ma`` and ``q_t = b / ma`` with ``(a, b)`` = ``(z, y)`` for an
   x face, ``(x, z)`` for y and ``(x, y)`` for z, through the reciprocal unit's divider
   (:class:`~fxmodel.units.divide.DivideParams`: ``recip(ma)`` once, ``a * mant`` and ``b * mant`` shifted, rounded
   half-up to ``s2.fq``). Dividing by the signed ``ma`` (the reciprocal handles the sign) instead of ``|ma|``
   needs no negation of an input, so the most negative code needs no extra bit. From the table,
   ``s_c / |ma| = -q_s`` on faces +x, -x, -y and ``+q_s`` otherwise; ``t_c / |ma| = -q_t`` on faces +x, +z and
   ``+q_t`` otherwise.
3. **s, t** ``= (1 +- q) / 2``, exact in ``st_fmt = u1.(fq + 1)``: no second rounding.

**Zero vector**: the tie rule picks +Z, ``ma = 0`` and both numerators are 0, so the divider returns ``q = 0``
(its ``dbz`` rule for ``n = 0``) and ``s = t = 1/2``; ``degenerate`` is the divider's ``dbz``, which is set only
for the zero vector. The rule costs no logic beyond routing that flag.

No overflow, and ``s, t`` exactly 0 or 1 when a minor equals +-major
--------------------------------------------------------------------
The exact quotients satisfy ``|a / ma| <= 1``. Before its single rounding the divider's value is within
``|q| E 2**-(p-1) <= E 2**-(p-1)`` of the exact quotient (``E`` = ``divide.recip.error_bound_ulp``, the
reciprocal's relative error in mantissa ulps), and :class:`CubeParams` requires ``E 2**-(p-1) < 2**-(fq+1)``, half
an ulp of ``q``. Half-up rounding then maps every value in ``[-1 - h, 1 + h)`` (``h`` half an ulp) into
``[-1, 1]``, so ``|q| <= 1`` (``s, t`` in ``[0, 1]``, the divider's saturation never fires) and a quotient of
exactly +-1 or 0 is returned exactly. The model checks this on every value (``OverflowError`` otherwise).

Error bound (:attr:`CubeParams.st_bound`)
-----------------------------------------
``|s - s_exact| = |q - q_exact| / 2 <= (E 2**-(p-1) + 2**-(fq+1)) / 2``; the face is exact. For ``default``
(``p = 17``, ``fq = 15``, ``E ~ 0.887``) this is about ``1.44e-5 < 2**-16``, 1/135 of the 2**-9 target: it lets
a 256-texel face get its 8-bit bilinear weights right to within one step.

Negating the vector gives the opposite face and, per the table, ``t -> 1 - t`` on x and z faces and
``s -> 1 - s`` on y faces, with the other coordinate unchanged: bit-exactly, because the divider is odd in
``(n, d) -> (-n, -d)`` and ``(1 +- q)/2`` is exact (tested).

Texel addressing and bilinear weights for the lookups are the texture sampler's (``fxmodel/units/sampler.py``, edge
rule ``border`` or ``clamp``, any face size): one rule for every lookup of the pipeline.

Hard cases (each has a test): exact ties of two and of three components with every sign; all combinations of
``{min, min + 1, -max/2, -2, -1, 0, 1, 2, max/2, max - 1, max}`` per component (corners, axis-aligned vectors,
zero components, the most negative codes); minor = +-major (``s`` or ``t`` exactly 0 or 1); the zero vector.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, Unit, register, require
from fxmodel.units.divide import DivideParams
from fxmodel.units.recip import RecipParams

__all__ = ["CubeParams", "cube_divider", "FACE_NAMES", "FLIP_S", "FLIP_T"]

FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: Per face: does ``s_c / |ma|`` equal ``-q_s`` (True) or ``+q_s``?  (``q_s = a / ma``, see the module docstring)
FLIP_S = (True, True, False, True, False, False)
#: Per face: does ``t_c / |ma|`` equal ``-q_t``?
FLIP_T = (True, False, False, False, True, False)




def cube_divider(in_fmt: Fmt, m: int, b: int, t: int, p: int, guard: int) -> DivideParams:
    """The cube unit's divider: ``minor / major`` with the reciprocal's table size ``m``, word bits ``b``, terms
    ``t``, result bits ``p`` and ``guard`` bits (see :class:`RecipParams`), quotient ``s2.(p - 2)`` limited to
    ``|q| <= 1``; ``in_fmt`` is both the numerator's and the denominator's format (the unit's input)."""
    return DivideParams(recip=RecipParams(in_fmt=in_fmt, m=m, b=b, t=t, p=p, guard=guard),
                        num_fmt=in_fmt, out_fmt=Fmt(True, 2, p - 2), quotient_limit=1)


@dataclass(frozen=True)
class CubeParams(Unit):
    """Parameters of the cube-map address unit.

    Parameters
    ----------
    divide : DivideParams
        The divider used for ``minor / major``. Its ``recip.in_fmt`` is the unit's input format and must equal
        its ``num_fmt``; its reciprocal's error must stay below half an ulp of its ``out_fmt`` (see the module
        docstring), so that ``|q| <= 1`` and ``s, t`` in ``[0, 1]`` hold without a clamp.
    """

    NAME = "cube"

    divide: DivideParams = cube_divider(Fmt(True, 1, 17), m=7, b=20, t=3, p=17, guard=5)

    def __post_init__(self):
        require(isinstance(self.divide, DivideParams), "divide", self.divide, "must be a DivideParams")
        d = self.divide
        require(d.num_fmt == d.recip.in_fmt, "divide", f"num_fmt={d.num_fmt}, recip.in_fmt={d.recip.in_fmt}",
                 "numerator and denominator must share the input format")
        # |q| <= 1 after rounding needs the pre-rounding error below half an ulp of q (module docstring)
        pre = d.recip.error_bound_ulp / (1 << d.recip.fo)
        half = Fraction(1, 1 << (d.out_fmt.frac_bits + 1))
        require(pre < half, "divide",
                 f"p={d.recip.p}, out_fmt={d.out_fmt}",
                 f"the reciprocal's error {float(pre):.3g} is not below half an ulp of q ({float(half):.3g}): "
                 f"raise p or lower out_fmt.frac_bits")
        require(d.out_fmt.int_bits >= 2, "divide", f"out_fmt={d.out_fmt}", "q needs the range [-1, 1] (int_bits >= 2)")

    # -- formats (the RTL reads these) --------------------------------------------------------------------
    @property
    def in_fmt(self) -> Fmt:
        return self.divide.recip.in_fmt

    @property
    def q_fmt(self) -> Fmt:
        return self.divide.out_fmt

    @cached_property
    def st_fmt(self) -> Fmt:
        """``s = (1 +- q) / 2`` exactly: one more fraction bit than ``q``."""
        return Fmt(False, 1, self.q_fmt.frac_bits + 1)

    @property
    def face_fmt(self) -> Fmt:
        return Fmt(False, 3, 0)

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        return tuple(Port(c, self.in_fmt, "direction vector component") for c in "xyz")

    @property
    def outputs(self):
        return (Port("face", self.face_fmt, "0..5 = +X, -X, +Y, -Y, +Z, -Z"),
                Port("s", self.st_fmt, "face coordinate in [0, 1]"),
                Port("t", self.st_fmt, "face coordinate in [0, 1]"),
                Port("degenerate", Fmt(False, 1, 0), "the zero vector (face +Z, s = t = 1/2)"))

    def products(self) -> tuple:
        """One reciprocal of the major component and ``a * mant``, ``b * mant`` (``rtl/cube.py``)."""
        r = self.divide.recip
        return (*r.products(), r.times_product(self.in_fmt.width, "minor*mant", count=2))

    def memories(self) -> tuple:
        return self.divide.recip.memories()

    @property
    def latency(self) -> int:
        """Stages: magnitudes | comparisons and face select | the divider (reciprocal, products, shift and
        rounding) | ``(1 +- q) / 2`` (each a stage of its own: ECP5 timing)."""
        return 3 + self.divide.latency

    # -- bit-exact model ----------------------------------------------------------------------------------
    @staticmethod
    def select(x, y, z):
        """``(face, ma, a, b)``: face by the tie rule, signed major, and the numerators of ``q_s``, ``q_t``."""
        ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
        zsel = (az >= ax) & (az >= ay)
        ysel = ~zsel & (ay >= ax)
        ma = np.where(zsel, z, np.where(ysel, y, x))
        a = np.where(zsel | ysel, x, z)
        b = np.where(zsel, y, np.where(ysel, z, y))
        axis = np.where(zsel, 2, np.where(ysel, 1, 0))
        face = 2 * axis + (ma < 0)
        return face.astype(np.int64), ma, a, b

    def _compute(self, cols):
        x, y, z = cols
        face, ma, a, b = self.select(x, y, z)
        qs = self.divide.compute(np.stack([a, ma], axis=1))
        qt = self.divide.compute(np.stack([b, ma], axis=1))
        one = 1 << self.q_fmt.frac_bits
        for q in (qs, qt):
            # Overflow.PROVEN (module docstring): |q| <= 1 and the divider never saturates
            if np.any(np.abs(q[:, 0]) > one) or np.any(q[:, 2] != 0):
                raise OverflowError("cube: |minor / major| > 1 after rounding: the no-overflow proof is wrong")
        flip_s = np.asarray(FLIP_S)[face]
        flip_t = np.asarray(FLIP_T)[face]
        s = one + np.where(flip_s, -qs[:, 0], qs[:, 0])
        t = one + np.where(flip_t, -qt[:, 0], qt[:, 0])
        return [face, s, t, qs[:, 1]]

    # -- hard cases ---------------------------------------------------------------------------------------
    def hard_cases(self) -> np.ndarray:
        fmt = self.in_fmt
        mn, mx = fmt.min_code, fmt.max_code
        vals = sorted({mn, mn + 1, -(mx // 2), -2, -1, 0, 1, 2, mx // 2, mx - 1, mx})
        grid = np.array(np.meshgrid(vals, vals, vals, indexing="ij")).reshape(3, -1).T
        rows = [grid, self.tie_cases()]
        out = np.concatenate(rows).astype(np.int64)
        return np.unique(out, axis=0)

    def tie_cases(self, magnitudes=None) -> np.ndarray:
        """Exact ties of two and three components (every sign) and minor = +-major, for several magnitudes."""
        fmt = self.in_fmt
        mn, mx = fmt.min_code, fmt.max_code
        rng = np.random.default_rng(11)
        if magnitudes is None:
            magnitudes = sorted({1, 2, 3, mx // 2, mx - 1, mx, -mn} |
                                set(int(v) for v in rng.integers(4, mx, size=12)))
        rows = []
        for a in magnitudes:
            signed = [v for v in (a, -a) if mn <= v <= mx]
            others = [v for v in {0, a - 1, -(a - 1), a // 2, -(a // 2), a + 1, -(a + 1)} if mn <= v <= mx]
            for u in signed:
                for v in signed:
                    for w in signed:
                        rows.append((u, v, w))                  # three-way tie
                    for o in others:                            # two-way ties, third component smaller/larger
                        rows += [(u, v, o), (u, o, v), (o, u, v)]
        return np.array(rows, dtype=np.int64)

    # -- documented error bound ---------------------------------------------------------------------------
    @cached_property
    def st_bound(self) -> Fraction:
        """Bound on ``|s - s_exact|`` and ``|t - t_exact|`` (real units): half the divider's bound at ``|q| <= 1``."""
        return self.divide.error_bound(Fraction(1)) / 2

    def _info(self):
        st = float(self.st_bound)
        r = self.divide.recip
        return {
            "max_error": {"face": 0.0, "s": st, "t": st, "degenerate": 0.0},
            "st_max_error_log2": float(np.log2(st)),
            "divider": {"recip": {"in_fmt": str(r.in_fmt), "m": r.m, "b": r.b, "t": r.t, "p": r.p,
                                  "guard": r.guard, "table_bits": r.table_bits,
                                  "max_error_ulp": float(r.error_bound_ulp)},
                        "q_fmt": str(self.q_fmt), "shared_reciprocal": True},
        }


CubeParams.PRESETS = {
    # 18-bit input (the width of the reflection unit's default R and of the bump engine's N': wired by codes);
    # the recip default's table (64 x 19 bits, 3 terms) at p = 17; every multiplier within 18x18; s, t with 16
    # fraction bits.
    "default": CubeParams(),
    # 14-bit input (the reflection unit's ``small`` R), 32-entry table, p = 12; s, t with 11 fraction bits.
    "small": CubeParams(divide=cube_divider(Fmt(True, 1, 13), m=6, b=14, t=3, p=12, guard=4)),
}
register(CubeParams)
