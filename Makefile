# The two set-up commands of the README: `make demo` and `make test`. Both create .venv when absent.
# `make demo` installs the package and its base dependencies only (what the demo runs on); the
# targets that test, lint or type-check install the dev extras (the optional formats and tools).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
BASE_STAMP := $(VENV)/.installed-base
STAMP := $(VENV)/.installed
OUT ?= out/demo
# "compat" editable installs put the clone on sys.path, so Python started in the clone's parent
# folder imports the package, not the clone's folder (which the default editable finder loses to).
EDITABLE := --config-settings editable_mode=compat

.PHONY: demo test test-houses lint typecheck bench clean

# Both installs leave everything compiled: pip writes the dependencies' bytecode (its default),
# and compileall the package's own (an editable install leaves it as source). Where Python may
# not write bytecode (PYTHONDONTWRITEBYTECODE=1, common in containers; a read-only install) every
# command would otherwise compile all it imports again, each time: 10-27 s a command instead of
# about 1 s (benchmarks/cli.py). The cost is disk (every dependency's bytecode beside its
# sources) and a slightly longer install.
$(BASE_STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e . $(EDITABLE)
	$(BIN)/python -m compileall -q scenemosaic
	touch $(BASE_STAMP)

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]' $(EDITABLE)
	$(BIN)/python -m compileall -q scenemosaic
	touch $(STAMP) $(BASE_STAMP)

demo: $(BASE_STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/scenemosaic demo --out $(OUT)

# TEST_WORKERS: pytest-xdist processes for make test (the suite is CPU-bound and single-threaded
# per test: two workers on a 2-core machine take it from ~22 to ~12 minutes); 0 runs in one process.
TEST_WORKERS ?= 2

test: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS) -m "not house and not long"

test-houses: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -q -p no:cacheprovider -m "house or long"

lint: $(STAMP)
	$(BIN)/ruff check scenemosaic tests benchmarks examples

typecheck: $(STAMP)
	$(BIN)/mypy scenemosaic

bench: $(STAMP)
	for f in benchmarks/*.py; do $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) out .scenemosaic-cache
