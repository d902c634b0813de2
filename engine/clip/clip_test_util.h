// Test helpers: a small, valid clip written into a directory (images, depth
// maps, LiDAR sweeps, box tracks) for tests to break one thing at a time.
#ifndef POINTFORWARD_ENGINE_CLIP_CLIP_TEST_UTIL_H_
#define POINTFORWARD_ENGINE_CLIP_CLIP_TEST_UTIL_H_

#include <string>

#include "pointforward/v1/clip.pb.h"

namespace pf::testing {

// The test clip's shape.
inline constexpr int kTestWidth = 32;
inline constexpr int kTestHeight = 24;
inline constexpr int kTestTimestamps = 3;    // 0, 100000, 200000 us.
inline constexpr int kTestLidarPoints = 10;  // Per sweep.

// Writes the files of a valid clip into `dir` and returns its manifest (not
// written; see WriteTestClip):
// - cameras[0] "front" (pinhole) and cameras[1] "left" (OPENCV distortion),
//   both kTestWidth x kTestHeight;
// - frames[2t] is "front" and frames[2t+1] is "left" at timestamp t * 100000
//   us, t in [0, 3): images/<camera>_<t>.png; "front" frames also have
//   depth/front_<t>.exr. t = 0 is CONTEXT ("front") and ROLE_UNSPECIFIED
//   ("left"), the rest TARGET;
// - lidar[0..1] at 0 and 100000 us: lidar/<t>.bin with kTestLidarPoints
//   points each;
// - instances[0] "car-1" with boxes at 0, 100000, 200000 us.
// Summary: 2 cameras, 6 frames (2 CONTEXT, 4 TARGET), timestamps 0..200000
// us, 1 instance, 2 LiDAR sweeps. Aborts the test binary if a file cannot be
// written.
pointforward::v1::Clip MakeTestClip(const std::string& dir);

// Writes `clip` as dir/clip.json and returns that path.
std::string WriteTestClip(const std::string& dir, const pointforward::v1::Clip& clip);

// Writes an RGB test-pattern PNG of the given size.
void WriteTestImage(const std::string& path, int width, int height);

// Writes a float EXR depth map of the given size (constant 10 m).
void WriteTestDepth(const std::string& path, int width, int height);

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_CLIP_CLIP_TEST_UTIL_H_
