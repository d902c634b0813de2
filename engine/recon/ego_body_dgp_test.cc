// The ego body found on real frames: DGP scene_02's front camera (CAMERA_09)
// sees the hood in the bottom sixth of every frame while the car drives
// 1.3 m between frames; its left-front camera (CAMERA_01) sees none of the
// car. Skips without the sample data (PF_DATA_DIR).
#include <gtest/gtest.h>

#include "engine/importers/dgp_importer.h"
#include "engine/recon/depth_stage.h"
#include "engine/recon/ego_body.h"
#include "engine/recon/reconstruction.h"
#include "tests/test_util.h"

namespace pf {
namespace {

TEST(EgoBodyDgp, TheHoodOfTheFrontCameraAndNothingElse) {
  PF_REQUIRE_DATA(dir, "dgp_test_scene/scene_02");
  ImportOptions import;
  import.out_dir = testing::MakeTempDir("ego_body_dgp");
  import.cameras = {"CAMERA_01", "CAMERA_09"};
  import.roles = RolePolicy::kAllContext;
  absl::StatusOr<ImportResult> imported = ImportDgp(dir, import);
  ASSERT_TRUE(imported.ok()) << imported.status();
  absl::StatusOr<LoadedClip> loaded = LoadClip(imported->manifest_path);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  absl::StatusOr<ReconInputs> inputs = LoadReconInputs(*loaded, ReconOptions{});
  ASSERT_TRUE(inputs.ok()) << inputs.status();
  ASSERT_EQ(inputs->views.size(), 6u);

  DepthStage stage = MeasureViewDepths(inputs->views, inputs->sweeps, inputs->tracks, {});
  const std::vector<ViewDepth> depths = AddFarLayer(inputs->views, &stage);
  const std::vector<EgoLayer> layers = DetectEgoBodies(inputs->views, depths, inputs->tracks);
  ASSERT_EQ(layers.size(), 1u);
  const EgoLayer& hood = layers[0];
  EXPECT_EQ(hood.camera_id, "CAMERA_09");
  ASSERT_EQ(hood.width, 1936);
  ASSERT_EQ(hood.height, 1216);
  // The hood's top edge lies at rows 960-1060 (highest in the middle); it
  // covers the image's bottom rows. Above it, flat road that its depth does
  // not explain is taken too: a patch the same in every frame, and the band
  // below a run of such blocks (10 % of the body; the bound leaves room for
  // 12 %).
  size_t on = 0, above = 0;
  for (int y = 0; y < hood.height; ++y) {
    for (int x = 0; x < hood.width; ++x) {
      if (!hood.on_body(size_t(y) * hood.width + x)) continue;
      ++on;
      above += y < 950;
    }
  }
  const double share = double(on) / double(hood.mask.size());
  EXPECT_GT(share, 0.10);
  EXPECT_LT(share, 0.25);
  EXPECT_LT(double(above), 0.12 * double(on));
  size_t bottom_row = 0;
  for (int x = 0; x < hood.width; ++x) bottom_row += hood.on_body(size_t(1215) * hood.width + x);
  EXPECT_GT(bottom_row, size_t(0.9 * hood.width));
}

}  // namespace
}  // namespace pf
