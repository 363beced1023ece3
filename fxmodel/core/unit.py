"""The contract every unit's parameter object keeps, and the registry of units and presets.

One frozen dataclass per unit (``RecipParams``, ``DivideParams``, ...) holds the unit's formats and knobs. The
same object drives the golden model (:meth:`Unit.compute`), the RTL (``rtl.build(params)``), the co-simulation
(``cosim``) and the tests. Ports are named and typed once, here, by :attr:`Unit.inputs` / :attr:`Unit.outputs`;
the RTL component has one port per entry (plus ``i_valid`` / ``o_valid``) with exactly these names and widths.

Codes are passed as a 2-D integer array of shape ``(K, ports)`` whose columns follow the port order; this is the
form the CLI, the ``$readmemh`` writer and the co-simulation harness share.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fxmodel.core import cost as _cost
from fxmodel.core.fixed import Fmt, as_codes

__all__ = ["require", "Port", "Unit", "register", "units", "unit_class", "preset", "preset_names"]


def require(cond: bool, param: str, value, why: str):
    """Raise ``ValueError("<param>=<value>: <why>")`` unless ``cond``: every parameter object validates this way,
    so an error always names the parameter and its bad value."""
    if not cond:
        raise ValueError(f"{param}={value!r}: {why}")


@dataclass(frozen=True)
class Port:
    """A named, typed port of a unit."""

    name: str
    fmt: Fmt
    doc: str = ""


class Unit:
    """Mixin for a unit's frozen parameter dataclass.

    A subclass sets ``NAME`` (the unit's file stem, e.g. ``"recip"``) and implements :attr:`inputs`,
    :attr:`outputs`, :attr:`latency`, :meth:`_compute`, :meth:`hard_cases` and :meth:`_info`, and declares its
    hardware for the cost model (:meth:`products`, :meth:`memories`; :mod:`fxmodel.core.cost`).
    """

    NAME: ClassVar[str] = ""
    #: Rows per chunk in :meth:`compute`.
    CHUNK: ClassVar[int] = 1 << 13
    #: Named parameter sets, filled by :func:`register`.
    PRESETS: ClassVar[dict]

    # -- to be provided by each unit ----------------------------------------------------------------------
    @property
    def inputs(self) -> tuple[Port, ...]:
        raise NotImplementedError

    @property
    def outputs(self) -> tuple[Port, ...]:
        raise NotImplementedError

    @property
    def latency(self) -> int:
        """Clock cycles from an input accepted to its result on the outputs (the RTL asserts it matches)."""
        raise NotImplementedError

    def _compute(self, cols: list[np.ndarray]) -> list[np.ndarray]:
        """Output code columns for one chunk of input code columns (already range-checked)."""
        raise NotImplementedError

    def hard_cases(self) -> np.ndarray:
        """Input codes ``(K, inputs)`` of the corner cases named in the unit's docstring."""
        raise NotImplementedError

    def _info(self) -> dict:
        return {}

    def products(self) -> tuple:
        """The products the unit's RTL computes (:class:`fxmodel.core.cost.Product`: operand widths, signedness, how
        many, whether split into registered partial products); none by default."""
        return ()

    def memories(self) -> tuple:
        """The memories the unit's RTL holds (:class:`fxmodel.core.cost.Memory`: words x bits, read ports); none by
        default."""
        return ()

    def cost(self) -> dict:
        """The hardware estimate of :func:`fxmodel.core.cost.estimate`: MULT18X18D and DP16KD blocks, multipliers,
        table and memory bits."""
        return _cost.estimate(self)

    # -- shared behaviour ---------------------------------------------------------------------------------
    def replace(self, **changes):
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def compute(self, codes) -> np.ndarray:
        """Bit-exact golden model: input codes ``(K, inputs)`` (or ``(K,)`` for one input) to output codes.

        Input codes are range-checked against their formats (``ValueError`` naming the port and row).
        """
        codes = np.asarray(codes)
        if codes.ndim == 1 and len(self.inputs) == 1:
            codes = codes[:, None]
        if codes.ndim != 2 or codes.shape[1] != len(self.inputs):
            raise ValueError(f"{self.NAME}: expected input codes of shape (K, {len(self.inputs)}), got {codes.shape}")
        cols = [port.fmt.check(codes[:, i], what=f"{self.NAME} input {port.name}")
                for i, port in enumerate(self.inputs)]
        width = max(p.fmt.width for p in self.outputs)
        out = np.empty((codes.shape[0], len(self.outputs)), dtype=as_codes([], width).dtype, order="F")
        # Cache-sized chunks: every temporary of a chunk stays in L1/L2 (measured 1.5-2x faster than whole
        # arrays of millions of rows, which also spend their time in page faults).
        step = self.CHUNK
        for lo in range(0, codes.shape[0], step):
            for i, col in enumerate(self._compute([c[lo:lo + step] for c in cols])):
                out[lo:lo + step, i] = col
        return out

    def random_inputs(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """``k`` input codes drawn uniformly from each input's full code range."""
        cols = [rng.integers(p.fmt.min_code, p.fmt.max_code, size=k, endpoint=True, dtype=np.int64)
                for p in self.inputs]
        return np.stack(cols, axis=1)

    def input_space(self) -> int:
        """Number of distinct input vectors."""
        return int(np.prod([float(1 << p.fmt.width) for p in self.inputs]))

    def all_inputs(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Input vectors ``start..stop`` of the whole input space, enumerated in code order (first port slowest)."""
        total = self.input_space()
        stop = total if stop is None else min(stop, total)
        idx = np.arange(start, stop, dtype=np.int64)
        cols = []
        for port in reversed(self.inputs):
            size = 1 << port.fmt.width
            cols.append(port.fmt.min_code + idx % size)
            idx = idx // size
        return np.stack(cols[::-1], axis=1)

    def info(self) -> dict:
        """JSON-ready description: ports with formats, latency and the unit's documented bounds."""
        return {
            "unit": self.NAME,
            "params": {f.name: _jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)},
            "inputs": [p.fmt.describe(p.name) for p in self.inputs],
            "outputs": [p.fmt.describe(p.name) for p in self.outputs],
            "latency": self.latency,
            "cost": self.cost(),
            **self._info(),
        }


def _jsonable(value):
    if isinstance(value, Fmt):
        return str(value)
    if isinstance(value, Unit):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (tuple, list)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (int, float, str, bool)) or value is None:
        return value
    if hasattr(value, "value"):                      # enums
        return value.value
    return repr(value)                               # e.g. a texel memory: shape and digest


_UNITS: dict[str, type] = {}


def register(cls):
    """Class decorator: enter a unit (with its ``PRESETS``) in the registry used by the CLI and the harness."""
    if not cls.NAME:
        raise TypeError(f"{cls.__name__} has no NAME")
    if "default" not in cls.PRESETS:
        raise TypeError(f"{cls.__name__}.PRESETS has no 'default'")
    _UNITS[cls.NAME] = cls
    return cls


#: Modules of the units (importing registers them); a unit's RTL lives under the same file stem in ``rtl/``.
UNIT_MODULES = tuple(f"fxmodel.units.{s}" for s in ("recip", "divide", "persp", "reflect", "cube", "bump", "sampler",
                                                     "shade", "lod")) + ("fxmodel.pipeline.pixel",)


#: Blocks with a parameter object and presets but not a unit's one-result-per-input contract (a variable number of
#: outputs per input): ``info`` and ``presets`` know them; the per-unit tests, harnesses and sweeps do not.
BLOCK_MODULES = ("raster", "rop")


def _load_all():
    import importlib
    for module in UNIT_MODULES:
        importlib.import_module(module)


def _block(name: str):
    import importlib
    if name in BLOCK_MODULES:
        module = importlib.import_module(f"fxmodel.units.{name}")
        return next(v for v in vars(module).values() if isinstance(v, type) and getattr(v, "NAME", None) == name
                    and hasattr(v, "PRESETS"))
    return None


def units() -> list[str]:
    _load_all()
    return sorted(_UNITS)


def unit_class(name: str) -> type:
    _load_all()
    if name in _UNITS:
        return _UNITS[name]
    block = _block(name)
    if block is None:
        raise ValueError(f"unknown unit {name!r}; known units: {', '.join(sorted(_UNITS) + list(BLOCK_MODULES))}")
    return block


def preset_names(unit: str) -> list[str]:
    return sorted(unit_class(unit).PRESETS)


def preset(unit: str, name: str = "default"):
    """The parameter object of preset ``name`` of ``unit``."""
    cls = unit_class(unit)
    try:
        return cls.PRESETS[name]
    except KeyError:
        raise ValueError(f"unit {unit!r} has no preset {name!r}; presets: {', '.join(sorted(cls.PRESETS))}") \
            from None
