"""The golden model's core: fixed-point formats, rounding and overflow rules, the unit registry, cost model, paths."""
