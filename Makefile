# One command to see it play (`make demo`), one to test it (`make test`).
# Both create .venv and install the project on first use; nothing but Python 3.10+ is needed.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out

.PHONY: install test test-slow test-ray test-rl test-wheel lint demo bench reproduce reproduce-quick \
        reproduce-quick-hard clean

# setuptools notes every editable install of a package folder at the project's root ("Editable
# installation ... be careful with folders in your working directory"); that note alone is
# silenced. `pip install .` warns of nothing (tests/test_packaging.py checks the build's log).
$(STAMP): pyproject.toml setup.py
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	PYTHONWARNINGS='ignore:Editable installation' $(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check .

test: lint
	$(BIN)/python -m pytest -m "not slow and not ray and not rl" -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow -q

# Builds the wheel, installs it into a fresh venv and serves with the shipped learned player from
# a folder outside the checkout (a few minutes: the venv installs Drake, from pip's cache).
test-wheel: $(STAMP)
	$(BIN)/python -m pytest -m wheel -q

test-ray: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[ray,test]'
	$(BIN)/python -m pytest -m ray -q

# Stable-Baselines3 (and torch) for the reinforcement-learning baselines: optional, as Ray.
test-rl: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[rl,test]'
	$(BIN)/python -m pytest -m rl -q

# The learned MoMP player with the artefacts shipped in models/learned/ (made by `make
# reproduce`; models/learned/README.md says how to regenerate them), which `serve --player momp`
# uses when given no artefact. DEMO_SEED is one no training stage used: `tt-drake reproduce`
# serves with base seeds 1 (teacher), 11-12 (predictor), 21-23 (CrKR), 30, 40, 50-69
# (responsibility batches), 7 and 2026 (final; ReproduceConfig in diagrams/reproduce.py).
DEMO_SEED ?= 1000
demo: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/tt-drake serve --player momp --serves 5 --seed $(DEMO_SEED) \
	    --html $(OUT)/demo.html --json $(OUT)/demo.json

# The paper's experiments from nothing (resumable: run it again to continue). The quick run
# executes every stage on few serves; CI runs it.
reproduce: $(STAMP)
	$(BIN)/tt-drake reproduce --out $(OUT)/reproduce

reproduce-quick: $(STAMP)
	$(BIN)/tt-drake reproduce --quick --out $(OUT)/reproduce-quick

# Every stage of the hard profile (spin, real and rally serves; docs/reproducing.md) on few
# serves; CI runs it after reproduce-quick.
reproduce-quick-hard: $(STAMP)
	$(BIN)/tt-drake reproduce --quick --protocol hard --out $(OUT)/reproduce-quick-hard

bench: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/tt-drake bench --json $(OUT)/bench.json

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info .pytest_cache .ruff_cache
