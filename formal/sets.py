"""The property sets ``make formal`` runs, the broken variants that must fail, and running them into a record.

A property set is one design with its properties; it runs as a proof (k-induction: ``prove`` to depth ``k``)
or, where noted, a bounded check (``bmc`` to a depth), plus a cover run that shows every ``Cover`` reached.
A broken variant runs the proof's assertions as a bounded check from reset (a real counterexample, not an
induction step): it must fail, naming the property, with its trace written as a VCD file.
"""

from __future__ import annotations

import dataclasses
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fxmodel.core.unit import preset, units
from rtl.streams import buffer_depth

from . import broken
from .abstract import Abstract
from .credit_fifo import DEPTH as CREDIT_DEPTH
from .credit_fifo import credit_fifo_set
from .engine import engine_set
from .fetch import DEC_PARAMS, small_texfetch
from .raster import raster_independence, raster_set
from .readers import READ_MANAGERS, read_manager_set
from .rop import STALL, rop_set, small_rop
from .rop_chip import ROP_CHIP_DEPTH, rop_chip_set, small_rop_chip
from .runner import Job, Result, run_job
from .streamunit import CUT, cover_depth, stream_independence, stream_unit

__all__ = ["PropertySet", "Variant", "property_sets", "variants", "run_set", "run_variant", "FAST_SETS",
           "FAST_VARIANTS", "SCOPE"]


@dataclass
class PropertySet:
    """One design and its properties.

    ``build(kind, wrap)`` returns the harness; ``mode`` is ``prove`` (k-induction) or ``bmc`` (bounded, with
    ``why`` saying why the depth suffices); ``cover_depth`` bounds the cover run (0: no covers)."""

    name: str
    design: str
    covers: str
    build: Callable
    mode: str
    depth: int
    cover_depth: int
    cut: str = ""
    why: str = ""


@dataclass
class Variant:
    """A broken variant of a set: ``wrap`` (a :mod:`formal.broken` wrapper) or ``build`` of its own, run as a
    bounded check to ``depth``; ``expect``: the property (name prefix) that must fail. ``skip``: the first steps
    not checked, for a bug that needs that many steps to show (its counterexample can be no shorter): the solver
    spends no time proving the steps before it clean."""

    name: str
    bug: str
    set_name: str
    expect: str
    depth: int
    wrap: type | None = None
    build: Callable | None = None
    cut: str = CUT
    skip: int = 0


#: The pixel pipeline's units, cut whole in its stream proof (their outputs free: only the pipeline's own valid
#: delay line and the stream wrapper are kept; each unit's own stream version is proven whole, above)
PIPELINE_UNITS = "top.dut.core.unit/t:top.dut.core.unit.*"

#: Units whose stream version runs without its cover run: the pixel pipeline's (its covers, 153 steps, run on
#: the same wrapper with the datapath abstracted, ``stream_pipeline_abstract``)
NO_COVERS = ("pipeline",)

#: Steps before the decoupled cache's extra burst can show: four misses through the input FIFO, the set stage, the
#: prefetch stage and the tag stage (after each fill a clock to compare again), then the fifth ``AR``: one step after
#: the set's cover ``misses_outstanding_reach`` (its cover run's log names the step). Its variant checks that step alone
#: (``skip``, and a depth one more): without ``skip`` its counterexample fails at step 15 and the solver spends most of
#: its time proving the steps before clean; with later steps checked too the solver may pick a trace whose extra burst
#: is older (a burst completed since, so ``ar_outstanding`` holds again and only the cache's own count ``owed_lines``
#: fails). At the earliest step the extra burst has just been accepted (:class:`formal.broken.ExtraBurst` starts it in a
#: clock in which no burst ends) and both fail. A change that makes the burst later leaves the variant missed: loudly.
EXTRA_BURST_STEPS = 15


def _unit_sets() -> list[PropertySet]:
    out = []
    for unit in units():
        p = preset(unit, "default")
        lat, depth = p.latency, buffer_depth(p)
        out.append(PropertySet(
            f"stream_{unit}", f"StreamUnit({unit} default): latency {lat}, FIFO {depth}",
            "rules 2 and 3 on o, no loss/duplication/reordering (sequence numbers in the sideband), used = "
            "transfers in - out = FIFO level + delay line, FIFO never above its depth",
            lambda kind, wrap=None, p=p: stream_unit(p, kind=kind, wrap=wrap), "prove", 1,
            0 if unit in NO_COVERS else cover_depth(p), CUT + (f"; {PIPELINE_UNITS}" if unit == "pipeline" else "")))
    p = Abstract.of(preset("pipeline", "default"))
    lat, depth = p.latency, buffer_depth(p)
    out.append(PropertySet(
        "stream_pipeline_abstract",
        f"StreamUnit(pipeline default), datapath abstracted (formal/abstract.py): latency {lat}, FIFO {depth}",
        "as the units: rules 2 and 3 on o, no loss/duplication/reordering, used = in - out = FIFO level + delay "
        "line, FIFO never above its depth (the control of the real wrapper: the datapath is data to it)",
        lambda kind, wrap=None, p=p: stream_unit(p, kind=kind, wrap=wrap), "prove", 1, cover_depth(p)))
    p = preset("recip", "small")
    out.append(PropertySet(
        "stream_independence", "StreamUnit(recip small), two copies (the miter)",
        "rule 3: o.valid does not depend on o.ready; i.ready does not depend on i.valid",
        lambda kind, wrap=None: stream_independence(p, kind=kind, wrap=wrap), "bmc",
        2 * buffer_depth(p) + p.latency + 2, 2 * buffer_depth(p) + 2, CUT,
        why="the handshake logic is the same for every unit (rtl/streams.py); the probe may fall in any of the "
            "first 2 (latency + 1) + latency + 2 cycles: after an empty, a full and an emptying FIFO; the "
            "payload is not compared (the cut datapath gives the copies different free values; rule 2 is proven)"))
    return out


def _reader_sets() -> list[PropertySet]:
    return [PropertySet(
        e.name, e.design,
        "AXI4 read channels (AR held until ready, declared burst, 4 KB, RLAST assumed on the last beat, no R "
        "without AR, outstanding bound, no writes); rule 2 on o assumed on i; no answer without a request, at "
        f"most {e.capacity} inside" + e.extra.get("covers", ""),
        lambda kind, wrap=None, e=e: read_manager_set(e, kind=kind, wrap=wrap), e.mode, e.depth, e.cover_depth,
        why=e.why) for e in READ_MANAGERS]


def property_sets() -> list[PropertySet]:
    rp, rc = small_rop(), small_rop_chip()
    return _unit_sets() + _reader_sets() + [
        PropertySet("credit_fifo", f"CreditFIFO (rtl/streams.py, depth {CREDIT_DEPTH})",
                    "the contract the scan converter's sets assume where they read it: words read in the order "
                    "written, none lost or repeated; level = written - read; r_rdy = level != 0; no overflow "
                    "while the writer keeps its credits",
                    lambda kind, wrap=None: credit_fifo_set(kind=kind, wrap=wrap), "prove", CREDIT_DEPTH + 2, 12),
        PropertySet("raster", "Raster (1 attribute, 16-pixel viewport, multipliers cut)",
                    "rule 2 on o, row and output credit FIFOs never overflow, rows and pixels conserved, "
                    "control copies agree",
                    lambda kind, wrap=None: raster_set(kind=kind, wrap=wrap), "prove", 3, 40, "t:$mul"),
        PropertySet("raster_independence", "Raster (as above), two copies (the miter)",
                    "rule 3 on o (o.valid; the payload is the output FIFO's head), i.ready does not depend on i.valid",
                    lambda kind, wrap=None: raster_independence(kind=kind, wrap=wrap), "bmc", 8, 0, "t:$mul",
                    why="the probe may fall in the first 8 cycles: a record accepted, its rows issued into the span "
                        "pipeline and the generator's ready falling and rising again (i.ready is its control state)"),
        PropertySet("engine", "Engine: scan converter -> pixel pipeline (datapath abstracted, latency 74) -> Rop "
                              f"behind AXI4 (16-pixel viewport, 4x4 frame, {rp.outstanding} slots)",
                    "the parts' properties composed (rule 2 on each internal stream asserted where its consumer "
                    "assumed it; credits; hazard; AXI4 rules on the port); fragments conserved from the scan "
                    "converter through the pipeline and the ROP",
                    lambda kind, wrap=None: engine_set(kind=kind, wrap=wrap), "prove", 4, 24, "t:$mul"),
        PropertySet("rop_axi", f"Rop behind AXI4 ({rp.width}x{rp.height} frame, {rp.outstanding} slots, "
                               f"memory stalls <= {STALL})",
                    "AXI4 manager rules on AW/W/AR/B/R, WLAST, outstanding bounds, 4 KB; hazard rule; slots "
                    "freed only by a failed test or B; slot accounting",
                    lambda kind, wrap=None: rop_set(kind=kind, wrap=wrap), "prove", 4, 16),
        PropertySet("rop_chip", f"Rop on chip ({rc.width}x{rc.height} frame in a {rc.max_size}-pixel viewport, "
                                f"{rc.z_fmt.width}-bit depths, latency {rc.latency}, the frame as registers)",
                    "the write decision equals a reference depth test taking the fragments in arrival order "
                    "(the forwarding of the five fragments ahead); the read-out's word the reference's; fragments "
                    "conserved; busy; the sticky flags; i.ready = ~fb.read; a clearing read-out begins with busy "
                    "low (assumed: the tile copy's contract)",
                    lambda kind, wrap=None: rop_chip_set(kind=kind, wrap=wrap), "prove", ROP_CHIP_DEPTH, 20),
    ]


def variants() -> list[Variant]:
    small = preset("recip", "small")
    (tc,) = [e for e in READ_MANAGERS if e.name == "texcache_axi"]
    (dec,) = [e for e in READ_MANAGERS if e.name == "texcache_decoupled_axi"]
    (tf,) = [e for e in READ_MANAGERS if e.name == "texfetch_axi"]
    wrong = dataclasses.replace(tf, make=lambda: small_texfetch(broken.texfetch_wrong_owner))
    return [
        Variant("payload_while_stalled", "o.payload changes while o.valid & ~o.ready", "stream_recip_small",
                "o_hold", small.latency + 4, broken.PayloadWhileStalled,
                lambda kind, wrap: stream_unit(small, kind=kind, wrap=wrap)),
        Variant("dropped_token", "the third result taken and never offered", "stream_recip_small", "o_",
                small.latency + 6, broken.DroppedToken, lambda kind, wrap: stream_unit(small, kind=kind, wrap=wrap)),
        Variant("valid_waits_for_ready", "o.valid only while o.ready", "stream_independence", "valid_indep",
                small.latency + 3, broken.ValidWaitsForReady,
                lambda kind, wrap: stream_independence(small, kind=kind, wrap=wrap)),
        Variant("ready_from_valid", "i.ready combinationally from i.valid", "stream_independence",
                "ready_indep", 3, broken.ReadyFromValid,
                lambda kind, wrap: stream_independence(small, kind=kind, wrap=wrap)),
        Variant("raster_payload_while_stalled", "the scan converter's o.payload changes while stalled", "raster",
                "o_hold", 14, broken.PayloadWhileStalled, lambda kind, wrap: raster_set(kind=kind, wrap=wrap),
                cut="t:$mul"),
        Variant("wlast_early", "AWLEN = 1 with WLAST on the first beat", "rop_axi", "wlast", 8, broken.WlastEarly,
                lambda kind, wrap: rop_set(kind=kind, wrap=wrap)),
        Variant("ar_changes_while_stalled", "ARADDR moves while AR waits", "rop_axi", "ar_hold", 8,
                broken.ArChangesWhileStalled, lambda kind, wrap: rop_set(kind=kind, wrap=wrap)),
        Variant("texcache_rlast_early", "the cache takes RLAST one beat early", "texcache_axi", "fill_", 16,
                broken.RlastEarly, lambda kind, wrap: read_manager_set(tc, kind=kind, wrap=wrap), cut=""),
        Variant("texcache_arlen_short", "ARLEN one beat short of the line", "texcache_axi", "ar_len_declared", 6,
                broken.ArlenShort, lambda kind, wrap: read_manager_set(tc, kind=kind, wrap=wrap), cut=""),
        Variant("texcache_ar_changes_while_stalled", "ARADDR moves while AR waits", "texcache_axi", "ar_hold", 8,
                broken.MemArChangesWhileStalled, lambda kind, wrap: read_manager_set(tc, kind=kind, wrap=wrap),
                cut=""),
        Variant("decoupled_extra_burst", f"a 5th burst issued with misses = {DEC_PARAMS.misses} outstanding",
                "texcache_decoupled_axi", "ar_outstanding", EXTRA_BURST_STEPS + 1, broken.ExtraBurst,
                lambda kind, wrap: read_manager_set(dec, kind=kind, wrap=wrap), cut="", skip=EXTRA_BURST_STEPS),
        Variant("texfetch_wrong_owner", "the owner FIFO records the other cache: R beats routed to the wrong one",
                "texfetch_axi", "r_to_owner", 12, None,
                lambda kind, wrap: read_manager_set(wrong, kind=kind), cut=""),
        Variant("texfetch_ar_changes_while_stalled", "ARADDR moves while AR waits", "texfetch_axi", "ar_hold", 9,
                broken.MemArChangesWhileStalled, lambda kind, wrap: read_manager_set(tf, kind=kind, wrap=wrap),
                cut=""),
        Variant("hazard_off", "RopParams(hazard=False): no same-pixel check", "rop_axi", "hazard_", 8, None,
                lambda kind, wrap: rop_set(small_rop(hazard=False), kind=kind)),
        Variant("rop_chip_no_forwarding", "RopParams(hazard=False) on chip: the fragments ahead not forwarded",
                "rop_chip", "write_decision", 12, None,
                lambda kind, wrap: rop_chip_set(small_rop_chip(hazard=False), kind=kind)),
    ]


#: What the record covers and how (printed under the tables by :func:`formal.report.markdown_table`).
SCOPE = (
    "Proven for all time (k-induction) unless the verdict says bounded; each set's cover run shows its "
    "Cover statements reached (a full FIFO, the longest stall, a burst, a hazard, ...).",
    "Datapath abstraction: multipliers and lookup tables are cut (yosys cutpoint: free values, sound), the "
    "properties read only registers; the stream versions run every unit's default preset whole otherwise.",
    "The scan converter, the ROP and the texel cache run small parameters (16-pixel viewport, one attribute; "
    "4 x 4 frame, 3 slots, 4-bit depths; 2 x 2 texel lines, 2 sets of 2 ways, for the decoupled cache a lookup FIFO "
    "of 2 and 4 lines owed at most): their control logic is the same for any size, only widths change.",
    "The pixel pipeline (latency 74, FIFO 75): stream_pipeline is the real one with its units cut (the valid "
    "delay line and the wrapper kept), stream_pipeline_abstract the same wrapper around a valid delay line of the "
    "same latency with an opaque token (formal/abstract.py; it carries the covers). The wrapper reads of the "
    "datapath only its valid line, so the handshake proofs hold of the real design; its values are checked "
    "bit-exact by co-simulation.",
    "The engine (rtl/engine.py Engine, with the ROP) is composed of the parts' own properties, each internal "
    "stream's rule 2 asserted of its producer where its consumer assumed it, the pipeline's datapath abstracted "
    "as above; fragments conserved from the scan converter to the ROP's finished fragments.",
    "The texel caches' AXI4 read ports (the blocking cache, the decoupled cache, the texture fetch's one port "
    "shared by both maps' decoupled caches): formal/axiread.py (any read manager; the ROP's read half too), "
    "formal/readers.py (one READ_MANAGERS entry per design; the decoupled ones in formal/fetch.py).",
    "White-box invariants read the designs' internal registers by name (formal/whitebox.py); the FIFOs' own "
    "contract (Amaranth's SyncFIFO, or rtl.streams.CreditFIFO, proven as credit_fifo, returns what was written, "
    "in order) is assumed where they are read.",
    "The depth test on chip (rop_chip: the one both board builds carry) is checked against a reference depth test "
    "taking the fragments in arrival order; its frame memory is an array of registers with the read port's "
    "behaviour (formal/rop_chip.py ArrayFrameRop), so the invariant relating memory and reference can be stated.",
    "The memory behind each AXI4 port is free within the AXI4 rules, with stalls and response latencies "
    "assumed of at most 3 cycles.",
)

#: The fast subset of ``make test`` (tests/test_formal.py).
FAST_SETS = ("stream_recip", "rop_axi", "rop_chip", "texcache_axi")
FAST_VARIANTS = ("payload_while_stalled", "texcache_rlast_early")


def _entry(res: Result, kind: str) -> dict:
    return {"kind": kind, "mode": res.mode, "depth": res.depth, "status": res.status,
            "seconds": round(res.seconds, 2), "failed": res.failed, "traces": res.traces[:1]}


def run_set(ps: PropertySet, folder: Path, covers: bool = True, timeout: int = 900) -> dict:
    """Run a set's proof (or bounded check) and its covers; the record entry."""
    runs = []
    h = ps.build("proof")
    asserted, assumed = list(h.asserted), list(h.assumed)
    runs.append(_entry(run_job(Job(f"{ps.name}_{ps.mode}", h.m, h.ports, ps.mode, ps.depth, ps.cut, timeout),
                               folder), "proof" if ps.mode == "prove" else "bounded"))
    covered = []
    if covers and ps.cover_depth:
        h = ps.build("cover")
        covered = list(h.covered)
        runs.append(_entry(run_job(Job(f"{ps.name}_cover", h.m, h.ports, "cover", ps.cover_depth, ps.cut,
                                       timeout), folder), "cover"))
    ok = all(r["status"] == "PASS" for r in runs)
    verdict = (f"proven (k-induction, k = {ps.depth})" if ps.mode == "prove" else f"bounded (depth {ps.depth})")
    return {"name": ps.name, "design": ps.design, "properties": ps.covers, "verdict": verdict,
            "status": "PASS" if ok else "FAIL", "why": ps.why, "cut": ps.cut, "runs": runs,
            "checks": asserted, "assumptions": assumed, "covers": covered,
            "seconds": round(sum(r["seconds"] for r in runs), 2)}


def run_variant(v: Variant, folder: Path, timeout: int = 600) -> dict:
    """Run a broken variant (bounded, from reset): caught when it fails on the expected property with a
    waveform."""
    h = v.build("proof", v.wrap)
    res = run_job(Job(f"broken_{v.name}", h.m, h.ports, "bmc", v.depth, v.cut, timeout, v.skip), folder)
    caught = res.status == "FAIL" and any(f.startswith(v.expect) for f in res.failed) and bool(res.traces)
    return {"name": v.name, "bug": v.bug, "set": v.set_name, "expect": v.expect, "depth": v.depth, "skip": v.skip,
            "status": res.status, "failed": res.failed, "trace": res.traces[0] if res.traces else None,
            "caught": caught, "seconds": round(res.seconds, 2)}


def machine() -> dict:
    import os
    return {"nproc": os.cpu_count(), "loadavg": [round(x, 2) for x in os.getloadavg()],
            "python": platform.python_version(), "system": platform.system(), "date": time.strftime("%Y-%m-%d")}
