# The two commands a new user needs: `make demo` and `make test`. Each builds .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/adverbs info data/cmu16/16_15_walk.bvh
	$(BIN)/adverbs convert data/cmu16/16_19_walk_90-degree_right_turn.bvh out/demo_left_turn.bvh --mirror
	$(BIN)/adverbs info out/demo_left_turn.bvh

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/verbs.py

clean:
	rm -rf $(VENV) out .pytest_cache
