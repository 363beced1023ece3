"""What every unit's RTL shares: the port signature derived from the parameter object, a pipeline builder that
counts stages (so the latency the model documents is checked, not trusted), the registry from parameter class
to component, and Verilog generation.

Flat port convention (the per-vector co-simulation harness relies on it; :mod:`rtl.streams` wraps every unit
in stream interfaces for everything else): ``i_valid`` and one input port per
``params.inputs`` entry, ``o_valid`` and one output port per ``params.outputs`` entry, same names, widths from the
formats; plus Amaranth's ``clk`` and ``rst``. ``o_valid`` is ``i_valid`` delayed by ``params.latency`` cycles and
each output belongs to the input accepted ``latency`` cycles earlier: one result per clock.
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Module, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .dsp import RegisterSources, block, logic_product, registered_product, uses_blocks
from .fixed import shape

__all__ = ["unit_signature", "Pipe", "kept_copy", "named", "with_next", "COPY_SUFFIX", "KEEP_COPIES", "register",
           "build", "stream_native", "component_class"]


def unit_signature(params) -> wiring.Signature:
    members = {"i_valid": In(1)}
    members.update({p.name: In(shape(p.fmt)) for p in params.inputs})
    members["o_valid"] = Out(1)
    members.update({p.name: Out(shape(p.fmt)) for p in params.outputs})
    return wiring.Signature(members)


class UnitComponent(wiring.Component):
    """Base class: a component whose signature comes from its parameter object."""

    def __init__(self, params):
        self.params = params
        super().__init__(unit_signature(params))

    def finish(self, m: Module, pipe: Pipe, outputs: dict):
        """Register ``outputs`` (port name -> expression) as the last stage, drive ``o_valid``, check latency."""
        for name, expr in outputs.items():
            m.d.sync += getattr(self, name).eq(expr)
        pipe.depth += 1
        m.d.comb += self.o_valid.eq(pipe.delay(self.i_valid, pipe.depth, "valid"))
        if pipe.depth != self.params.latency:
            raise AssertionError(f"{type(self).__name__}: pipeline has {pipe.depth} stages but "
                                 f"{type(self.params).__name__}.latency says {self.params.latency}")


#: The name's end of every flip-flop copy of a net with a device-wide fan-out (:func:`kept_copy`: the registers
#: beside each block RAM of the on-chip frame, ``rtl/rop.py``; the scan converter's span offset beside each
#: attribute's multiplier blocks, ``rtl/raster.py``). Yosys's ``opt_merge`` merges flip-flops with one input into
#: one (a ``keep`` on the wire does not stop it), undoing the copies; a ``keep`` on the cell does:
#: :data:`KEEP_COPIES`.
COPY_SUFFIX = "_kept_copy"

#: The Yosys command (run after reading the design, before any optimisation) that marks the cells driving the
#: copies (:data:`COPY_SUFFIX`) ``keep`` (``%a``: Amaranth's RTLIL may name the register's output after a port
#: it drives, the copy's name an alias of it). The registers must be cells by then: Amaranth's RTLIL makes them
#: so; a design read from Verilog is elaborated first (``hierarchy``, ``proc``: ``tools.fpga.SYNTH_SCRIPT``), or
#: the selection is empty and every copy merged.
KEEP_COPIES = f"setattr -set keep 1 w:*{COPY_SUFFIX} %a %ci1 t:* %i"


def kept_copy(m: Module, value, name: str) -> Signal:
    """A register copy of ``value`` (one clock late) named ``name`` + :data:`COPY_SUFFIX`: synthesis with
    :data:`KEEP_COPIES` keeps it apart from its twins, so the placer can put each copy near the loads it drives.
    Not a :class:`Pipe` register: a multiplier block never takes it as its input register (``rtl/dsp.py``)."""
    value = Value.cast(value)
    reg = Signal(value.shape(), name=f"{name}{COPY_SUFFIX}")
    m.d.sync += reg.eq(value)
    return reg


def with_next(m: Module, reg: Signal) -> Signal:
    """The value ``reg`` takes at the end of this clock, a combinational signal named ``<reg>_next``: ``reg``
    unless assigned (in ``m.d.comb``, under the conditions that change the register, where ``m.d.sync`` would
    assign ``reg``), and ``reg`` its register. For a decision taken a clock ahead from what the registers become,
    so that it is itself a register (the texel cache's step: :mod:`rtl.texcache_step`); ``reg`` must have no
    other driver."""
    nxt = Signal(reg.shape(), name=f"{reg.name}_next")
    m.d.comb += nxt.eq(reg)
    m.d.sync += reg.eq(nxt)
    return nxt


def named(m: Module, value, name: str) -> Signal:
    """A combinational signal ``name`` equal to ``value``, for a subexpression read more than once (a bit at a
    time, or by several expressions). Amaranth lowers each statement's expression tree by copying it (its
    ``DomainLowerer`` shares nothing), so an expression read ``k`` times is emitted ``k`` times and a tree of such
    reads grows with their product (the level of detail's leading-zero counts over magnitudes, the scan converter's
    carry-save span products: ``docs/performance.md``). Through a signal each is emitted once."""
    value = Value.cast(value)
    sig = Signal(value.shape(), name=name)
    m.d.comb += sig.eq(value)
    return sig


class Pipe:
    """Builds a pipeline one registered stage at a time and counts its depth.

    ``platform`` is the one ``elaborate`` received: on an ECP5 (:func:`rtl.dsp.uses_blocks`) a stage that
    registers a product puts it in a multiplier block with the block's own registers (:mod:`rtl.dsp`); the function
    is the same, clock for clock. ``sources`` is shared by the pipes of one design whose stages feed each other's
    products (by default each pipe keeps its own)."""

    def __init__(self, m: Module, prefix: str = "", platform=None, sources: RegisterSources | None = None):
        self.m = m
        self.depth = 0
        self.prefix = prefix
        self.blocks = uses_blocks(platform)
        self.sources = RegisterSources() if sources is None else sources

    def _register(self, reg: Signal, expr: Value) -> None:
        self.m.d.sync += reg.eq(expr)
        if self.blocks and not self._conditional():         # a register with an enable is not its input delayed
            self.sources.add(reg, expr)

    def _conditional(self) -> bool:
        """Whether the module is inside an ``If``/``Switch``/``FSM`` (Amaranth's private control stack)."""
        return bool(self.m._ctrl_stack)

    def stage(self, **exprs) -> SimpleNamespace:
        """Register each expression (shape kept) as the next stage; return the registers by name."""
        self.depth += 1
        regs = {}
        for name, expr in exprs.items():
            product = registered_product(expr) if self.blocks and not self._conditional() else None
            narrow = logic_product(expr) if self.blocks else None
            expr = Value.cast(expr) if narrow is None else narrow
            reg = Signal(expr.shape(), name=f"{self.prefix}s{self.depth}_{name}")
            if product is None:
                self._register(reg, expr)
            else:
                self.m.d.comb += reg.eq(block(self.m, product, self.sources, reg.name))
            regs[name] = reg
        return SimpleNamespace(**regs)

    def delay(self, value, cycles: int, name: str = "dly") -> Value:
        """``value`` delayed by ``cycles`` registers (a shift register; 0 returns ``value``)."""
        value = Value.cast(value)
        for i in range(cycles):
            reg = Signal(value.shape(), name=f"{self.prefix}{name}{i + 1}")
            self._register(reg, value)
            value = reg
        return value


_COMPONENTS: dict[type, type] = {}


def register(params_cls):
    """Class decorator on a component: it is the RTL of ``params_cls``."""
    def deco(component_cls):
        _COMPONENTS[params_cls] = component_cls
        return component_cls
    return deco


def build(params) -> wiring.Component:
    """The RTL component of a parameter object."""
    return component_class(params)(params)


def stream_native(params) -> bool:
    """Whether the RTL of ``params`` has stream ports of its own (``i``, ``o``: the scan converter, the engine
    from the triangle) rather than being a flat :class:`UnitComponent` that :class:`rtl.streams.StreamUnit`
    wraps."""
    return not issubclass(component_class(params), UnitComponent)


def component_class(params) -> type:
    """The registered RTL component class of a parameter object (``ValueError`` if it has none)."""
    import importlib

    # the RTL of a unit lives under its model's file stem: fxmodel/units/recip.py -> rtl/recip.py
    stem = type(params).__module__.rpartition(".")[2]
    try:
        importlib.import_module(f"{__package__}.{stem}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__package__}.{stem}":       # a broken import inside the unit's RTL: say so
            raise
    try:
        return _COMPONENTS[type(params)]
    except KeyError:
        raise ValueError(f"no RTL for {type(params).__name__}") from None
