# Wavekeep: the two commands a new user needs are `make run` and `make test`.
# Both create ./.venv on first use and install the project into it.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-fast lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,lint,view,blueos]'
	# The real-browser test of the view (tests/test_view_browser.py, skipped where either cannot install):
	# Debian's Chromium, driven by Playwright's Python client (it drives /usr/bin/chromium; no browser download)
	-command -v chromium >/dev/null || (apt-get install -y chromium >/dev/null 2>&1 || \
	  (apt-get update >/dev/null 2>&1 && apt-get install -y chromium >/dev/null 2>&1)) || \
	  echo "chromium not installed: the browser test of the view will be skipped"
	-$(BIN)/pip install --quiet playwright
	# A headless MAVProxy for the ground-station acceptance test (its GUI dependencies are not needed)
	$(BIN)/pip install --quiet --no-deps MAVProxy==1.8.75 pyserial
	# Third-party MAVLink clients for tests/test_mavlink_clients.py (skipped where they cannot be installed):
	# MAVSDK-Python's gRPC API with its bundled mavsdk_server (mavsdk<4), and dronekit2 (dronekit 2.9 fails on 3.11)
	-$(BIN)/pip install --quiet "mavsdk<4" dronekit2
	touch $(STAMP)

# make run ARGS="--case W1 --duration 60": options are passed through (later ones win); the folder follows them
# (runs/sim-W1-cpd_ff-60s; docs: `wavekeep sim -h`, --out), and --force replaces that folder's previous run
ARGS ?=
run: $(STAMP)
	$(BIN)/wavekeep sim --case W3 --controller cpd_ff --force $(ARGS)

# Two pytest-xdist workers, one test file each at a time (a file's shared boots and module fixtures stay on one
# worker). A third was faster still (the suite waits on real time more than on the CPU) but loaded the machine
# past what the real-ArduSub conformance timings hold. TEST_WORKERS=0 runs in one process.
TEST_WORKERS ?= 2
test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# The inner loop's tier (about 2 minutes): every package's tests but those that start processes
# (launcher, companion, campaigns, the real ArduSub, the browser), which `make test` adds
test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not processes"

# ruff (style and bugs), mypy (types), import-linter (the layers of docs/architecture.md)
lint: $(STAMP)
	$(BIN)/ruff check firmware_py sitl bridge blueos tests benchmarks
	$(BIN)/mypy
	$(BIN)/lint-imports

bench: $(STAMP)
	$(BIN)/python -m benchmarks.run_all

clean:
	rm -rf $(VENV) runs .pytest_cache
