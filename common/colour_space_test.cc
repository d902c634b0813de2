// The sRGB transfer functions and the encoding names.
#include "common/colour_space.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace pf {
namespace {

TEST(ColourSpace, SrgbTransferFunctionsMatchTheStandard) {
  // IEC 61966-2-1: the linear toe below 0.04045 (0.0031308 linear), the
  // 2.4 power above; 0 and 1 are fixed points.
  EXPECT_FLOAT_EQ(SrgbToLinear(0.f), 0.f);
  EXPECT_FLOAT_EQ(SrgbToLinear(1.f), 1.f);
  EXPECT_FLOAT_EQ(SrgbToLinear(0.04f), 0.04f / 12.92f);
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.21404114f, 1e-6);
  EXPECT_NEAR(SrgbToLinear(128 / 255.f), 0.21586050f, 1e-6);
  EXPECT_NEAR(LinearToSrgb(0.18f), 0.46135613f, 1e-6);  // Middle grey.
  EXPECT_FLOAT_EQ(LinearToSrgb(0.003f), 0.003f * 12.92f);
  // Not a 2.2 power: at 0.5 that would give 0.2176.
  EXPECT_GT(std::fabs(SrgbToLinear(0.5f) - std::pow(0.5f, 2.2f)), 3e-3);
}

TEST(ColourSpace, TheTwoFunctionsInvertEachOtherOverAllReals) {
  for (float v = -1.f; v <= 2.f; v += 1.f / 512) {
    EXPECT_NEAR(LinearToSrgb(SrgbToLinear(v)), v, 2e-6f * std::max(1.f, std::fabs(v))) << v;
    EXPECT_NEAR(SrgbToLinear(LinearToSrgb(v)), v, 2e-6f * std::max(1.f, std::fabs(v))) << v;
  }
  // Odd extension: an overshoot below 0 maps to minus the positive value.
  EXPECT_FLOAT_EQ(SrgbToLinear(-0.5f), -SrgbToLinear(0.5f));
  // Continuous at the toe.
  EXPECT_NEAR(SrgbToLinear(0.04045f), SrgbToLinear(0.0404501f), 1e-6);
}

TEST(ColourSpace, ConvertColoursTouchesOnlyTheColourChannels) {
  std::vector<float> rgba = {0.5f, 0.25f, 1.f, 0.5f, 0.f, 0.04f, 0.75f, 0.25f};
  ConvertColours(rgba.data(), 2, 4, 3, ColourEncoding::kSrgb, ColourEncoding::kLinear);
  EXPECT_FLOAT_EQ(rgba[0], SrgbToLinear(0.5f));
  EXPECT_FLOAT_EQ(rgba[2], 1.f);
  EXPECT_FLOAT_EQ(rgba[3], 0.5f);  // Alpha untouched.
  EXPECT_FLOAT_EQ(rgba[6], SrgbToLinear(0.75f));
  EXPECT_FLOAT_EQ(rgba[7], 0.25f);
  std::vector<float> same = {0.5f, 0.5f, 0.5f};
  ConvertColours(same.data(), 1, 3, 3, ColourEncoding::kLinear, ColourEncoding::kLinear);
  EXPECT_FLOAT_EQ(same[0], 0.5f);
}

TEST(ColourSpace, NamesParseBackAndOthersNameTheField) {
  for (ColourEncoding e : {ColourEncoding::kSrgb, ColourEncoding::kLinear}) {
    absl::StatusOr<ColourEncoding> parsed = ParseColourEncoding(ColourEncodingName(e), "--x");
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, e);
  }
  absl::StatusOr<ColourEncoding> bad = ParseColourEncoding("gamma22", "--working-space");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().message(),
            "--working-space: unknown colour encoding 'gamma22' (srgb or linear)");
}

}  // namespace
}  // namespace pf
