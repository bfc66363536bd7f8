# granflow: two commands on a fresh machine.
#   make demo  - create .venv, install everything, run the default campaign on 2 cores
#   make test  - create .venv if missing, install, run the test suite
#   make test-thorough - the same suite with 20x the property-test examples from a fresh seed
#   make test-durations - the suite, recording each test file's seconds in tests/durations.json (make test starts the longest first)
#   make test-slurm - the cluster path: a one-node SLURM cluster on localhost (root), the smoke campaign through profiles/slurm
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
CORES  ?= 2
STAMP  := $(VENV)/.installed

.PHONY: venv demo test test-durations test-thorough test-slurm report cost validate bench clean-results help

help:
	@echo "make demo   - install into .venv and run the default campaign (snakemake --cores $(CORES))"
	@echo "make test   - install into .venv and run the tests (property tests: a fixed, seeded budget)"
	@echo "make test-thorough - the same tests, property tests with 20x the examples from a fresh random seed"
	@echo "              (GRANFLOW_THOROUGH=1; a failure prints how to reproduce it)"
	@echo "make test-durations - the same tests, writing each file's seconds to tests/durations.json: make test hands"
	@echo "              the files to its workers longest first (run it on a quiet machine after adding long tests)"
	@echo "make test-slurm - start a one-node SLURM cluster on localhost (root; installs Debian's slurm if missing),"
	@echo "              run the smoke campaign through profiles/slurm, compare it with a local run, stop the cluster"
	@echo "make report - build report.html from finished results (runs what is missing first)"
	@echo "make venv   - create .venv and install, nothing else"
	@echo "make clean-results - delete results/, .snakemake/ and report.html (every run is lost)"
	@echo "make cost   - run the error-versus-cost study (snakemake cost: 30 smoke-size LAMMPS runs, an estimated 20-40 min on 2 cores) and add it to report.html"
	@echo "make validate - run the validation campaign (config/validation.yaml, hours on 2 cores, resumable) and"
	@echo "              write the committed record validation/<scene>/ and validation/README.md"
	@echo "make bench  - run the benchmarks in bench/ (by hand; results are recorded, not asserted)"

# the install's wall seconds go to $(VENV)/.install_seconds (read by granflow.timing)
$(STAMP): requirements.txt pyproject.toml
	mkdir -p $(VENV) && date +%s > $(VENV)/.install_started
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -r requirements.txt
	$(BIN)/python -m pip install --quiet --no-deps -e .
	touch $(STAMP)
	echo $$(( $$(date +%s) - $$(cat $(VENV)/.install_started) )) > $(VENV)/.install_seconds

venv: $(STAMP)

# the wall seconds of both calls go to results/timing/ (read by granflow.timing)
demo: $(STAMP)
	start=$$(date +%s) && $(BIN)/snakemake --cores $(CORES) && mkdir -p results/timing \
		&& echo $$(( $$(date +%s) - $$start )) > results/timing/workflow_seconds
	start=$$(date +%s) && $(BIN)/snakemake --cores $(CORES) --report report.html \
		&& echo $$(( $$(date +%s) - $$start )) > results/timing/report_seconds

# one worker per core (pytest-xdist), each test file on one worker so a file's shared fixtures run once,
# the longest files first (tests/conftest.py, from tests/durations.json): no long file starts last
test: $(STAMP)
	PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/python -m pytest -q -n auto --dist loadfile

# each test file's seconds into tests/durations.json (tests/conftest.py: longest files first under xdist)
test-durations: $(STAMP)
	GRANFLOW_RECORD_DURATIONS=1 PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/python -m pytest -q -n auto --dist loadfile

# the Hypothesis profile granflow-thorough (tests/conftest.py): 20x the examples, a new seed each run
test-thorough: $(STAMP)
	GRANFLOW_THOROUGH=1 PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/python -m pytest -q -n auto --dist loadfile

test-slurm: $(STAMP)
	bash tests/slurm/run.sh

report: $(STAMP)
	$(BIN)/snakemake --cores $(CORES) --report report.html

cost: $(STAMP)
	$(BIN)/snakemake --cores $(CORES) cost
	$(BIN)/snakemake --cores $(CORES) --report report.html all cost

# one MPI rank per case: two cases side by side on 2 cores run faster than one case on 2 ranks
validate: $(STAMP)
	$(BIN)/snakemake --configfile config/validation.yaml --cores $(CORES) --set-threads simulate=1 --keep-going validate

bench: $(STAMP)
	$(BIN)/python bench/bench_channel.py
	$(BIN)/python bench/bench_reader.py

clean-results:
	rm -rf results .snakemake report.html
