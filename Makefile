# Two commands for a new user: `make demo` and `make test` (each sets up .venv first).
VENV := .venv
PY := $(VENV)/bin/python
RATE ?= 1.0

.PHONY: setup demo test test-unit test-fast bench clean

setup:
	@bash scripts/setup_env.sh

demo: setup
	@$(VENV)/bin/nav-demo --rate $(RATE)

# The CI command: two workers (one per core); node tests mostly wait on simulated clocks.
test: setup
	@$(PY) -m pytest -q -n 2 test

# Every test that starts no ROS process and no long simulation: the contributor's loop (< 2 minutes).
test-unit: setup
	@$(PY) -m pytest -q -n 2 -m "not ros and not slow" test

test-fast: setup
	@$(PY) -m pytest -q -n 2 -m "not slow" test

bench: setup
	@$(PY) benchmarks/run_all.py

clean:
	rm -rf build install log $(VENV)
