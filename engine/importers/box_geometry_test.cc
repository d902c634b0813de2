// Tests of box corners, containment, projection and IoU.
#include "engine/importers/box_geometry.h"

#include <gtest/gtest.h>

#include <cmath>

#include "engine/importers/jpeg_header.h"

namespace pf {
namespace {

TEST(BoxGeometry, CornersAndContainmentFollowSizeAndRotation) {
  // 4 m long (x), 2 m wide (y), 1 m high, turned 90 degrees: long along world y.
  const OrientedBox box{{10, 20, 1}, {4, 2, 1}, RotationZ(M_PI / 2)};
  double max_dx = 0, max_dy = 0;
  for (const Vec3& c : BoxCorners(box)) {
    max_dx = std::max(max_dx, std::abs(c.x - 10));
    max_dy = std::max(max_dy, std::abs(c.y - 20));
    EXPECT_NEAR(std::abs(c.z - 1), 0.5, 1e-12);
  }
  EXPECT_NEAR(max_dx, 1.0, 1e-12);
  EXPECT_NEAR(max_dy, 2.0, 1e-12);
  EXPECT_TRUE(BoxContains(box, {10, 21.9, 1}));
  EXPECT_FALSE(BoxContains(box, {11.5, 20, 1}));  // Would be inside unrotated.
  EXPECT_FALSE(BoxContains(box, {10, 20, 1.6}));
}

TEST(BoxGeometry, ProjectsBoxAheadOfPinholeCamera) {
  // Camera at the origin looking along +z; a 2 m cube 10 m ahead.
  const CameraModel camera(1000, 800, 500, 500, 500, 400);
  const OrientedBox box{{0, 0, 10}, {2, 2, 2}, Mat3::Identity()};
  const auto fp = ProjectBox(box, camera, Rigid{});
  ASSERT_TRUE(fp.has_value());
  EXPECT_TRUE(fp->fully_in_view);
  // The near face at z = 9 spans +-1 m: 500 * 1 / 9 pixels around the centre.
  EXPECT_NEAR(fp->rect.x0, 500 - 500.0 / 9, 1e-9);
  EXPECT_NEAR(fp->rect.x1, 500 + 500.0 / 9, 1e-9);
  EXPECT_NEAR(fp->rect.y0, 400 - 500.0 / 9, 1e-9);
  // Behind the camera: no footprint.
  const OrientedBox behind{{0, 0, -5}, {2, 2, 2}, Mat3::Identity()};
  EXPECT_FALSE(ProjectBox(behind, camera, Rigid{}).has_value());
}

TEST(BoxGeometry, IouAndClipping) {
  const PixelRect a{0, 0, 10, 10}, b{5, 0, 15, 10};
  EXPECT_NEAR(Iou(a, b), 50.0 / 150.0, 1e-12);
  EXPECT_NEAR(Iou(a, a), 1.0, 1e-12);
  EXPECT_EQ(Iou(a, PixelRect{20, 20, 30, 30}), 0.0);
  const PixelRect c = ClipRect({-5, -5, 50, 8}, 20, 10);
  EXPECT_EQ(c.x0, 0);
  EXPECT_EQ(c.y0, 0);
  EXPECT_EQ(c.x1, 20);
  EXPECT_EQ(c.y1, 8);
}

TEST(JpegHeader, ReadsSizeFromStartOfFrameAndRejectsGarbage) {
  // SOI, an APP0 segment, then SOF0 with height 886 and width 1920.
  const std::string jpeg("\xFF\xD8\xFF\xE0\x00\x04\xAB\xCD\xFF\xC0\x00\x11\x08\x03\x76\x07\x80",
                         17);
  const auto size = ReadJpegSize(jpeg, "x.jpg");
  ASSERT_TRUE(size.ok()) << size.status();
  EXPECT_EQ(size->width, 1920);
  EXPECT_EQ(size->height, 886);
  EXPECT_EQ(ReadJpegSize("\x89PNG....", "y.png").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ReadJpegSize(std::string("\xFF\xD8\xFF\xE0\x00\x10", 6), "z.jpg").status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pf
