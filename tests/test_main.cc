// The main() of every test binary: GoogleTest's, plus one line when tests ran
// and every one of them was skipped, which cmake/gtest_suites.cmake makes ctest
// report as skipped (a suite whose tests all need absent sample data), while a
// suite with one test passed or failed is reported by its exit status.
#include <cstdio>

#include "gtest/gtest.h"

namespace {

class AllSkippedLine : public testing::EmptyTestEventListener {
  void OnTestProgramEnd(const testing::UnitTest& unit) override {
    if (unit.test_to_run_count() > 0 && unit.skipped_test_count() == unit.test_to_run_count()) {
      std::printf("[ PF SKIPPED ] all %d tests of this run were skipped\n",
                  unit.skipped_test_count());
      std::fflush(stdout);
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  testing::UnitTest::GetInstance()->listeners().Append(new AllSkippedLine);
  return RUN_ALL_TESTS();
}
