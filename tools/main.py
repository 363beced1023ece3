"""``bumpmap``: one command for every job of the project (a console script; also ``python -m tools``).

Each command lives in the module that owns its work; this module only maps command names to them. A module with
one command gives ``add_arguments(parser)`` and ``run(args) -> int``; a module with several gives ``COMMANDS``, a
dict ``name -> (help, add_arguments, run)``. The ``make`` targets call these commands.

Exit codes, the same for every command (``docs/exit-codes.md``):

- 0: success (``render`` of a frame that covers no pixel also exits 0, with a warning line);
- 1: a result beyond its bound: a frame farther than ``--max-lsb`` from reference (a), an RTL mismatch, a failed
  proof, or ``fit`` finding no preset within its limits that meets ``--max-lsb`` (it names the best it reached);
- 2: bad input: a bad argument (out of its range, the range in the message), a bad scene or preset file, a
  scene the preset cannot draw, a scene that draws nothing (``fit``, ``sim``), or an output that cannot be
  written (a directory, a read-only folder, a missing file's folder), named in one line;
- 130: interrupted (SIGINT, Ctrl-C); 143: terminated (SIGTERM). Outputs are written atomically, so an
  interrupted run leaves the previous complete files or the new ones.

Errors are one line on stderr (``error: ...``), never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import shlex
import signal
import sys

__all__ = ["COMMANDS", "build_parser", "main"]

#: Command name -> (module, help for single-command modules). Listed in the order ``bumpmap --help`` shows them.
COMMANDS: dict[str, tuple[str, str | None]] = {
    "sim": ("cosim.sim", "draw a scene through the RTL (the engine from triangles), bit-exact against the model"),
    "render": ("tools.cli", None),
    "fit": ("tools.cli", None),
    "info": ("tools.cli", None),
    "eval": ("tools.cli", None),
    "errors": ("tools.cli", None),
    "presets": ("tools.cli", None),
    "verilog": ("tools.cli", None),
    "fpga": ("tools.fpga", "ECP5-85 synthesis, place and route of units and pipelines"),
    "bench": ("tools.bench", "model and co-simulation throughput, then the speed-against-error sweep"),
    "sweep": ("tools.sweep", "the reciprocal's and the units' speed-against-error sweep"),
    "formal": ("formal.cli", "SymbiYosys proofs of the handshakes and the broken variants that must fail"),
    "exhaustive": ("tools.exhaustive", "exhaustive RTL equivalence runs and the 2^32 proof (Dask)"),
    "scenes-stress": ("tools.scenes_stress", "random valid scenes rendered in bulk against the bound"),
    "depth": ("tools.depth", "overdraw, depth disagreements and frame-buffer traffic of the shipped scenes"),
    "precision": ("tools.precision", "where the fixed-point error goes against the true image, unit by unit, and "
                  "what a wider diffuse factor buys"),
    "filtering": ("tools.filtering", "every shipped scene against the true image (reference (c)), and the "
                  "filtering study: MIP maps, LEAN bump maps, level of detail"),
    "figures": ("tools.figures", "re-render the documentation's scene pictures"),
    "tables": ("tools.tables", "the reciprocal's error tables"),
    "docs": ("tools.docs", "write the generated pages of the docs (docs/generated/) and the README's blocks"),
    "record": ("tools.record", "run a command and record what it printed (the docs' sample output)"),
    "raster-errors": ("tools.measure", None),
    "frontend": ("tools.measure", None),
    "maps": ("tools.measure", None),
    "rop-throughput": ("tools.measure", None),
    "mip": ("tools.mip", "the bit-exact pipeline with MIP mapping of the color texture against the true image"),
    "cache-sweep": ("tools.cache_sweep", "size the texel cache in the model on the shipped scenes and grazing floor"),
    "cache-rate": ("tools.cache_rate", "the decoupled texel cache's lookups per clock under memory latency (co-sim)"),
    "engine-rate": ("tools.engine_rate", "the engine from triangles with its maps in external memory: clocks per "
                    "fragment under memory latency (co-sim)"),
    "bitstream": ("board.top", "the board top (ULX3S) through Yosys, nextpnr-ecp5 and ecppack: bitstream and report"),
    "litedram": ("board.litedram", "generate the SDRAM controller core (LiteDRAM) from board/sdram.yml"),
    "board-budget": ("board.budget", "the board's memory bandwidth budget (frame-buffer strategy)"),
    "sdram-bandwidth": ("board.sdram_bandwidth", "the SDRAM bandwidth of the frame in SDRAM (scan-out and copies)"),
    "board-sim": ("tools.board_sim", "the board simulated end to end (host bytes, UART, engine, DVI), frame checked"),
    "animate": ("tools.animate", "a scene's animation as the board shows it (GIF) and frames per second at 640x480"),
    "send": ("tools.send", "send a scene to the board over the UART (or its bytes to a file: --dry-run)"),
}


def _command(name: str):
    """``(help, add_arguments, run, parser options)`` of command ``name`` (imports its module)."""
    module_name, help_text = COMMANDS[name]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.split(".")[0] in ("fxmodel", "host", "rtl", "cosim", "tools"):
            raise
        raise SystemExit(f"error: 'bumpmap {name}' needs the package {exc.name!r}: install the project with its "
                         f"extras (make setup, or pip install -e '.[all]')") from None
    options = dict(getattr(module, "PARSER_OPTIONS", {}))
    if hasattr(module, "COMMANDS"):
        help_text, add, run = module.COMMANDS[name]
        return help_text, add, run, options
    return help_text, module.add_arguments, module.run, options


def _add(sub, name: str) -> None:
    help_text, add, run, options = _command(name)
    options.setdefault("description", (run.__doc__ or help_text).strip().split("\n\n")[0])
    p = sub.add_parser(name, help=help_text, **options)
    add(p)
    p.set_defaults(_run=run)


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose refusals are one line (``bumpmap render: error: argument --size: ...``, exit 2);
    ``--help`` shows the usage."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(names=None) -> argparse.ArgumentParser:
    """The parser of ``bumpmap`` with a subparser for each command (``names``: only those, to import less)."""
    ap = OneLineParser(prog="bumpmap", description="One command for every job of the bump-mapping "
                                 "hardware project (also: python -m tools).",
                                 epilog="Run 'bumpmap COMMAND --help' for a command's options.")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS if names is None else names:
        _add(sub, name)
    return ap


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C so that the same clean-up runs."""


def _on_sigterm(signum, frame):
    raise Terminated()


def main(argv=None) -> int:
    """Parse ``argv`` and run the command; every error ends in one line on stderr and the exit code above."""
    argv = sys.argv[1:] if argv is None else list(argv)
    known = [a for a in argv[:1] if a in COMMANDS]       # import only the command's own module
    trailing = argv[argv.index("--") + 1:] if "--" in argv else []    # a command to run (bumpmap record)
    argv = argv[:argv.index("--")] if "--" in argv else argv
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:                                                 # an interrupt while importing is caught too
        args = build_parser(known or None).parse_args(argv)
        args.command_line = " ".join(["bumpmap", *map(shlex.quote, argv)])       # for a record of the run
        args.trailing = trailing
        return args._run(args)
    except Terminated:
        print("terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except SystemExit as exc:           # a command's one-line refusal: bad input
        if isinstance(exc.code, str):
            print(exc.code if exc.code.startswith("error") else f"error: {exc.code}", file=sys.stderr)
            return 2
        raise
    except OSError as exc:              # an output that cannot be written (or an input that cannot be read)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except ValueError as exc:           # unknown unit / preset: one clear line, no traceback
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:                 # the inputs' limits should prevent it; if not, still one line
        print("error: out of memory: the inputs ask for more than this machine holds (docs/exit-codes.md: "
              "limits)", file=sys.stderr)
        return 2
    finally:
        signal.signal(signal.SIGTERM, previous)
