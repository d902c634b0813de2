// The analytic model (the paper's method without learned weights): N_s
// sparse queries per view and N_d per instance, fused across every context
// view (fusion.h), decoded to surface discs, colours fitted with gradients.
#include "common/status_macros.h"
#include "engine/recon/pipeline.h"
#include "engine/recon/recon_model.h"

namespace pf {
namespace {

class AnalyticModel : public ReconModel {
 public:
  bool DefaultColourGradients() const override { return true; }

  absl::StatusOr<ReconResult> Reconstruct(ReconInputs inputs,
                                          const ReconOptions& options) const override {
    Pipeline p(std::move(inputs), options);
    RETURN_IF_ERROR(p.Depth());
    p.Lift();
    p.SceneGraph();
    p.Sample(/*dense=*/false);
    RETURN_IF_ERROR(p.Fuse());
    p.Decode();
    RETURN_IF_ERROR(p.FitColours());
    RETURN_IF_ERROR(p.Optimize());
    return p.Finish();
  }
};

}  // namespace

std::unique_ptr<ReconModel> MakeAnalyticModel() { return std::make_unique<AnalyticModel>(); }

}  // namespace pf
