# The two set-up commands (README): `make demo` and `make test`. Both install what is missing
# (scripts/install-deps), configure and build the release preset, then run.
BUILD_DIR := build/release
ECHOREG := $(BUILD_DIR)/cli/echoreg
DEMO_DIR := $(BUILD_DIR)/demo

.PHONY: all deps bench-deps configure build demo test bench clean

all: build

deps:
	@./scripts/install-deps

configure: deps
	@test -f $(BUILD_DIR)/build.ninja || cmake --preset release

build: configure
	@cmake --build $(BUILD_DIR)

# The small sample study, simulated by echoreg itself, then the steps that exist so far run on
# it: the stylus tip by pivoting, the transducer's calibration on the sphere (speed of sound
# fitted), and the bone sweeps turned into points in each bone tracker's frame with that
# calibration. Registration, figures and the report come with their issues.
DEMO_CAL := $(DEMO_DIR)/results/calibration.json
demo: build
	@rm -rf $(DEMO_DIR)
	@mkdir -p $(dir $(DEMO_DIR))
	@$(ECHOREG) simulate --out $(DEMO_DIR) --size small --seed 2008
	@mkdir -p $(DEMO_DIR)/results
	@$(ECHOREG) pivot --capture $(DEMO_DIR)/captures/stylus_pivot.igs.mha --out $(DEMO_DIR)/results/stylus_tip.json
	@$(ECHOREG) calibrate --sphere-capture $(DEMO_DIR)/captures/calibration_sphere_stylus.igs.mha \
	  --stylus-tip-to-stylus $(DEMO_DIR)/results/stylus_tip.json --stylus-tip-radius 1.5 \
	  --capture $(DEMO_DIR)/captures/calibration_shots.igs.mha --sphere-radius 25.4 \
	  --initial $$(/usr/bin/python3 -c "import json; print(*json.load(open('$(DEMO_DIR)/study.json'))['calibration']['initial_beam_to_probe_mm'])") \
	  --window-mm 14 34 --fit-speed-of-sound --out $(DEMO_CAL)
	@$(ECHOREG) detect $(DEMO_DIR)/captures/femur_ultrasound.igs.mha --pose ProbeToTracker \
	  --reference FemurToTracker --beam-to-probe $(DEMO_CAL) --out $(DEMO_DIR)/results/femur_points.csv
	@$(ECHOREG) detect $(DEMO_DIR)/captures/tibia_ultrasound.igs.mha --pose ProbeToTracker \
	  --reference TibiaToTracker --beam-to-probe $(DEMO_CAL) --out $(DEMO_DIR)/results/tibia_points.csv
	@echo "demo: study in $(abspath $(DEMO_DIR)) (study.json, ct/, captures/, truth/);" \
	  "calibration and bone points in $(abspath $(DEMO_DIR))/results/"

test: build
	@ctest --test-dir $(BUILD_DIR) --output-on-failure -j 2

# The benchmarks also install the optional peers they compare with (OpenCV), then reconfigure so
# that the build finds them.
bench-deps:
	@./scripts/install-deps --bench

bench: bench-deps configure
	@cmake $(BUILD_DIR) > /dev/null
	@cmake --build $(BUILD_DIR)
	@./bench/run_benchmarks.sh $(BUILD_DIR)

clean:
	@rm -rf build
