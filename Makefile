# Two commands a newcomer needs: `make run` and `make test`. Both create .venv first.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin

.PHONY: run test test-slow lint clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

# `make run` writes your run to runs/ (not tracked) and compares it with the committed result,
# so the checkout stays clean: wall times and compile times belong to a run, not to a result.
run: $(BIN)/.installed
	$(BIN)/rrr4 check problems/paper_circle.yaml
	$(BIN)/rrr4 run problems/paper_circle.yaml --out runs/paper_circle
	$(BIN)/rrr4 compare results/paper_circle runs/paper_circle

lint: $(BIN)/.installed
	$(BIN)/ruff check .
	$(BIN)/lint-imports

test: lint
	$(BIN)/python -m pytest -q

test-slow: $(BIN)/.installed
	$(BIN)/python -m pytest -q -m slow

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
