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

# The users' main job on the bundled sample study: the small study simulated by echoreg itself
# (with its ground truth), then `echoreg study run` end to end (stylus pivot, calibration, hip
# centre, CT segmentation, detection, registrations from ultrasound and from the mechanical probe,
# evaluation, figures) into results/report.html, report.md and results.json.
demo: build
	@rm -rf $(DEMO_DIR)
	@mkdir -p $(dir $(DEMO_DIR))
	@$(ECHOREG) simulate --out $(DEMO_DIR) --size small --seed 2008
	@$(ECHOREG) study run $(DEMO_DIR)

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
