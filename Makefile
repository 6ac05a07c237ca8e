# The two set-up commands of the README: `make demo` and `make test`. Each installs missing Debian packages
# (scripts/install-deps), configures CMake + Ninja in Release, builds, then runs the demo or the whole suite.
BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

# Sanitizers: `make test-sanitize` builds the whole tree with ASan + UBSan (RelWithDebInfo) in its own directory and
# runs the whole ctest suite there; any report stops the process that made it (halt_on_error), so it fails its test.
# No suppressions of our code; third-party leaks only (fuzz/lsan.supp: urdfdom on a URDF with a kinematic loop).
SANITIZE_DIR ?= build-sanitize
SANITIZE ?= address,undefined
SANITIZER_ENV = ASAN_OPTIONS=halt_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 LSAN_OPTIONS=suppressions=$(CURDIR)/fuzz/lsan.supp

# `make soak SOAK_STEPS=N`: random-action env steps over every task x interface mode, 0 non-finite values expected.
SOAK_STEPS ?= 10000000

# `make fuzz FUZZ_SECONDS=N [FUZZ_TARGETS="robot policy"]`: the libFuzzer targets of fuzz/ (clang, ASan + UBSan,
# -O1) built in their own directory, each run for N seconds seeded with the shipped files (scripts/run-fuzz).
# The checkpoint target is built by g++ in FUZZ_GCC_DIR (Debian's libtorch headers do not compile with clang 14).
FUZZ_DIR ?= build-fuzz
FUZZ_GCC_DIR ?= build-fuzz-gcc
FUZZ_SECONDS ?= 600
FUZZ_TARGETS ?=

.PHONY: all deps configure build demo view test bench install clean test-sanitize soak fuzz

all: build

deps:
	@bash scripts/install-deps

$(BUILD_DIR)/build.ninja:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(CMAKE_FLAGS)

configure: deps $(BUILD_DIR)/build.ninja

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

# the product at work: plan + the shipped controller for cells (marl-rmp-gated), plan + RMPflow and the plan alone
# (open loop) on the same DEMO_EPISODES generated cells (shelves, boxes, tables, under tables) with a cube crossing: a
# success table with 95 % intervals and a video of the first episode of each. Builds the command-line program only.
# The one-episode comparison in the crossing scene: ./build/rmpmarl demo
DEMO_EPISODES ?= 50
demo: configure
	cmake --build $(BUILD_DIR) --target rmpmarl_cli -j $(JOBS)
	$(BUILD_DIR)/rmpmarl demo --scenario cells --plan --episodes $(DEMO_EPISODES) \
	  --policy models/policies/marl-rmp-gated.rmpp --video $(BUILD_DIR)/demo.mp4

# the live viewer in the browser (docs/viewer.md); VIEW_ARGS="--robot ur5e --side-by-side" etc.
VIEW_ARGS ?=
view: build
	$(BUILD_DIR)/rmpmarl view $(VIEW_ARGS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 900

bench: build
	@mkdir -p $(BUILD_DIR)/bench-results
	@for b in $(BUILD_DIR)/bench/*_bench; do echo "== $$b"; $$b --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true --benchmark_out=$(BUILD_DIR)/bench-results/$$(basename $$b).json --benchmark_out_format=json; done
	@echo "== bench/python_bench.py"; /usr/bin/python3 bench/python_bench.py $(BUILD_DIR)
	@echo "== bench/train_scaling_bench.py"; /usr/bin/python3 bench/train_scaling_bench.py $(BUILD_DIR) --json $(BUILD_DIR)/bench-results/train_scaling.json
	@echo "== bench/speed_table.py"; /usr/bin/python3 bench/speed_table.py $(BUILD_DIR)

test-sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRMPMARL_SANITIZE=$(SANITIZE) \
	  -DRMPMARL_BUILD_BENCH=OFF $(CMAKE_FLAGS)
	$(SANITIZER_ENV) cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && $(SANITIZER_ENV) ctest --output-on-failure -j $(JOBS)

fuzz:
	@bash scripts/install-deps --fuzz
	CXX=clang++ cmake -S . -B $(FUZZ_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" -DRMPMARL_SANITIZE=address,undefined \
	  -DRMPMARL_FUZZ=ON -DRMPMARL_BUILD_TESTS=OFF -DRMPMARL_BUILD_BENCH=OFF
	cmake --build $(FUZZ_DIR) --target fuzzers -j $(JOBS)
	@if [ -z "$(FUZZ_TARGETS)" ] || echo " $(FUZZ_TARGETS) " | grep -q " checkpoint "; then \
	  cmake -S . -B $(FUZZ_GCC_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DRMPMARL_SANITIZE=address,undefined \
	    -DRMPMARL_FUZZ_GCC=ON -DRMPMARL_BUILD_TESTS=OFF -DRMPMARL_BUILD_BENCH=OFF && \
	  cmake --build $(FUZZ_GCC_DIR) --target fuzzers -j $(JOBS); fi
	CHECKPOINT_FUZZ_DIR=$(FUZZ_GCC_DIR) bash scripts/run-fuzz $(FUZZ_DIR) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

soak: configure
	cmake --build $(BUILD_DIR) --target rmpmarl_soak -j $(JOBS)
	./$(BUILD_DIR)/bench/rmpmarl_soak --steps $(SOAK_STEPS) --threads $(JOBS)

install: build
	cmake --install $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR)
