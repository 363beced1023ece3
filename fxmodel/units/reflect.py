r"""Reflection-vector unit: ``R = 2 N (N.E) - E (N.N)`` (paper, section 2, EQ 1), block-normalized.

The specular reflectance cube is addressed by the *unnormalized* reflection vector of EQ 1 (the paper follows
Voorhies and Foran: multiplying the reflection formula by ``|N|**2`` removes every division and square root).
The cube address unit (``fxmodel/units/cube.py``) only uses R's direction, so this unit keeps R exact and then scales
it by a power of two common to all three components (block floating point) before one narrowing, so that short
and long vectors reach the cube stage with the same relative precision.

Algorithm (bit-exact; ``rtl/reflect.py`` builds the same datapath from the same :class:`ReflectParams`)
--------------------------------------------------------------------------------------------------------------
Inputs are integer codes ``N = (Nx, Ny, Nz)`` in ``n_fmt`` and ``E = (Ex, Ey, Ez)`` in ``e_fmt`` (signed). The
binary points do not matter: R's direction depends only on the codes, so everything below is integer arithmetic.

1. **Exact dot products.** ``p = N.E`` and ``q = N.N`` (three products and two adds each).
2. **Exact EQ 1.** ``R_i = 2 N_i p - E_i q``, an integer of ``W + 1`` bits (:attr:`ReflectParams.exact_fmt`).
3. **Normalization shift, common to the three components.** ``L`` = bit length of
   ``max_i (R_i XOR sign(R_i))`` (the one's-complement magnitude: no negation; it equals ``|R_i|`` for
   ``R_i >= 0`` and ``|R_i| - 1`` for ``R_i < 0``; computed as the bit length of the OR of the three), and
   ``lz = W - L``. Then ``R 2**lz`` read with ``W`` fraction bits, i.e. ``Rn = R 2**(lz - W)``, lies in
   ``[-1, 1)`` and its largest component has magnitude at least 1/2 (proof below).
4. **One narrowing**: ``Rn`` to ``r_fmt = s1.(r_bits - 1)`` with :attr:`~fxmodel.core.rounding.Rounding.TRUNC`
   (floor, free in hardware: the low bits are dropped) and :attr:`~fxmodel.core.rounding.Overflow.PROVEN`.

Outputs ``Rx, Ry, Rz`` (``r_fmt``) and ``degenerate``. **Degenerate rule:** ``R = 0`` exactly when ``N = 0`` or
``E = 0`` (from ``|R| = |E| |N|**2``); then the outputs are ``R = (0, 0, 0)`` and ``degenerate = 1``, which the
cube unit maps to its own zero-vector rule (face +Z, ``s = t = 1/2``, ``degenerate = 1``). Otherwise
``degenerate = 0`` and the output is never the zero vector.

No-overflow proof (every width is derived from the input formats by :class:`ReflectParams`)
------------------------------------------------------------------------------------------
Let ``a = 2**(nN - 1)`` and ``b = 2**(nE - 1)`` be the magnitudes of the most negative codes (``nN``, ``nE`` the
input widths); every code magnitude is at most ``a`` (resp. ``b``).

* ``N_i E_i``, ``N.E``, ``N_i N_i``, ``N.N``, ``2 N_i (N.E)`` and ``E_i (N.N)``: interval arithmetic on the code
  ranges (corner products), turned into the narrowest integer formats by ``Fmt.integer``
  (:meth:`ReflectParams.widths`). In particular ``0 <= N.N <= 3 a**2`` and ``|N.E| <= 3 a b``.
* ``R``: the interval bound of ``2 N_i p - E_i q`` is ``9 a**2 b``, one bit more than needed. The identity
  ``|R|**2 = |E|**2 |N|**4`` (expand EQ 1: ``|R|**2 = 4 p**2 q - 4 p**2 q + |E|**2 q**2``) gives
  ``|R_i| <= |R| = |E| |N|**2 <= sqrt(3) b * 3 a**2 = sqrt(27) a**2 b < 0.65 * 2**(2 nN + nE)``, so ``R`` fits
  ``W + 1 = 2 nN + nE + 1`` signed bits. The bound is reached within that bit: some input has
  ``|R_i| > 2**(2 nN + nE - 1)`` (tested), so the width is tight. The difference of the two terms may be
  formed modulo ``2**(W + 1)``: the true value fits.
* Normalization: with ``M = max_i (R_i XOR sign(R_i))`` of bit length ``L <= W``, every ``R_i >= 0`` has
  ``R_i <= M < 2**L`` and every ``R_i < 0`` has ``-R_i = (R_i XOR sign) + 1 <= 2**L``, so
  ``-2**W <= R_i 2**lz < 2**W``: the shifted word fits ``W + 1`` bits, ``Rn`` lies in ``[-1, 1)``.
* Narrowing: the floor of a value in ``[-1, 1)`` at ``r_bits - 1`` fraction bits lies in
  ``[-1, 1 - 2**(1 - r_bits)]``, the range of ``r_fmt``. No rounding can carry out: TRUNC never rounds up.
* Largest component: the component that sets ``L`` has ``|Rn_i| >= 2**(L-1) 2**(lz - W) = 1/2`` (its
  one's-complement magnitude has bit ``L - 1`` set); ``R_i = -1`` in all non-zero components (``L = 0``) gives
  ``Rn_i = -1``.

The model checks each of these on every value it computes (``Overflow.PROVEN``: ``OverflowError`` if a proof
is wrong); the tests run the extremes of the input formats, the most negative codes included.

Error bound (:attr:`ReflectParams.direction_bound`)
---------------------------------------------------
The output is ``r' = r - e`` with ``r`` the exact normalized vector in output ulps and ``0 <= e_i < 1`` (floor),
so ``|e| < sqrt(3)``, and ``|r| >= max_i |r_i| >= 2**(r_bits - 2)``. The angle ``theta`` between ``R`` and the
output satisfies ``sin(theta) <= |e| / |r| < sqrt(3) 2**(2 - r_bits)`` (and ``r . r' > 0``). Each component's
absolute error against ``Rn`` is below one output ulp, ``2**(1 - r_bits)`` (one-sided: the output is never
above ``Rn``). On a cube face, ``s = (u + 1)/2`` with ``|du| <= (1 + u**2 + v**2) |d theta| <= 3 |d theta|``,
so the narrowing moves ``s`` and ``t`` by at most ``1.5 theta`` (:attr:`ReflectParams.st_bound`) whenever it
does not move the vector to another face. ``R`` itself is exact: the inputs are the only other error source.

Hard cases (each has a test): the most negative and the largest codes in every component (all ``5**6``
combinations of ``{min, min + 1, 0, 1, max}``); N anti-parallel and parallel to E (``R`` along ``E``); grazing
``N.E = 0`` (``R = -E |N|**2``); tiny N and E (codes ``+-1``, ``+-2``); tiny N with long E and the converse;
``N = 0``; ``E = 0``; R on an axis with the largest magnitude (the tight case of the width proof); results with
all non-zero components ``-1`` (``L = 0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

import numpy as np

from fxmodel.core.cost import Product
from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow, saturate
from fxmodel.core.unit import Port, Unit, register, require

__all__ = ["ReflectParams", "bitlen_int64", "ones_magnitude"]




def _prod_range(a: tuple[int, int], b: tuple[int, int]) -> tuple[int, int]:
    corners = [x * y for x in a for y in b]
    return min(corners), max(corners)


def bitlen_int64(x: np.ndarray) -> np.ndarray:
    """Exact bit length of non-negative ``int64`` values below ``2**62`` (0 for 0).

    ``frexp`` of the float64 conversion is exact below ``2**53``; above, the conversion may round up to the next
    power of two, which is corrected by one test shift.
    """
    x = np.asarray(x, dtype=np.int64)
    bl = np.frexp(x.astype(np.float64))[1].astype(np.int64)
    over = (bl > 0) & ((x >> np.maximum(bl - 1, 0)) == 0)
    return bl - over


def ones_magnitude(x: np.ndarray) -> np.ndarray:
    """``x XOR sign(x)``: ``x`` for ``x >= 0``, ``-x - 1`` for ``x < 0`` (the hardware's negation-free magnitude)."""
    x = np.asarray(x, dtype=np.int64)
    return x ^ (x >> 63)


@dataclass(frozen=True)
class ReflectParams(Unit):
    """Parameters of the reflection-vector unit.

    Parameters
    ----------
    n_fmt : Fmt
        Signed format of the normal ``N`` (e.g. the bump engine's perturbed normal ``N'``).
    e_fmt : Fmt
        Signed format of the eye vector ``E``.
    r_bits : int
        Width of each output component; the output format is ``s1.(r_bits - 1)`` (values in ``[-1, 1)``, the
        largest magnitude at least 1/2 unless degenerate). Choose it equal to the cube unit's input width so
        that the two units chain directly.
    """

    NAME = "reflect"

    #: Digit size of the wide second-level operands ``N.E``, ``N.N``: a 17-bit unsigned digit is an 18-bit
    #: signed operand of one ECP5 multiplier block.
    DIGIT_BITS = 17
    #: A top digit of at most this many bits (sign included) is multiplied by shifts and adds (logic), not by a
    #: multiplier block.
    LUT_DIGIT_BITS = 4

    n_fmt: Fmt = Fmt(True, 2, 16)
    e_fmt: Fmt = Fmt(True, 2, 16)
    r_bits: int = 18

    def __post_init__(self):
        for name in ("n_fmt", "e_fmt"):
            fmt = getattr(self, name)
            require(isinstance(fmt, Fmt) and fmt.signed, name, fmt, "must be a signed Fmt")
        require(isinstance(self.r_bits, int) and not isinstance(self.r_bits, bool), "r_bits", self.r_bits,
                 "must be an int")
        require(self.r_bits >= 2, "r_bits", self.r_bits, "the output needs a sign and at least one bit (>= 2)")
        W = self.exact_fmt.width
        require(W <= INT64_SAFE_BITS, "n_fmt", str(self.n_fmt),
                 f"with e_fmt={self.e_fmt} the exact R needs {W} bits (> {INT64_SAFE_BITS})")
        require(self.r_bits <= W, "r_bits", self.r_bits, f"exceeds the exact R's width {W} (nothing to narrow)")

    # -- formats (the RTL reads these) --------------------------------------------------------------------
    @cached_property
    def _ranges(self) -> dict:
        """Exact integer ranges of every intermediate (see the module docstring's proof)."""
        n = (self.n_fmt.min_code, self.n_fmt.max_code)
        e = (self.e_fmt.min_code, self.e_fmt.max_code)
        ne = _prod_range(n, e)
        nn = (0, max(c * c for c in n))
        dot_ne = (3 * ne[0], 3 * ne[1])
        dot_nn = (0, 3 * nn[1])
        t1 = _prod_range(n, dot_ne)
        t1 = (2 * t1[0], 2 * t1[1])
        t2 = _prod_range(e, dot_nn)
        a2 = max(c * c for c in n)
        b2 = max(c * c for c in e)
        rmax = math.isqrt(3 * b2 * (3 * a2) ** 2)       # |R_i| <= |E| |N|**2 <= sqrt(3 b2) * 3 a2
        return {"N*E": ne, "N*N": nn, "N.E": dot_ne, "N.N": dot_nn, "2N(N.E)": t1, "E(N.N)": t2,
                "R": (-rmax, rmax)}

    def widths(self) -> dict:
        """Format of every exact intermediate, derived from the input formats: name -> ``Fmt``."""
        return {k: Fmt.integer(*v) for k, v in self._ranges.items()}

    @cached_property
    def exact_fmt(self) -> Fmt:
        """Exact ``R`` (integer, ``W + 1 = 2 nN + nE + 1`` bits, proven by ``|R| = |E| |N|**2``)."""
        return self.widths()["R"]

    @cached_property
    def W(self) -> int:
        """Magnitude bits of the exact ``R``: the normalization shift ``lz`` lies in ``[0, W]``."""
        return self.exact_fmt.width - 1

    @cached_property
    def norm_fmt(self) -> Fmt:
        """``Rn = R 2**lz`` read with ``W`` fraction bits: in ``[-1, 1)``."""
        return Fmt(True, 1, self.W)

    @cached_property
    def r_fmt(self) -> Fmt:
        return Fmt(True, 1, self.r_bits - 1)

    @cached_property
    def lz_fmt(self) -> Fmt:
        return Fmt.integer(0, self.W)

    def multiplier_sizes(self) -> dict:
        """Operand widths of the two multiplier levels (three multipliers each, twice)."""
        w = self.widths()
        return {"N_i*E_i": (self.n_fmt.width, self.e_fmt.width), "N_i*N_i": (self.n_fmt.width, self.n_fmt.width),
                "N_i*(N.E)": (self.n_fmt.width, w["N.E"].width), "E_i*(N.N)": (self.e_fmt.width, w["N.N"].width)}

    def digits(self, key: str) -> list[tuple[int, int, int]]:
        """How the RTL cuts the second-level operand ``key`` (``"N.E"`` or ``"N.N"``) into signed digits:
        ``[(low bit, high bit, digit width)]`` with the operand ``= sum_j d_j 2**low_j``. Every digit but the
        top one is :attr:`DIGIT_BITS` bits zero-extended (one bit more); the top one keeps the sign of a signed
        operand (an unsigned one is zero-extended too)."""
        fmt = self.widths()[key]
        out = []
        for lo in range(0, fmt.width, self.DIGIT_BITS):
            hi = min(lo + self.DIGIT_BITS, fmt.width)
            out.append((lo, hi, hi - lo + (0 if hi == fmt.width and fmt.signed else 1)))
        return out

    def products(self) -> tuple:
        """First level ``N_i E_i``, ``N_i N_i``; second level ``N_i`` times each digit of ``p = N.E`` and
        ``E_i`` times each digit of ``q = N.N`` (:meth:`digits`) wider than :attr:`LUT_DIGIT_BITS`."""
        nN, nE = self.n_fmt.width, self.e_fmt.width
        out = [Product(nN, nE, count=3, name="N_i*E_i"), Product(nN, nN, count=3, name="N_i*N_i")]
        for key, width, name in (("N.E", nN, "N_i*digit(N.E)"), ("N.N", nE, "E_i*digit(N.N)")):
            out += [Product(width, bits, count=3, name=name) for _, _, bits in self.digits(key)
                    if bits > self.LUT_DIGIT_BITS]
        return tuple(out)

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        return tuple(Port(f"N{c}", self.n_fmt, "normal") for c in "xyz") + \
            tuple(Port(f"E{c}", self.e_fmt, "eye vector") for c in "xyz")

    @property
    def outputs(self):
        return tuple(Port(f"R{c}", self.r_fmt, "reflection vector, block-normalized") for c in "xyz") + \
            (Port("degenerate", Fmt(False, 1, 0), "R = 0 (N = 0 or E = 0); outputs then zero"),)

    @property
    def latency(self) -> int:
        """Stages: the inputs | N_i E_i, N_i N_i | dot sums | the same registered again | digit products of
        2 N_i p, E_i q | the same registered again | per-digit differences | R | the OR of the magnitudes' bits |
        its leading-zero count | shift, truncate (``rtl/reflect.py`` splits the wide products and the
        normalization for ECP5 timing, registers the inputs for the first products' multiplier blocks and the sums
        for the digit products', and the digit products again in the fabric, between their blocks and the
        differences' carry chains)."""
        return 11

    # -- bit-exact model ----------------------------------------------------------------------------------
    def exact_r(self, cols) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """``(N.E, N.N, [Rx, Ry, Rz])``: the exact integers before the narrowing (every width checked)."""
        Nx, Ny, Nz, Ex, Ey, Ez = (np.asarray(c, dtype=np.int64) for c in cols)
        w = self.widths()
        p = Nx * Ex + Ny * Ey + Nz * Ez
        q = Nx * Nx + Ny * Ny + Nz * Nz
        saturate(p, w["N.E"], Overflow.PROVEN, "reflect N.E")
        saturate(q, w["N.N"], Overflow.PROVEN, "reflect N.N")
        R = []
        for Ni, Ei in ((Nx, Ex), (Ny, Ey), (Nz, Ez)):
            t1 = 2 * Ni * p
            t2 = Ei * q
            saturate(t1, w["2N(N.E)"], Overflow.PROVEN, "reflect 2N(N.E)")
            saturate(t2, w["E(N.N)"], Overflow.PROVEN, "reflect E(N.N)")
            R.append(saturate(t1 - t2, self.exact_fmt, Overflow.PROVEN, "reflect R")[0])
        return p, q, R

    def shift_of(self, R: list[np.ndarray]) -> np.ndarray:
        """The common normalization shift ``lz = W - bitlen(OR_i (R_i XOR sign R_i))``."""
        M = ones_magnitude(R[0]) | ones_magnitude(R[1]) | ones_magnitude(R[2])
        return self.W - bitlen_int64(M)

    def _compute(self, cols):
        _, _, R = self.exact_r(cols)
        lz = self.shift_of(R)
        out = []
        for Ri in R:
            shifted, _ = saturate(Ri << lz, self.norm_fmt, Overflow.PROVEN, "reflect normalized R")
            r, _ = narrow(shifted, self.W, self.r_fmt, Rounding.TRUNC, Overflow.PROVEN, "reflect R narrowing")
            out.append(r)
        zero = (R[0] == 0) & (R[1] == 0) & (R[2] == 0)
        if np.any(~zero & (out[0] == 0) & (out[1] == 0) & (out[2] == 0)):
            raise OverflowError("reflect: a non-zero R narrowed to the zero vector: the normalization proof is wrong")
        return out + [zero.astype(np.int64)]

    # -- hard cases ---------------------------------------------------------------------------------------
    def hard_cases(self) -> np.ndarray:
        nf, ef = self.n_fmt, self.e_fmt
        rows = []
        # every combination of extreme codes (5**6 = 15625 vectors)
        nv = sorted({nf.min_code, nf.min_code + 1, 0, 1, nf.max_code})
        ev = sorted({ef.min_code, ef.min_code + 1, 0, 1, ef.max_code})
        grid = np.array(np.meshgrid(nv, nv, nv, ev, ev, ev, indexing="ij")).reshape(6, -1).T
        rows.append(grid)
        rows.append(self.special_cases())
        out = np.concatenate(rows).astype(np.int64)
        return np.unique(out, axis=0)

    def special_cases(self) -> np.ndarray:
        """Named geometric cases: parallel, anti-parallel, grazing, tiny, long, zero, width-tight."""
        nf, ef = self.n_fmt, self.e_fmt
        rng = np.random.default_rng(3)
        rows = []

        def add(n, e):
            n, e = list(n), list(e)
            if all(nf.min_code <= c <= nf.max_code for c in n) and all(ef.min_code <= c <= ef.max_code for c in e):
                rows.append(n + e)

        big_n, big_e = nf.max_code, ef.max_code
        dirs = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 1, 1), (3, -2, 1), (-5, 7, 2), (1, 2, 3)]
        for d in dirs:
            for sn in (1, -1):
                for scale_n in (1, 2, big_n // max(map(abs, d))):
                    n = [sn * scale_n * c for c in d]
                    for scale_e in (1, 2, big_e // max(map(abs, d)), -1, -(big_e // max(map(abs, d)))):
                        e = [scale_e * c for c in d]                 # E parallel / anti-parallel to N
                        add(n, e)
                    # grazing: E perpendicular to N (N.E = 0), short and long
                    perp = np.cross(np.array(d), np.array([1, 0, 0]) if d[0] == 0 else np.array([0, 1, 0]))
                    for k in (1, big_e // max(1, int(np.abs(perp).max()))):
                        add(n, k * perp)
                        add(n, -k * perp)
        # grazing with a long random N: E = N x random, scaled into range
        for _ in range(64):
            n = rng.integers(nf.min_code // 4, nf.max_code // 4, size=3, endpoint=True)
            v = rng.integers(-3, 3, size=3, endpoint=True)
            e = np.cross(n, v)
            m = int(np.abs(e).max())
            if m:
                g = math.gcd(*(int(abs(c)) for c in e))
                e = e // g
                k = max(1, ef.max_code // max(1, int(np.abs(e).max())))
                add(n, e * k)
                add(n, e)
        # tiny N and E, tiny with long
        tiny = [(1, 0, 0), (0, -1, 0), (0, 0, 1), (1, 1, 1), (-1, -1, -1), (2, -1, 1), (-2, 2, -2)]
        for n in tiny:
            for e in tiny:
                add(n, e)
                add(n, [c * (big_e // 2) for c in e])
                add([c * (big_n // 2) for c in n], e)
        # zero N or E, with extreme partners
        for v in ([nf.min_code] * 3, [nf.max_code, 0, nf.min_code], [1, 0, 0]):
            add([0, 0, 0], [min(max(c, ef.min_code), ef.max_code) for c in v])
            add([min(max(c, nf.min_code), nf.max_code) for c in v], [0, 0, 0])
        add([0, 0, 0], [0, 0, 0])
        # the tight case of the width proof: R along an axis with |R| near |E| |N|**2 at the extremes
        a, B = nf.min_code, -ef.min_code
        for n in ([a, a, a], [-a - 1, -a - 1, -a - 1]):
            add(n, [B // 2, -B, -B])
            add(n, [-B // 2, B - 1, B - 1])
            add(n, [-B, B // 2, -B])
            add(n, [-B, -B, B // 2])
        # L = 0: R = (-1, 0, 0) style results
        add([1, 0, 0], [-1, 0, 0])
        add([0, 1, 0], [0, -1, 0])
        return np.array(rows, dtype=np.int64)

    # -- documented error bound ---------------------------------------------------------------------------
    @property
    def sin2_bound(self) -> Fraction:
        """Exact bound on ``sin(theta)**2`` between the exact ``R`` and the output: ``3 * 2**(4 - 2 r_bits)``."""
        return Fraction(3, 1) * Fraction(2) ** (4 - 2 * self.r_bits)

    @property
    def direction_bound(self) -> float:
        """Bound on the angle (radians) between the exact ``R`` and the output: ``asin(sqrt(3) 2**(2-r_bits))``."""
        return math.asin(min(1.0, math.sqrt(float(self.sin2_bound))))

    @property
    def st_bound(self) -> float:
        """Bound on the change of cube ``s``, ``t`` (same face) caused by the narrowing: ``1.5 * theta``."""
        return 1.5 * self.direction_bound

    @property
    def max_error(self) -> Fraction:
        """Per-component absolute error bound (real units) against ``Rn``: one output ulp, floor."""
        return self.r_fmt.ulp

    def _info(self):
        comp = float(self.max_error)
        return {
            "max_error": {"Rx": comp, "Ry": comp, "Rz": comp, "degenerate": 0.0},
            "rounding": Rounding.TRUNC.value, "overflow": Overflow.PROVEN.value,
            "direction_max_error_rad": self.direction_bound,
            "cube_st_max_error_from_narrowing": self.st_bound,
            "exact_R_bits": self.exact_fmt.width,
            "intermediate_formats": {k: str(v) for k, v in self.widths().items()},
            "multipliers": {k: f"{a}x{b}" for k, (a, b) in self.multiplier_sizes().items()},
        }


ReflectParams.PRESETS = {
    # N (the bump engine's N') and E in 18 bits; R in 18 bits, the cube unit's default input width. First-level
    # products are 18x18; the exact second level is 18x38 (two DSP tiles each on ECP5).
    "default": ReflectParams(n_fmt=Fmt(True, 2, 16), e_fmt=Fmt(True, 2, 16), r_bits=18),
    # 12-bit N and E; R in 14 bits, the cube unit's ``small`` input width.
    "small": ReflectParams(n_fmt=Fmt(True, 2, 10), e_fmt=Fmt(True, 2, 10), r_bits=14),
}
register(ReflectParams)
