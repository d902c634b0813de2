// Small helpers shared by the service's end-to-end tests: a regex search on
// command output; reading operations (google.longrunning) back from a
// running pf-server over plaintext loopback gRPC; the small synth clip and
// the views files the tests render.
//
//   ASSERT_EQ(SynthSmallClip(dir + "/clip").exit_code, 0);
//   std::ofstream(views_path) << ViewsOfFirstCamera(clip, 4, 0.1).dump(2);
//   const std::string scene = Find(create.out, "scenes/[0-9a-f]+");
//   const Operation done = WaitDone(server.address(), op.name());
//   EXPECT_EQ(Metadata(done).stage(), "done");
#ifndef POINTFORWARD_TESTS_SERVICE_CHECKS_H_
#define POINTFORWARD_TESTS_SERVICE_CHECKS_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "tests/test_util.h"

namespace pf::testing {

// The first match of the regex `pattern` in `text`, or "".
std::string Find(const std::string& text, const std::string& pattern);

// The operation `name` from the server at `address` (one GetOperation call
// with a deadline of `deadline_seconds`), or the call's error as an
// absl::Status.
absl::StatusOr<google::longrunning::Operation> GetOperation(const std::string& address,
                                                            const std::string& name,
                                                            int deadline_seconds = 30);

// Polls GetOperation until the operation `name` is done, for at most
// `seconds`; returns the last operation read (not done if time ran out,
// empty if no call succeeded).
google::longrunning::Operation WaitDone(const std::string& address, const std::string& name,
                                        int seconds = 120);

// Every operation matching `filter`, over as many pages of `page_size` as it
// takes; empty when a call fails.
std::vector<google::longrunning::Operation> ListOperations(const std::string& address,
                                                           const std::string& filter,
                                                           int page_size);

// Runs `pf synth` for the small clip the service tests share (2 cameras x 6
// frames of 192x144) into the directory `out`, with `extra` flags (a seed).
CommandResult SynthSmallClip(const std::string& out, const std::vector<std::string>& extra = {});

// The name of the i-th view of ViewsOfFirstCamera: "v00", "v01", ...
std::string ViewName(int i);

// A views file (render/views.h) of `count` views of the first camera of
// `clip` (a clip.json manifest): view i at the camera's frame i (cycling
// through its frames) and that frame's time, its pose moved `sideways_m` * i
// metres along the camera's x axis, named ViewName(i).
nlohmann::json ViewsOfFirstCamera(const nlohmann::json& clip, int count, double sideways_m);

// The operation's metadata unpacked (empty if it holds none).
pointforward::v1::OperationMetadata Metadata(const google::longrunning::Operation& op);

}  // namespace pf::testing

#endif  // POINTFORWARD_TESTS_SERVICE_CHECKS_H_
