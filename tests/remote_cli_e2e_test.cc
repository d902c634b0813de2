// The remote command line end to end: the real `pf --server` run as a
// process against a real pf-server (SQLite store, blob directory) and real
// pf-worker processes on loopback (tests/service_harness.h). Every remote
// command is run and its output, files and exit code asserted; scenes and
// PLYs are compared with what embedded mode (`pf reconstruct`, `pf scene
// export`) writes for the same clip. Failures are real ones: a render job
// whose actor edit names an instance the reconstructed scene lacks, and
// render jobs left waiting for a scene that is deleted or cancelled.
//
// One server per test: tests assert the exact output of `scene list` and
// `jobs list`, delete scenes, and some need a server with no worker yet, so
// a shared server would make each test depend on the ones before it.
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/hash.h"
#include "engine/image/image_io.h"
#include "gtest/gtest.h"
#include "tests/service_checks.h"
#include "tests/service_harness.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using testing::BinPath;
using testing::CommandResult;
using testing::Find;
using testing::RunCommand;
using testing::ServerProcess;
using testing::SynthSmallClip;
using testing::ViewsOfFirstCamera;
using testing::WorkerProcess;

std::string Pf() { return BinPath("pf"); }

// The first capture group of `pattern` in `text`, or "".
std::string Capture(const std::string& text, const std::string& pattern) {
  std::smatch match;
  return std::regex_search(text, match, std::regex(pattern)) ? match.str(1) : "";
}

// The lines of `text`, without their newlines.
std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::string Sha256Of(const std::string& path) {
  const absl::StatusOr<std::string> digest = Sha256File(path);
  return digest.ok() ? *digest : "<" + std::string(digest.status().message()) + ">";
}

// The "N" of "element vertex N" in a PLY header, or -1.
long long PlyVertexCount(const std::string& ply) {
  const std::string count = Capture(ply.substr(0, ply.find("end_header")), "element vertex (\\d+)");
  return count.empty() ? -1 : std::stoll(count);
}

// A row of `jobs list`: name, kind, state and frames in columns.
std::string JobRow(const std::string& name, const std::string& kind, const std::string& state,
                   const std::string& frames) {
  char line[256];
  std::snprintf(line, sizeof(line), "%-32s %-11s %-17s %-16s", name.c_str(), kind.c_str(),
                state.c_str(), frames.c_str());
  return line;
}

// A small synth clip, views of it, and what embedded mode makes of it: the
// scene, its PLY at the time origin and at a time inside the clip. Made
// once for all tests.
class RemoteCliE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("remote_cli_e2e"));
    const CommandResult synth = SynthSmallClip(*dir_ + "/clip");
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    std::ifstream in(Clip());
    const nlohmann::json clip = nlohmann::json::parse(in);
    // Views at the first camera's frames and times, unmoved.
    std::ofstream(Views4()) << ViewsOfFirstCamera(clip, 4, 0).dump(2);
    std::ofstream(*dir_ + "/views20.json") << ViewsOfFirstCamera(clip, 20, 0).dump(2);
    // An actor edit naming an instance no scene of this clip has.
    const nlohmann::json edits = {{{"instance", "no-such-actor"}, {"kind", "REMOVE"}}};
    nlohmann::json bad_edit = ViewsOfFirstCamera(clip, 4, 0);
    bad_edit["edits"] = nlohmann::json::array({edits});
    std::ofstream(*dir_ + "/bad_edit.json") << bad_edit.dump(2);
    // A time between the clip's first and last frame, where actors are
    // placed differently than at the time origin.
    const nlohmann::json& time = clip["frames"][clip["frames"].size() / 2]["timestampUs"];
    mid_time_us_ = new std::string(time.is_string() ? time.get<std::string>()
                                                    : std::to_string(time.get<long long>()));

    const CommandResult recon =
        RunCommand({Pf(), "reconstruct", Clip(), "--out", *dir_ + "/embedded.pfs"});
    ASSERT_EQ(recon.exit_code, 0) << recon.err;
    for (const auto& [ply, time] : std::vector<std::pair<std::string, std::string>>{
             {"/embedded.ply", ""}, {"/embedded_mid.ply", *mid_time_us_}}) {
      std::vector<std::string> argv = {Pf(),    "scene",    "export", *dir_ + "/embedded.pfs",
                                       "--ply", *dir_ + ply};
      if (!time.empty()) argv.insert(argv.end(), {"--time-us", time});
      const CommandResult exported = RunCommand(argv);
      ASSERT_EQ(exported.exit_code, 0) << exported.err;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete mid_time_us_;
    dir_ = mid_time_us_ = nullptr;
  }

  static std::string Clip() { return *dir_ + "/clip/clip.json"; }
  static std::string Views4() { return *dir_ + "/views4.json"; }

  static std::string* dir_;
  static std::string* mid_time_us_;

  void SetUp() override { test_dir_ = testing::MakeTempDir("remote_cli_case"); }

  // Starts this test's server; its address is then in address_.
  void StartServer(const std::vector<std::string>& extra = {}) {
    server_ = std::make_unique<ServerProcess>(test_dir_);
    ASSERT_TRUE(server_->Start(extra)) << server_->Log();
  }

  // Starts worker `id` of this test's server.
  WorkerProcess& StartWorker(const std::string& id, const std::vector<std::string>& extra = {}) {
    workers_.push_back(std::make_unique<WorkerProcess>(server_->address(), test_dir_, id));
    EXPECT_TRUE(workers_.back()->Start(extra));
    return *workers_.back();
  }

  // Runs pf --server ADDRESS `args`.
  CommandResult Remote(std::vector<std::string> args) {
    args.insert(args.begin(), {Pf(), "--server", server_->address()});
    return RunCommand(args);
  }

  // `scene create CLIP --wait` with `flags`; returns the scene's name.
  std::string CreateScene(const std::vector<std::string>& flags = {},
                          const std::string& clip = Clip()) {
    std::vector<std::string> args = {"scene", "create", clip, "--wait"};
    args.insert(args.end(), flags.begin(), flags.end());
    const CommandResult create = Remote(args);
    EXPECT_EQ(create.exit_code, 0) << create.out << create.err;
    const std::string scene = Capture(create.out, "scene: +(scenes/[0-9a-f]+)\n");
    EXPECT_FALSE(scene.empty()) << create.out;
    return scene;
  }

  // Returns the PLY of `clip` reconstructed here with `flags` (empty, with
  // a failure recorded, when a command fails).
  std::string EmbeddedPly(const std::string& clip, const std::vector<std::string>& flags,
                          const std::string& name) {
    const std::string scene = test_dir_ + "/" + name + ".pfs";
    std::vector<std::string> argv = {Pf(), "reconstruct", clip, "--out", scene};
    argv.insert(argv.end(), flags.begin(), flags.end());
    CommandResult result = RunCommand(argv);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    const std::string ply = test_dir_ + "/" + name + "_embedded.ply";
    result = RunCommand({Pf(), "scene", "export", scene, "--ply", ply});
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return ReadAll(ply);
  }

  // Returns the PLY of the server's `scene`, exported at its time origin.
  std::string RemotePly(const std::string& scene, const std::string& name) {
    const std::string ply = test_dir_ + "/out/" + name + ".ply";
    const CommandResult result = Remote({"scene", "export", scene, "--ply", ply});
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return ReadAll(ply);
  }

  // What the server and workers logged, for failure messages.
  std::string Logs() const {
    std::string logs = server_ ? server_->Log() : "";
    for (const auto& worker : workers_) logs += worker->Log();
    return logs;
  }

  std::string test_dir_;
  std::unique_ptr<ServerProcess> server_;
  std::vector<std::unique_ptr<WorkerProcess>> workers_;
};

std::string* RemoteCliE2e::dir_ = nullptr;
std::string* RemoteCliE2e::mid_time_us_ = nullptr;

// `scene create --wait` prints the operation, progress lines on stderr (a
// pipe, not a terminal), then the READY scene; `scene get` prints the same
// scene as proto3 JSON; the same clip again is a cache hit, also when the
// server reads it from a trusted directory instead of an upload.
TEST_F(RemoteCliE2e, SceneCreateWaitThenGetAndCacheHits) {
  StartServer({"--trusted-root", fs::canonical(*dir_ + "/clip").string()});
  StartWorker("w1");
  const CommandResult create = Remote({"scene", "create", Clip(), "--wait"});
  ASSERT_EQ(create.exit_code, 0) << create.out << create.err << Logs();
  const std::vector<std::string> out = Lines(create.out);
  ASSERT_GE(out.size(), 5u) << create.out;
  const std::string operation = out[0];
  ASSERT_TRUE(std::regex_match(operation, std::regex("operations/[0-9a-f]+"))) << create.out;
  const std::string scene = Capture(out[1], "^scene: +(scenes/[0-9a-f]{24})$");
  ASSERT_FALSE(scene.empty()) << create.out;
  EXPECT_EQ(out[2], "state:      READY");
  EXPECT_EQ(out[3], "model:      analytic");
  const long long gaussians = std::stoll(Capture(create.out, "\ngaussians:  (\\d+) "));
  EXPECT_GT(gaussians, 0);
  const std::string content_hash = Capture(create.out, "\ncontent:    ([0-9a-f]{64})\n");
  EXPECT_EQ(content_hash.substr(0, 24), scene.substr(7)) << "the id is the cache key's prefix";

  // Progress: one plain line per change, ending with the finished scene.
  const std::vector<std::string> progress = Lines(create.err);
  ASSERT_FALSE(progress.empty());
  for (const std::string& line : progress) {
    EXPECT_TRUE(std::regex_match(
        line, std::regex(scene + ": (QUEUED|RUNNING|SUCCEEDED) \\(\\d+%\\)( [a-z_]+)?")))
        << line;
  }
  EXPECT_EQ(progress.back().rfind(scene + ": SUCCEEDED (100%)", 0), 0u) << create.err;

  const CommandResult get = Remote({"scene", "get", scene});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  const nlohmann::json json = nlohmann::json::parse(get.out);
  EXPECT_EQ(json["name"], scene);
  EXPECT_EQ(json["state"], "READY");
  EXPECT_EQ(json["model"], "analytic");
  EXPECT_EQ(json["operation"], operation);
  EXPECT_EQ(json["contentHash"], content_hash);
  EXPECT_EQ(std::stoll(json["gaussians"].get<std::string>()), gaussians);  // int64: a string.
  EXPECT_EQ(std::stoll(json["staticGaussians"].get<std::string>()) +
                std::stoll(json["dynamicGaussians"].get<std::string>()),
            gaussians);

  // The same upload again: finished at once, no second reconstruction.
  const CommandResult again = Remote({"scene", "create", Clip(), "--wait"});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(
      again.out.rfind(operation + "\ncache hit: " + scene + "\nscene:      " + scene + "\n", 0), 0u)
      << again.out;
  EXPECT_EQ(again.err, "");  // Nothing waited for.
  // The clip read by the server from its trusted root has the same content,
  // so the same scene: the upload sent every file under the manifest's name.
  const CommandResult by_uri =
      Remote({"scene", "create", "file://" + fs::canonical(Clip()).string()});
  ASSERT_EQ(by_uri.exit_code, 0) << by_uri.err;
  EXPECT_EQ(by_uri.out, operation + "\ncache hit: " + scene + "\n");

  const CommandResult jobs = Remote({"jobs", "list"});
  ASSERT_EQ(jobs.exit_code, 0) << jobs.err;
  EXPECT_EQ(Lines(jobs.out),
            std::vector<std::string>{JobRow(operation, "reconstruct", "SUCCEEDED", "-")})
      << jobs.out;
  EXPECT_EQ(testing::CountOf(workers_[0]->Log(), "reconstructed " + scene), 1) << Logs();
}

// Two scenes of one clip (two models): `scene list` shows both, also when
// it has to follow page tokens.
TEST_F(RemoteCliE2e, SceneListShowsEveryScene) {
  StartServer();
  StartWorker("w1");
  const std::string analytic = CreateScene();
  const std::string pixel = CreateScene({"--model", "pixel-aligned"});
  ASSERT_FALSE(analytic.empty());
  ASSERT_NE(analytic, pixel);

  std::set<std::string> expected;
  for (const auto& [scene, model] : {std::pair{analytic, std::string("analytic")},
                                     std::pair{pixel, std::string("pixel-aligned")}}) {
    const CommandResult get = Remote({"scene", "get", scene});
    ASSERT_EQ(get.exit_code, 0) << get.err;
    const nlohmann::json json = nlohmann::json::parse(get.out);
    EXPECT_EQ(json["model"], model);
    char line[256];
    std::snprintf(line, sizeof(line), "%-32s %-8s %-14s %s gaussians", scene.c_str(), "READY",
                  model.c_str(), json["gaussians"].get<std::string>().c_str());
    expected.insert(line);
  }
  const CommandResult list = Remote({"scene", "list"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  const std::vector<std::string> lines = Lines(list.out);
  EXPECT_EQ(lines.size(), 2u) << list.out;
  EXPECT_EQ(std::set<std::string>(lines.begin(), lines.end()), expected) << list.out;

  // --page-size: one page of that many, and the command for the next on
  // stderr; the last page says nothing more.
  const CommandResult first = Remote({"scene", "list", "--page-size", "1"});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_EQ(Lines(first.out).size(), 1u) << first.out;
  const std::string token = Capture(first.err, "--page-token (\\S+)\n");
  ASSERT_FALSE(token.empty()) << first.err;
  EXPECT_NE(first.err.find("more: pf --server " + server_->address() +
                           " scene list --page-size 1 --page-token " + token),
            std::string::npos)
      << first.err;
  const CommandResult second = Remote({"scene", "list", "--page-size", "1", "--page-token", token});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  ASSERT_EQ(Lines(second.out).size(), 1u) << second.out;
  EXPECT_EQ(std::set<std::string>({Lines(first.out)[0], Lines(second.out)[0]}), expected);
  EXPECT_EQ(second.err.find("more:"), std::string::npos) << second.err;
}

// `scene delete`, after which the scene is NOT_FOUND (exit 2) everywhere.
TEST_F(RemoteCliE2e, SceneDeleteThenNotFound) {
  StartServer();
  StartWorker("w1");
  const std::string scene = CreateScene();
  ASSERT_FALSE(scene.empty());
  const CommandResult deleted = Remote({"scene", "delete", scene});
  ASSERT_EQ(deleted.exit_code, 0) << deleted.err;
  EXPECT_EQ(deleted.out, "deleted " + scene + "\n");

  const std::string id = scene.substr(7);
  const CommandResult get = Remote({"scene", "get", scene});
  EXPECT_EQ(get.exit_code, 2) << get.out << get.err;
  EXPECT_EQ(get.err, "pf scene get: name: " + scene + " not found\n");
  EXPECT_EQ(get.out, "");
  const CommandResult again = Remote({"scene", "delete", id});  // A bare id works too.
  EXPECT_EQ(again.exit_code, 2) << again.err;
  EXPECT_EQ(again.err, "pf scene delete: name: " + scene + " not found\n");
  const CommandResult exported =
      Remote({"scene", "export", scene, "--ply", test_dir_ + "/gone.ply"});
  EXPECT_EQ(exported.exit_code, 2) << exported.err;
  EXPECT_FALSE(fs::exists(test_dir_ + "/gone.ply"));
  const CommandResult render =
      Remote({"render", scene, "--cameras", Views4(), "--out", test_dir_ + "/r", "--wait"});
  EXPECT_EQ(render.exit_code, 2) << render.err;
  EXPECT_EQ(render.err, "pf render: scene: " + scene + " not found\n");
  const CommandResult list = Remote({"scene", "list"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  EXPECT_EQ(list.out, "");
}

// `scene export` writes the PLY embedded mode writes for the same clip,
// byte for byte, at the time origin and at --time-us.
TEST_F(RemoteCliE2e, SceneExportMatchesEmbeddedMode) {
  StartServer();
  StartWorker("w1");
  const std::string scene = CreateScene();
  ASSERT_FALSE(scene.empty());

  const std::string ply = test_dir_ + "/out/scene.ply";
  const CommandResult exported = Remote({"scene", "export", scene, "--ply", ply});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  const std::string bytes = ReadAll(ply);
  const std::string embedded = ReadAll(*dir_ + "/embedded.ply");
  EXPECT_EQ(exported.out, "wrote " + ply + ": " + std::to_string(bytes.size()) + " bytes of " +
                              scene + " at the scene's time origin (sha256 checked)\n");
  ASSERT_EQ(bytes.substr(0, bytes.find("end_header")),
            embedded.substr(0, embedded.find("end_header")));
  EXPECT_GT(PlyVertexCount(bytes), 0);
  EXPECT_TRUE(bytes == embedded) << "same header, different data: " << bytes.size() << " vs "
                                 << embedded.size() << " bytes";

  const std::string mid = test_dir_ + "/out/mid.ply";
  const CommandResult at_time =
      Remote({"scene", "export", scene, "--ply", mid, "--time-us", *mid_time_us_});
  ASSERT_EQ(at_time.exit_code, 0) << at_time.err;
  EXPECT_NE(at_time.out.find(" at " + *mid_time_us_ + " us"), std::string::npos) << at_time.out;
  const std::string mid_bytes = ReadAll(mid);
  EXPECT_TRUE(mid_bytes == ReadAll(*dir_ + "/embedded_mid.ply"));
  // The actors moved: the time was used.
  EXPECT_FALSE(mid_bytes == bytes);
  // Nothing but the two PLYs: no temporary files left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(test_dir_ + "/out"), fs::directory_iterator()), 2);
}

// A camera's ego mask travels with the clip: uploaded with the images,
// staged by the server, fetched and honoured by the worker, so the remote
// scene is the embedded one of the same masked clip, and not the unmasked.
TEST_F(RemoteCliE2e, AnEgoMaskIsUploadedAndHonouredByTheWorker) {
  const std::string clip_dir = test_dir_ + "/masked";
  fs::copy(*dir_ + "/clip", clip_dir, fs::copy_options::recursive);
  std::ifstream in(clip_dir + "/clip.json");
  nlohmann::json clip = nlohmann::json::parse(in);
  nlohmann::json& camera = clip["cameras"][0];
  const int width = camera["width"], height = camera["height"];
  ImageF mask(width, height, 1);
  for (int y = height * 3 / 4; y < height; ++y)
    for (int x = 0; x < width; ++x) mask.at(x, y) = 1.f;
  fs::create_directories(clip_dir + "/masks");
  ASSERT_TRUE(WritePng(clip_dir + "/masks/hood.png", mask).ok());
  camera["egoMask"] = "masks/hood.png";
  const std::string manifest = clip_dir + "/masked.json";
  std::ofstream(manifest) << clip.dump(2);

  const std::string embedded = EmbeddedPly(manifest, {}, "masked");

  StartServer();
  StartWorker("w1");
  const std::string scene = CreateScene({}, manifest);
  ASSERT_FALSE(scene.empty()) << Logs();
  const std::string bytes = RemotePly(scene, "masked");
  EXPECT_GT(PlyVertexCount(bytes), 0);
  EXPECT_TRUE(bytes == embedded) << "the worker's scene is not the masked clip's";
  EXPECT_FALSE(bytes == ReadAll(*dir_ + "/embedded.ply")) << "the mask changed nothing";
}

// The tuning flags of local pf reconstruct reach the worker: the remote
// scene made with --low-pass 2 --refine 2 --hidden-band 0 --splat-sigma 0.5
// --colour flat is the embedded one made with the same flags (a worker that
// dropped --colour would fit gradients, which the PLY carries), and another
// scene than the default one; a value out of range is refused by the client
// naming the flag. (--no-ground-fill and --no-facades change nothing on a
// clip with depth maps; ReconOptionsFromProto's test covers them.)
TEST_F(RemoteCliE2e, TuningFlagsReachTheWorkerAndMakeAnotherScene) {
  const std::vector<std::string> tuning = {"--low-pass",    "2",   "--refine",      "2",
                                           "--hidden-band", "0",   "--splat-sigma", "0.5",
                                           "--colour",      "flat"};
  const std::string embedded = EmbeddedPly(Clip(), tuning, "tuned");

  StartServer();
  StartWorker("w1");
  const CommandResult bad = Remote({"scene", "create", Clip(), "--refine", "65"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--refine: must be in [0, 64] iterations, got 65"), std::string::npos)
      << bad.err;
  const CommandResult bad_colour = Remote({"scene", "create", Clip(), "--colour", "sh"});
  EXPECT_EQ(bad_colour.exit_code, 2);
  EXPECT_NE(bad_colour.err.find("--colour: unknown colour model 'sh'"), std::string::npos)
      << bad_colour.err;

  const std::string scene = CreateScene(tuning);
  ASSERT_FALSE(scene.empty());
  const std::string bytes = RemotePly(scene, "tuned");
  EXPECT_GT(PlyVertexCount(bytes), 0);
  EXPECT_TRUE(bytes == embedded) << "the worker did not use the flags";
  EXPECT_FALSE(bytes == ReadAll(*dir_ + "/embedded.ply")) << "the flags changed nothing";
  // The default scene of the same clip is another one.
  EXPECT_NE(CreateScene(), scene);
}

// `render --clip --wait`: the scene is created in the same call, the job
// waits for it, renders, and every file is downloaded with the digest the
// server lists. Progress lines on stderr count frames.
TEST_F(RemoteCliE2e, RenderOfAClipWaitsShowsProgressAndDownloads) {
  StartServer();
  // Each frame takes 0.1 s longer: the job runs long enough to be seen running.
  StartWorker("w1", {"--stage-delay-ms", "100"});
  const std::string out_dir = test_dir_ + "/out";
  const CommandResult render =
      Remote({"render", "--clip", Clip(), "--cameras", *dir_ + "/views20.json", "--out", out_dir,
              "--wait", "--chunk-frames", "20"});
  ASSERT_EQ(render.exit_code, 0) << render.out << render.err << Logs();
  const std::string operation = Find(render.out, "^operations/[0-9a-f]+");
  ASSERT_FALSE(operation.empty()) << render.out;
  const std::string job = "renderJobs/" + operation.substr(11);
  EXPECT_EQ(render.out, operation + "\ndownloaded 41 files to " + out_dir + "\n");

  // Progress: frames counted up, never down, ending at 20/20.
  const std::vector<std::string> progress = Lines(render.err);
  const std::regex line_pattern(job + ": ([A-Z_]+) (\\d+)/20 frames \\((\\d+)%\\)( [a-z_]+)?");
  int running_lines = 0;
  int last_frames = 0;
  for (const std::string& line : progress) {
    std::smatch match;
    ASSERT_TRUE(std::regex_match(line, match, line_pattern)) << line;
    const int frames = std::stoi(match.str(2));
    EXPECT_GE(frames, last_frames) << render.err;
    EXPECT_EQ(std::stoi(match.str(3)), frames * 100 / 20) << line;
    last_frames = frames;
    if (match.str(1) == "RUNNING") ++running_lines;
  }
  EXPECT_GE(running_lines, 1) << render.err;
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.front(), job + ": WAITING_FOR_SCENE 0/20 frames (0%)") << render.err;
  EXPECT_EQ(progress.back(), job + ": SUCCEEDED 20/20 frames (100%) render") << render.err;

  // The files the job lists, each downloaded intact.
  const CommandResult get = Remote({"jobs", "get", operation});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  const nlohmann::json op = nlohmann::json::parse(get.out);
  const nlohmann::json& files = op["response"]["files"];
  ASSERT_EQ(files.size(), 41u) << get.out;  // EXR and PNG per view, manifest.json.
  for (const nlohmann::json& file : files) {
    const std::string path = out_dir + "/" + file["name"].get<std::string>();
    EXPECT_EQ(Sha256Of(path), file["digest"]["sha256"]) << path;
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(out_dir), fs::directory_iterator()), 41);
  EXPECT_EQ(ReadAll(out_dir + "/v07.exr").substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
  EXPECT_EQ(ReadAll(out_dir + "/v07.png").substr(1, 3), "PNG");
  const nlohmann::json manifest = nlohmann::json::parse(ReadAll(out_dir + "/manifest.json"));
  EXPECT_EQ(manifest["renderJob"], job);
  ASSERT_EQ(manifest["views"].size(), 20u);
  EXPECT_EQ(manifest["views"][19]["name"], "v19");

  // The scene made in the same call is the one `scene create` finds cached.
  const CommandResult scenes = Remote({"scene", "list"});
  ASSERT_EQ(Lines(scenes.out).size(), 1u) << scenes.out;
  EXPECT_EQ(manifest["scene"]["name"], Find(scenes.out, "^scenes/[0-9a-f]+"));
  const CommandResult create = Remote({"scene", "create", Clip()});
  EXPECT_NE(create.out.find("cache hit: " + manifest["scene"]["name"].get<std::string>()),
            std::string::npos)
      << create.out;
}

// `render SCENE` without --wait only submits; `jobs wait ID --out DIR`
// waits and downloads; `jobs list` shows both jobs with their states,
// `--kind` filters, `jobs get` prints the operation with its metadata.
TEST_F(RemoteCliE2e, RenderThenJobsWaitListAndGet) {
  StartServer();
  StartWorker("w1");
  const std::string scene = CreateScene();
  ASSERT_FALSE(scene.empty());
  const std::string out_dir = test_dir_ + "/out";
  const CommandResult render =
      Remote({"render", scene, "--cameras", Views4(), "--out", out_dir, "--chunk-frames", "2"});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const std::string operation = Find(render.out, "^operations/[0-9a-f]+");
  ASSERT_EQ(render.out, operation + "\n");
  const std::string id = operation.substr(11);
  EXPECT_NE(render.err.find("jobs wait " + operation + " --out " + out_dir), std::string::npos)
      << render.err;
  EXPECT_FALSE(fs::exists(out_dir));

  const CommandResult wait = Remote({"jobs", "wait", id, "--out", out_dir});
  ASSERT_EQ(wait.exit_code, 0) << wait.err << Logs();
  EXPECT_EQ(Lines(wait.out).back(), "downloaded 9 files to " + out_dir) << wait.out;
  for (const char* name : {"v00.exr", "v00.png", "v03.exr", "v03.png", "manifest.json"}) {
    EXPECT_TRUE(fs::exists(out_dir + "/" + name)) << name;
  }
  const CommandResult no_out = Remote({"jobs", "wait", "renderJobs/" + id});
  ASSERT_EQ(no_out.exit_code, 0) << no_out.err;
  EXPECT_EQ(no_out.out,
            "renderJobs/" + id + " SUCCEEDED: 9 files (add --out DIR to download them)\n");

  // Both kinds, newest first.
  const std::string reconstruct =
      Capture(Remote({"scene", "get", scene}).out, "\"operation\": \"(operations/[0-9a-f]+)\"");
  ASSERT_FALSE(reconstruct.empty());
  const std::string render_row = JobRow(operation, "render", "SUCCEEDED", "4/4 frames") + "\n";
  const std::string recon_row = JobRow(reconstruct, "reconstruct", "SUCCEEDED", "-") + "\n";
  const CommandResult all = Remote({"jobs", "list"});
  ASSERT_EQ(all.exit_code, 0) << all.err;
  EXPECT_EQ(all.out, render_row + recon_row);
  const CommandResult renders = Remote({"jobs", "list", "--kind", "render"});
  ASSERT_EQ(renders.exit_code, 0) << renders.err;
  EXPECT_EQ(renders.out, render_row);
  const CommandResult reconstructs = Remote({"jobs", "list", "--kind", "reconstruct"});
  ASSERT_EQ(reconstructs.exit_code, 0) << reconstructs.err;
  EXPECT_EQ(reconstructs.out, recon_row);

  // jobs get: proto3 JSON, the metadata unpacked.
  const CommandResult get = Remote({"jobs", "get", "renderJobs/" + id});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  const nlohmann::json op = nlohmann::json::parse(get.out);
  EXPECT_EQ(op["name"], operation);
  EXPECT_EQ(op["done"], true);
  const nlohmann::json& metadata = op["metadata"];
  EXPECT_EQ(metadata["@type"], "type.googleapis.com/pointforward.v1.OperationMetadata");
  EXPECT_EQ(metadata["kind"], "render");
  EXPECT_EQ(metadata["target"], "renderJobs/" + id);
  EXPECT_EQ(metadata["state"], "SUCCEEDED");
  EXPECT_EQ(metadata["framesDone"], 4);
  EXPECT_EQ(metadata["framesTotal"], 4);
  ASSERT_EQ(metadata["attempts"].size(), 2u) << get.out;  // Two chunks of two views.
  for (const nlohmann::json& attempt : metadata["attempts"]) {
    EXPECT_EQ(attempt["worker"], "w1");
    EXPECT_EQ(attempt["outcome"], "succeeded");
  }
  EXPECT_EQ(metadata["attempts"][1]["task"], "chunk 1 (views 2-3)");
  EXPECT_EQ(op["response"]["@type"], "type.googleapis.com/pointforward.v1.RenderJob");
  EXPECT_EQ(op["response"]["scene"], scene);
  EXPECT_EQ(op["response"]["files"].size(), 9u);
}

// A views file of LiDAR sweeps alone renders them: the range image and the
// point record of each, and the manifest's "lidars", as `pf render` writes
// them locally.
TEST_F(RemoteCliE2e, RenderOfLidarSweepsAloneDownloadsTheirFiles) {
  StartServer();
  StartWorker("w1");
  const std::string scene = CreateScene();
  ASSERT_FALSE(scene.empty());
  const nlohmann::json clip = nlohmann::json::parse(std::ifstream(Clip()));
  ASSERT_FALSE(clip["lidar"].empty());
  nlohmann::json views;
  views["lidars"] = {{{"name", "top"},
                      {"spec", {{"beamElevationsDeg", {-20, -10, 0}}, {"azimuthResolutionDeg", 1}}},
                      {"timestampUs", clip["lidar"][0]["timestampUs"]},
                      {"worldFromSensor", clip["lidar"][0]["worldFromSensor"]}}};
  const std::string views_path = test_dir_ + "/lidar_views.json";
  std::ofstream(views_path) << views.dump();
  const std::string out_dir = test_dir_ + "/out";
  const CommandResult render =
      Remote({"render", scene, "--cameras", views_path, "--out", out_dir, "--wait"});
  ASSERT_EQ(render.exit_code, 0) << render.err << Logs();
  EXPECT_EQ(Lines(render.out).back(), "downloaded 3 files to " + out_dir) << render.out;
  const CommandResult local = RunCommand({Pf(), "render", *dir_ + "/embedded.pfs", "--cameras",
                                          views_path, "--out", test_dir_ + "/local"});
  ASSERT_EQ(local.exit_code, 0) << local.err;
  EXPECT_EQ(Sha256Of(out_dir + "/top.lidar.bin"), Sha256Of(test_dir_ + "/local/top.lidar.bin"));
  const nlohmann::json manifest = nlohmann::json::parse(std::ifstream(out_dir + "/manifest.json"));
  EXPECT_TRUE(manifest["views"].empty());
  ASSERT_EQ(manifest["lidars"].size(), 1u);
  EXPECT_EQ(manifest["lidars"][0]["rangeExr"], "top.range.exr");
  EXPECT_EQ(manifest["lidars"][0]["beams"], 3);
  EXPECT_EQ(manifest["lidars"][0]["columns"], 360);
  EXPECT_GT(manifest["lidars"][0]["returns"].get<int>(), 10);
  const nlohmann::json local_manifest =
      nlohmann::json::parse(std::ifstream(test_dir_ + "/local/manifest.json"));
  EXPECT_EQ(manifest["lidars"][0]["returns"], local_manifest["lidars"][0]["returns"]);
}

// A render job that fails on the worker is exit 1 with the job's error: an
// actor edit for an instance the scene lacks passes the server's check
// while the scene is still being built (only the worker knows its
// instances), and fails when the worker renders. Submitted with no worker
// running, so the scene is certainly not READY yet. Against the READY
// scene the same views are refused at once (exit 2).
TEST_F(RemoteCliE2e, RenderJobFailingOnTheWorkerIsExitOne) {
  StartServer();
  const std::string out_dir = test_dir_ + "/out";
  const CommandResult render =
      Remote({"render", "--clip", Clip(), "--cameras", *dir_ + "/bad_edit.json", "--out", out_dir});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const std::string operation = Find(render.out, "^operations/[0-9a-f]+");
  ASSERT_FALSE(operation.empty()) << render.out;
  const std::string job = "renderJobs/" + operation.substr(11);
  StartWorker("w1");

  const CommandResult wait = Remote({"jobs", "wait", operation, "--out", out_dir});
  EXPECT_EQ(wait.exit_code, 1) << wait.out << wait.err << Logs();
  const std::string error_line = Lines(wait.err).back();
  EXPECT_EQ(error_line.rfind("pf: " + job + " FAILED: ", 0), 0u) << wait.err;
  EXPECT_NE(error_line.find("edits[0].instance: unknown instance 'no-such-actor'"),
            std::string::npos)
      << wait.err;
  EXPECT_EQ(wait.out, "");
  EXPECT_FALSE(fs::exists(out_dir));

  // The operation says the same, and which worker tried.
  const nlohmann::json op = nlohmann::json::parse(Remote({"jobs", "get", operation}).out);
  EXPECT_EQ(op["metadata"]["state"], "FAILED");
  EXPECT_EQ(op["error"]["code"], 3);  // INVALID_ARGUMENT: not retried.
  EXPECT_EQ(error_line.substr(("pf: " + job + " FAILED: ").size()), op["error"]["message"]);
  ASSERT_EQ(op["metadata"]["attempts"].size(), 1u) << op.dump(2);
  EXPECT_EQ(op["metadata"]["attempts"][0]["worker"], "w1");

  // The scene itself was built; now that it is READY the server refuses
  // the same views before queueing anything.
  const CommandResult scenes = Remote({"scene", "list"});
  const std::string scene = Find(scenes.out, "^scenes/[0-9a-f]+");
  EXPECT_NE(scenes.out.find(" READY "), std::string::npos) << scenes.out;
  const CommandResult refused =
      Remote({"render", scene, "--cameras", *dir_ + "/bad_edit.json", "--out", out_dir, "--wait"});
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(
      refused.err.find("pf render: views.edits[0].instance: unknown instance 'no-such-actor'"),
      std::string::npos)
      << refused.err;
  EXPECT_EQ(refused.out, "");
}

// With no worker, jobs wait in line: `jobs list` shows them queued and
// waiting. Deleting the scene being built cancels its reconstruction and
// fails the render job waiting for it; `jobs cancel` cancels another; each
// is exit 1 for `jobs wait`, with its error.
TEST_F(RemoteCliE2e, DeletedSceneAndCancelledJobsAreExitOne) {
  StartServer();
  const CommandResult create = Remote({"scene", "create", Clip()});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const std::string reconstruct = Find(create.out, "^operations/[0-9a-f]+");
  ASSERT_EQ(create.out, reconstruct + "\n");
  const std::string scene =
      Capture(Remote({"jobs", "get", reconstruct}).out, "\"target\": \"(scenes/[0-9a-f]+)\"");
  ASSERT_FALSE(scene.empty());
  std::vector<std::string> renders;
  for (int i = 0; i < 2; ++i) {
    const CommandResult render = Remote({"render", scene, "--cameras", Views4()});
    ASSERT_EQ(render.exit_code, 0) << render.err;
    renders.push_back(Find(render.out, "^operations/[0-9a-f]+"));
  }

  const CommandResult list = Remote({"jobs", "list"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  const std::vector<std::string> lines = Lines(list.out);
  ASSERT_EQ(lines.size(), 3u) << list.out;
  std::set<std::string> rows(lines.begin(), lines.end());
  for (const std::string& render : renders) {
    EXPECT_EQ(rows.count(JobRow(render, "render", "WAITING_FOR_SCENE", "0/4 frames")), 1u)
        << list.out;
  }
  EXPECT_EQ(rows.count(JobRow(reconstruct, "reconstruct", "QUEUED", "-")), 1u) << list.out;

  const CommandResult cancel = Remote({"jobs", "cancel", renders[1]});
  ASSERT_EQ(cancel.exit_code, 0) << cancel.err;
  EXPECT_EQ(cancel.out, "cancel requested: " + renders[1] + "\n");
  const CommandResult cancelled = Remote({"jobs", "wait", renders[1]});
  EXPECT_EQ(cancelled.exit_code, 1) << cancelled.out << cancelled.err;
  EXPECT_EQ(Lines(cancelled.err).back(),
            "pf: renderJobs/" + renders[1].substr(11) + " CANCELLED: cancelled")
      << cancelled.err;

  const CommandResult deleted = Remote({"scene", "delete", scene});
  ASSERT_EQ(deleted.exit_code, 0) << deleted.err;
  const CommandResult recon_wait = Remote({"jobs", "wait", reconstruct});
  EXPECT_EQ(recon_wait.exit_code, 1) << recon_wait.err;
  EXPECT_EQ(Lines(recon_wait.err).back(),
            "pf: " + scene + " CANCELLED: cancelled: the scene was deleted")
      << recon_wait.err;
  const CommandResult render_wait =
      Remote({"jobs", "wait", renders[0], "--out", test_dir_ + "/never"});
  EXPECT_EQ(render_wait.exit_code, 1) << render_wait.err;
  EXPECT_EQ(Lines(render_wait.err).back(),
            "pf: renderJobs/" + renders[0].substr(11) + " FAILED: scene " + scene.substr(7) +
                " could not be created: cancelled: the scene was deleted")
      << render_wait.err;
  EXPECT_FALSE(fs::exists(test_dir_ + "/never"));
}

// Unknown names are NOT_FOUND (exit 2); a server that dies during
// `jobs wait` is unreachable (exit 3), naming its address. (A new command
// to an address where nothing listens is remote_cli_test's.)
TEST_F(RemoteCliE2e, NotFoundIsExitTwoAndServerDyingDuringWaitIsExitThree) {
  StartServer();
  const std::string unknown = "0123456789abcdef01234567";
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"scene", "get", "scenes/" + unknown},
        std::vector<std::string>{"scene", "export", unknown, "--ply", test_dir_ + "/x.ply"},
        std::vector<std::string>{"jobs", "get", "operations/" + unknown},
        std::vector<std::string>{"jobs", "wait", "renderJobs/" + unknown},
        std::vector<std::string>{"jobs", "cancel", unknown},
        std::vector<std::string>{"render", "scenes/" + unknown, "--cameras", Views4()}}) {
    const CommandResult result = Remote(args);
    EXPECT_EQ(result.exit_code, 2) << args[0] << " " << args[1] << ": " << result.err;
    EXPECT_NE(result.err.find(unknown), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("not found"), std::string::npos) << result.err;
    EXPECT_EQ(result.out, "") << args[0] << " " << args[1];
  }
  EXPECT_FALSE(fs::exists(test_dir_ + "/x.ply"));

  // `jobs wait` on a job waiting for its scene (no worker), then the server
  // dies: the wait ends with exit 3 instead of hanging.
  const CommandResult create = Remote({"scene", "create", Clip()});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const std::string reconstruct = Find(create.out, "^operations/[0-9a-f]+");
  testing::ChildProcess wait;
  ASSERT_TRUE(wait.Start({Pf(), "--server", server_->address(), "jobs", "wait", reconstruct},
                         test_dir_ + "/wait.log"));
  ASSERT_TRUE(testing::WaitFor([&] { return wait.Log().find(": QUEUED") != std::string::npos; },
                               std::chrono::seconds(10)))
      << wait.Log();
  const std::string address = server_->address();
  EXPECT_EQ(server_->Kill(SIGKILL), 128 + SIGKILL);
  ASSERT_TRUE(testing::WaitFor([&] { return !wait.running(); }, std::chrono::seconds(10)))
      << wait.Log();
  EXPECT_EQ(wait.Kill(SIGTERM), 3) << wait.Log();
  EXPECT_NE(wait.Log().find("pf: server " + address + " unreachable: " + reconstruct + ": "),
            std::string::npos)
      << wait.Log();
}

}  // namespace
}  // namespace pf
