# impactsim: every command a developer or CI needs. `make test` is what CI runs.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
BIN := $(VENV)/bin
CASES := elastic-bar-wall taylor-bar two-cubes two-cylinders elastic-bars hertz-spheres sphere-plate oblique-sphere elastic-bar-wall-hex taylor-bar-hex taylor-bar-42crmo4 two-cylinders-hex sphere-plate-hex three-plate-shield
SWEEP ?= cases/sweeps/mesh-size.toml
REV ?= HEAD

.PHONY: setup test hard bench bench-quasistatic bench-peers compare accuracy validate fracture-compare sweep cases demo clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --upgrade pip >/dev/null

# the install, then every numba kernel compiled once into the cache next to the sources
# (impactsim/warmup.py), so that no run waits for compilation
setup: $(PY)
	$(BIN)/pip install -e '.[test]'
	$(BIN)/python -m impactsim.warmup

# the whole fast suite: unit, verification, CLI and the fast share of the stability suite
test: setup
	$(BIN)/python -m pytest -q -m "not slow"

# the long versions of the stability suite
hard: setup
	$(BIN)/python -m pytest -q -m slow tests

bench: setup
	$(BIN)/python benchmarks/run.py

# the quasistatic pellet stack: 10, 50 and 350 bodies with 1 and 2 Dask workers (minutes)
bench-quasistatic: setup
	QS_SIZES=10,50,350 QS_WORKERS=1,2 $(BIN)/python benchmarks/bench_quasistatic.py

# impactsim beside PySPH, each refined until its Taylor bar's length converges to 1 % (about an
# hour; PySPH is built from source into its own environment, $(PEERS_VENV), the first time)
PEERS_VENV ?= .venv-peers
$(PEERS_VENV)/bin/pysph:
	$(PYTHON) -m venv $(PEERS_VENV)
	$(PEERS_VENV)/bin/pip install pysph

bench-peers: setup $(PEERS_VENV)/bin/pysph
	$(BIN)/python benchmarks/peers.py --peer-python $(PEERS_VENV)/bin/python --write

# whole-step time of the working tree against a revision, in one process: make compare REV=HEAD~3
compare: setup
	$(BIN)/python benchmarks/compare.py $(REV)

# accuracy against cost: runs the studies, writes docs/accuracy.md and docs/accuracy/*.png
accuracy: setup
	$(BIN)/python benchmarks/accuracy.py

# the validation ladder: Taylor bars, a plate impact, a perforation, both tet formulations;
# writes docs/validation.md, docs/validation/*.png, benchmarks/validation_results.json (every
# rung's last result: `--rungs X` reruns some and keeps the rest) and benchmarks/validation_reference.json
validate: setup
	$(BIN)/python benchmarks/validate.py

# the three fracture methods on the three-plate shield (coarse, minutes): writes the table and
# pictures of docs/fracture.md ("Comparing the fracture methods") and docs/fracture/*.png
fracture-compare: setup
	$(BIN)/python benchmarks/compare_fracture.py

# the variants of a sweep file (docs/user-guide.md, Sweeps): make sweep SWEEP=cases/sweeps/x.toml
sweep: setup
	$(BIN)/impactsim sweep $(SWEEP)

# run the bundled scenes (outputs in out/<case>/)
cases: setup
	@for c in $(CASES); do \
	  if [ -f cases/$$c.toml ]; then $(BIN)/impactsim run cases/$$c.toml --overwrite || exit $$?; fi; \
	done

demo: setup
	$(BIN)/impactsim run cases/elastic-bar-wall.toml --overwrite

clean:
	rm -rf out build *.egg-info .pytest_cache
	find . -name __pycache__ -prune -exec rm -rf {} +
