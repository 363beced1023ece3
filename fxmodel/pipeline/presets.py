"""Pipeline presets: the units dict of each built-in preset and the preset files (``presets/<name>.toml``).

A pipeline preset is a *units dict*: one parameter object per unit of the pixel pipeline (``persp``, ``bump``,
``reflect``, ``cube``, ``shade``; their classes in :data:`UNIT_TYPES`) plus the integer :data:`TOP_KEYS`
(``weight_bits``, ``cube_size``). ``default`` is built in (:data:`BUILTIN_PRESET_UNITS`); any other name is read
from a preset file by :func:`load_preset` (what ``bumpmap fit`` writes with :func:`write_preset`).
:func:`preset_units` turns a name or a units dict into the units that ``PipelineParams.assemble`` uses.

Preset files
------------

A preset file holds one table per unit with that unit's parameter fields; nested parameter objects are sub-tables
(``[persp.recip]``, ``[cube.divide]``, ``[cube.divide.recip]``). Formats are written in their short form
(``str(Fmt)``, a string), enums by name. A field that is missing keeps the ``default`` preset's value. Top-level
keys: ``weight_bits`` (the bump-map and texture bilinear weights), ``cube_size`` (texels per reflectance-cube face
edge), the other :data:`TOP_KEYS` and the free-form ``[fit]`` table (what ``fit`` measured; not read back). A missing
top-level key keeps the ``default`` preset's value too, except those of :data:`FILE_MISSING` (``diffuse_extra_frac``):
there a missing key means the value before the key existed (0), so a file written before keeps its meaning, and
``write_preset`` always writes the key.

``shade.diffuse_fmt`` of a preset is the diffuse reflectance cube's texel format; the pipeline's shading unit takes
the diffuse sampler's output format, ``diffuse_extra_frac`` fraction bits finer (``PipelineParams.assemble`` derives
it: :attr:`fxmodel.units.sampler.SamplerParams.out_channels`).

The folder is ``presets/`` at the repository root, or the environment variable ``FXMODEL_PRESETS``.
"""

from __future__ import annotations

import dataclasses
import enum
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import atomic_writer, presets_dir
from fxmodel.core.unit import require
from fxmodel.units.bump import BumpParams
from fxmodel.units.cube import CubeParams
from fxmodel.units.persp import PerspParams
from fxmodel.units.reflect import ReflectParams
from fxmodel.units.shade import ShadeParams

__all__ = ["TOP_KEYS", "UNIT_KEYS", "UNIT_TYPES", "PRESET_KEYS", "PipelinePreset", "BUILTIN_PRESET_UNITS",
           "PRESET_UNITS", "PresetError",
           "top_value", "top_problem", "preset_units", "presets_dir", "check_preset_name", "preset_path", "load_preset",
           "dump_preset", "write_preset"]

#: The integer keys of a pipeline preset beside its units: ``(default, smallest, largest)``. ``weight_bits``: the
#: bump-map and texture bilinear weights; ``cube_size``: texels per reflectance-cube face edge (6 faces of
#: ``(edge + 2)**2`` words each); ``raster_guard``: the scan converter's interpolators' guard bits beyond the
#: proof's minimum (:class:`fxmodel.units.raster.RasterParams` ``extra_guard``: 1 keeps the accumulated error within a
#: quarter of an output ulp).
#: ``mip_levels``: MIP levels of the color texture's trilinear filter, 0 for none (the default: bilinear at level 0),
#: capped at the full pyramid; ``lod_bias``: the level-of-detail bias, a code of the LOD unit's ``lod_frac`` (8)
#: fraction bits (-128: half a level sharper); ``level_bits``: the blend weight between two levels
#: (:mod:`fxmodel.units.sampler`, step 5). ``diffuse_extra_frac``: fraction bits the diffuse cube sampler's bilinear
#: blend keeps beyond its texels' (``SamplerParams.extra_frac``; the shading unit's diffuse input is that much finer,
#: the texels unchanged); the built-in ``default`` preset sets it. ``span_dsp``: 1 builds the scan converter's
#: span-start products on multiplier blocks, 0 in logic (``RasterParams.span_dsp``: the same sums). ``blend_frac``:
#: with MIP mapping, the fraction bits beyond the texels' that each level's bilinear blends keep before the level
#: blend (``SamplerParams.blend_frac``: 0, the default, keeps them exact; at most ``weight_bits``).
TOP_KEYS = {"weight_bits": (12, 1, 16), "cube_size": (64, 1, 1024), "raster_guard": (1, 0, 8),
            "mip_levels": (0, 0, 16), "lod_bias": (0, -4096, 4096), "level_bits": (8, 1, 8),
            "diffuse_extra_frac": (0, 0, 8), "span_dsp": (1, 0, 1), "blend_frac": (0, 0, 16)}

#: Top-level keys whose value in a preset file that leaves them out is fixed (the value before the key existed),
#: not the base preset's: a file written before keeps its meaning.
FILE_MISSING = {"diffuse_extra_frac": 0}

#: Widest number format a preset file may give a field (sign included): the model's integer arithmetic and the
#: RTL's ports are sized from it; the default preset's widest is 26 bits.
MAX_FMT_BITS = 48

#: The parameter class of each unit in a pipeline preset's units dict.
UNIT_TYPES = {"persp": PerspParams, "bump": BumpParams, "reflect": ReflectParams, "cube": CubeParams,
              "shade": ShadeParams}

#: The units of a preset, in pipeline order.
UNIT_KEYS = tuple(UNIT_TYPES)

#: The free-form table of a preset file that records what ``fit`` measured (written, not read back).
META_KEY = "fit"


class PresetError(KeyError, ValueError):
    """An unknown preset name or a bad preset file (a ``KeyError`` for dict-style lookups, a ``ValueError``
    for the command lines, which print it as one line)."""

    def __str__(self):
        return str(self.args[0]) if self.args else ""


def top_value(units: dict, key: str) -> int:
    """The preset's ``key`` (one of :data:`TOP_KEYS`), or its default when ``units`` leaves it out."""
    return units.get(key, TOP_KEYS[key][0])


def top_problem(key: str, value) -> str | None:
    """Why ``value`` cannot be the preset's ``key`` (one of :data:`TOP_KEYS`), or ``None`` if it can."""
    _, lo, hi = TOP_KEYS[key]
    if isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi:
        return None
    return f"must be an int in {lo}..{hi}"


@dataclasses.dataclass(frozen=True)
class PipelinePreset(Mapping):
    """A pipeline preset: one parameter object per unit of the pixel pipeline and the :data:`TOP_KEYS`, frozen and
    validated like every unit's parameter object.

    It is also a read-only mapping (``preset["persp"]``, ``{**preset, "cube_size": 32}``, ``preset.get(key)``), the
    *units dict* the pipeline's ``assemble``, ``fit`` and the sweeps read; :meth:`from_mapping` validates any such
    mapping into one.

    Parameters
    ----------
    persp, bump, reflect, cube, shade
        The units' parameter objects (classes in :data:`UNIT_TYPES`).
    weight_bits, cube_size, raster_guard, mip_levels, lod_bias, level_bits, diffuse_extra_frac, span_dsp, \
blend_frac : int
        The bilinear weights' bits of the bump map and texture, texels per reflectance-cube face edge, guard bits
        of the scan converter's interpolators, the color texture's MIP mapping, the diffuse cube blend's extra
        fraction bits, the span start's products on multiplier blocks or in logic, the trilinear blends' kept
        fraction bits (ranges and defaults in :data:`TOP_KEYS`).
    """

    persp: PerspParams
    bump: BumpParams
    reflect: ReflectParams
    cube: CubeParams
    shade: ShadeParams
    weight_bits: int = TOP_KEYS["weight_bits"][0]
    cube_size: int = TOP_KEYS["cube_size"][0]
    raster_guard: int = TOP_KEYS["raster_guard"][0]
    mip_levels: int = TOP_KEYS["mip_levels"][0]
    lod_bias: int = TOP_KEYS["lod_bias"][0]
    level_bits: int = TOP_KEYS["level_bits"][0]
    diffuse_extra_frac: int = TOP_KEYS["diffuse_extra_frac"][0]
    span_dsp: int = TOP_KEYS["span_dsp"][0]
    blend_frac: int = TOP_KEYS["blend_frac"][0]

    def __post_init__(self):
        for key, cls in UNIT_TYPES.items():
            value = getattr(self, key)
            require(isinstance(value, cls), f"type(preset[{key!r}])", type(value).__name__, f"must be {cls.__name__}")
        for key in TOP_KEYS:
            problem = top_problem(key, getattr(self, key))
            require(problem is None, f"preset[{key!r}]", getattr(self, key), problem)

    @classmethod
    def from_mapping(cls, units) -> PipelinePreset:
        """A preset from a units mapping: the five units required, the :data:`TOP_KEYS` optional (their defaults),
        any other key refused by name."""
        if isinstance(units, cls):
            return units
        allowed = (*UNIT_TYPES, *TOP_KEYS)
        for key in units:
            require(key in allowed, "preset key", key, f"unknown (a units dict has {', '.join(allowed)})")
        for key in UNIT_TYPES:
            require(key in units, "preset keys", sorted(units),
                    f"a units dict needs {key!r} (all of {', '.join(UNIT_TYPES)})")
        return cls(**dict(units))

    def __getitem__(self, key: str):
        if key not in PRESET_KEYS:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter(PRESET_KEYS)

    def __len__(self) -> int:
        return len(PRESET_KEYS)

    def __hash__(self) -> int:                  # Mapping sets __hash__ = None; a frozen preset is hashable
        return hash(tuple(getattr(self, key) for key in PRESET_KEYS))

    def __eq__(self, other) -> bool:
        """Equal to a preset, or to a units dict of the same entries (its missing :data:`TOP_KEYS` at their
        defaults)."""
        if isinstance(other, Mapping):
            return dict(self) == {**{k: v[0] for k, v in TOP_KEYS.items()}, **dict(other)}
        return NotImplemented


#: The keys of a pipeline preset, in file order: the units, then the :data:`TOP_KEYS`.
PRESET_KEYS = (*UNIT_TYPES, *TOP_KEYS)

#: The built-in ``default`` preset's ``diffuse_extra_frac``: the diffuse factor's second rounding (the cube
#: sampler's blend) that much finer, no more block RAM. Chosen by ``bumpmap precision --extra-frac 0 2 3``
#: (docs/records/precision.json, docs/design-space.md): against the true image (c) 2 is a little better than 3 on
#: the tin plane (3 moves the model nearer float (a), which is not (c)) and the same PSNR on every other shipped
#: scene (FLIP within a unit of its last recorded digit); one bit less.
DIFFUSE_EXTRA_FRAC = 2

BUILTIN_PRESET_UNITS = {
    "default": PipelinePreset(persp=PerspParams.PRESETS["color"], bump=BumpParams.PRESETS["default"],
                              reflect=ReflectParams.PRESETS["default"], cube=CubeParams.PRESETS["default"],
                              shade=ShadeParams.PRESETS["default"], diffuse_extra_frac=DIFFUSE_EXTRA_FRAC),
}


class _PresetUnits(dict):
    """Built-in unit presets by name; a name that is not built in is read from ``presets/<name>.toml``
    (:func:`load_preset`, re-read on every lookup; errors name the file and the key)."""

    def __missing__(self, name):
        return load_preset(name)


PRESET_UNITS = _PresetUnits(BUILTIN_PRESET_UNITS)


def preset_units(preset: str | Mapping) -> PipelinePreset:
    """The units of a pipeline preset, given by name or as the units themselves.

    Parameters
    ----------
    preset : str or mapping
        A name: built in (:data:`BUILTIN_PRESET_UNITS`) or a preset file ``presets/<name>.toml`` (see
        :func:`load_preset`). Or a units mapping (a :class:`PipelinePreset`, or a dict of the same keys:
        ``persp``, ``bump``, ``reflect``, ``cube``, ``shade`` and optionally the :data:`TOP_KEYS`), validated
        into a :class:`PipelinePreset` (:meth:`PipelinePreset.from_mapping`); nothing is registered anywhere.

    Raises
    ------
    PresetError
        An unknown name or a bad preset file (a ``KeyError`` and a ``ValueError``).
    ValueError
        A mapping with a missing, unknown or wrongly typed entry (naming it).
    TypeError
        Anything but a str or a mapping.
    """
    if isinstance(preset, str):
        return PRESET_UNITS[preset]
    if not isinstance(preset, Mapping):
        raise TypeError(f"preset: must be a pipeline preset name (str) or a units dict like "
                        f"BUILTIN_PRESET_UNITS['default'], not {type(preset).__name__} {preset!r}")
    return PipelinePreset.from_mapping(preset)


#: What a preset name may be: it names a file in the presets folder, so no path separators, no leading dot.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}")


def check_preset_name(name) -> str:
    """``name`` if it can name a preset file (:data:`NAME_PATTERN`: letters, digits, ``_ . + -``, not starting
    with a dot, at most 100 characters), else :class:`PresetError` naming it (nothing outside the folder)."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise PresetError(f"bad pipeline preset name {name!r}: use letters, digits, '_', '.', '+', '-' (not first), "
                          f"at most 100 characters")
    return name


def preset_path(name: str, directory=None) -> Path:
    """The file of preset ``name`` (checked, :func:`check_preset_name`) in ``directory`` (default
    :func:`presets_dir`)."""
    return Path(directory if directory is not None else presets_dir()) / f"{check_preset_name(name)}.toml"


# -- writing ------------------------------------------------------------------------------------------------
def _toml_value(value, where: str):
    """``value`` as a TOML value for ``tomli_w``: a format in its short form, an enum by name, a parameter
    object as a table of its init fields."""
    if isinstance(value, Fmt):
        return str(value)
    if isinstance(value, enum.Enum):
        return value.name
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _toml_value(getattr(value, f.name), f"{where}.{f.name}")
                for f in dataclasses.fields(value) if f.init}
    if isinstance(value, dict):
        return {str(k): _toml_value(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_toml_value(v, where) for v in value]
    if isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"{where}: cannot write {type(value).__name__} {value!r} to TOML")


def dump_preset(units: dict, meta: dict | None = None, comment: str = "") -> str:
    """TOML text of a preset (written by ``tomli_w``): ``units`` maps ``persp, bump, reflect, cube, shade`` to
    parameter objects (and optionally the :data:`TOP_KEYS` to ints); ``meta`` (scalars and dicts of scalars)
    goes to the ``[fit]`` table; ``comment`` lines go first, as TOML comments."""
    doc = {key: _toml_value(units[key], key) for key in TOP_KEYS if key in units}
    doc.update({key: _toml_value(units[key], key) for key in UNIT_KEYS})
    if meta:
        doc[META_KEY] = _toml_value(meta, META_KEY)
    head = "".join(f"# {line}\n" for line in comment.splitlines())
    import tomli_w  # the host extra: only writing a preset file needs it
    return head + ("\n" if head else "") + tomli_w.dumps(doc)


def write_preset(name: str, units: dict, directory=None, meta: dict | None = None, comment: str = "") -> Path:
    """Write ``units`` (see :func:`dump_preset`) as preset ``name``; returns the file. Checks it reads back."""
    path = preset_path(name, directory)
    text = dump_preset(units, meta, comment)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_writer(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    back = load_preset(name, directory)
    for key in UNIT_KEYS:
        if back[key] != units[key]:
            raise RuntimeError(f"{path}: [{key}] does not read back equal to what was written")
    return path


# -- reading ------------------------------------------------------------------------------------------------
def _convert(base, value, file: Path, where: str):
    """``value`` from the file, of the same kind as ``base`` (the default preset's value of that field)."""
    def bad(why):
        return PresetError(f"{file}: key {where}: {why}")

    if isinstance(base, Fmt):                   # before the tables: a format is a dataclass written as a string
        if not isinstance(value, str):
            raise bad(f"must be a format string like \"s2.16\", got {value!r}")
        try:
            fmt = Fmt.parse(value)
        except (ValueError, TypeError) as exc:
            raise bad(str(exc)) from None
        if fmt.width > MAX_FMT_BITS:
            raise bad(f"{value!r} is {fmt.width} bits wide, at most {MAX_FMT_BITS} allowed")
        return fmt
    if dataclasses.is_dataclass(base):
        if not isinstance(value, dict):
            raise bad(f"must be a table, got {value!r}")
        return _build(base, value, file, where)
    if isinstance(base, enum.Enum):
        try:
            return type(base)[value]
        except (KeyError, TypeError):
            raise bad(f"must be one of {[e.name for e in type(base)]}, got {value!r}") from None
    if isinstance(base, bool):
        if not isinstance(value, bool):
            raise bad(f"must be true or false, got {value!r}")
        return value
    if isinstance(base, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise bad(f"must be an integer, got {value!r}")
        if not -(1 << 16) <= value <= 1 << 16:
            raise bad(f"must be an integer of magnitude at most {1 << 16}, got {value!r}")
        return value
    if isinstance(base, str):
        if not isinstance(value, str):
            raise bad(f"must be a string, got {value!r}")
        return value
    raise bad(f"fields of type {type(base).__name__} cannot be set from a preset file")


def _build(base, table: dict, file: Path, where: str):
    names = {f.name for f in dataclasses.fields(base) if f.init}
    changes = {}
    for key, value in table.items():
        if key not in names:
            raise PresetError(f"{file}: key {where}.{key}: unknown field of {type(base).__name__} "
                              f"(have {', '.join(sorted(names))})")
        changes[key] = _convert(getattr(base, key), value, file, f"{where}.{key}")
    try:
        return dataclasses.replace(base, **changes)
    except (ValueError, TypeError) as exc:
        raise PresetError(f"{file}: table [{where}]: {exc}") from None


def load_preset(name: str, directory=None, base: Mapping | None = None) -> PipelinePreset:
    """The units of preset file ``name`` (``persp, bump, reflect, cube, shade``, ``weight_bits``, ``cube_size``).

    Parameters
    ----------
    name : str
        Preset name: the file ``<directory>/<name>.toml``.
    directory : path, optional
        Default :func:`presets_dir`.
    base : dict, optional
        Units that missing fields fall back to (default: the pipeline's ``default`` preset).

    Raises
    ------
    PresetError
        If the file does not exist (naming it and the built-in presets), is not TOML, or has an unknown or
        invalid key (naming the file and the key).
    """
    path = preset_path(name, directory)
    if not path.is_file():
        raise PresetError(f"unknown pipeline preset {name!r}: not built in ({', '.join(BUILTIN_PRESET_UNITS)}) "
                          f"and no file {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))      # a byte-order mark is accepted
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise PresetError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:              # tomllib recurses per level: [[[[...]]]] a few hundred deep
        raise PresetError(f"{path}: TOML nested too deeply to read (arrays or inline tables within each other "
                          "hundreds of levels deep)") from None
    base = base if base is not None else BUILTIN_PRESET_UNITS["default"]
    allowed = (*UNIT_KEYS, *TOP_KEYS, META_KEY)
    for key in data:
        if key not in allowed:
            raise PresetError(f"{path}: key {key}: unknown (have {', '.join(allowed)})")
    units = {key: _convert(base[key], data[key], path, key) if key in data else base[key] for key in UNIT_KEYS}
    for key in TOP_KEYS:
        value = data.get(key, FILE_MISSING[key] if key in FILE_MISSING else top_value(base, key))
        problem = top_problem(key, value)
        if problem:
            raise PresetError(f"{path}: key {key}: {problem}, got {value!r}")
        units[key] = value
    try:
        return PipelinePreset(**units)
    except (ValueError, TypeError) as exc:
        raise PresetError(f"{path}: {exc}") from None
