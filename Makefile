# One entry point for humans and CI. `make run` and `make test` are all a fresh machine needs.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The versions that were tested, for every platform (docs/install.md: "Upgrading").
LOCK := requirements.lock
DEV_LOCK := requirements-dev.lock
PIP_VERSION := 26.3
# The installer of `make install` (uv, or INSTALLER=pip) and uv's version.
INSTALLER ?= uv
UV_VERSION := 0.13.9
# The install with pip alone. setuptools warns about every editable install that folders
# named like its packages may shadow them: here they are those packages.
PIP_INSTALL = $(BIN)/python -m pip install --quiet --disable-pip-version-check 'pip==$(PIP_VERSION)' && \
	PYTHONWARNINGS="ignore:Editable installation" $(BIN)/python -m pip install \
	--quiet --disable-pip-version-check -c $(DEV_LOCK) -e '.[test]'
# `make wheelhouse`: wheels for these targets (CPython, glibc >= 2.35: Debian 12, Ubuntu 22.04).
WHEEL_ARCHS ?= x86_64 aarch64
WHEEL_PYTHON ?= 3.11
WHEEL_GLIBC_MINORS := $(shell seq 17 35)

.PHONY: install run test lint format bench eval lock wheelhouse example clean browser

install: $(STAMP)

$(STAMP): pyproject.toml $(LOCK) $(DEV_LOCK)
	@echo "installing into $(VENV) the versions pinned in $(DEV_LOCK)"
	$(PYTHON) -m venv $(VENV)
	@# uv installs the same pinned wheels as pip does, in 21 s instead of 53 s here (downloads
	@# in parallel, bytecode compiled on both cores). --compile-bytecode as pip does: where
	@# PYTHONDONTWRITEBYTECODE is set, each of the suite's subprocesses would otherwise compile
	@# numpy's, numba's and zenoh's modules again at every start. `make install INSTALLER=pip`
	@# installs with pip alone (where uv has no wheel).
ifeq ($(INSTALLER),pip)
	$(PIP_INSTALL)
else
	@# uses the system's certificates, as pip does here (PIP_CERT); where uv cannot install
	@# (no wheel of it, an index it cannot reach), pip does it all
	($(BIN)/python -m pip install --quiet --disable-pip-version-check 'uv==$(UV_VERSION)' && \
		PYTHONWARNINGS="ignore:Editable installation" UV_LINK_MODE=copy UV_NATIVE_TLS=1 \
		$(BIN)/uv pip install --quiet --python $(BIN)/python --compile-bytecode \
		-c $(DEV_LOCK) -e '.[test]' 'pip==$(PIP_VERSION)') || \
		(echo "uv could not install the packages: installing them with pip" && $(PIP_INSTALL))
endif
	@# Compile the detector's numba kernels into their on-disk cache now, in two processes (11 s
	@# instead of 20 s), not during the first run.
	$(BIN)/python -c "import hos._jit as j; print(f'detector kernels ready ({j.compile_in_parallel():.1f} s)')"
	touch $(STAMP)

run: install
	$(BIN)/weatherd run --config config/weatherd.toml

lint: install
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

format: install
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

# The suite runs on up to TEST_JOBS workers (pytest-xdist; one per core, CI has two): every
# test starts its own servers on ports it is given, so they do not meet. A worker that runs
# out of tests takes some of the other's (worksteal), so the slowest tests (a minute of
# rendered video) do not leave one core idle at the end. TEST_JOBS=0 runs it in this
# process, for pdb.
TEST_JOBS ?= 2
test:
	@# Debian's chromium (about a minute to install where it is missing) is installed beside
	@# the Python packages, not after them.
	@$(MAKE) --no-print-directory browser & browser=$$!; \
		$(MAKE) --no-print-directory install lint; status=$$?; wait $$browser; exit $$status
	@# Where PYTHONDONTWRITEBYTECODE is set (it is on this machine, and may be on CI), Python caches no
	@# bytecode, and each of the suite's ~200 weatherd and python subprocesses would compile the
	@# project's modules again: 0.5 s of a 1.5 s start. They are compiled once here instead.
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m compileall -q daemon drivers hos bench
	@# pytest rewrites the asserts of the tests and of its plugins' packages (hypothesis,
	@# xdist) in each of its three processes, and caches the result only where bytecode may be
	@# written: 8-9 s of each worker's 12 s collection here, again at every run.
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -q $(if $(filter 0,$(TEST_JOBS)),,-n auto --maxprocesses=$(TEST_JOBS) --dist worksteal)

# The status page's tests drive Debian's chromium (tests/daemon/web/test_browser.py): installed
# here when this runs as root on Debian, else they are skipped with the reason (under CI=true a
# missing browser fails them). Playwright itself comes from the dev lock; it never downloads a
# browser.
browser:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's chromium for the status page's browser tests (about a minute)"; \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium \
			>/dev/null) || echo "WARNING: apt-get could not install chromium: the browser tests will fail"; \
	else \
		echo "NOTE: chromium is missing and this is not root on Debian: the status page's browser"; \
		echo "      tests are skipped (install it with: sudo apt-get install chromium)"; \
	fi

# The worked example of docs/offline.md: a short rainy MCAP log and a matching gauge CSV, made
# by the simulator into build/example (about 30 s).
example: install
	PATH="$(CURDIR)/$(BIN):$$PATH" sh docs/example/make_example.sh build/example

bench: install
	$(BIN)/python bench/bench_detector.py
	$(BIN)/python bench/bench_memory.py
	$(BIN)/python bench/bench_zenoh_sites.py --sites 200 --seconds 20

# The scene-family benchmark: the detector on randomised scenes of a tuning and an evaluation
# split, scored against the targets of docs/figures.md ("Scene-family benchmark"); about
# 20 minutes on 2 cores (each rain scene is rendered twice), and it says how long it took.
eval: install
	$(BIN)/python bench/eval_scenes.py

# Resolve pyproject.toml's ranges again to today's newest versions, for every platform
# (uv's universal resolution), then `make test` and commit both files.
lock: install
	$(BIN)/python -m pip install --quiet --disable-pip-version-check 'uv==$(UV_VERSION)'
	$(BIN)/uv pip compile pyproject.toml --universal --python-version 3.11 --no-header \
		--annotation-style line --upgrade -o $(LOCK)
	$(BIN)/uv pip compile pyproject.toml --extra test --universal --python-version 3.11 \
		--no-header --annotation-style line -c $(LOCK) -o $(DEV_LOCK)

# Every wheel the daemon needs, per target, for an installation without network
# (docs/install.md: "Offline"). Fails when a dependency has no wheel for a target.
wheelhouse: install
	rm -rf wheelhouse
	$(BIN)/python -m pip wheel --quiet --disable-pip-version-check --no-deps -w wheelhouse/any .
	for arch in $(WHEEL_ARCHS); do \
		$(BIN)/python -m pip download --quiet --disable-pip-version-check --no-deps \
			--only-binary=:all: --implementation cp --python-version $(WHEEL_PYTHON) \
			$(foreach m,$(WHEEL_GLIBC_MINORS),--platform manylinux_2_$(m)_$$arch) \
			--platform manylinux2014_$$arch -r $(LOCK) -d wheelhouse/$$arch || exit 1; \
		cp wheelhouse/any/*.whl wheelhouse/$$arch/; \
		echo "wheelhouse/$$arch: $$(ls wheelhouse/$$arch | wc -l) wheels"; \
	done

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache wheelhouse
