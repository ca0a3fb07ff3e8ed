# Two entry points: `make demo` (install, then run the fleet demo with its dashboard)
# and `make test` (install, make the compiled build, then run the whole suite, then the
# tests of the compiled packages again on that build: tests/compiled_suite.py). Both build
# .venv from this project's own files, so a fresh machine needs nothing installed by hand.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint docs bench chromium mosquitto nftables compiled clean soak soak-floors

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@touch $@

demo: $(STAMP)
	$(BIN)/objectplaces demo

chromium:
	@scripts/ensure-debian-package.sh /usr/bin/chromium chromium fonts-dejavu-core

# The MQTT broker the VDA 5050 tests start on 127.0.0.1.
mosquitto:
	@scripts/ensure-debian-package.sh /usr/sbin/mosquitto mosquitto

# The simulation's modules compiled with mypyc, for this source, into the user's cache
# (objectplaces/compiled.py): a few minutes from a cold cache, nothing when it is there.
# Made before the suite, never inside a test, so no test's time depends on it.
compiled: $(STAMP)
	$(BIN)/python -m agv_app.fleet.compiled

# Packet loss on the test hosts (network namespaces) of tests/hosts and bench/netfaults.py.
nftables:
	@scripts/ensure-debian-package.sh /usr/sbin/nft nftables

test: $(STAMP) chromium mosquitto nftables compiled
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -n 2 --dist worksteal
	$(BIN)/python -m tests.compiled_suite --no-slow

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

# The documentation site (mkdocs.yml) into site/, offline; any warning fails the build.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict

BENCHMARKS := tuplespace groups mesh fleet dashboard vda5050 tls stop

bench: $(STAMP) chromium mosquitto
	for name in $(BENCHMARKS); do $(BIN)/python -m bench.$$name || exit 1; done

# The simulation suite (docs/soak.md): SEEDS seeds from 1, on two worker processes; a
# failing seed prints its replay command and the target fails.
SEEDS ?= 200
soak: $(STAMP)
	$(BIN)/python -m tests.soak.runner --seeds 1-$(SEEDS) --jobs 2

# Fleets on random one-way floors (docs/soak.md): FLOOR_SEEDS seeds from 0.
FLOOR_SEEDS ?= 300
soak-floors: $(STAMP)
	$(BIN)/python -m tests.soak.floors --seeds 0-$$(($(FLOOR_SEEDS) - 1)) --jobs 2

clean:
	rm -rf $(VENV) site .pytest_cache .mypy_cache .ruff_cache .hypothesis
