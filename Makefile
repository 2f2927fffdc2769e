# The README's two commands: `make demo` and `make test`. Both create/refresh
# .venv only when the requirement files changed (stamp file), so they are
# quick when nothing changed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.drill_twin-installed
REQS := requirements/base.txt requirements/ros.txt requirements/dev.txt requirements/constraints.txt requirements/bootstrap.txt setup.py setup.cfg pyproject.toml
# the locked install: uv (pinned in requirements/bootstrap.txt, ~12 s for the whole set
# against pip's ~50 s), pip itself if uv cannot (an index only pip.conf knows, no uv wheel).
# --compile-bytecode as pip does: where PYTHONDONTWRITEBYTECODE is set, a package installed
# without its .pyc is compiled from source by every process that imports it
LOCKED := -c requirements/constraints.txt -r requirements/base.txt -r requirements/ros.txt -r requirements/dev.txt
define install
	$(VENV)/bin/uv pip install -q --native-tls --compile-bytecode --python $(PY) $(1) || \
	{ echo "make venv: uv could not install, pip does (slower)"; $(PY) -m pip install -q $(1); }
endef

# parallel pytest workers (each its own ROS domain; the kernels are compiled once, by make
# venv): three on two cores, because a sixth of the suite waits on processes and DDS (two
# workers keep 1.65 of 2 cores busy: 7 min 04 s; three 6 min 31 s)
TEST_WORKERS ?= 3
# the unit tier is all numerics: one worker per core
FAST_WORKERS ?= 2

.PHONY: venv demo test test-fast lint bench bench-smoke clean clean-cache

venv: $(STAMP)

$(STAMP): $(REQS)
	@echo "make venv: installing the locked dependencies into $(VENV) (first time: under a minute with uv, 2-4 min with pip; later only when a requirement file changed)"
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -r requirements/bootstrap.txt || echo "make venv: no uv wheel"
	$(call install,$(LOCKED))
	$(call install,--no-deps -e .)
	@echo "make venv: dependencies installed"
	$(PY) -m drill_twin.cli compile
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m drill_twin.cli demo --out runs/demo

test: $(STAMP)
	$(PY) -m ruff check drill_twin test launch bench
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist worksteal

# the unit tier: numerics in one process, no ROS, no processes, no studies (< 1 min)
test-fast: $(STAMP)
	$(PY) -m pytest -q -m unit -n $(FAST_WORKERS) --dist worksteal

bench: $(STAMP)
	$(PY) -m pip install -q -c requirements/constraints.txt -r requirements/bench.txt
	$(PY) bench/run.py

bench-smoke: $(STAMP)
	$(PY) -m pip install -q -c requirements/constraints.txt -r requirements/bench.txt
	$(PY) -m pytest -q -m bench test/test_bench_smoke.py

lint: $(STAMP)
	$(PY) -m ruff check drill_twin test launch bench

clean:
	rm -rf $(VENV) build install log runs *.egg-info

clean-cache:
	find drill_twin -name '*.nbi' -delete -o -name '*.nbc' -delete
	$(PY) -c "import drill_twin.physics.numba_cache as c; print(c.clear(), 'numba cache directories removed under', c.cache_root())"
