"""RTL construction from parameter objects: ports and latency come from the model's parameters."""

import pytest

from fxmodel.fixed import Fmt
from fxmodel.unit import preset
from rtl import build, write_verilog
from rtl.unit import Pipe, UnitComponent


@pytest.mark.parametrize("unit, name", [("recip", "default"), ("recip", "small"), ("divide", "default")])
def test_ports_follow_the_parameter_object(unit, name):
    params = preset(unit, name)
    comp = build(params)
    members = comp.signature.members
    for port in params.inputs + params.outputs:
        shape = members[port.name].shape
        assert (shape.width, shape.signed) == (port.fmt.width, port.fmt.signed), port.name
    assert {"i_valid", "o_valid"} <= set(members.keys())


def test_verilog_is_written_with_the_module_name(tmp_path):
    path = write_verilog(preset("recip", "small"), tmp_path / "recip_small.v")
    text = path.read_text()
    assert "module recip_small(" in text and "mant" in text


def test_latency_mismatch_is_caught():
    params = preset("recip", "small")

    class Wrong(UnitComponent):
        def elaborate(self, platform):
            from amaranth.hdl import Module
            m = Module()
            pipe = Pipe(m)
            pipe.stage(x=self.w)
            self.finish(m, pipe, {"mant": 0, "exp": 0, "dbz": 0})
            return m

    from amaranth.back import rtlil
    with pytest.raises(AssertionError, match="pipeline has 2 stages but RecipParams.latency says"):
        rtlil.convert(Wrong(params))


def test_unknown_params_have_no_rtl():
    with pytest.raises(ValueError, match="no RTL for Fmt"):
        build(Fmt(True, 2, 2))
