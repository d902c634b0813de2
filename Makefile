# The README's two commands, and a few helpers. Each target installs what it
# needs first, so `make test` and `make demo` work on a fresh Debian 12 machine.
BUILD_DIR ?= build
BUILD_TYPE ?= RelWithDebInfo
JOBS ?= $(shell nproc)
CTEST_JOBS ?= $(JOBS)

.PHONY: all deps configure build test demo format format-check clean configure-asan \
	build-asan-tree test-asan test-asan-all configure-tsan test-tsan test-tsan-all fuzz-smoke \
	test-sanitizers

all: build

deps:
	@scripts/install-deps.sh

# Extra CMake settings for every tree (CI: -DPF_UNITY=ON).
CMAKE_ARGS ?=

configure: deps
	@cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(CMAKE_ARGS) >/dev/null

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

# The sanitizer configurations (docs/RELIABILITY.md, "Sanitizers"), built
# with clang at -O1 with line tables, each in its own tree:
# - build-asan: AddressSanitizer + UBSan (undefined behaviour aborts). The same
#   tree holds the libFuzzer targets (PF_FUZZ=ON, fuzz/).
# - build-tsan: ThreadSanitizer over multi-threaded tests that do not run gRPC.
#   Debian's gRPC and abseil are not instrumented and TSan reports races
#   between gRPC's own threads in every gRPC test; those run under ASan.
# Both trees leave LibTorch out (PF_TORCH=OFF): Debian's LibTorch is not
# instrumented, and fusion runs the C++ kernel there, which
# tensor_fusion_test checks the LibTorch path against in the GCC tree. They
# leave CUDA out too (PF_CUDA=OFF): nvcc's objects are not instrumented, and
# no GPU runs here.
#
# CI (.ci/run) runs the short forms: `test-asan` builds and runs the `unit`
# tests (in-process; `pf_add_test` without E2E) and the fuzzers, `fuzz-smoke`
# gives each fuzzer FUZZ_SECONDS, `test-tsan` runs TSAN_TESTS. The end-to-end
# tests (label `e2e`: our programs as processes) run once, in `make test`.
# The deeper checks: `test-asan-all` (every test under ASan, the e2e ones
# with a longer patience, tests/test_util.h TimeScale), `test-tsan-all`
# (TSAN_ALL_TESTS), `fuzz-smoke FUZZ_SECONDS=600`.
SAN_CMAKE = CC=clang CXX=clang++ cmake -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPF_TORCH=OFF -DPF_CUDA=OFF \
	-DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" $(CMAKE_ARGS)
ASAN_FLAGS = -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
TSAN_FLAGS = -fsanitize=thread -fno-omit-frame-pointer
ASAN_ENV = ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=0 \
	LSAN_OPTIONS=suppressions=$(CURDIR)/fuzz/lsan_suppressions.txt \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
TSAN_ENV = TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1"
TSAN_TESTS = job_store_test blob_store_test auth_test metrics_test common_test
TSAN_ALL_TESTS = $(TSAN_TESTS) scene_cache_test task_runner_test
tsan_regex = ^($(shell echo $(1) | tr ' ' '|'))\.
FUZZ_SECONDS ?= 20

configure-asan: deps
	@$(SAN_CMAKE) -S . -B build-asan -DPF_FUZZ=ON -DCMAKE_CXX_FLAGS="$(ASAN_FLAGS)" >/dev/null

# The whole tree (every program and test, the fuzzers).
build-asan-tree: configure-asan
	@cmake --build build-asan -j $(JOBS)

test-asan: configure-asan
	@cmake --build build-asan -j $(JOBS) --target pf_unit_tests pf_fuzzers
	cd build-asan && $(ASAN_ENV) ctest -L unit --output-on-failure -j $(CTEST_JOBS)

test-asan-all: build-asan-tree
	cd build-asan && $(ASAN_ENV) ctest --output-on-failure -j $(CTEST_JOBS)

configure-tsan: deps
	@$(SAN_CMAKE) -S . -B build-tsan -DCMAKE_CXX_FLAGS="$(TSAN_FLAGS)" >/dev/null

test-tsan: configure-tsan
	@cmake --build build-tsan -j $(JOBS) --target $(TSAN_TESTS)
	cd build-tsan && $(TSAN_ENV) ctest -R '$(call tsan_regex,$(TSAN_TESTS))' --output-on-failure -j $(CTEST_JOBS)

test-tsan-all: configure-tsan
	@cmake --build build-tsan -j $(JOBS) --target $(TSAN_ALL_TESTS) pf
	cd build-tsan && $(TSAN_ENV) ctest -R '$(call tsan_regex,$(TSAN_ALL_TESTS))' --output-on-failure -j $(CTEST_JOBS)

# Each libFuzzer target for FUZZ_SECONDS (20) on seeds made with the GCC
# tree's pf; fails if any crashes. docs/RELIABILITY.md, "Fuzzing".
fuzz-smoke: build configure-asan
	@cmake --build build-asan -j $(JOBS) --target pf_fuzzers
	PF=$(CURDIR)/$(BUILD_DIR)/bin/pf fuzz/run_fuzzers.sh build-asan $(FUZZ_SECONDS)

# What CI runs after `make test`.
test-sanitizers: test-asan fuzz-smoke test-tsan
