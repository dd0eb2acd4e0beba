# Set-up and entry points. `make campaign` and `make test` each create .venv if it is missing
# and install the project into it from the pinned lock, then do their job. The install reruns
# only when pyproject.toml or constraints.txt changes (stamp file).

PYTHON ?= python3
, := ,
VENV   := .venv
PY     := $(VENV)/bin/python
LOCK   := constraints.txt
STAMP  := $(VENV)/.campaign-installed
CLUSTER_STAMP := $(VENV)/.campaign-cluster-installed
# The installer: uv (PyPI's `uv`, a fast installer: it downloads in parallel and links from its
# cache) when it is on the PATH, else pip; both install the same pinned lock into the same
# .venv. `make UV= ...` uses pip even where uv is installed.
UV ?= $(shell command -v uv 2>/dev/null)
# the interpreter's own path for uv venv, so that uv never picks or downloads another Python
PYTHON_EXE = $$($(PYTHON) -c 'import sys; print(sys.executable)')
# install the project (the extras in $(1)) into .venv from the lock; pip first installs itself
# into a venv that uv made without it
ifneq ($(UV),)
INSTALL = $(UV) pip install --python $(PY) -c $(LOCK) -e '.[$(1)]'
else
INSTALL = { $(PY) -m pip --version >/dev/null 2>&1 || $(PY) -m ensurepip -q; } && \
	$(PY) -m pip install --disable-pip-version-check -c $(LOCK) -e '.[$(1)]'
endif
# `make test-slurm SLURM_TEST_ARGS=--skip-if-unable` passes on a machine that cannot run it
SLURM_TEST_ARGS ?=

# The one place that says what `make campaign` runs: the full campaign through Snakemake on
# 2 cores (profiles/default), then its HTML report, whose path it prints.
CAMPAIGN_CMD = $(VENV)/bin/snakemake --cores 2 && $(VENV)/bin/snakemake --report results/full/report.html && echo "campaign report: $(CURDIR)/results/full/report.html"

.PHONY: campaign test test-slurm bench docs screenshots install install-cluster lock help

help:
	@echo "make campaign   set up .venv if needed, then run the campaign ($(CAMPAIGN_CMD))"
	@echo "make test       set up .venv if needed, then run the linter (ruff) and the test suite (pytest)"
	@echo "make test-slurm as root: the reduced campaign through a one-node SLURM cluster (tests/cluster/slurm.sh)"
	@echo "make bench      run every benchmarks/bench_*.py on one BLAS thread, each output also in benchmarks/out/ (timings; see benchmarks/README.md)"
	@echo "make docs       build the user guide into docs/_build/html (Sphinx, warnings are errors)"
	@echo "make screenshots  build the reduced campaign's report and the guide, check them in headless Chromium, PNGs in build/screenshots/"
	@echo "make install    only (re)install the project into .venv from $(LOCK) (with $(if $(UV),uv,pip))"
	@echo "make install-cluster  the same plus the SLURM executor plugin (extra 'cluster')"
	@echo "make lock       re-resolve pyproject.toml in a scratch venv and rewrite $(LOCK)"

campaign: $(STAMP)
	$(CAMPAIGN_CMD)

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/pytest

# Installs munge and Slurm (apt-get) and starts a private one-node cluster: root only, and
# separate from `make test`, which needs neither.
test-slurm: $(CLUSTER_STAMP)
	tests/cluster/slurm.sh $(SLURM_TEST_ARGS)

# Timings of one core: BLAS pinned to one thread before numpy loads (each script pins it too,
# for a run by hand); each script's output also goes to benchmarks/out/<script>.txt (git-ignored).
# A script that misses its target exits 1, which stops the loop after printing its output.
BENCH_ENV := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

bench: $(STAMP)
	@mkdir -p benchmarks/out
	@set -e; for script in benchmarks/bench_*.py; do \
	  out=benchmarks/out/$$(basename $$script .py).txt; echo "== $$script (output: $$out)"; \
	  status=0; $(BENCH_ENV) $(PY) $$script > $$out 2>&1 || status=$$?; cat $$out; test $$status -eq 0; done

# The user guide (docs/): every warning, a broken cross-reference included, fails the build.
docs: $(STAMP)
	$(VENV)/bin/sphinx-build -b html -W --keep-going -n docs docs/_build/html
	@echo "user guide: $(CURDIR)/docs/_build/html/index.html"

# The report and the guide as a reader sees them (tests/screenshots.py): the reduced campaign,
# its report and the guide built, then checked and photographed in headless Chromium
# (Debian: apt-get install -y chromium); without Chromium it says so and succeeds. Not part
# of `make test`.
screenshots: $(STAMP)
	$(PY) tests/screenshots.py

install: $(STAMP)

install-cluster: $(CLUSTER_STAMP)

$(PY):
ifneq ($(UV),)
	UV_PYTHON_DOWNLOADS=never $(UV) venv --python "$(PYTHON_EXE)" $(VENV)
else
	$(PYTHON) -m venv $(VENV)
endif

$(STAMP): pyproject.toml $(LOCK) | $(PY)
	$(call INSTALL,test)
	touch $@

$(CLUSTER_STAMP): pyproject.toml $(LOCK) | $(PY)
	$(call INSTALL,test$(,)cluster)
	touch $@ $(STAMP)

# Newest versions allowed by pyproject.toml (with the test and cluster extras), resolved in a
# scratch venv, frozen into the lock.
lock:
	@set -e; tmp=$$(mktemp -d); \
	$(PYTHON) -m venv $$tmp/venv; \
	$$tmp/venv/bin/python -m pip install --disable-pip-version-check -q -e '.[test,cluster]'; \
	{ echo "# Exact versions of every dependency (incl. transitive) for 'pip install -c $(LOCK) -e .[test,cluster]'."; \
	  echo "# Generated by 'make lock' (pip freeze --exclude-editable); pyproject.toml keeps the ranges."; \
	  $$tmp/venv/bin/python -m pip freeze --exclude-editable; } > $(LOCK).tmp; \
	mv $(LOCK).tmp $(LOCK); rm -rf $$tmp; echo "wrote $(LOCK)"
