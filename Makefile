# The README's two commands. Each sets up .venv (once, re-done when pyproject.toml or the lock
# changes) with the exact versions in requirements.lock, then the project itself without its ranges.
PY := .venv/bin/python
FLAGSHIP ?= lebedev_spinup_cmg

.PHONY: run test test-fast fuzz bench docs
run: .venv/.installed
	$(PY) -m testbed run $(FLAGSHIP)

test: .venv/.installed
	$(PY) -m pytest

# Everything but the tests marked slow (whole-scenario runs): under a minute.
test-fast: .venv/.installed
	$(PY) -m pytest -m "not slow"

# The documentation site (mkdocs.yml, docs/) into site/; --strict: a broken link or reference fails.
docs: .venv/.installed
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict -d site

# The long hostile-input fuzz: 3000 examples instead of the suite's 150 (about 2 min quiet, 15 under load).
fuzz: .venv/.installed
	TESTBED_FUZZ_EXAMPLES=3000 $(PY) -m pytest tests/test_fuzz.py

bench: .venv/.installed
	$(PY) bench/bench_pipeline.py
	$(PY) bench/bench_minimax.py
	$(PY) bench/bench_sweep.py
	$(PY) bench/bench_stepping.py

.venv/.installed: pyproject.toml requirements.lock
	python3 -m venv .venv
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	touch $@
