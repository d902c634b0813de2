// Small checks shared by the service's end-to-end tests (service_checks.h).
#include "tests/service_checks.h"

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>
#include <regex>

#include "google/longrunning/operations.grpc.pb.h"
#include "rpc/grpc_status.h"
#include "tests/service_harness.h"

namespace pf::testing {

using google::longrunning::Operation;

std::string Find(const std::string& text, const std::string& pattern) {
  std::smatch match;
  return std::regex_search(text, match, std::regex(pattern)) ? match.str(0) : "";
}

absl::StatusOr<Operation> GetOperation(const std::string& address, const std::string& name,
                                       int deadline_seconds) {
  auto stub = google::longrunning::Operations::NewStub(MakeChannel(address));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       Scaled(std::chrono::seconds(deadline_seconds)));
  google::longrunning::GetOperationRequest request;
  request.set_name(name);
  Operation op;
  const grpc::Status status = stub->GetOperation(&context, request, &op);
  if (!status.ok()) return FromGrpc(status);
  return op;
}

Operation WaitDone(const std::string& address, const std::string& name, int seconds) {
  Operation op;
  WaitFor(
      [&] {
        absl::StatusOr<Operation> got = GetOperation(address, name);
        if (got.ok()) op = *got;
        return got.ok() && got->done();
      },
      std::chrono::seconds(seconds));
  return op;
}

std::vector<Operation> ListOperations(const std::string& address, const std::string& filter,
                                      int page_size) {
  auto stub = google::longrunning::Operations::NewStub(MakeChannel(address));
  std::vector<Operation> all;
  std::string token;
  do {
    grpc::ClientContext context;
    google::longrunning::ListOperationsRequest request;
    request.set_filter(filter);
    request.set_page_size(page_size);
    request.set_page_token(token);
    google::longrunning::ListOperationsResponse response;
    if (!stub->ListOperations(&context, request, &response).ok()) return {};
    all.insert(all.end(), response.operations().begin(), response.operations().end());
    token = response.next_page_token();
  } while (!token.empty());
  return all;
}

CommandResult SynthSmallClip(const std::string& out, const std::vector<std::string>& extra) {
  std::vector<std::string> argv = {BinPath("pf"), "synth", "--out",    out, "--width",   "192",
                                   "--height",    "144",   "--frames", "6", "--cameras", "2"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return RunCommand(argv);
}

std::string ViewName(int i) {
  char name[16];
  std::snprintf(name, sizeof(name), "v%02d", i);
  return name;
}

nlohmann::json ViewsOfFirstCamera(const nlohmann::json& clip, int count, double sideways_m) {
  nlohmann::json views;
  views["cameras"] = nlohmann::json::array({clip["cameras"][0]});
  const std::string camera = clip["cameras"][0]["id"];
  std::vector<nlohmann::json> frames;
  for (const nlohmann::json& frame : clip["frames"]) {
    if (frame["camera"] == camera) frames.push_back(frame);
  }
  for (int i = 0; i < count; ++i) {
    const nlohmann::json& frame = frames[i % frames.size()];
    nlohmann::json pose = frame["worldFromCamera"];
    // Along the camera's x axis: the first column of the rotation.
    for (int r = 0; r < 3; ++r) {
      pose[r * 4 + 3] = pose[r * 4 + 3].get<double>() + sideways_m * i * pose[r * 4].get<double>();
    }
    views["views"].push_back({{"camera", camera},
                              {"timestampUs", frame["timestampUs"]},
                              {"worldFromCamera", pose},
                              {"name", ViewName(i)}});
  }
  return views;
}

pointforward::v1::OperationMetadata Metadata(const Operation& op) {
  pointforward::v1::OperationMetadata metadata;
  op.metadata().UnpackTo(&metadata);
  return metadata;
}

}  // namespace pf::testing
