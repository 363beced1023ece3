"""``rtl/fixed.py`` simulated against ``fxmodel/core/rounding.py`` and exact integer math, mode by mode.

Every rounding (TRUNC, HALF_UP, HALF_EVEN) and overflow rule (SATURATE with its flag, PROVEN) of the project's
one narrowing, on format pairs that narrow the fraction, the integer part or both, widen the fraction, mix signed
and unsigned words, and shift by as much as or more than the input's width. All lanes go into one combinational
circuit (:mod:`amaranth.sim`, no HDL simulator), built from the same :class:`~fxmodel.core.fixed.Fmt` objects as the
model; each lane is driven with the hard cases (both ends of both ranges, every output boundary and one code past
it, the exact ties ``.5`` next to even and odd codes and the codes either side of them) and random codes. The
expected value comes from exact integer math, so a failure says which side (RTL or model) is wrong.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest
from amaranth.hdl import Module, Signal, signed, unsigned
from amaranth.sim import Simulator

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow, shift_round
from fxmodel.units.exact import narrow_exact, round_exact
from rtl import fixed as rfixed

# (input format, output format): the narrowing reads the input's code with input.frac_bits fraction bits
PAIRS = [
    ("s4.32", "s2.14"),     # the bench's product narrowed as the units do: fraction and integer bits
    ("s2.16", "s2.14"),     # fraction only
    ("s8.8", "s4.8"),       # integer bits only (shift 0)
    ("s3.4", "s3.6"),       # widening the fraction (left shift)
    ("s6.10", "s2.0"),      # down to the narrowest signed word
    ("u4.8", "u2.4"),       # unsigned to unsigned
    ("u4.8", "s3.4"),       # unsigned to signed
    ("s4.8", "u2.4"),       # signed to unsigned: negatives saturate to 0
    ("u3.0", "s5.0"),       # an unsigned word narrower than its signed target
    ("u4.2", "s3.2"),       # an unsigned word wider than its signed target
    ("s3.2", "u5.2"),       # a signed word narrower than its unsigned target
    ("u3.2", "s6.1"),
    ("s-2.8", "s2.2"),      # shift (6) equal to the input's width
    ("s-3.8", "s2.0"),      # shift (8) beyond the input's width (5)
    ("u0.8", "u0.3"),
]
MODES = list(itertools.product(Rounding, Overflow))
RANDOM = 160


def hard_codes(src: Fmt, dst: Fmt) -> list[int]:
    """Input codes at every edge that matters for this pair, clipped to the input's range."""
    shift = src.frac_bits - dst.frac_bits
    codes = {src.min_code, src.min_code + 1, src.max_code, src.max_code - 1, -1, 0, 1}
    targets = {dst.min_code - 1, dst.min_code, dst.min_code + 1, dst.max_code - 1, dst.max_code, dst.max_code + 1,
               *range(-4, 5)}                       # consecutive targets: ties next to even and odd codes
    if shift > 0:
        half = 1 << (shift - 1)
        offsets = {0, 1, -1, half - 1, half, half + 1, -half - 1, -half, -half + 1}
    else:
        offsets = {0}
    codes |= {(t << shift if shift >= 0 else t >> -shift) + o for t in targets for o in offsets}
    return sorted(c for c in codes if src.min_code <= c <= src.max_code)


def run_lanes(lanes, steps):
    """Simulate ``lanes`` (``(input signal, {name: (value expr, capture signal)}, codes)``) for ``steps`` settles
    of the combinational circuit; return ``{lane index: {name: [values]}}``."""
    m = Module()
    for _x, outs, _codes in lanes:
        for expr, sig in outs.values():
            m.d.comb += sig.eq(expr)
    got = {i: {name: [] for name in outs} for i, (_x, outs, _c) in enumerate(lanes)}

    async def bench(ctx):
        for step in range(steps):
            for _x, _outs, codes in lanes:
                for sig, code in zip(_x, codes):
                    ctx.set(sig, code[step % len(code)])
            for i, (_x, outs, _c) in enumerate(lanes):
                for name, (_e, sig) in outs.items():
                    got[i][name].append(ctx.get(sig))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    return got


def wide(expr_width: int) -> Signal:
    """A capture wide enough to show any value of the expression, so a width or sign slip cannot hide."""
    return Signal(signed(expr_width + 2))


def test_narrow_every_mode_and_pair_matches_model_and_exact_math():
    rng = np.random.default_rng(11)
    lanes, cases = [], []
    for src_text, dst_text in PAIRS:
        src, dst = Fmt.parse(src_text), Fmt.parse(dst_text)
        base = hard_codes(src, dst) + rng.integers(src.min_code, src.max_code + 1, RANDOM).tolist()
        for rounding, overflow in MODES:
            x = Signal(rfixed.shape(src), name="x")
            value, flag = rfixed.narrow(x, src.frac_bits, dst, rounding, overflow)
            # the value has the shape its format names (a narrower or other-signed word would hide a slip)
            assert value.shape() == rfixed.shape(dst), (src, dst, rounding, overflow)
            outs = {"value": (value, wide(len(value))), "flag": (flag, Signal())}
            if src.frac_bits == dst.frac_bits and rounding is Rounding.TRUNC:
                # saturate() alone, as the units also call it: on the raw input word, not narrow()'s shifted copy
                value, flag = rfixed.saturate(x, dst, overflow)
                assert value.shape() == rfixed.shape(dst), (src, dst, overflow)
                outs |= {"saturate value": (value, wide(len(value))), "saturate flag": (flag, Signal())}
            lanes.append(([x], outs, [base]))
            cases.append((src, dst, rounding, overflow, base))
    steps = max(len(c[-1]) for c in cases)
    got = run_lanes(lanes, steps)
    for i, (src, dst, rounding, overflow, codes) in enumerate(cases):
        codes = [codes[s % len(codes)] for s in range(steps)]
        want = [narrow_exact(c, src.frac_bits, dst, rounding, overflow) for c in codes]
        tag = f"{src}->{dst} {rounding.name}+{overflow.name}"
        for c, (v, f, _fits), rv, rf in zip(codes, want, got[i]["value"], got[i]["flag"]):
            assert (rv, rf) == (v, f), f"RTL {tag}: code {c}: got {(rv, rf)}, exact {(v, f)}"
        if "saturate value" in got[i]:
            for c, (v, f, _fits), rv, rf in zip(codes, want, got[i]["saturate value"], got[i]["saturate flag"]):
                assert (rv, rf) == (v, f), f"RTL saturate {tag}: code {c}: got {(rv, rf)}, exact {(v, f)}"
        keep = [k for k, w in enumerate(want) if w[2] or overflow is Overflow.SATURATE]
        mv, mf = narrow(np.array(codes, dtype=np.int64)[keep], src.frac_bits, dst, rounding, overflow)
        assert mv.tolist() == [want[k][0] for k in keep], f"model {tag}"
        assert mf.tolist() == [want[k][1] for k in keep], f"model {tag} flag"
        bad = [c for c, w in zip(codes, want) if not w[2]]
        if overflow is Overflow.PROVEN and bad:           # the model checks the proof: one code over raises
            with pytest.raises(OverflowError, match="proof is wrong"):
                narrow(np.array(bad[:1]), src.frac_bits, dst, rounding, overflow)


@pytest.mark.parametrize("src_text", ["s6.10", "u6.10", "s-2.8"])
def test_data_dependent_shift_matches_model_and_exact_math(src_text):
    src = Fmt.parse(src_text)
    rng = np.random.default_rng(12)
    max_shift = src.width + 3
    pairs = [(c, s) for c in (src.min_code, src.min_code + 1, src.max_code, -1, 0, 1) if src.min_code <= c
             for s in range(max_shift + 1)]
    pairs += [(int(c), int(s)) for c, s in zip(rng.integers(src.min_code, src.max_code + 1, 200),
                                                rng.integers(0, max_shift + 1, 200))]
    # ties: x = (2k + 1) 2**(s - 1) for a few k either side of zero
    pairs += [((2 * k + 1) << (s - 1), s) for s in range(1, max_shift + 1) for k in range(-3, 3)
              if src.min_code <= (2 * k + 1) << (s - 1) <= src.max_code]
    lanes, modes = [], [Rounding.TRUNC, Rounding.HALF_UP]
    for rounding in modes:
        x, sh = Signal(rfixed.shape(src)), Signal(unsigned(max_shift.bit_length()))
        value = rfixed.shift_round(x, sh, rounding)
        lanes.append(([x, sh], {"value": (value, wide(len(value)))}, [[c for c, _ in pairs], [s for _, s in pairs]]))
    got = run_lanes(lanes, len(pairs))
    xs, shifts = np.array([c for c, _ in pairs]), np.array([s for _, s in pairs])
    for i, rounding in enumerate(modes):
        want = [round_exact(Fraction(c, 1 << s), rounding) for c, s in pairs]
        assert got[i]["value"] == want, f"RTL {src} {rounding.name}"
        assert shift_round(xs, shifts, rounding).tolist() == want, f"model {src} {rounding.name}"
    with pytest.raises(NotImplementedError):
        rfixed.shift_round(Signal(rfixed.shape(src)), Signal(4), Rounding.HALF_EVEN)
    with pytest.raises(NotImplementedError):
        shift_round(xs, shifts, Rounding.HALF_EVEN)
