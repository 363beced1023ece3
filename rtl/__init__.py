"""Amaranth RTL of the pipeline's units, each built from its ``fxmodel`` parameter object (see ``rtl.unit``)."""

from .unit import build
from .verilog import verilog_text, write_verilog

__all__ = ["build", "verilog_text", "write_verilog"]
