"""Measured tables of the board's documentation (``docs/board.md``), generated from the committed records of the
commands that measured them (``docs/board/``, ``docs/records/``): the bandwidth budget, the bitstream's clocks and
resources, the engine's endpoints that miss a clock, the end-to-end simulations, the frames per second.
"""

from __future__ import annotations

import json

from .docs_records import DOCS, col_align, load_record, md_table, misses_tables, missing_record, provenance

# -- the board --------------------------------------------------------------------------------------------------
BOARD = DOCS / "board"


def _board_record(name: str):
    path = BOARD / f"{name}.json"
    if not path.is_file():
        return None, path
    return json.loads(path.read_text(encoding="utf-8")), path


def board_budget() -> str:
    """The memory-bandwidth arithmetic of the board's frame-buffer strategy (``bumpmap board-budget``)."""
    r, path = _board_record("budget")
    if r is None:
        return missing_record(path, "bumpmap board-budget docs/board/budget.json")
    rows = [["SDRAM peak (one x16 SDR chip)", f"{r['sdram_peak_MBps']} MB/s"],
            [f"scan-out, {r['mode']}, 16-bit color",
             f"{r['scanout_MBps']} MB/s ({100 * r['scanout_share_of_peak']:.1f} % of the peak)"],
            ["left after scan-out", f"{r['sdram_left_after_scanout_MBps']} MB/s"],
            [f"drawing at one fragment a clock ({r['engine_Mpx_per_s']} Mfragment/s), compact "
             f"{r['bytes_per_fragment_compact']}-byte fragments", f"{r['drawing_MBps_compact']} MB/s"],
            [f"the same with today's ROP ({r['bytes_per_fragment_rop_today']} bytes a fragment)",
             f"{r['drawing_MBps_rop_today']} MB/s"],
            ["a frame buffer in SDRAM sustains at most (compact / today's)",
             f"{r['direct_fb_Mpx_per_s_compact_at_peak']} / {r['direct_fb_Mpx_per_s_rop_today_at_peak']} Mfragment/s "
             f"({100 * r['direct_fb_share_of_engine_rate_compact']:.0f} % of the engine's rate)"],
            [f"on-chip tile {r['tile_edge']} x {r['tile_edge']}, depth and color",
             f"{r['tile_bits']} bits: {r['tile_dp16kd']} DP16KD, {r['tile_dp16kd_double_buffered']} double-buffered "
             f"of {r['dp16kd_total']}"],
            ["tiles a frame; finished tiles written to SDRAM",
             f"{r['tiles_per_frame']}; {r['tile_writeback_MB_per_frame']} MB a frame, "
             f"{r['tile_writeback_MBps_at_60fps']} MB/s at 60 frames a second"]]
    return md_table(["quantity", "value"], rows, col_align("lr")) + f"\n*Computed by `{r['command']}`; record: " \
        f"[`board/budget.json`](board/budget.json).*\n"


def board_sdram_bandwidth() -> str:
    """The SDRAM bandwidth of the frame in SDRAM (``bumpmap sdram-bandwidth``)."""
    r, path = _board_record("sdram-bandwidth")
    if r is None:
        return missing_record(path, "bumpmap sdram-bandwidth docs/board/sdram-bandwidth.json")
    rows = [[f"{f['width']} x {f['height']}", f"{f['frame_bytes']:,}", f"{f['scanout_MBps']}", f"{f['copy_MBps']}",
             f"{f['total_MBps']}", f"{100 * f['share_of_peak']:.1f} %",
             f"{f['bursts_per_frame']:,} of {f['burst_beats']} beats"] for f in r["frames"]]
    return (md_table(["frame", "bytes", "scan-out MB/s", "copies MB/s", "total MB/s", f"of {r['sdram_peak_MBps']} MB/s",
                    "bursts a frame (each way)"], rows, col_align("lrrrrrr"))
            + f"\n*{r['mode']}, the peak of the SDRAM's clock on the board ({r['sdram_clock_MHz']:g} MHz; the chip "
              f"is rated for {r['chip_clock_MHz']:g}), a copy every display frame ({r['copies_per_s']} a second, the "
              "most the display shows); "
              f"line FIFO {r['line_fifo_words']} words ({r['line_fifo_us_at_pixel_clock']} us of pixels, "
              f"{r['line_fifo_lines_640']} lines of 640). Computed by `{r['command']}`; record: "
              "[`board/sdram-bandwidth.json`](board/sdram-bandwidth.json).*\n")


def _clock_tables(r: dict, fmax_head: str) -> str:
    """A board record's two tables: Fmax per clock domain against its target (column ``fmax_head``), and the
    resources used against the device's."""
    clocks = [[f"`{name}`", f"{c['target_mhz']} MHz", f"{c['fmax_mhz']} MHz", "yes" if c["met"] else "**no**"]
              for name, c in r["clocks"].items()]
    res = [[kind, used, avail] for kind, (used, avail) in r["resources"].items()]
    return (md_table(["clock", "target", fmax_head, "met"], clocks, col_align("lrrl")) + "\n"
            + md_table(["resource", "used", "available"], res, col_align("lrr")))


#: The options of the command each board record is made with, beyond ``--record`` (a missing record's hint): the
#: frame on chip (``--frame chip``) or in SDRAM (the default, ``board.frame.BOARD_FRAME``).
RECORD_OPTIONS = {"bitstream": "--frame chip", "bitstream-sdram": "", "bitstream-textures": "--textures",
                  "board-sim": "--frame chip", "board-sim-sdram": "",
                  "board-sim-uploads": "--frame chip --uploads --size 32", "board-sim-textures": "--textures"}


def _record_command(tool: str, name: str, folder: str) -> str:
    """The command that makes board record ``name`` (:data:`RECORD_OPTIONS`)."""
    return " ".join(filter(None, (f"bumpmap {tool}", RECORD_OPTIONS[name], f"--record {folder}/{name}.json")))


def board_bitstream(name: str = "bitstream") -> str:
    """The board top's last bitstream: Fmax per clock domain against its target, and resources; ``name`` the
    record (``bitstream``: the frame on chip; ``bitstream-sdram``: the frame in SDRAM, ``make bitstream``'s
    build; ``bitstream-textures``: the maps in SDRAM too, ``make bitstream MAPS=sdram``'s)."""
    r, path = _board_record(name)
    if r is None:
        return missing_record(path, _record_command("bitstream", name, "docs/board"))
    how = ", ".join(filter(None, (f"placer seed {r['seed']}" if "seed" in r else "",
                                  f"floorplan `{r['floorplan']}`" if r.get("floorplan") else "")))
    return (_clock_tables(r, "Fmax")
            + f"\n*Measured by `{r['command']}`{f' ({how})' if how else ''} in {r['seconds']} s; record: "
              f"[`board/{name}.json`](board/{name}.json).*\n")


def board_sim(name: str = "board-sim") -> str:
    """The board's end-to-end simulation (``make board-sim``): host bytes to the decoded DVI frame; ``name`` the
    record (``board-sim``: the frame on chip; ``board-sim-sdram``: the frame in SDRAM, the default;
    ``board-sim-uploads``: the uploads sent into blank texel memories, the frame on chip; ``board-sim-textures``:
    the maps in SDRAM, loaded by the TEXTURE frames)."""
    record, path = load_record(name)
    if record is None:
        return missing_record(path, _record_command("board-sim", name, "docs/records"))
    r = record["result"]
    t, ms = r["timing"], r["sim_ms"]
    tiles = r.get("tiles", 1)
    place = (f"{r['picture_size'][0]} x {r['picture_size'][1]} in {tiles} tiles of {r['tile'][0]} x {r['tile'][1]}"
             if tiles > 1 else f"{r['tile'][0]} x {r['tile'][1]} (the tile)")
    rows = [["scene, picture", f"{r['scene']}, {place}, {r['triangles']} triangle records"],
            ["host bytes into the UART", f"{r['bytes_sent']} in {r['frames_sent']} frames " + (
                "(the uploads into blank texel memories; an upload's word refused: "
                f"{'**yes**' if r['upload_bad'] else 'no'})" if r.get("uploads") else
                "(the maps' TEXTURE frames into the SDRAM; an upload's word refused: "
                f"{'**yes**' if r['upload_bad'] else 'no'}; CUBE frames left out: {r['frames_left_out']} frames, "
                f"{r['bytes_left_out']} bytes)" if r.get("textures") else
                f"(uploads left out: {r['frames_left_out']} frames, {r['bytes_left_out']} bytes)")],
            ["answers", f"{len(r['replies']) // 2} bytes, all ACK: {'yes' if r['acks_ok'] else '**no**'}"],
            *([["STATUS after the picture", f"0x{r['state_answer'] or '--'}: "
                + ("not busy, no flag set" if r["state_ok"] else "**busy or a flag set**")]]
              if "state_ok" in r else []),
            ["pixels compared (640 x 480)", f"{r['pixels']:,}"], ["mismatches", str(r["mismatches"])],
            ["line / hsync / active (clocks)", f"{t['line_periods']} / {t['hsync_widths']} / {t['active_widths']}"],
            ["vsync / frame (clocks), lines", f"{t['vsync_widths']} / {t['frame_periods']}, {t['lines_per_frame']}"],
            ["timing as the mode's", "yes" if r["timing_ok"] else "**no**"],
            ["simulated time", f"{ms['uart_done']:.2f} ms UART, buffer shown at {ms['shown']:.2f} ms, "
                               f"end {ms['end']:.2f} ms"],
            ["seconds (Verilog, Verilator build, simulation, wall)",
             f"{r['verilog_seconds']}, {r['build_seconds']}, {r['sim_seconds']}, {r['wall_seconds']}"]]
    if r.get("frame") == "sdram":
        rows.insert(4, ["frame store; scan-out underrun, AXI error", f"SDRAM (LiteDRAM's simulation core); "
                        f"{'**yes**' if r['underrun'] else 'no'}, {'**yes**' if r['mem_error'] else 'no'}"])
    return md_table(["quantity", "value"], rows, col_align("lr")) + "\n" + provenance(record, path)


def board_animation() -> str:
    """Frames per second of the board at 640 x 480 for every shipped scene (``bumpmap animate``)."""
    record, path = load_record("animation")
    if record is None:
        return missing_record(path, "bumpmap animate --record docs/records/animation.json")
    r = record["result"]
    rows = [[f"`{s['scene']}`" + (" (clamped)" if s["clamped"] else ""), str(s["frames"]), str(s["triangles"]),
             f"{s['tiles']}, {s['tile_records_max']}",
             f"{s['engine_clocks_per_frame_max']:,} ({s['engine_clocks_drawing']:,})", f"{s['engine_fps']:,}",
             f"{s['link_bytes_per_frame_max']:,}", f"{s['link_fps']:,}", f"{s['shown_fps']:,}",
             f"{s['sdram_MBps_total']} ({100 * s['sdram_share_of_peak']:.1f} %)"] for s in r["scenes"]]
    head = ["scene", "frames", "triangles", "tiles, records sent (max)", "engine clocks a picture, max (drawing)",
            "engine pictures/s", "UART bytes a picture (max)", "UART pictures/s", "shown pictures/s",
            f"SDRAM MB/s (of {r['sdram_peak_MBps']:g})"]
    note = (f"\n*Engine at {r['engine_mhz']:g} MHz ({r['engine_clock']}), UART at {r['baud']:,} baud, "
            f"{r['mode']} a {r.get('tile', 128)}-pixel tile at a time; a picture's clocks are its tiles' triangles "
            "(the scan converter's, in brackets) and each tile's clear and copy (a lower bound: "
            "`tools/animate.py` `picture_clocks`); the SDRAM figure is scan-out plus the tiles' write-back at the "
            "rate shown (texel-cache misses not counted).*\n")
    return md_table(head, rows, col_align("lrrrrrrrrr")) + note + "\n" + provenance(record, path)


def board_engine_misses() -> str:
    """The board top with the engine routed at a clock its engine misses (``bumpmap bitstream --engine-div N
    --misses``): Fmax per clock, resources, and every endpoint that misses the engine clock."""
    r, path = _board_record("engine-misses")
    if r is None:
        return missing_record(path, "bumpmap bitstream --engine-div 5 --misses --record docs/board/engine-misses.json")
    return (_clock_tables(r, "Fmax (routed)") + "\n" + misses_tables(r["misses"])
            + f"\n*Measured by `{r['command']}` in {r['seconds']} s; record: "
              "[`board/engine-misses.json`](board/engine-misses.json).*\n")
