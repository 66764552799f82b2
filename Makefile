# The README's two commands. Each sets up .venv (once, re-done when pyproject.toml or the lock
# changes) with the exact versions in requirements.lock, then the project itself without its ranges.
PY := .venv/bin/python
FLAGSHIP ?= lebedev_spinup_cmg

.PHONY: run test test-fast fuzz bench docs
run: .venv/.installed
	$(PY) -m testbed run $(FLAGSHIP)

test: .venv/.installed
	$(PY) -m pytest

# Everything but the tests marked slow (whole-scenario runs). Times: docs/validation.md "Measured times".
test-fast: .venv/.installed
	$(PY) -m pytest -m "not slow"

# The documentation site (mkdocs.yml, docs/) into site/; --strict: a broken link or reference fails.
docs: .venv/.installed
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict -d site

# The long hostile-input fuzz: 3000 examples instead of the suite's 150.
fuzz: .venv/.installed
	TESTBED_FUZZ_EXAMPLES=3000 $(PY) -m pytest tests/test_fuzz.py

# The last one fails (exit 1) when a shipped scenario's wall time per simulated second grew by
# more than 15 % against the commit in bench/speed_baseline.json, both run here, alternately.
bench: .venv/.installed
	$(PY) bench/bench_pipeline.py
	$(PY) bench/bench_minimax.py
	$(PY) bench/bench_sweep.py
	$(PY) bench/bench_stepping.py
	$(PY) bench/bench_speed_regression.py

.venv/.installed: pyproject.toml requirements.lock
	python3 -m venv .venv
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	touch $@
