// The stages a reconstruction model is built from, as the paper names them
// (recon_stages.h lists them): depth, lifting, scene graph, sampling,
// fusion, decoding, the colour fit. A model (models/) runs them in turn on
// one Pipeline; each stage records its time in the result's stats and
// reports itself through ReconOptions::progress. A learned model replaces
// Fuse (phi, phi_c, phi_v) and Decode and keeps the rest.
//
//   Pipeline p(inputs, options);
//   RETURN_IF_ERROR(p.Depth());
//   p.Lift();  p.SceneGraph();  p.Sample(/*dense=*/false);
//   RETURN_IF_ERROR(p.Fuse());
//   p.Decode();
//   RETURN_IF_ERROR(p.FitColours());
//   RETURN_IF_ERROR(p.Optimize());
//   return p.Finish();
#ifndef POINTFORWARD_ENGINE_RECON_PIPELINE_H_
#define POINTFORWARD_ENGINE_RECON_PIPELINE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "engine/recon/depth_stage.h"
#include "engine/recon/ego_body.h"
#include "engine/recon/query_lifting.h"
#include "engine/recon/query_set.h"
#include "engine/recon/recon_stages.h"
#include "engine/recon/reconstruction.h"

namespace pf {

class Pipeline {
 public:
  // `options` must outlive the pipeline.
  Pipeline(ReconInputs inputs, const ReconOptions& options);

  // 1. Each view's depth: measured (map or LiDAR, completed), facades, the far
  // layer; then the ego body of each camera (ego_body.h, when options.ego_layer).
  absl::Status Depth();
  // 2. Every pixel lifted to the world.
  void Lift();
  // 3. Box membership of the lifted points, and the dynamic masks.
  void SceneGraph();
  // 4. Queries: N_s per view and N_d per instance, or every valid pixel (`dense`).
  void Sample(bool dense);
  // 5. Fusion of every query across the context views (fusion.h), on options.device.
  absl::Status Fuse();
  // 5'. No fusion: each query keeps its own pixel's colour (one Gaussian per pixel).
  void KeepQueriesUnfused();
  // 6. Queries to Gaussians; frees the queries, their fusion and the views'
  // depths, owners and masks.
  void Decode();
  // 7. The colour fit against the context images (when iterations > 0), with
  // colour gradients as ColourGradientsFor(options) says.
  absl::Status FitColours();
  // 8. Per-scene optimisation against the context views (when
  // options.optimize.steps > 0), the far layer's geometry fixed.
  absl::Status Optimize();
  // The scene and its statistics.
  ReconResult Finish();

 private:
  void Done(ReconStage stage, std::string detail = "");

  ReconInputs inputs_;
  const ReconOptions& options_;
  ReconResult result_;
  double start_ = 0, last_ = 0;
  DepthStage depth_stage_;
  std::vector<ViewDepth> depths_;
  std::vector<LiftedView> lifted_;
  std::vector<std::vector<uint32_t>> owners_;
  std::vector<std::vector<uint8_t>> masks_;
  std::vector<EgoLayer> ego_layers_;
  std::vector<BlurAnchor> blur_anchors_;     // The CONTEXT views' (GaussianScene::blur_anchors).
  std::vector<InstanceTrack> still_tracks_;  // Tracks that do not move (IsStillTrack).
  QuerySet queries_;
  FusedQueries fused_;
  std::vector<uint8_t> far_;  // Per Gaussian of the decoded scene: 1 on the far layer.
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_PIPELINE_H_
