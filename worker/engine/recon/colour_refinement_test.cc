// Tests of colour refinement against the context views.
#include "worker/engine/recon/colour_refinement.h"

#include <gtest/gtest.h>

#include "worker/engine/recon/fusion.h"
#include "worker/engine/recon/gaussian_decoder.h"
#include "worker/engine/recon/sparse_sampling.h"

namespace pf {
namespace {

TEST(ColourRefinement, ColoursMoveTowardsTheContextImage) {
  // One view of a plane at 10 m, one Gaussian per pixel, decoded with the
  // wrong colour 0.4 where the image says 0.8.
  ContextView view;
  view.camera = CameraModel(48, 36, 48, 48, 24, 18);
  view.rgb = ImageF(48, 36, 3);
  for (float& v : view.rgb.pixels) v = 0.8f;
  ViewDepth depth;
  depth.width = 48;
  depth.height = 36;
  depth.depth.assign(48 * 36, 10.f);
  depth.source.assign(48 * 36, 0);
  const LiftedView lifted = LiftView(view, depth);
  const std::vector<uint32_t> owners(48 * 36, 0);
  SamplingOptions sampling;
  sampling.dense = true;
  const QuerySet queries = SampleQueries({{&view, &depth, &lifted, &owners}}, {}, sampling);
  GaussianScene scene = DecodeGaussians(queries, UnfusedQueries(queries), {0}, 0, {});
  for (size_t i = 0; i < scene.size(); ++i)
    for (int c = 0; c < 3; ++c) scene.features[i * kReconChannels + c] = 0.4f;

  RefinementOptions options;  // 2 iterations, step 0.5.
  ASSERT_TRUE(RefineColours({view}, queries, options, &scene).ok());
  // The render of a uniform field is that colour: 0.4 -> 0.6 -> 0.7.
  const size_t centre = 18 * 48 + 24;
  size_t index = 0;
  while (queries.pixels[index] != int(centre)) ++index;
  EXPECT_NEAR(scene.features[index * kReconChannels], 0.7f, 0.02f);
  EXPECT_NEAR(scene.features[index * kReconChannels + 3], 0.0f, 1e-6);  // Normals untouched.

  QuerySet fewer = queries;
  fewer.depths.pop_back();
  EXPECT_FALSE(RefineColours({view}, fewer, options, &scene).ok());
}

}  // namespace
}  // namespace pf
