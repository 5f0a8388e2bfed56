# netdae: two commands on a fresh Debian machine with Python 3.11.
#   make demo   the whole story on netlists/differentiator.cir
#   make test   the whole test suite
# Each target sets up what it needs (virtualenv, pip, ngspice) and is idempotent.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
VPY    := $(VENV)/bin/python
STAMP  := $(VENV)/.netdae-installed
DEMO   := netlists/differentiator.cir
# One BLAS thread: netdae's dense problems are small and its sparse LU is
# single-threaded; BLAS threads only contend on small machines.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
OUT    := out

.PHONY: demo test fuzz bench validation system-deps venv warm clean

$(VPY):
	@$(PYTHON) -m venv $(VENV) 2>/dev/null || { \
	  if [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null; then \
	    echo "netdae: installing python3-venv"; \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -q python3-venv >/dev/null 2>&1 || \
	    { apt-get update -q >/dev/null 2>&1; DEBIAN_FRONTEND=noninteractive apt-get install -y -q python3-venv >/dev/null; }; \
	    rm -rf $(VENV); $(PYTHON) -m venv $(VENV); \
	  else echo "netdae: cannot create a virtualenv; install it with: sudo apt-get install python3-venv" >&2; exit 1; fi; }

$(STAMP): pyproject.toml | $(VPY)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -e '.[test,dev,results,models,dask]'
	@touch $(STAMP)

venv: $(STAMP)

# Compile the transient engine into numba's cache (a no-op taking about a second when it is there).
warm: venv
	@$(VPY) -m netdae.dae.compiled.warm

system-deps:
	@./.ci/ensure-system-deps.sh

demo: system-deps venv warm
	$(VENV)/bin/netdae demo $(DEMO) --out $(OUT)

test: system-deps venv warm
	$(VPY) -m pytest -q

# the long fixed-seed fuzzing runs (a few minutes), kept out of make test
fuzz: venv
	$(VPY) -m pytest -q -m fuzz tests/test_netlist_fuzz.py tests/test_random_circuits.py

bench: system-deps venv warm
	$(VPY) benchmarks/run.py --quick

validation: system-deps venv warm
	$(VPY) scripts/validation.py

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
