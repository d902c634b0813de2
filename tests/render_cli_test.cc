// pf render and pf scene, run as processes on a small hand-made scene: a blue
// background Gaussian 10 m ahead and a red instance Gaussian 5 m ahead that
// moves 2 m to the right over one second.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "common/colour_space.h"
#include "common/file_util.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/scene_file.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using testing::BinPath;
using testing::RunCommand;

constexpr int kChannels = 4;
constexpr float kBlue[kChannels] = {0.1f, 0.2f, 0.9f, 0.3f};
constexpr float kRed[kChannels] = {0.9f, 0.1f, 0.1f, 0.7f};

// The EXR's scene-linear value of a pixel whose sRGB-encoded colour,
// premultiplied by `alpha`, is `premultiplied` (the scene is sRGB).
float Linear(float premultiplied, float alpha) {
  return alpha * SrgbToLinear(premultiplied / alpha);
}

GaussianScene MakeScene() {
  GaussianScene scene;
  scene.num_channels = kChannels;
  InstanceTrack car;
  car.id = "car1";
  car.category = "car";
  car.boxes.push_back({0, {0, 0, 5}, {1, 1, 1}, {}});
  car.boxes.push_back({1'000'000, {2, 0, 5}, {1, 1, 1}, {}});
  scene.instances.push_back(car);
  scene.Resize(2);
  const float means[2][3] = {{0, 0, 10}, {0, 0, 5}};
  const float sigmas[2] = {0.5f, 0.3f};
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      scene.means[3 * i + a] = means[i][a];
      scene.log_scales[3 * i + a] = std::log(sigmas[i]);
    }
    scene.opacity_logits[i] = 8.f;  // Opacity 0.9997, clamped to 0.99 by the renderer.
    for (int c = 0; c < kChannels; ++c)
      scene.features[i * kChannels + c] = i == 0 ? kBlue[c] : kRed[c];
  }
  scene.owners[1] = 1;
  return scene;
}

// A 64x48 pinhole at the origin looking along +z; pixel (32, 24) is centred
// on the optical axis.
std::string ViewsJson(const std::string& edits) {
  return absl::StrCat(R"({
  "cameras": [{"id": "cam", "width": 64, "height": 48,
               "intrinsics": {"fx": 50, "fy": 50, "cx": 32.5, "cy": 24.5}}],
  "views": [
    {"camera": "cam", "timestampUs": 0, "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "name": "t0"},
    {"camera": "cam", "timestampUs": 1000000, "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}
  ],
  "edits": [)",
                      edits, "]}");
}

// An EXR read back: channel values by name at every pixel, and its header.
struct Exr {
  int width = 0;
  std::map<std::string, int> index;
  std::vector<float> pixels;
  std::vector<uint32_t> instance;
  OIIO::ImageSpec spec;
  float at(int x, int y, const std::string& channel) const {
    return pixels[(size_t(y) * width + x) * index.size() + index.at(channel)];
  }
};

Exr ReadExr(const std::string& path) {
  Exr exr;
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return exr;
  exr.spec = in->spec();
  exr.width = exr.spec.width;
  for (int c = 0; c < exr.spec.nchannels; ++c) exr.index[exr.spec.channelnames[c]] = c;
  exr.pixels.resize(size_t(exr.spec.width) * exr.spec.height * exr.spec.nchannels);
  EXPECT_TRUE(
      in->read_image(0, 0, 0, exr.spec.nchannels, OIIO::TypeDesc::FLOAT, exr.pixels.data()));
  if (exr.index.count("instance")) {
    const int c = exr.index["instance"];
    exr.instance.resize(size_t(exr.spec.width) * exr.spec.height);
    EXPECT_TRUE(in->read_image(0, 0, c, c + 1, OIIO::TypeDesc::UINT, exr.instance.data()));
  }
  return exr;
}

class RenderCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("render_cli");
    scene_ = dir_ + "/scene.pfscene";
    ASSERT_TRUE(SaveScene(MakeScene(), scene_, {{"model", "hand-made"}}).ok());
  }

  testing::CommandResult Render(const std::string& edits, const std::string& out,
                                const std::vector<std::string>& extra = {},
                                const std::string& scene = "") {
    const std::string views =
        absl::StrCat(dir_, "/views_", fs::path(out).filename().string(), ".json");
    EXPECT_TRUE(WriteFileAtomic(views, ViewsJson(edits)).ok());
    std::vector<std::string> argv = {
        BinPath("pf"), "render", scene.empty() ? scene_ : scene, "--cameras", views, "--out", out};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return RunCommand(argv);
  }

  // Renders the views with the car removed and `outputs` selected into
  // dir_/name; returns the first view's EXR.
  Exr RenderWithoutTheCar(const std::string& name, const std::string& outputs) {
    const std::string out = dir_ + "/" + name;
    const testing::CommandResult result =
        Render(R"({"instance": "car1", "kind": "REMOVE"})", out, {"--outputs", outputs});
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return ReadExr(out + "/t0.exr");
  }

  std::string dir_;
  std::string scene_;
};

TEST_F(RenderCliTest, WritesExrPngAndManifestWithTheExpectedPixels) {
  const std::string out = dir_ + "/out";
  const testing::CommandResult result = Render("", out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("[1/2] t0: 64x48"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("[2/2] cam_1000000: 64x48"), std::string::npos) << result.err;
  EXPECT_NE(result.out.find("rendered 2 views"), std::string::npos) << result.out;
  for (const char* file :
       {"t0.exr", "t0.png", "cam_1000000.exr", "cam_1000000.png", "manifest.json"}) {
    EXPECT_TRUE(fs::exists(absl::StrCat(out, "/", file))) << file;
  }

  // t = 0: the red instance, 5 m ahead, covers the centre (alpha 0.99) in
  // front of the blue background (the remaining 1% of transmittance).
  const Exr t0 = ReadExr(out + "/t0.exr");
  ASSERT_EQ(t0.index.size(), 3u + 1 + 1 + kChannels + 1);
  const float front = 0.99f, back = 0.01f * 0.99f;
  EXPECT_NEAR(t0.at(32, 24, "A"), front + back, 2e-3);
  EXPECT_NEAR(t0.at(32, 24, "R"), Linear(front * kRed[0] + back * kBlue[0], front + back), 2e-3);
  EXPECT_NEAR(t0.at(32, 24, "B"), Linear(front * kRed[2] + back * kBlue[2], front + back), 2e-3);
  EXPECT_NEAR(t0.at(32, 24, "feature.003"), front * kRed[3] + back * kBlue[3], 2e-3);
  EXPECT_NEAR(t0.at(32, 24, "Z"), (front * 5 + back * 10) / (front + back), 2e-3);
  EXPECT_EQ(t0.instance[24 * 64 + 32], 1u);
  // A corner sees nothing.
  EXPECT_EQ(t0.at(0, 0, "A"), 0.f);
  EXPECT_EQ(t0.at(0, 0, "Z"), 0.f);
  EXPECT_EQ(t0.instance[0], 0u);
  EXPECT_EQ(t0.spec.get_string_attribute("pf:timestampUs"), "0");
  EXPECT_EQ(t0.spec.get_string_attribute("pf:model"), "hand-made");
  EXPECT_EQ(t0.spec.get_string_attribute("pf:sceneId").size(), 64u);

  // t = 1 s: the instance moved 2 m right (u = 32.5 + 50 * 2 / 5 = 52.5),
  // uncovering the background at the centre.
  const Exr t1 = ReadExr(out + "/cam_1000000.exr");
  EXPECT_NEAR(t1.at(32, 24, "A"), 0.99, 2e-3);
  EXPECT_NEAR(t1.at(32, 24, "B"), 0.99 * SrgbToLinear(kBlue[2]), 2e-3);
  EXPECT_NEAR(t1.at(32, 24, "Z"), 10, 2e-3);
  EXPECT_EQ(t1.instance[24 * 64 + 32], 0u);
  EXPECT_NEAR(t1.at(52, 24, "R"), 0.99 * SrgbToLinear(kRed[0]), 2e-3);
  EXPECT_NEAR(t1.at(52, 24, "Z"), 5, 2e-3);
  EXPECT_EQ(t1.instance[24 * 64 + 52], 1u);
  EXPECT_EQ(t1.spec.get_string_attribute("pf:timestampUs"), "1000000");

  const nlohmann::json manifest = nlohmann::json::parse(*ReadFileToString(out + "/manifest.json"));
  EXPECT_EQ(manifest["scene"]["model"], "hand-made");
  ASSERT_EQ(manifest["views"].size(), 2u);
  EXPECT_EQ(manifest["views"][0]["name"], "t0");
  EXPECT_EQ(manifest["views"][0]["exr"], "t0.exr");
  EXPECT_EQ(manifest["views"][1]["name"], "cam_1000000");
  EXPECT_EQ(manifest["views"][1]["timestampUs"], 1000000);
  EXPECT_EQ(manifest["views"][1]["width"], 64);
  EXPECT_EQ(manifest["views"][1]["channels"].size(), t0.index.size());
  EXPECT_EQ(manifest["views"][1]["intrinsics"]["cx"], 32.5);
}

TEST_F(RenderCliTest, RemovedInstanceLeavesTheBackgroundVisible) {
  const Exr t0 = RenderWithoutTheCar("removed", "rgb,depth");
  // Only the selected layers.
  ASSERT_EQ(t0.index.size(), 4u);
  EXPECT_TRUE(t0.index.count("Z"));
  EXPECT_FALSE(t0.index.count("A"));
  EXPECT_NEAR(t0.at(32, 24, "B"), 0.99 * SrgbToLinear(kBlue[2]), 2e-3);
  EXPECT_NEAR(t0.at(32, 24, "Z"), 10, 2e-3);
}

TEST_F(RenderCliTest, FilledLayerGivesUncoveredPixelsTheColourAround) {
  // The car removed, only the blue Gaussian is left: covered pixels keep
  // their colour, the empty corners take blue instead of black (all
  // scene-linear, as the RGB layer).
  const Exr t0 = RenderWithoutTheCar("filled", "rgb,alpha,filled");
  ASSERT_EQ(t0.index.size(), 7u);
  const float blue[3] = {SrgbToLinear(kBlue[0]), SrgbToLinear(kBlue[1]), SrgbToLinear(kBlue[2])};
  EXPECT_NEAR(t0.at(32, 24, "filled.B"), 0.99 * blue[2], 2e-3);
  EXPECT_EQ(t0.at(0, 0, "A"), 0.f);
  EXPECT_EQ(t0.at(0, 0, "B"), 0.f);
  // Blue, as dark as the mean of the pixels around (those with alpha >= 0.5
  // count as they are, composited over black).
  const float scale = t0.at(0, 0, "filled.B") / blue[2];
  EXPECT_GT(scale, 0.5f);
  EXPECT_LE(scale, 1.f);
  EXPECT_NEAR(t0.at(0, 0, "filled.R"), scale * blue[0], 2e-3);
  EXPECT_NEAR(t0.at(0, 0, "filled.G"), scale * blue[1], 2e-3);
}

TEST_F(RenderCliTest, BadInputExitsTwoNamingTheField) {
  std::string views = ViewsJson("");
  views.replace(views.find(R"("camera": "cam")"), 15, R"("camera": "rear")");
  const std::string path = dir_ + "/bad_views.json";
  ASSERT_TRUE(WriteFileAtomic(path, views).ok());
  testing::CommandResult result =
      RunCommand({BinPath("pf"), "render", scene_, "--cameras", path, "--out", dir_ + "/bad"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("views[0].camera: unknown camera 'rear'"), std::string::npos)
      << result.err;

  result = Render(R"({"instance": "car9", "kind": "REMOVE"})", dir_ + "/bad2");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("edits[0].instance: unknown instance 'car9'"), std::string::npos)
      << result.err;

  result = Render("", dir_ + "/bad3", {"--outputs", "rgb,normals"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--outputs: unknown layer 'normals'"), std::string::npos) << result.err;
  result = Render("", dir_ + "/bad3", {"--outputs", ""});  // Not the default set.
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--outputs: unknown layer ''"), std::string::npos) << result.err;

  result = RunCommand({BinPath("pf"), "render", scene_, "--out", dir_ + "/bad5"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--cameras: required\nusage: pf render SCENE"), std::string::npos)
      << result.err;
  result = RunCommand({BinPath("pf"), "scene", "export", scene_});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--ply: required"), std::string::npos) << result.err;

  result = Render("", dir_ + "/bad6", {"--device", "gpu0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--device: unknown device 'gpu0'"), std::string::npos) << result.err;
  if (!CheckCudaDevice(7).ok()) {  // No eighth GPU: a clear refusal, nothing written.
    result = Render("", dir_ + "/bad7", {"--device", "cuda:7"});
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_NE(result.err.find("--device: 'cuda:7' cannot render: "), std::string::npos)
        << result.err;
    EXPECT_FALSE(fs::exists(dir_ + "/bad7/manifest.json"));
  }

  result = RunCommand({BinPath("pf"), "render", dir_ + "/missing.pfscene", "--cameras", path,
                       "--out", dir_ + "/bad4"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("file not found"), std::string::npos) << result.err;
}

TEST_F(RenderCliTest, OnAGpuTheSameViewsGiveTheSameFiles) {
  if (absl::Status gpu = CheckCudaDevice(0); !gpu.ok()) {
    GTEST_SKIP() << "no GPU to render on: " << gpu.message();
  }
  const testing::CommandResult cpu = Render("", dir_ + "/cpu");
  ASSERT_EQ(cpu.exit_code, 0) << cpu.err;
  const testing::CommandResult gpu = Render("", dir_ + "/gpu", {"--device", "cuda:0"});
  ASSERT_EQ(gpu.exit_code, 0) << gpu.err;
  EXPECT_NE(gpu.err.find("on cuda:0"), std::string::npos) << gpu.err;
  for (const char* view : {"t0.exr", "cam_1000000.exr"}) {
    const Exr a = ReadExr(absl::StrCat(dir_, "/cpu/", view));
    const Exr b = ReadExr(absl::StrCat(dir_, "/gpu/", view));
    ASSERT_EQ(a.index, b.index);
    for (const auto& [name, unused] : a.index) {
      for (int y = 0; y < 48; y += 3) {
        for (int x = 0; x < 64; x += 3) EXPECT_NEAR(a.at(x, y, name), b.at(x, y, name), 1e-3);
      }
    }
    EXPECT_EQ(a.instance, b.instance);
  }
}

// PF_THREADS=N: N threads render (the pool's N - 1 workers and the caller).
TEST(PfBench, PfThreadsIsTheNumberOfWorkingThreads) {
  for (const char* threads : {"1", "3"}) {
    const testing::CommandResult result = RunCommand(
        {"/usr/bin/env", absl::StrCat("PF_THREADS=", threads), BinPath("pf"), "bench", "raster",
         "--gaussians", "2000", "--width", "64", "--height", "48", "--repeat", "1"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    const nlohmann::json bench = nlohmann::json::parse(result.out);
    EXPECT_EQ(bench["threads"], std::stoi(threads)) << result.out;
    EXPECT_EQ(bench["device"], "cpu");
    EXPECT_GT(bench["pairs_contributing"].get<int64_t>(), 0);
    // The render's passes, inside its wall time (one timed render; the
    // figures are printed to 0.001 ms).
    const double project = bench["project_ms_median"], sort_bin = bench["sort_bin_ms_median"],
                 composite = bench["composite_ms_median"];
    EXPECT_GT(project, 0);
    EXPECT_GT(sort_bin, 0);
    EXPECT_GT(composite, 0);
    EXPECT_LE(project + sort_bin + composite, bench["ms_median"].get<double>() + 0.002)
        << result.out;
    // The machine's blend peak, measured in the same run, and the share of
    // it the render reached.
    EXPECT_EQ(bench["peak_gaussians_per_tile"], 128);
    EXPECT_GT(bench["peak_pairs_per_ms"].get<double>(), 0);
    EXPECT_GT(bench["share_of_peak"].get<double>(), 0);
    const std::string peak_kernel = bench["peak_kernel"];
    EXPECT_TRUE(peak_kernel == "baseline" || peak_kernel == "avx2" || peak_kernel == "avx512")
        << peak_kernel;
  }
  const testing::CommandResult bad =
      RunCommand({BinPath("pf"), "bench", "raster", "--device", "tpu"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--device: unknown device 'tpu'"), std::string::npos) << bad.err;
}

// pf COMMAND --help prints that command's lines of pf help, on stdout.
TEST(PfHelp, EveryCommandAnswersHelp) {
  for (const std::string command : {"synth", "validate", "import", "scene", "render", "bench",
                                    "reconstruct", "eval", "depth-eval"}) {
    const testing::CommandResult result = RunCommand({BinPath("pf"), command, "--help"});
    EXPECT_EQ(result.exit_code, 0) << command << ": " << result.err;
    EXPECT_NE(result.out.find("usage:"), std::string::npos) << command;
    EXPECT_NE(result.out.find(command + " "), std::string::npos) << command << ": " << result.out;
  }
  const testing::CommandResult render = RunCommand({BinPath("pf"), "render", "-h"});
  EXPECT_NE(render.out.find("render SCENE --cameras VIEWS.json --out DIR"), std::string::npos)
      << render.out;
  EXPECT_EQ(render.out.find("reconstruct CLIP.json"), std::string::npos) << render.out;
}

// A scene with an ego layer for "cam" (the body in the bottom 8 rows, at
// 0 s and 2 s): every view of the camera shows it on top, whatever the
// pose, as its time falls between the frames; pf scene info lists it and a
// PLY export says it is left out.
TEST_F(RenderCliTest, TheEgoLayerIsDrawnOverEveryViewOfItsCamera) {
  GaussianScene scene = MakeScene();
  EgoLayer body{"cam", 64, 48, std::vector<uint8_t>(64 * 48, 0),
                std::vector<float>(64 * 48 * 3, 0.f)};
  body.frames = {{0, {}}, {2'000'000, {}}};
  for (size_t i = 40 * 64; i < body.mask.size(); ++i) {
    body.mask[i] = 1;
    body.rgb[i * 3] = body.rgb[i * 3 + 1] = body.rgb[i * 3 + 2] = 0.1f;  // The mean: not drawn.
    body.frames[0].rgb.insert(body.frames[0].rgb.end(), {0.25f, 0.5f, 0.75f});
    body.frames[1].rgb.insert(body.frames[1].rgb.end(), {0.75f, 0.5f, 0.25f});
  }
  scene.ego_layers = {body};
  const std::string with_body = dir_ + "/body.pfscene";
  ASSERT_TRUE(SaveScene(scene, with_body, {{"model", "hand-made"}}).ok());
  const testing::CommandResult result = Render("", dir_ + "/body", {}, with_body);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  ASSERT_EQ(Render("", dir_ + "/plain").exit_code, 0);
  for (const char* view : {"t0", "cam_1000000"}) {
    const Exr e = ReadExr(absl::StrCat(dir_, "/body/", view, ".exr"));
    const Exr plain = ReadExr(absl::StrCat(dir_, "/plain/", view, ".exr"));
    // At 0 s the first frame; at 1 s halfway to the second.
    const bool first = std::string(view) == "t0";
    for (int x : {0, 31, 63}) {
      // Row 44 is on the body: its colour (scene-linear in the EXR), opaque,
      // no depth, no instance, the colour in the first feature channels.
      EXPECT_NEAR(e.at(x, 44, "R"), SrgbToLinear(first ? 0.25f : 0.5f), 2e-3) << view << " " << x;
      EXPECT_NEAR(e.at(x, 44, "B"), SrgbToLinear(first ? 0.75f : 0.5f), 2e-3) << view << " " << x;
      EXPECT_EQ(e.at(x, 44, "A"), 1.f);
      EXPECT_EQ(e.at(x, 44, "Z"), 0.f);
      EXPECT_EQ(e.instance[44 * 64 + x], 0u);
      EXPECT_NEAR(e.at(x, 44, "feature.001"), 0.5f, 1e-3);
      EXPECT_EQ(e.at(x, 44, "feature.003"), 0.f);
      // Row 24 is the scene's, as without the layer.
      for (const char* channel : {"R", "A", "Z", "feature.003"}) {
        EXPECT_EQ(e.at(x, 24, channel), plain.at(x, 24, channel)) << view << " " << channel;
      }
    }
  }
  const testing::CommandResult info = RunCommand({BinPath("pf"), "scene", "info", with_body});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(
      info.out.find("ego layers:   1\n  cam          64x48, 16.7 % of the pixels on the body, "
                    "2 frames in t [0, 2000000] us"),
      std::string::npos)
      << info.out;
  const testing::CommandResult exported =
      RunCommand({BinPath("pf"), "scene", "export", with_body, "--ply", dir_ + "/body.ply"});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  EXPECT_NE(exported.out.find("note: the scene's 1 ego layers"), std::string::npos) << exported.out;
}

TEST_F(RenderCliTest, SceneInfoAndPlyExportRenderTheSame) {
  testing::CommandResult info = RunCommand({BinPath("pf"), "scene", "info", scene_});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("gaussians:    2 (static 1, dynamic 1)"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("channels:     4"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("sh degree:    none"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("low-pass:     0.3 px^2"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("car1"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("t [0, 1000000] us (1.000 s)"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("[0.000, 0.000, 5.000] .. [0.000, 0.000, 10.000]"), std::string::npos)
      << info.out;

  // Export at the time origin; the PLY renders the t = 0 view like the scene.
  const std::string ply = dir_ + "/scene.ply";
  testing::CommandResult exported =
      RunCommand({BinPath("pf"), "scene", "export", scene_, "--ply", ply});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  info = RunCommand({BinPath("pf"), "scene", "info", ply});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("3dgs ply"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("gaussians:    2 (static 2, dynamic 0)"), std::string::npos) << info.out;

  ASSERT_EQ(Render("", dir_ + "/from_scene").exit_code, 0);
  const testing::CommandResult from_ply = Render("", dir_ + "/from_ply", {}, ply);
  ASSERT_EQ(from_ply.exit_code, 0) << from_ply.err;
  const Exr a = ReadExr(dir_ + "/from_scene/t0.exr");
  const Exr b = ReadExr(dir_ + "/from_ply/t0.exr");
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  for (const char* channel : {"R", "G", "B", "A", "Z", "feature.003"}) {
    float diff = 0;
    for (int y = 0; y < 48; ++y) {
      for (int x = 0; x < 64; ++x)
        diff = std::max(diff, std::abs(a.at(x, y, channel) - b.at(x, y, channel)));
    }
    EXPECT_LE(diff, 1e-3) << channel;
  }
  EXPECT_EQ(b.spec.get_string_attribute("pf:model"), "3dgs-ply");
}

}  // namespace
}  // namespace pf
