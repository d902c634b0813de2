// Reading EXRs back and comparing them, for tests that check a render
// against embedded mode's. Kept apart from the service harness because it
// needs OpenImageIO, which only some tests link.
//
//   EXPECT_GT(RgbPsnr(remote_exr, embedded_exr), 60);
#ifndef POINTFORWARD_TESTS_EXR_COMPARE_H_
#define POINTFORWARD_TESTS_EXR_COMPARE_H_

#include <map>
#include <string>
#include <vector>

namespace pf::testing {

// EXR channels by name (each width * height floats, row by row), read with
// OpenImageIO; empty when the file cannot be read.
std::map<std::string, std::vector<float>> ReadExr(const std::string& path);

// PSNR of the R, G, B channels of two EXRs (peak 1); +inf when identical,
// -1 when either cannot be read or they differ in size.
double RgbPsnr(const std::string& a_path, const std::string& b_path);

}  // namespace pf::testing

#endif  // POINTFORWARD_TESTS_EXR_COMPARE_H_
