// The pixel-aligned model (the baseline the paper contrasts with): one
// Gaussian per valid context pixel with its own colour, no fusion; the same
// depth, scene graph (instances in canonical frames), scale and rotation
// rules as the analytic model. Flat colours by default: one Gaussian per
// pixel has no room for a gradient inside its pixel.
#include "common/status_macros.h"
#include "engine/recon/pipeline.h"
#include "engine/recon/recon_model.h"

namespace pf {
namespace {

class PixelAlignedModel : public ReconModel {
 public:
  bool DefaultColourGradients() const override { return false; }

  absl::StatusOr<ReconResult> Reconstruct(ReconInputs inputs,
                                          const ReconOptions& options) const override {
    Pipeline p(std::move(inputs), options);
    RETURN_IF_ERROR(p.Depth());
    p.Lift();
    p.SceneGraph();
    p.Sample(/*dense=*/true);
    p.KeepQueriesUnfused();
    p.Decode();
    RETURN_IF_ERROR(p.FitColours());
    RETURN_IF_ERROR(p.Optimize());
    return p.Finish();
  }
};

}  // namespace

std::unique_ptr<ReconModel> MakePixelAlignedModel() {
  return std::make_unique<PixelAlignedModel>();
}

}  // namespace pf
