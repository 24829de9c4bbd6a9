# Everything runs inside .venv, created on first use from the system python3.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_DIR := demo_output

.PHONY: demo test lint bench sweep sample-data clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

## demo: estimate knee axis and ankle position on the shipped sample recording, calibrate
## it, and measure knee flexion on the sample walking trial of the same mounting
demo: $(STAMP)
	mkdir -p $(DEMO_DIR)
	$(BIN)/imucal info sample_data/circling.h5
	$(BIN)/imucal axis sample_data/circling.h5 --sensors thigh,shank --seed 1 \
		--out $(DEMO_DIR)/knee_axis.json --plot $(DEMO_DIR)/knee_axis.png
	$(BIN)/imucal position sample_data/circling.h5 --sensors shank,foot --seed 1 \
		--out $(DEMO_DIR)/ankle_position.json --plot $(DEMO_DIR)/ankle_position.png
	$(BIN)/imucal calibrate sample_data/circling.h5 --seed 1 --out $(DEMO_DIR)/calibration.json
	$(BIN)/imucal angles sample_data/walking.h5 --calibration $(DEMO_DIR)/calibration.json \
		--out $(DEMO_DIR)/knee_angles.csv --plot $(DEMO_DIR)/knee_angles.png
	@echo "demo: results written to $(DEMO_DIR)/ (knee_axis.json/.png, ankle_position.json/.png,"
	@echo "      calibration.json, knee_angles.csv/.png); the true values are in"
	@echo "      sample_data/circling.truth.json (axes, centres) and sample_data/walking.truth.json"
	@echo "      (knee_flexion_deg per sample; its zero is straight, imucal's the calibration"
	@echo "      trial's most extended posture: compare after removing the mean difference)"

## test: lint and the whole test suite (on every core; one BLAS thread per worker, as
## the command line runs)
test: $(STAMP)
	$(BIN)/ruff check .
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(BIN)/python -m pytest

## sweep: the real-data crash sweep with 100 restarts for every estimator (the suite
## runs the position estimators with 25) and the 1 h recording on a second seed
sweep: $(STAMP)
	IMUCAL_SWEEP_FULL=1 OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 \
		$(BIN)/python -m pytest tests/test_crash_sweep.py

lint: $(STAMP)
	$(BIN)/ruff check .

## bench: the performance targets against their baselines (docs/performance.md)
bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

## sample-data: regenerate sample_data/ with the simulator (deterministic seeds);
## walking.h5 is a gait trial with the mounting of circling.h5 (--mounting-seed 7)
sample-data: $(STAMP)
	$(BIN)/imucal simulate sample_data/circling.h5 --seed 7 --rate 100 --duration 20 --snr 100 --motion circling
	$(BIN)/imucal simulate sample_data/circling_40hz.csv --seed 7 --rate 40 --duration 20 --snr 100 --motion circling
	$(BIN)/imucal simulate sample_data/walking.h5 --seed 8 --mounting-seed 7 --rate 100 \
		--duration 30 --motion gait --gyr-noise 0.01 --acc-noise 0.05 --gyr-bias 0.02

clean:
	rm -rf $(VENV) $(DEMO_DIR) .pytest_cache .ruff_cache
