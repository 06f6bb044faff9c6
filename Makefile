# pmmw: two commands on a fresh machine.
#   make render   create .venv, install pmmw, render the shipped landing scenario (Murakowski 2014, sec. 3.1)
#   make test     create .venv, install pmmw with test extras, run the test suite
#   make blender-addon   the Blender add-on as dist/pmmw_blender.zip (Blender: Preferences > Install from Disk)
#   make test-blender    the Blender tests with bpy in a venv of its own (Python 3.11; ~1 GB, ~80 s to install)
#   make docs     install the docs extra, build the documentation site into site/ (offline, strict)
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
SCENARIO ?= configs/landing_95ghz.yaml
# two test processes, whole files each (a file's module fixtures are built once); PYTEST_ARGS= runs one
PYTEST_ARGS ?= -n 2 --dist loadfile

.PHONY: render test test-full lint docs install install-test install-docs clean blender-addon test-blender

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip >/dev/null

# the tracer's kernels for smooth scenes compiled once at install (numba's disk cache), so that the
# first render does not (pmmw.trace.compile; docs/benchmarks_command.md)
COMPILE = @echo "compiling the tracer's kernels: once, about 20 s on 2 cores ..." && $(BIN)/python -m pmmw.trace.compile

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -e .
	$(COMPILE)
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -e '.[test]'
	$(COMPILE)
	touch $@ $(VENV)/.installed

$(VENV)/.installed-docs: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -e '.[docs]'
	touch $@ $(VENV)/.installed

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test
install-docs: $(VENV)/.installed-docs

render: install
	$(BIN)/pmmw render $(SCENARIO)

test: install-test
	$(BIN)/python -m pytest $(PYTEST_ARGS)

# ruff's rules of pyproject.toml ([tool.ruff]): pyflakes, pycodestyle's errors, import order; ruff's
# formatting (line length 120, checked, `ruff format` applies it); mypy on
# the numerics and the application layer ([tool.mypy] in pyproject.toml)
lint: install-test
	$(BIN)/ruff check pmmw pmmw_cli tests examples scenes docs bench
	$(BIN)/ruff format --check pmmw pmmw_cli tests examples scenes docs bench
	$(BIN)/mypy

# also the longest convergence renders of the shipped configs (about 2.5 minutes more)
test-full: install-test
	PMMW_TEST_FULL=1 $(BIN)/python -m pytest $(PYTEST_ARGS)

# the Blender add-on's zip (docs/blender.md); needs only Python's standard library
blender-addon:
	$(PYTHON) -m pmmw.blender dist/pmmw_blender.zip

# Blender's bpy in a venv of its own (its wheels need Python 3.11 up to Blender 5.0), for tests/blender/test_blender.py
BPY_PYTHON ?= python3.11
BPY_VENV   ?= .venv-bpy
$(BPY_VENV)/bin/python:
	$(BPY_PYTHON) -m venv $(BPY_VENV)
	$(BPY_VENV)/bin/python -m pip install 'bpy==5.0.1'  # the version tested (pyproject's extra allows 4.2+)

test-blender: install-test $(BPY_VENV)/bin/python
	PMMW_BLENDER_PYTHON=$(abspath $(BPY_VENV))/bin/python $(BIN)/python -m pytest tests/blender/test_blender.py "tests/cli/test_docs_commands.py::test_the_cheap_documented_commands_run"

# the site (mkdocs.yml): guides, reference pages generated from the code, the examples run small
# (PMMW_GALLERY=skip leaves them out, for a quick look); warnings (a broken link) fail it
docs: install-docs
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(BIN)/mkdocs build --strict

clean:
	rm -rf out site .pytest_cache .hypothesis
