# The README's two commands, and a few helpers. Each target installs what it
# needs first, so `make test` and `make demo` work on a fresh Debian 12 machine.
BUILD_DIR ?= build
BUILD_TYPE ?= RelWithDebInfo
JOBS ?= $(shell nproc)
CTEST_JOBS ?= $(JOBS)

.PHONY: all deps configure build test demo format format-check clean fuzz-smoke test-sanitizers

all: build

deps:
	@scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) >/dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(CTEST_JOBS)

demo: build
	@scripts/demo.sh $(BUILD_DIR)

FORMAT_FILES = $(shell git ls-files '*.cc' '*.h')

format: deps
	@clang-format -i $(FORMAT_FILES)

format-check: deps
	@clang-format --dry-run --Werror $(FORMAT_FILES)

clean:
	rm -rf $(BUILD_DIR)

# libFuzzer targets (fuzz/, needs clang) for 20 s each on seeds made with the
# regular build's pf; fails if any crashes. docs/RELIABILITY.md, "Fuzzing".
fuzz-smoke: build
	@CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DPF_FUZZ=ON \
		-DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
	@cmake --build build-fuzz -j $(JOBS) --target pf_fuzzers
	PF=$(abspath $(BUILD_DIR))/bin/pf fuzz/run_fuzzers.sh build-fuzz 20

# The whole suite under AddressSanitizer + UBSan (build-asan), then the
# multi-threaded store, blob, metrics, thread-pool and worker scene-cache /
# task-runner tests under ThreadSanitizer (build-tsan). Tests that run gRPC
# are left out of TSan: Debian's gRPC and abseil are not instrumented, and
# TSan reports races between gRPC's own threads in every one of them.
# docs/RELIABILITY.md, "Sanitizers".
TSAN_TESTS = job_store_test blob_store_test scene_cache_test task_runner_test \
	metrics_test common_test
TSAN_REGEX = ^($(shell echo $(TSAN_TESTS) | tr ' ' '|'))\.
test-sanitizers: deps
	@cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
		-DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined" >/dev/null
	@cmake --build build-asan -j $(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=0 \
		LSAN_OPTIONS=suppressions=$(CURDIR)/fuzz/lsan_suppressions.txt \
		UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j $(CTEST_JOBS)
	@cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
		-DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" >/dev/null
	@cmake --build build-tsan -j $(JOBS) --target $(TSAN_TESTS)
	cd build-tsan && TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
		ctest -R '$(TSAN_REGEX)' --output-on-failure -j $(CTEST_JOBS)
