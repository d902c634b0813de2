// The registry of reconstruction models: see recon_model.h.
#include <map>
#include <mutex>
#include <utility>

#include "absl/strings/str_cat.h"
#include "engine/recon/models/model_list.h"
#include "engine/recon/recon_model.h"
#include "engine/recon/recon_option_table.h"

namespace pf {

#define PF_DECLARE_MODEL(name, make) std::unique_ptr<ReconModel> make();
PF_RECON_MODELS(PF_DECLARE_MODEL)
#undef PF_DECLARE_MODEL

namespace {

struct Registry {
  std::mutex mutex;
  std::vector<std::string> names;  // In order.
  std::map<std::string, std::unique_ptr<ReconModel>> models;
};

Registry& TheRegistry() {
  static Registry* registry = [] {
    auto* r = new Registry;
#define PF_ADD_MODEL(name, make) \
  r->names.push_back(name);      \
  r->models.emplace(name, make());
    PF_RECON_MODELS(PF_ADD_MODEL)
#undef PF_ADD_MODEL
    return r;
  }();
  return *registry;
}

}  // namespace

const ReconModel* FindReconModel(const std::string& name) {
  Registry& registry = TheRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  const auto it = registry.models.find(name);
  return it == registry.models.end() ? nullptr : it->second.get();
}

std::vector<std::string> ReconModelNames() {
  Registry& registry = TheRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  return registry.names;
}

absl::Status CheckReconModel(const std::string& name, const std::string& field) {
  return CheckModelName(name, ReconModelNames(), field);
}

absl::Status RegisterReconModel(const std::string& name, std::unique_ptr<ReconModel> model) {
  if (name.empty() || model == nullptr) {
    return absl::InvalidArgumentError("RegisterReconModel: a model needs a name");
  }
  Registry& registry = TheRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  if (!registry.models.emplace(name, std::move(model)).second) {
    return absl::AlreadyExistsError(absl::StrCat("model '", name, "' is already registered"));
  }
  registry.names.push_back(name);
  return absl::OkStatus();
}

}  // namespace pf
