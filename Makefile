# The two commands a new user needs: `make demo` and `make test`. Each builds .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The third-party loaders our exported files are checked with (three.js, the Khronos glTF validator), from npm.
JS := tests/js/node_modules/.package-lock.json

.PHONY: demo examples test bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	$(BIN)/python -m adverbs.apps.warm
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/adverbs demo --out out/demo

# More of what the library does, one command each: verbs built, synthesized, evaluated; a graph played.
examples: $(STAMP)
	$(BIN)/adverbs info data/bandai/dataset-1_walk_happy_001.bvh
	$(BIN)/adverbs build specs/bandai_styled_walk.toml -o out/bandai_styled_walk.verb
	$(BIN)/adverbs describe out/bandai_styled_walk.verb
	$(BIN)/adverbs synth out/bandai_styled_walk.verb --adverb valence=1 --adverb energy=0.6 --adverb turn=45 --cycles 4 -o out/happy_walk_turning_left.bvh
	$(BIN)/adverbs synth out/bandai_styled_walk.verb --adverb valence=-1 --adverb energy=-1 --adverb turn=-40 --cycles 3 -o out/sad_walk_turning_right.bvh
	$(BIN)/adverbs synth out/bandai_styled_walk.verb --adverb valence=0.3 --adverb energy=0.3 --adverb turn=0 --cycles 4 --floor slope:10 -o out/walk_up_a_10_degree_slope.bvh
	$(BIN)/adverbs build specs/cmu_walk.toml -o out/cmu_walk.verb
	$(BIN)/adverbs synth out/cmu_walk.verb --adverb speed=2.1 --adverb turn=0 --cycles 4 -o out/cmu_walk_faster_than_any_example.bvh
	$(BIN)/adverbs evaluate out/cmu_walk.verb --png out/cmu_walk_evaluate.png
	$(BIN)/adverbs build specs/cmu_run.toml -o out/cmu_run.verb
	$(BIN)/adverbs synth out/cmu_run.verb --adverb speed=3.0 --adverb turn=60 --cycles 4 --floor slope:5 -o out/cmu_run_turning_left_uphill.bvh
	$(BIN)/adverbs graph graphs/bandai.toml --describe
	$(BIN)/adverbs graph graphs/bandai.toml --play "1:walk,5:turn=30,8:run,12:walk,15:idle,17:bow,25:reach" --seconds 30 --adverb valence=0.5 -o out/bandai_graph.bvh

$(JS): tests/js/package.json tests/js/package-lock.json
	@if command -v npm >/dev/null 2>&1; then cd tests/js && npm ci --no-audit --no-fund --loglevel=error; \
	else echo "npm not found: the three.js and glTF validator checks will say they were skipped"; fi

test: $(STAMP) $(JS)
	$(BIN)/python -m pytest -q -n auto

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/verbs.py
	$(BIN)/python benchmarks/feet.py
	$(BIN)/python benchmarks/graph.py
	$(BIN)/python benchmarks/crowd.py
	$(BIN)/python benchmarks/runtime.py
	$(BIN)/python benchmarks/long_run.py
	$(BIN)/python benchmarks/viewer.py
	$(BIN)/python benchmarks/dataset.py
	$(BIN)/python benchmarks/edges.py

clean:
	rm -rf $(VENV) out .pytest_cache tests/js/node_modules
