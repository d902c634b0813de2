// What every remote `pf` command shares: the server address, the channel and
// the stubs of the services it calls, and where results are printed.
// Commands check their local input first and call Connect() only then, so
// bad input is reported without a server.
//
//   RemoteContext ctx("localhost:50051", stdout);
//   RETURN_IF_ERROR(ctx.Connect());
//   grpc::ClientContext call;
//   ctx.PrepareCall(call);
//   RETURN_IF_ERROR(FromGrpc(ctx.scenes().GetScene(&call, request, &scene)));
#ifndef POINTFORWARD_CLIENT_REMOTE_REMOTE_CONTEXT_H_
#define POINTFORWARD_CLIENT_REMOTE_REMOTE_CONTEXT_H_

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "grpcpp/channel.h"
#include "grpcpp/client_context.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "rpc/blob_transfer.h"
#include "rpc/grpc_status.h"

namespace pf {

class RemoteContext {
 public:
  // How long Connect() waits for the channel to become ready.
  static constexpr std::chrono::seconds kConnectTimeout{5};
  // The deadline PrepareCall() gives an ordinary call.
  static constexpr std::chrono::seconds kCallTimeout{60};

  // Results go to `out` (stdout in `pf`). `channel`: TLS and token.
  RemoteContext(std::string address, std::FILE* out, ChannelOptions channel = {})
      : address_(std::move(address)), out_(out), channel_options_(std::move(channel)) {}

  // Opens the channel and waits up to kConnectTimeout for it to be ready.
  // UNAVAILABLE when the server cannot be reached. Does nothing when already
  // connected.
  absl::Status Connect();

  const std::string& address() const { return address_; }
  std::FILE* out() const { return out_; }

  // Sets the default deadline on `call`. Valid after Connect().
  void PrepareCall(grpc::ClientContext& call, std::chrono::seconds timeout = kCallTimeout) const;

  // The stubs; valid after Connect().
  pointforward::v1::SceneService::Stub& scenes() { return *scenes_; }
  pointforward::v1::RenderService::Stub& renders() { return *renders_; }
  google::longrunning::Operations::Stub& operations() { return *operations_; }
  BlobClient& blobs() { return *blobs_; }

 private:
  std::string address_;
  std::FILE* out_;
  ChannelOptions channel_options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<pointforward::v1::SceneService::Stub> scenes_;
  std::unique_ptr<pointforward::v1::RenderService::Stub> renders_;
  std::unique_ptr<google::longrunning::Operations::Stub> operations_;
  std::unique_ptr<BlobClient> blobs_;
};

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_REMOTE_CONTEXT_H_
