# The two set-up commands (README): `make demo` and `make test`. Both install what is missing
# (scripts/install-deps), configure and build the release preset, then run.
BUILD_DIR := build/release
ECHOREG := $(BUILD_DIR)/cli/echoreg
DEMO_DIR := $(BUILD_DIR)/demo

.PHONY: all deps bench-deps configure build demo test bench asan fuzz clean

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

# Every suite under AddressSanitizer + UndefinedBehaviorSanitizer (preset asan, RelWithDebInfo):
# a finding fails the run; LeakSanitizer suppresses only the known leaks inside Debian's libopenjp2
# and libOSMesa (tests/sanitizers/lsan.supp, set by the test preset asan). Slow (a separate build of everything), so not part of `make test`
# or .ci/run.
ASAN_DIR := build/asan
asan: deps
	@test -f $(ASAN_DIR)/build.ninja || cmake --preset asan
	@cmake --build $(ASAN_DIR)
	@ctest --preset asan -j 2

# The readers' libFuzzer harnesses (fuzz/, preset fuzz: Debian's clang, installed only here by
# scripts/install-deps --fuzz), each run for FUZZ_SECONDS with its corpus seeded from fuzz/seeds and
# ../shared/data; findings in build/fuzz/findings fail the run.
FUZZ_DIR := build/fuzz
FUZZ_SECONDS ?= 300
fuzz:
	@./scripts/install-deps --fuzz
	@test -f $(FUZZ_DIR)/build.ninja || cmake --preset fuzz
	@cmake --build $(FUZZ_DIR) --target fuzz_sequence fuzz_json fuzz_mesh fuzz_dicom fuzz_volume \
	  fuzz_params fuzz_manifest
	@./scripts/run-fuzzers $(FUZZ_DIR) $(FUZZ_SECONDS)

clean:
	@rm -rf build
