"""RTL of the reflection-vector unit ``R = 2 N (N.E) - E (N.N)`` (paper, section 2, EQ 1), block-normalized.

Built from :class:`fxmodel.units.reflect.ReflectParams`; the datapath is the model's, stage for stage (see
``fxmodel/units/reflect.py`` for the algorithm, the no-overflow proof and the error bound). Fully pipelined, one
result per clock.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Value

from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.reflect import ReflectParams

from .fixed import narrow, saturate
from .recip import leading_zero_groups, leading_zeros_of_groups
from .unit import Pipe, UnitComponent, register

__all__ = ["Reflect", "LZ_GROUP"]

#: Bits of each group whose leading zeros the OR stage counts (the first two levels of the tree there, the rest
#: in the stage after it).
LZ_GROUP = 4

def _digits(P: ReflectParams, key: str, x) -> list:
    """The signal ``x`` of the second-level operand ``key`` as the signed digits of ``P.digits(key)``:
    ``x = sum_j d_j 2**low_j``; every digit but the top one is zero-extended (non-negative), the top one carries
    the sign of a signed ``x``."""
    x = Value.cast(x)
    out = []
    for lo, hi, bits in P.digits(key):
        digit = x[lo:hi] if bits == hi - lo else Cat(x[lo:hi], Const(0, 1))
        out.append(digit.as_signed())
    return out


def _mul(P: ReflectParams, a, d):
    """``a * d`` for signed ``a`` and a signed digit ``d``: a DSP product, or shifts and adds for a digit of at
    most ``P.LUT_DIGIT_BITS`` bits."""
    if len(d) > P.LUT_DIGIT_BITS:
        return a * d
    total = 0
    for b in range(len(d)):
        term = Mux(d[b], a << b, 0)
        total = total - term if b == len(d) - 1 else total + term      # the top bit of a signed digit weighs -2**b
    return total


@register(ReflectParams)
class Reflect(UnitComponent):
    """Reflection vector ``R = 2 N (N.E) - E (N.N)``, scaled by a common power of two and truncated.

    Ports (formats from :class:`~fxmodel.units.reflect.ReflectParams`)
    -----------------------------------------------------------
    i_valid : Signal(1), in
    Nx, Ny, Nz : Signal(signed(nN)), in -- ``n_fmt``
    Ex, Ey, Ez : Signal(signed(nE)), in -- ``e_fmt``
    o_valid : Signal(1), out
    Rx, Ry, Rz : Signal(signed(r_bits)), out -- ``r_fmt = s1.(r_bits-1)``; the
        largest magnitude is at least 1/2 unless ``degenerate``
    degenerate : Signal(1), out -- ``R = 0`` (``N = 0`` or ``E = 0``); ``Rx = Ry = Rz = 0`` then

    Latency: ``params.latency`` = 11 cycles. Stages: the inputs | ``N_i E_i``, ``N_i N_i`` (six 18x18
    multipliers) | dot sums ``p``, ``q`` | the same, registered again | partial products of ``N_i`` and ``E_i``
    with the 17-bit digits of ``p`` and ``q`` (18x18 DSP tiles; a top digit of at most 4 bits by shifts and adds)
    | the same, registered again | per digit ``A_j = 2 N_i p_j - E_i q_j`` | ``R_i = sum_j A_j 2**(17 j)`` | ``OR_i
    (R_i XOR sign)`` | its leading-zero count | barrel shift and truncation to ``r_fmt`` (output registers). Each
    stage holds one product or one to two carry chains (ECP5 timing).

    The ``degenerate`` flag is computed from the inputs (``N = 0`` or ``E = 0``, two narrow zero detectors)
    instead of a zero test of the wide ``R``; they agree by ``|R| = |E| |N|**2`` (the model tests ``R = 0``).
    """

    def elaborate(self, platform):
        P = self.params
        w = P.widths()
        W = P.W
        m = Module()
        pipe = Pipe(m, platform=platform)
        # 0: the inputs registered (on an ECP5 the first products' blocks take these registers as their own input
        #    registers: the route from the unit before ends in a block, not through its multiplier)
        s0 = pipe.stage(**{n: getattr(self, n) for n in ("Nx", "Ny", "Nz", "Ex", "Ey", "Ez")})
        N = [s0.Nx, s0.Ny, s0.Nz]
        E = [s0.Ex, s0.Ey, s0.Ez]

        # 1: first-level products
        st = {}
        for i in range(3):
            st[f"ne{i}"] = saturate(N[i] * E[i], w["N*E"], Overflow.PROVEN)[0]
            st[f"nn{i}"] = saturate(N[i] * N[i], w["N*N"], Overflow.PROVEN)[0]
            st[f"N{i}"] = N[i]
            st[f"E{i}"] = E[i]
        st["zero"] = (Cat(*N) == 0) | (Cat(*E) == 0)
        s1 = pipe.stage(**st)

        # 2: dot products p = N.E, q = N.N
        p, _ = saturate(s1.ne0 + s1.ne1 + s1.ne2, w["N.E"], Overflow.PROVEN)
        q, _ = saturate(s1.nn0 + s1.nn1 + s1.nn2, w["N.N"], Overflow.PROVEN)
        s2 = pipe.stage(p=p, q=q, zero=s1.zero, **{f"N{i}": getattr(s1, f"N{i}") for i in range(3)},
                        **{f"E{i}": getattr(s1, f"E{i}") for i in range(3)})
        # the sums registered once more, as their digits: p and q cut into 17-bit digits (18-bit signed DSP
        # operands). On an ECP5 the digit products' blocks take these registers as their input registers, fed from
        # registers (not from the sums' carry chains, three blocks a digit away); a digit registered as itself,
        # not as a slice of p with a zero bit joined in the next stage, is an operand rtl/dsp.py recognizes
        pd, qd = _digits(P, "N.E", s2.p), _digits(P, "N.N", s2.q)
        s2 = pipe.stage(**{f"pd{j}": d for j, d in enumerate(pd)}, **{f"qd{j}": d for j, d in enumerate(qd)},
                        **{k: getattr(s2, k) for k in ("zero", "N0", "N1", "N2", "E0", "E1", "E2")})

        # 3: second-level partial products: each wide product N_i p, E_i q is a few 18x18 tiles whose sum is left
        #    to the next stages
        pp = [getattr(s2, f"pd{j}") for j in range(len(pd))]
        qp = [getattr(s2, f"qd{j}") for j in range(len(qd))]
        st = {"zero": s2.zero}
        for i in range(3):
            Ni, Ei = getattr(s2, f"N{i}"), getattr(s2, f"E{i}")
            for j, d in enumerate(pp):
                st[f"np{i}{j}"] = _mul(P, Ni, d)
            for j, d in enumerate(qp):
                st[f"eq{i}{j}"] = _mul(P, Ei, d)
        s3 = pipe.stage(**st)
        # the partial products registered again in the fabric: on an ECP5 each is a block's output register, and
        # the route from a block to the carry chain below ran across the die (most of the engine's endpoints
        # missing 100 MHz were the differences A_j); this register lets the placer split that route
        s3 = pipe.stage(**{k: getattr(s3, k) for k in st})

        # 4: per digit position j, A_j = 2 N_i p_j - E_i q_j
        st = {"zero": s3.zero}
        for i in range(3):
            for j in range(max(len(pp), len(qp))):
                a = (getattr(s3, f"np{i}{j}") << 1) if j < len(pp) else 0
                b = getattr(s3, f"eq{i}{j}") if j < len(qp) else 0
                st[f"A{i}{j}"] = a - b
        s4 = pipe.stage(**st)

        # 5: R_i = sum_j A_j 2**(17 j) = 2 N_i p - E_i q (fits W + 1 bits by |R| = |E| |N|**2)
        st = {"zero": s4.zero}
        for i in range(3):
            total = 0
            for j in range(max(len(pp), len(qp))):
                total = total + (getattr(s4, f"A{i}{j}") << (P.DIGIT_BITS * j))
            st[f"R{i}"] = saturate(total, P.exact_fmt, Overflow.PROVEN)[0]
        s5 = pipe.stage(**st)
        R = [getattr(s5, f"R{i}") for i in range(3)]

        # 6: the W-bit OR_i (R_i XOR sign), whose leading zeros are the common shift lz = W - bitlen(...), and
        #    the first levels of their balanced tree: (all zero, count) of each LZ_GROUP-bit group
        ones = [(r ^ r[W].replicate(W + 1))[:W] for r in R]
        groups = leading_zero_groups(ones[0] | ones[1] | ones[2], LZ_GROUP)
        s6 = pipe.stage(**{f"gz{j}": z for j, (z, _) in enumerate(groups)},
                        **{f"gc{j}": c for j, (_, c) in enumerate(groups)},
                        zero=s5.zero, **{f"R{i}": R[i] for i in range(3)})

        # 7: lz, the rest of the tree (the whole tree in this stage was nine LUT levels on the board)
        lz = leading_zeros_of_groups([(getattr(s6, f"gz{j}"), getattr(s6, f"gc{j}")) for j in range(len(groups))], W)
        s6 = pipe.stage(lz=lz, zero=s6.zero, **{f"R{i}": getattr(s6, f"R{i}") for i in range(3)})

        # 8: shift left by lz (fits W + 1 bits: normalization proof), read with W fraction bits, truncate to r_fmt
        outs = {}
        for i, c in enumerate("xyz"):
            shifted, _ = saturate(getattr(s6, f"R{i}") << s6.lz, P.norm_fmt, Overflow.PROVEN)
            outs[f"R{c}"] = narrow(shifted, W, P.r_fmt, Rounding.TRUNC, Overflow.PROVEN)[0]
        outs["degenerate"] = s6.zero
        self.finish(m, pipe, outs)
        return m
