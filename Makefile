# The README's two commands, and a few helpers. Each target installs what it
# needs first, so `make test` and `make demo` work on a fresh Debian 12 machine.
BUILD_DIR ?= build
BUILD_TYPE ?= RelWithDebInfo
JOBS ?= $(shell nproc)
CTEST_JOBS ?= $(JOBS)

.PHONY: all deps configure build test demo format format-check clean \
	build-asan-tree test-asan test-tsan fuzz-smoke test-sanitizers

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

# The sanitizer configurations (docs/RELIABILITY.md, "Sanitizers"), built
# with clang at -O1 with line tables, each in its own tree:
# - build-asan: AddressSanitizer + UBSan (undefined behaviour aborts) over
#   the whole project and its whole test suite, every pf / pf-server /
#   pf-worker process the end-to-end tests start included. The same tree
#   holds the libFuzzer targets (PF_FUZZ=ON, fuzz/).
# - build-tsan: ThreadSanitizer over the multi-threaded tests that do not
#   run gRPC (job store on SQLite and PostgreSQL, blob store, auth token
#   reloading, worker scene cache and task runner, metrics, thread pool).
#   Debian's gRPC and abseil are not instrumented and TSan reports races
#   between gRPC's own threads in every gRPC test; those run under ASan.
# Both trees leave LibTorch out (PF_TORCH=OFF): Debian's LibTorch is not
# instrumented, and fusion runs the C++ kernel there, which
# tensor_fusion_test checks the LibTorch path against in the GCC tree.
SAN_CMAKE = CC=clang CXX=clang++ cmake -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPF_TORCH=OFF \
	-DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG"
ASAN_FLAGS = -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
TSAN_FLAGS = -fsanitize=thread -fno-omit-frame-pointer
ASAN_ENV = ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=0 \
	LSAN_OPTIONS=suppressions=$(CURDIR)/fuzz/lsan_suppressions.txt \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
TSAN_TESTS = job_store_test blob_store_test auth_test scene_cache_test task_runner_test \
	metrics_test common_test
TSAN_REGEX = ^($(shell echo $(TSAN_TESTS) | tr ' ' '|'))\.
FUZZ_SECONDS ?= 20

build-asan-tree: deps
	@$(SAN_CMAKE) -S . -B build-asan -DPF_FUZZ=ON -DCMAKE_CXX_FLAGS="$(ASAN_FLAGS)" >/dev/null
	@cmake --build build-asan -j $(JOBS)

test-asan: build-asan-tree
	cd build-asan && $(ASAN_ENV) ctest --output-on-failure -j $(CTEST_JOBS)

test-tsan: deps
	@$(SAN_CMAKE) -S . -B build-tsan -DCMAKE_CXX_FLAGS="$(TSAN_FLAGS)" >/dev/null
	@cmake --build build-tsan -j $(JOBS) --target $(TSAN_TESTS)
	cd build-tsan && TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
		ctest -R '$(TSAN_REGEX)' --output-on-failure -j $(CTEST_JOBS)

# Each libFuzzer target for FUZZ_SECONDS (20) on seeds made with the tree's
# own pf; fails if any crashes. docs/RELIABILITY.md, "Fuzzing".
fuzz-smoke: build-asan-tree
	PF=$(CURDIR)/build-asan/bin/pf fuzz/run_fuzzers.sh build-asan $(FUZZ_SECONDS)

# What CI runs after `make test`.
test-sanitizers: test-asan fuzz-smoke test-tsan
