"""``fxmodel/core/rounding.py`` against an outside oracle: apytypes, a well-kept fixed-point library.

Every rounding and overflow mode the project has, mapped to apytypes' by the one table in
``fxmodel/units/apy_oracle.py`` (its docstring says why each mapping is right), must give bit-identical codes and flags:
on single narrowings of any format pair (signed, unsigned, narrowing the fraction or the integer bits, ties next
to even and odd codes), on products and sums narrowed as the units do (apytypes doing the arithmetic too), on the
bump and shade units' own narrowings over their presets, on the host's float quantization and on the barrel
shifter's data-dependent shift. Where the two disagree, exact integer math (:mod:`fxmodel.units.exact`) says which one
is wrong, in the failure message.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from apytypes import APyFixedArray, OverflowMode, QuantizationMode
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow, quantize, shift_round
from fxmodel.core.unit import preset, preset_names
from fxmodel.units.apy_oracle import QUANTIZATION, codes_of, narrow_apy, to_apy
from fxmodel.units.exact import narrow_exact, round_exact


def formats(int_bits, frac_bits, signed=None):
    """Valid formats (a signed word needs a sign bit and one more); ``signed`` a strategy (default: either)."""
    signed = st.booleans() if signed is None else signed
    return st.tuples(signed, int_bits, frac_bits).filter(lambda t: t[1] + t[2] >= 1 + t[0]).map(lambda t: Fmt(*t))


fmts = formats(st.integers(-4, 12), st.integers(0, 20))
modes = st.sampled_from(list(Rounding))
overflows = st.sampled_from(list(Overflow))


def codes_in(fmt: Fmt, shift: int):
    """Codes of ``fmt``: anywhere in the range, at its ends, or exact ties of a right shift by ``shift``."""
    anywhere = st.integers(fmt.min_code, fmt.max_code)
    ends = st.sampled_from([fmt.min_code, fmt.min_code + 1, fmt.max_code - 1, fmt.max_code, 0])
    if shift <= 0:
        return st.one_of(anywhere, ends)
    half = 1 << (shift - 1)
    ties = st.integers(fmt.min_code >> shift, fmt.max_code >> shift).map(lambda q: (q << shift) + half).filter(
        lambda c: fmt.min_code <= c <= fmt.max_code)
    return st.one_of(anywhere, ends, ties)


def agree(codes, from_frac, fmt, rounding, overflow, model, apy, what):
    """Assert model == apytypes row by row; on a difference, name the wrong side against exact math."""
    for row, (c, m, a) in enumerate(zip(np.ravel(codes).tolist(), model, apy)):
        if m != a:
            e = narrow_exact(c, from_frac, fmt, rounding, overflow)[:2]
            wrong = " and ".join(n for n, v in (("model", m), ("apytypes", a)) if v != e) or "neither (?)"
            raise AssertionError(f"{what} {rounding.name}+{overflow.name} to {fmt}, row {row}, code {c}: "
                                 f"model {m}, apytypes {a}, exact {e}: {wrong} wrong")


def check_narrow(codes, src: Fmt, dst: Fmt, rounding: Rounding, overflow: Overflow, what: str, arr=None):
    """The model's narrowing of ``codes`` (``src.frac_bits`` fraction bits) against apytypes' of ``arr``."""
    codes = np.asarray(codes)
    ac, aflag = narrow_apy(to_apy(codes, src) if arr is None else arr, dst, rounding, overflow)
    if overflow is Overflow.SATURATE:
        mc, mflag = narrow(codes, src.frac_bits, dst, rounding, overflow)
        agree(codes, src.frac_bits, dst, rounding, overflow, zip(mc.tolist(), mflag.tolist()),
              zip(ac.tolist(), aflag.tolist()), what)
        return
    fits = ~aflag                                   # PROVEN: identical where the proof holds ...
    mc, mflag = narrow(codes[fits], src.frac_bits, dst, rounding, overflow)
    agree(codes[fits], src.frac_bits, dst, rounding, overflow, zip(mc.tolist(), mflag.tolist()),
          zip(ac[fits].tolist(), aflag[fits].tolist()), what)
    for c, a in zip(codes[~fits][:20].tolist(), ac[~fits][:20].tolist()):
        with pytest.raises(OverflowError, match="proof is wrong"):     # ... the model raises where it fails,
            narrow(np.array([c]), src.frac_bits, dst, rounding, overflow)
        assert a == narrow_exact(c, src.frac_bits, dst, rounding, overflow)[0]   # where the RTL keeps low bits


@given(fmts, fmts, modes, overflows, st.data())
def test_narrow_is_bit_identical_to_apytypes(src, dst, rounding, overflow, data):
    shift = src.frac_bits - dst.frac_bits
    codes = data.draw(st.lists(codes_in(src, shift), min_size=1, max_size=30))
    check_narrow(np.array(codes, dtype=np.int64), src, dst, rounding, overflow, "narrow")


operands = formats(st.integers(0, 8), st.integers(0, 18))


@given(operands, operands, fmts, modes, overflows, st.sampled_from(["product", "sum"]), st.data())
def test_products_and_sums_narrowed_as_the_units_do(fa, fb, dst, rounding, overflow, op, data):
    k = data.draw(st.integers(1, 20))
    a = np.array(data.draw(st.lists(codes_in(fa, 0), min_size=k, max_size=k)), dtype=np.int64)
    b = np.array(data.draw(st.lists(codes_in(fb, 0), min_size=k, max_size=k)), dtype=np.int64)
    A, B = to_apy(a, fa), to_apy(b, fb)
    if op == "product":                             # the exact product, as the units form it: a * b
        exact, frac, arr = a * b, fa.frac_bits + fb.frac_bits, A * B
    else:                                           # the exact sum, aligned to the finer operand
        frac = max(fa.frac_bits, fb.frac_bits)
        exact, arr = (a << (frac - fa.frac_bits)) + (b << (frac - fb.frac_bits)), A + B
    assert arr.frac_bits == frac and codes_of(arr).tolist() == exact.tolist()      # the same exact value
    check_narrow(exact, Fmt(True, 20, frac), dst, rounding, overflow, op, arr)


@pytest.mark.parametrize("rounding", list(Rounding))
@pytest.mark.parametrize("overflow", list(Overflow))
def test_s2_16_products_to_s2_14_on_100k_random_and_every_end(rounding, overflow):
    f, dst = Fmt.parse("s2.16"), Fmt.parse("s2.14")
    rng = np.random.default_rng(6)
    ends = np.array([f.min_code, f.min_code + 1, -1, 0, 1, f.max_code - 1, f.max_code])
    a = np.concatenate([np.repeat(ends, len(ends)), rng.integers(f.min_code, f.max_code + 1, 100_000)])
    b = np.concatenate([np.tile(ends, len(ends)), rng.integers(f.min_code, f.max_code + 1, 100_000)])
    check_narrow(a * b, Fmt(True, 4, 32), dst, rounding, overflow, "s2.16 * s2.16", to_apy(a, f) * to_apy(b, f))


def _unit_rows(params, rng):
    return np.concatenate([params.hard_cases(), params.random_inputs(rng, 5000)])


@pytest.mark.parametrize("name", preset_names("bump"))
@pytest.mark.parametrize("rounding", list(Rounding))
def test_bump_units_narrowing_is_apytypes(name, rounding):
    params = preset("bump", name).replace(rounding=rounding)
    rows = _unit_rows(params, np.random.default_rng(7))
    out = params.compute(rows)
    names = [p.name for p in params.inputs]
    e_col = rows[:, names.index("Ae")] if "Ae" in names else np.zeros(len(rows), dtype=np.int64)
    flags = np.zeros(len(rows), dtype=bool)
    for e in np.unique(e_col):                      # N' = N 2**-e + du A[:,0] + dv A[:,1], one narrowing
        sel = e_col == e
        cols = {p.name: to_apy(rows[sel, i], p.fmt) for i, p in enumerate(params.inputs)}
        n_fmt = params.n_fmt
        for i, c in enumerate("xyz"):               # N 2**-e exactly: the same codes read with e more fraction bits
            n = to_apy(rows[sel, names.index(f"N{c}")], Fmt(True, n_fmt.int_bits - int(e), n_fmt.frac_bits + int(e)))
            exact = n + cols["du"] * cols[f"A{i}0"] + cols["dv"] * cols[f"A{i}1"]
            codes, flag = narrow_apy(exact, params.out_fmt, rounding, Overflow.SATURATE)
            assert out[sel, i].tolist() == codes.tolist(), f"bump {name} N'{c} (e = {e})"
            flags[sel] |= flag
    assert out[:, 3].tolist() == flags.astype(int).tolist()


def test_shade_units_narrowing_is_apytypes():
    params = preset("shade")
    rows = _unit_rows(params, np.random.default_rng(8))
    out = params.compute(rows)
    cols = [to_apy(rows[:, i], p.fmt) for i, p in enumerate(params.inputs)]
    flags = np.zeros(len(rows), dtype=bool)
    for i in range(3):                              # byte = texel * diffuse + specular, one narrowing
        codes, flag = narrow_apy(cols[i] * cols[3 + i] + cols[6 + i], params.out_fmt, Rounding.HALF_UP,
                                 Overflow.SATURATE)
        assert out[:, i].tolist() == codes.tolist(), f"shade channel {i}"
        flags |= flag
    assert out[:, 3].tolist() == flags.astype(int).tolist()


@given(st.lists(st.floats(-3000, 3000, allow_nan=False), min_size=1, max_size=30),
       formats(st.integers(1, 10), st.integers(0, 20)), modes)
def test_quantize_is_apytypes(values, fmt, rounding):
    codes, flag = quantize(np.array(values), fmt, rounding, Overflow.SATURATE)
    exact = APyFixedArray.from_float(values, int_bits=13, frac_bits=1080)    # every float64 in range, exactly
    ac, aflag = narrow_apy(exact, fmt, rounding, Overflow.SATURATE)
    assert codes.tolist() == ac.tolist() and flag.tolist() == aflag.tolist(), (values, fmt, rounding)


@given(st.lists(st.tuples(st.integers(-(1 << 30), (1 << 30) - 1), st.integers(0, 34)), min_size=1, max_size=30),
       st.sampled_from([Rounding.TRUNC, Rounding.HALF_UP]))
def test_data_dependent_shift_is_apytypes(pairs, rounding):
    x = np.array([p[0] for p in pairs], dtype=np.int64)
    s = np.array([p[1] for p in pairs], dtype=np.int64)
    got = shift_round(x, s, rounding)
    for k in np.unique(s).tolist():                 # one cast per shift: x * 2**-k rounded to an integer
        sel = s == k
        codes, flag = narrow_apy(to_apy(x[sel], Fmt(True, 31 - k, k)), Fmt(True, 33, 0), rounding,
                                 Overflow.SATURATE)
        assert not flag.any() and got[sel].tolist() == codes.tolist(), (k, rounding)
        assert codes.tolist() == [round_exact(Fraction(v, 1 << k), rounding) for v in x[sel].tolist()]


def test_the_neighbouring_apytypes_modes_would_not_do():
    """Each mapping is the only right one of its neighbours: these differ from the project's mode."""
    x = APyFixedArray.from_float([-2.5, 2.5, -0.25], int_bits=4, frac_bits=2)

    def to_int(q):
        return codes_of(x.cast(int_bits=4, frac_bits=0, quantization=q, overflow=OverflowMode.SAT)).tolist()

    assert to_int(QUANTIZATION[Rounding.HALF_UP]) == [-2, 3, 0]         # floor(x + 1/2)
    assert to_int(QuantizationMode.RND_INF) == [-3, 3, 0]                # ties away from zero: -2.5 -> -3
    assert to_int(QUANTIZATION[Rounding.HALF_EVEN]) == [-2, 2, 0]
    assert to_int(QUANTIZATION[Rounding.TRUNC]) == [-3, 2, -1]           # floor
    assert to_int(QuantizationMode.TRN_ZERO) == [-2, 2, 0]               # toward zero
