r"""Shading: ``color = texture * (ambient + diffuse) + specular``, saturated to 8-bit RGB (paper, sections 2 and 4).

All light sources are baked into two reflectance cubes (``fxmodel/pipeline/lighting.py``): the diffuse cube, indexed by
the perturbed normal, holds the *factor* ``D = ambient + sum_l c_l max(0, n.l)`` that multiplies the texture
albedo; the specular cube, indexed by the reflection vector, holds ``S`` already scaled to output bytes
(``255 * sum_l k_s c_l max(0, r.l)**shininess``). With the texture byte ``b`` (albedo ``b / 255``) the output byte is
``o = 255 (b/255 * D + S/255) = b D + S``: no division anywhere.

Algorithm (bit-exact; ``rtl/shade.py`` from the same :class:`ShadeParams`): per channel the exact ``b D + S``
(``S`` aligned to ``D``'s fraction bits) and *one* narrowing to a byte, ``Rounding.HALF_UP`` and
``Overflow.SATURATE``; ``saturated`` is the OR of the three channels' flags (a highlight brighter than white).
Error: within half an output step of the exact ``b D + S`` unless saturated.

Hard cases (each has a test): black texture, white texture with the largest ``D`` and ``S`` (saturates),
``D = 0`` with ``S > 0`` (specular only), exact half steps (round up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxmodel.core.cost import Product
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, Unit, register

__all__ = ["ShadeParams", "RGB"]

RGB = "rgb"


@dataclass(frozen=True)
class ShadeParams(Unit):
    """Parameters of the shading unit.

    Parameters
    ----------
    tex_fmt : Fmt
        Unsigned format of a texture channel (a byte).
    diffuse_fmt : Fmt
        Unsigned format of a diffuse-cube channel (the factor ``D``).
    specular_fmt : Fmt
        Unsigned format of a specular-cube channel (``S`` in output-byte units).
    """

    NAME = "shade"

    tex_fmt: Fmt = Fmt(False, 8, 0)
    diffuse_fmt: Fmt = Fmt(False, 2, 10)
    specular_fmt: Fmt = Fmt(False, 8, 4)

    def __post_init__(self):
        for name in ("tex_fmt", "diffuse_fmt", "specular_fmt"):
            fmt = getattr(self, name)
            if not isinstance(fmt, Fmt) or fmt.signed:
                raise ValueError(f"{name}={fmt!r}: must be an unsigned Fmt")

    @property
    def out_fmt(self) -> Fmt:
        return Fmt(False, 8, 0)

    @property
    def frac(self) -> int:
        return max(self.tex_fmt.frac_bits + self.diffuse_fmt.frac_bits, self.specular_fmt.frac_bits)

    @property
    def inputs(self):
        return (tuple(Port(f"t{c}", self.tex_fmt, "texture byte") for c in RGB)
                + tuple(Port(f"d{c}", self.diffuse_fmt, "diffuse factor") for c in RGB)
                + tuple(Port(f"s{c}", self.specular_fmt, "specular, in output bytes") for c in RGB))

    @property
    def outputs(self):
        return (tuple(Port(c, self.out_fmt, "output byte") for c in RGB)
                + (Port("saturated", Fmt(False, 1, 0), "some channel clipped at 255"),))

    def products(self) -> tuple:
        """``t D`` per channel."""
        t, d = self.tex_fmt, self.diffuse_fmt
        return (Product(t.width, d.width, t.signed, d.signed, count=len(RGB), name="t*D"),)

    @property
    def latency(self) -> int:
        """Products | sum, rounding, saturation."""
        return 2

    def shade(self, tex, diffuse, specular):
        """Bytes ``(K, 3)`` and the saturation flag from code arrays of shape ``(K, 3)``."""
        a = self.frac - self.tex_fmt.frac_bits - self.diffuse_fmt.frac_bits
        b = self.frac - self.specular_fmt.frac_bits
        exact = ((tex * diffuse) << a) + (specular << b)
        out, flag = narrow(exact, self.frac, self.out_fmt, Rounding.HALF_UP, Overflow.SATURATE, "shade")
        return out, flag.any(axis=-1)

    def _compute(self, cols):
        out, sat = self.shade(np.stack(cols[0:3], 1), np.stack(cols[3:6], 1), np.stack(cols[6:9], 1))
        return [out[:, 0], out[:, 1], out[:, 2], sat.astype(np.int64)]

    def hard_cases(self) -> np.ndarray:
        t, d, s = self.tex_fmt, self.diffuse_fmt, self.specular_fmt
        half = 1 << (self.diffuse_fmt.frac_bits - 1)
        rows = []
        for tv in (0, 1, t.max_code):
            for dv in (0, 1 << d.frac_bits, d.max_code, half):
                for sv in (0, 1 << (s.frac_bits - 1) if s.frac_bits else 0, s.max_code):
                    rows.append([tv, tv, tv, dv, dv, dv, sv, sv, sv])
        return np.array(rows, dtype=np.int64)

    def _info(self):
        return {"max_error": {c: 0.5 for c in RGB}, "max_error_units": "output bytes, unless saturated"}


ShadeParams.PRESETS = {"default": ShadeParams()}
register(ShadeParams)
