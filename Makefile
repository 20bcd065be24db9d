# One command to see it play (`make demo`), one to test it (`make test`).
# Both create .venv and install the project on first use; nothing but Python 3.10+ is needed.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out

.PHONY: install test test-slow test-ray lint demo bench reproduce reproduce-quick clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check .

test: lint
	$(BIN)/python -m pytest -m "not slow and not ray" -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow -q

test-ray: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[ray,test]'
	$(BIN)/python -m pytest -m ray -q

# The learned MoMP player with the artefacts shipped in models/learned/ (made by `make
# reproduce`; models/learned/README.md says how to regenerate them).
LEARNED := models/learned
demo: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/tt-drake serve --player momp --library $(LEARNED)/library.npz \
	    --crkr $(LEARNED)/crkr.npz --predictor $(LEARNED)/predictor.npz \
	    --serves 5 --seed 1 --html $(OUT)/demo.html --json $(OUT)/demo.json

# The paper's experiments from nothing (resumable: run it again to continue). The quick run
# executes every stage on few serves; CI runs it.
reproduce: $(STAMP)
	$(BIN)/tt-drake reproduce --out $(OUT)/reproduce

reproduce-quick: $(STAMP)
	$(BIN)/tt-drake reproduce --quick --out $(OUT)/reproduce-quick

bench: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/tt-drake bench --json $(OUT)/bench.json

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info .pytest_cache .ruff_cache
