// Reconstruction models behind one interface, chosen by name from one
// registry (models/model_list.h). A model turns decoded inputs into a scene,
// usually by running the stages of pipeline.h in its own way.
//
//   const ReconModel* model = FindReconModel("analytic");
//   ASSIGN_OR_RETURN(ReconResult result, model->Reconstruct(inputs, options));
#ifndef POINTFORWARD_ENGINE_RECON_RECON_MODEL_H_
#define POINTFORWARD_ENGINE_RECON_RECON_MODEL_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/recon/reconstruction.h"

namespace pf {

class ReconModel {
 public:
  virtual ~ReconModel() = default;

  // Whether the colour fit gives Gaussians a colour gradient unless
  // ReconOptions::colour_gradients says.
  virtual bool DefaultColourGradients() const = 0;

  // Reconstructs `inputs` (at least one view; options.device usable).
  virtual absl::StatusOr<ReconResult> Reconstruct(ReconInputs inputs,
                                                  const ReconOptions& options) const = 0;
};

// The model named `name`, or null. Thread-safe; the model lives as long as
// the process.
const ReconModel* FindReconModel(const std::string& name);

// Every model's name: those of models/model_list.h in its order, then those
// registered at run time.
std::vector<std::string> ReconModelNames();

// OK when `name` is a model; else INVALID_ARGUMENT "`field`: unknown model
// 'x' (expected analytic or pixel-aligned)".
absl::Status CheckReconModel(const std::string& name, const std::string& field);

// Adds a model at run time (a test's, a plug-in's); INVALID_ARGUMENT for an
// empty name, ALREADY_EXISTS for a name taken.
absl::Status RegisterReconModel(const std::string& name, std::unique_ptr<ReconModel> model);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_RECON_MODEL_H_
