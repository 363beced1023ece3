"""Input spaces of the streaming co-simulation (:mod:`cosim.stream`) and how runs are cut into shards.

A :class:`Space` is an ordered, indexable set of input vectors of a unit, enumerated by index, so a run or a shard
of a run is an index range ``[lo, hi)``: :func:`shard_range` cuts a space into ``N`` independent shards for
processes or machines, :func:`shard_weights` cuts a list of unequal inputs into shards of about equal work.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Space", "FullSpace", "ProductSpace", "ArraySpace", "ConcatSpace", "full_space", "grid_space", "edge_codes",
           "as_space", "parse_pair", "parse_shard", "shard_range", "shard_weights"]


class Space:
    """An ordered, indexable set of input vectors of a unit (codes, one column per input port).

    ``len(space)`` vectors; ``space.take(lo, hi)`` returns rows ``lo..hi-1`` as an int64 array
    ``(hi - lo, inputs)`` without materializing the rest, so a space of 2**32 vectors streams in chunks.
    """

    def __len__(self) -> int:
        raise NotImplementedError

    def take(self, lo: int, hi: int) -> np.ndarray:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError


class FullSpace(Space):
    """Every input vector, in :meth:`fxmodel.core.unit.Unit.all_inputs` order (first port slowest)."""

    def __init__(self, params):
        self.params = params

    def __len__(self):
        return self.params.input_space()

    def take(self, lo, hi):
        return self.params.all_inputs(lo, hi)

    def describe(self):
        ports = " x ".join(f"{p.name}:{p.fmt} (2^{p.fmt.width})" for p in self.params.inputs)
        return f"all {len(self)} inputs ({ports})"


class ProductSpace(Space):
    """The Cartesian product of one code list per input port, first port slowest.

    Parameters
    ----------
    params : Unit
        The unit (gives the ports and their formats).
    codes : dict
        ``port name -> codes`` (1-D integer array, each code inside the port's format). A port left out takes
        every code of its format.
    why : str
        How the code lists were chosen, for the report.
    """

    def __init__(self, params, codes: dict, why: str = ""):
        names = [p.name for p in params.inputs]
        unknown = sorted(set(codes) - set(names))
        if unknown:
            raise ValueError(f"ProductSpace: {params.NAME} has no input port {', '.join(unknown)} "
                             f"(ports: {', '.join(names)})")
        self.params, self.why, self.lists = params, why, []
        for p in params.inputs:
            if p.name in codes:
                c = np.unique(p.fmt.check(np.asarray(codes[p.name], dtype=np.int64).ravel(),
                                          what=f"ProductSpace codes of port {p.name}"))
                if not len(c):
                    raise ValueError(f"ProductSpace: empty code list for port {p.name}")
            else:
                c = None
            self.lists.append((p, c))

    def __len__(self):
        n = 1
        for p, c in self.lists:
            n *= (1 << p.fmt.width) if c is None else len(c)
        return n

    def take(self, lo, hi):
        idx = np.arange(lo, min(hi, len(self)), dtype=np.int64)
        cols = []
        for p, c in reversed(self.lists):
            size = (1 << p.fmt.width) if c is None else len(c)
            digit = idx % size
            cols.append(p.fmt.min_code + digit if c is None else c[digit])
            idx = idx // size
        return np.stack(cols[::-1], axis=1)

    def describe(self):
        parts = [f"{p.name}: {'all ' + str(1 << p.fmt.width) if c is None else len(c)} codes" for p, c in self.lists]
        return f"{len(self)} inputs, product of {'; '.join(parts)}" + (f" ({self.why})" if self.why else "")


class ArraySpace(Space):
    """Explicit input vectors (codes ``(K, inputs)``)."""

    def __init__(self, codes: np.ndarray, why: str = "given vectors"):
        codes = np.asarray(codes, dtype=np.int64)
        self.codes = codes[:, None] if codes.ndim == 1 else codes
        if self.codes.ndim != 2:
            raise ValueError(f"ArraySpace: input codes must have shape (K, inputs), not {codes.shape}")
        self.why = why

    def __len__(self):
        return len(self.codes)

    def take(self, lo, hi):
        return self.codes[lo:hi]

    def describe(self):
        return f"{len(self)} {self.why}"


class ConcatSpace(Space):
    """Several spaces one after the other."""

    def __init__(self, *parts: Space):
        self.parts = parts
        self.starts = np.cumsum([0] + [len(p) for p in parts]).tolist()

    def __len__(self):
        return self.starts[-1]

    def take(self, lo, hi):
        out = []
        for part, s, e in zip(self.parts, self.starts, self.starts[1:]):
            a, b = max(lo, s), min(hi, e)
            if a < b:
                out.append(part.take(a - s, b - s))
        return np.concatenate(out) if out else self.parts[0].take(0, 0)

    def describe(self):
        return " + ".join(p.describe() for p in self.parts)


def full_space(params) -> FullSpace:
    return FullSpace(params)


def edge_codes(fmt) -> np.ndarray:
    """The codes at the ends and around zero of a format: ``min, min+1, -1, 0, 1, max-1, max`` (those that exist)."""
    c = np.array([fmt.min_code, fmt.min_code + 1, -1, 0, 1, fmt.max_code - 1, fmt.max_code], dtype=np.int64)
    return np.unique(c[(c >= fmt.min_code) & (c <= fmt.max_code)])


def grid_space(params, bits: int, full=(), hard: bool = True) -> Space:
    """A documented large subset of a big input space: a product grid, plus the unit's hard cases.

    Each input port takes ``2**bits`` evenly strided codes (every ``2**(width - bits)``-th code from the most
    negative, so zero and the most negative code are included for signed ports, and with the same codes on every
    port of one format, ties such as ``|x| = |y|`` occur) plus :func:`edge_codes`; a port no wider than ``bits``,
    or named in ``full``, takes every code. The unit's :meth:`hard_cases` come first when ``hard``.
    """
    codes = {}
    for p in params.inputs:
        if p.name in full or p.fmt.width <= bits:
            continue
        stride = 1 << (p.fmt.width - bits)
        codes[p.name] = np.union1d(p.fmt.min_code + stride * np.arange(1 << bits, dtype=np.int64),
                                   edge_codes(p.fmt))
    unknown = sorted(set(full) - {p.name for p in params.inputs})
    if unknown:
        raise ValueError(f"grid_space: {params.NAME} has no input port {', '.join(unknown)}")
    why = f"every 2^(width-{bits})-th code and the edge codes" + (f"; all codes of {', '.join(full)}" if full else "")
    grid = ProductSpace(params, codes, why)
    if not hard:
        return grid
    return ConcatSpace(ArraySpace(params.hard_cases(), f"hard cases of {params.NAME}"), grid)


def as_space(params, space) -> Space:
    """``None`` (the whole input space), a :class:`Space`, or explicit codes ``(K, inputs)``."""
    if space is None:
        return FullSpace(params)
    if isinstance(space, Space):
        return space
    return ArraySpace(space)


def parse_pair(text: str, option: str, sep: str, names: str, example: str, what: str) -> tuple[int, int]:
    """``"a<sep>b"`` (1-based, ``1 <= a <= b``) to ``(a, b)``; ``ValueError`` naming ``option`` and the bad text
    (``names``: the two letters as the message spells them, e.g. ``"iN"``; ``what``: the things numbered)."""
    a_, b_ = names
    try:
        a, b = (int(x) for x in str(text).split(sep))
    except ValueError:
        raise ValueError(f"{option} {text!r}: expected {a_}{sep}{b_} with integers, e.g. {example}") from None
    if not 1 <= a <= b:
        raise ValueError(f"{option} {text!r}: need 1 <= {a_} <= {b_} ({what} are numbered from 1)")
    return a, b


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/N"`` (1-based, ``1 <= i <= N``) to ``(i, N)``; ``ValueError`` naming the bad text."""
    return parse_pair(text, "--shard", "/", "iN", "1/4", "shards")


def shard_range(size: int, shard: tuple[int, int] | str | None) -> tuple[int, int]:
    """Index range ``[lo, hi)`` of shard ``i`` of ``N`` (1-based) of a space of ``size`` vectors.

    The ``N`` ranges are contiguous, disjoint, cover ``[0, size)`` and differ in length by at most one.
    """
    if shard is None:
        return 0, size
    i, n = parse_shard(shard) if isinstance(shard, str) else shard
    if not 1 <= i <= n:
        raise ValueError(f"shard {i}/{n}: need 1 <= i <= N")
    return size * (i - 1) // n, size * i // n



def shard_weights(weights, shards: int) -> list[tuple[int, int]]:
    """``shards`` contiguous ranges ``[a, b)`` covering ``range(len(weights))``, each as close as whole items
    allow to an equal share of the total weight (none empty: at most ``len(weights)`` ranges)."""
    weights = np.asarray(weights, dtype=np.float64)
    n = len(weights)
    shards = max(1, min(int(shards), n))
    cum = np.concatenate([[0.0], np.cumsum(weights)])
    cuts = [0]
    for k in range(1, shards):
        # the boundary nearest k/shards of the weight, kept strictly inside and increasing
        target = cum[-1] * k / shards
        cut = int(np.searchsorted(cum, target, side="left"))
        if cut > 0 and (cut > n or target - cum[cut - 1] <= cum[cut] - target):
            cut -= 1
        cut = min(max(cut, cuts[-1] + 1), n - (shards - k))
        cuts.append(cut)
    cuts.append(n)
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:])]
