# The two set-up commands (README): `make demo` and `make test`. Both install what is missing
# (scripts/install-deps), configure and build the release preset, then run.
BUILD_DIR := build/release
ECHOREG := $(BUILD_DIR)/cli/echoreg
DEMO_DIR := $(BUILD_DIR)/demo

.PHONY: all deps configure build demo test bench clean

all: build

deps:
	@./scripts/install-deps

configure: deps
	@test -f $(BUILD_DIR)/build.ninja || cmake --preset release

build: configure
	@cmake --build $(BUILD_DIR)

# The small sample study, simulated by echoreg itself, then the steps that exist so far run on
# it: `echoreg info`, and `echoreg detect` turning the bone sweeps into points in each bone
# tracker's frame (with the true BeamToProbe until `echoreg calibrate` exists).
demo: build
	@rm -rf $(DEMO_DIR)
	@mkdir -p $(dir $(DEMO_DIR))
	@$(ECHOREG) simulate --out $(DEMO_DIR) --size small --seed 2008
	@mkdir -p $(DEMO_DIR)/results
	@$(ECHOREG) info $(DEMO_DIR)/captures/femur_ultrasound.igs.mha
	@$(ECHOREG) detect $(DEMO_DIR)/captures/femur_ultrasound.igs.mha --pose ProbeToTracker \
	  --reference FemurToTracker --beam-to-probe $(DEMO_DIR)/truth/BeamToProbe.json \
	  --out $(DEMO_DIR)/results/femur_points.csv
	@$(ECHOREG) detect $(DEMO_DIR)/captures/tibia_ultrasound.igs.mha --pose ProbeToTracker \
	  --reference TibiaToTracker --beam-to-probe $(DEMO_DIR)/truth/BeamToProbe.json \
	  --out $(DEMO_DIR)/results/tibia_points.csv
	@echo "demo: study in $(abspath $(DEMO_DIR)) (study.json, ct/, captures/, truth/);" \
	  "bone points in $(abspath $(DEMO_DIR))/results/"

test: build
	@ctest --test-dir $(BUILD_DIR) --output-on-failure -j 2

bench: build
	@./bench/run_benchmarks.sh $(BUILD_DIR)

clean:
	@rm -rf build
