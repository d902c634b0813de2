// Connecting to the server once, with a short deadline.
#include "client/remote/remote_context.h"

#include "absl/strings/str_cat.h"
#include "rpc/grpc_status.h"

namespace pf {
namespace {

const char* ChannelStateName(grpc_connectivity_state state) {
  switch (state) {
    case GRPC_CHANNEL_IDLE:
      return "IDLE";
    case GRPC_CHANNEL_CONNECTING:
      return "CONNECTING";
    case GRPC_CHANNEL_READY:
      return "READY";
    case GRPC_CHANNEL_TRANSIENT_FAILURE:
      return "TRANSIENT_FAILURE";
    case GRPC_CHANNEL_SHUTDOWN:
      return "SHUTDOWN";
  }
  return "UNKNOWN";
}

}  // namespace

absl::Status RemoteContext::Connect() {
  if (channel_ != nullptr) return absl::OkStatus();
  std::shared_ptr<grpc::Channel> channel = MakeChannel(address_, channel_options_);
  if (!channel->WaitForConnected(std::chrono::system_clock::now() + kConnectTimeout)) {
    return absl::UnavailableError(absl::StrCat("no connection within ", kConnectTimeout.count(),
                                               " s (channel state ",
                                               ChannelStateName(channel->GetState(false)), ")"));
  }
  channel_ = std::move(channel);
  scenes_ = pointforward::v1::SceneService::NewStub(channel_);
  renders_ = pointforward::v1::RenderService::NewStub(channel_);
  operations_ = google::longrunning::Operations::NewStub(channel_);
  blobs_ = std::make_unique<BlobClient>(channel_);
  return absl::OkStatus();
}

void RemoteContext::PrepareCall(grpc::ClientContext& call, std::chrono::seconds timeout) const {
  call.set_deadline(std::chrono::system_clock::now() + timeout);
}

}  // namespace pf
