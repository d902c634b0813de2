// Test helper for the importers' tests: a clip's box as the OrientedBox that
// box_geometry.h projects and tests containment with.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_BOX_TEST_UTIL_H_
#define POINTFORWARD_ENGINE_IMPORTERS_BOX_TEST_UTIL_H_

#include "common/geometry.h"
#include "engine/importers/box_geometry.h"
#include "pointforward/v1/clip.pb.h"

namespace pf::testing {

// Returns `b` (centre, size, rotation quaternion w, x, y, z) as an OrientedBox.
inline OrientedBox BoxFromProto(const pointforward::v1::Box& b) {
  return {{b.center(0), b.center(1), b.center(2)},
          {b.size(0), b.size(1), b.size(2)},
          ToMatrix(Quat{b.rotation(0), b.rotation(1), b.rotation(2), b.rotation(3)})};
}

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_IMPORTERS_BOX_TEST_UTIL_H_
