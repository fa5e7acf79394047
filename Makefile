# Two entry points for a fresh machine: `make run` and `make test`. Both create .venv when missing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
SCENARIO ?= configs/paper.toml
OUT ?= runs/paper
# Python's bytecode cache on, whatever the environment says: with PYTHONDONTWRITEBYTECODE set (as on our dev machine)
# every cpf, vehicle and broker process compiled our modules from source again, ~0.2 s of each start-up (cpf
# validate: 1.10 -> 0.90 s), paid by hundreds of processes in `make test`.
unexport PYTHONDONTWRITEBYTECODE

.PHONY: run test bench lint typecheck pytest unit clean docs readme study lock

# uv installs what pip would (the same packages and versions, checked with pip list) in 18 s instead of 75 s. The
# versions are pinned in requirements.lock (every dependency, the dev tools too), so that two clones a month apart
# install the same; `make lock` refreshes it to the newest pyproject.toml allows.
$(STAMP): pyproject.toml requirements.lock
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip uv
	$(BIN)/uv pip install --quiet --python $(BIN)/python -r requirements.lock
	$(BIN)/uv pip install --quiet --python $(BIN)/python --no-deps -e .
	touch $(STAMP)

lock: $(STAMP)
	$(BIN)/uv pip compile --quiet pyproject.toml --extra dev --universal --upgrade --custom-compile-command "make lock" \
		-o requirements.lock

run: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/cpf run $(SCENARIO) --out $(OUT)/run.mcap
	$(BIN)/cpf report $(OUT)/run.mcap --out $(OUT)

# The scenario reference and JSON Schema, generated from supervisor/config/scenario_schema.py (tests/test_reference.py).
docs: $(STAMP)
	mkdir -p docs
	$(BIN)/cpf schema --markdown > docs/scenario-reference.md
	$(BIN)/cpf schema > docs/scenario.schema.json

# The README's example outputs, rerun with the current code (tests/test_readme.py checks the paper block).
readme: $(STAMP)
	$(BIN)/python scripts/readme_numbers.py

# The robustness study (README, "Robustness study"): each effect alone, fix-period and current sweeps; ~12 min of
# CPU on 2 cores with 4 seeds. Output in runs/study/ (results.csv, table.md, study_*.png). Then coordination on
# slow links (README, "Coordination on slow links"): real_links.md, period_loss.csv, period_loss_map.png, ~6 min.
# Then robust vehicles (README, "Robust vehicles"): mismatch.md, mismatch.csv, current.md, 10 seeds, ~5 min; and
# the REMUS on its fins: fins.md, fins.csv, ~8 min.
SEEDS ?= 4
study: $(STAMP)
	$(BIN)/python scripts/robustness_study.py --seeds $(SEEDS) --jobs 2 --out runs/study
	$(BIN)/python scripts/real_links_study.py --jobs 2 --out runs/study
	$(BIN)/python scripts/vehicle_robustness.py --seeds 10 --jobs 2 --out runs/study
	$(BIN)/python scripts/fins_robustness.py --seeds 10 --jobs 2 --out runs/study

bench: $(STAMP)
	$(BIN)/python -m benchmarks

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

# Lint and the type checker run beside the tests, not before them: alone, mypy's ~32 s on one core left the other
# idle. `make test` fails if any of the three does.
test: $(STAMP)
	$(MAKE) --no-print-directory -j 3 lint typecheck pytest

# Two workers (pytest-xdist), one per core: the suite is CPU-bound (its e2e runs' processes included, both cores
# are busy with two workers; three gave no gain); worksteal balances the long tests between them.
pytest: $(STAMP)
	$(BIN)/pytest -n 2 --dist worksteal --durations=30

clean:
	rm -rf $(VENV) runs .pytest_cache .mypy_cache .ruff_cache
