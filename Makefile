# One entry point for humans and CI. `make run` and `make test` are all a fresh machine needs.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install run test lint format bench clean example

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@# Compile the detector's numba kernels into their on-disk cache now (a few seconds, once),
	@# not during the first run.
	$(BIN)/python -c "import hos._jit as j; print(f'detector kernels ready ({j.warm_up():.1f} s)')"
	touch $(STAMP)

run: install
	$(BIN)/weatherd run --config config/weatherd.toml

lint: install
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

format: install
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

test: install lint
	$(BIN)/python -m pytest -q

# The worked example of docs/offline.md: a short rainy MCAP log and a matching gauge CSV, made
# by the simulator into build/example (about 30 s).
example: install
	PATH="$(CURDIR)/$(BIN):$$PATH" sh docs/example/make_example.sh build/example

bench: install
	$(BIN)/python bench/bench_detector.py
	$(BIN)/python bench/bench_zenoh_sites.py --sites 200 --seconds 20

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
