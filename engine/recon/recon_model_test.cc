// Tests of the model registry and the pipeline's stages: a model made in
// this file from the stages is one class and one registry line, and is then
// chosen by name like the built-in ones; the engine reports every stage, in
// the order recon_stages.h lists them.
#include "engine/recon/recon_model.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "engine/recon/pipeline.h"
#include "engine/recon/recon_option_table.h"
#include "engine/recon/recon_options.h"
#include "engine/synth/synth_clip_writer.h"
#include "tests/test_util.h"

namespace pf {
namespace {

// The stages without fusion or the colour fit: each query keeps its own
// pixel's colour.
class UnfusedQueriesModel : public ReconModel {
 public:
  bool DefaultColourGradients() const override { return false; }

  absl::StatusOr<ReconResult> Reconstruct(ReconInputs inputs,
                                          const ReconOptions& options) const override {
    Pipeline p(std::move(inputs), options);
    if (absl::Status depth = p.Depth(); !depth.ok()) return depth;
    p.Lift();
    p.SceneGraph();
    p.Sample(/*dense=*/false);
    p.KeepQueriesUnfused();
    p.Decode();
    return p.Finish();
  }
};

class ReconModelTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string dir = testing::MakeTempDir("recon_model");
    SynthOptions synth;
    synth.num_cameras = 1;
    synth.num_frames = 16;
    synth.width = 96;
    synth.height = 72;
    synth.antialias = 1;
    ASSERT_TRUE(WriteSynthClip(synth, dir).ok());
    absl::StatusOr<LoadedClip> loaded = LoadClip(dir + "/clip.json");
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    absl::StatusOr<ReconInputs> inputs = LoadReconInputs(*loaded, {});
    ASSERT_TRUE(inputs.ok()) << inputs.status();
    inputs_ = new ReconInputs(*std::move(inputs));
    // The one line that adds a model.
    ASSERT_TRUE(RegisterReconModel("test-unfused", std::make_unique<UnfusedQueriesModel>()).ok());
  }

  static ReconOptions Options(const std::string& model) {
    ReconOptions options;
    options.model = model;
    options.static_per_view = 400;
    options.dynamic_per_instance = 60;
    options.refinement.iterations = 0;
    return options;
  }

  static ReconInputs* inputs_;
};

ReconInputs* ReconModelTest::inputs_ = nullptr;

TEST_F(ReconModelTest, AModelAddedByOneLineIsChosenByName) {
  const std::vector<std::string> names = ReconModelNames();
  EXPECT_EQ(names, (std::vector<std::string>{"analytic", "pixel-aligned", "test-unfused"}));
  ASSERT_NE(FindReconModel("test-unfused"), nullptr);
  EXPECT_EQ(FindReconModel("nerf"), nullptr);

  absl::StatusOr<ReconResult> ours = ReconstructInputs(*inputs_, Options("test-unfused"));
  ASSERT_TRUE(ours.ok()) << ours.status();
  absl::StatusOr<ReconResult> analytic = ReconstructInputs(*inputs_, Options("analytic"));
  ASSERT_TRUE(analytic.ok()) << analytic.status();
  // The same queries, decoded without fusion: as many Gaussians, other colours.
  ASSERT_GT(ours->scene.size(), 100u);
  EXPECT_EQ(ours->scene.size(), analytic->scene.size());
  EXPECT_EQ(ours->scene.means, analytic->scene.means);
  EXPECT_NE(ours->scene.features, analytic->scene.features);
  // The synth rig has no body in its images: nothing is taken for one.
  EXPECT_TRUE(analytic->scene.ego_layers.empty());
  EXPECT_TRUE(analytic->stats.ego_body.empty());
  std::vector<std::string> stages;
  for (const auto& [name, seconds] : ours->stats.stage_seconds) stages.push_back(name);
  EXPECT_EQ(stages,
            (std::vector<std::string>{"depth", "lift", "scene_graph", "sample", "fuse", "decode"}));

  // The flags and the message format take it as they take the built-in ones.
  absl::StatusOr<CommandLine> cl = ParseReconCommandLine({"--model", "test-unfused"});
  ASSERT_TRUE(cl.ok()) << cl.status();
  absl::StatusOr<ReconOptions> options = ReconOptionsFromFlags(*cl);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_EQ(options->model, "test-unfused");
  EXPECT_EQ(CheckReconModel("nerf", "--model").message(),
            "--model: unknown model 'nerf' (expected analytic, pixel-aligned or test-unfused)");
  EXPECT_EQ(ReconstructInputs(*inputs_, Options("nerf")).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(RegisterReconModel("analytic", std::make_unique<UnfusedQueriesModel>()).code(),
            absl::StatusCode::kAlreadyExists);
  // What the server knows without the engine is the registry's start.
  EXPECT_EQ(BuiltInReconModelNames(), (std::vector<std::string>{"analytic", "pixel-aligned"}));
}

TEST_F(ReconModelTest, ProgressReportsEachStageInTheListedOrder) {
  ReconOptions options = Options("analytic");
  options.refinement.iterations = 2;
  options.optimize.steps = 2;
  std::vector<ReconProgress> reports;
  options.progress = [&](const ReconProgress& p) { reports.push_back(p); };
  absl::StatusOr<ReconResult> result = ReconstructInputs(*inputs_, options);
  ASSERT_TRUE(result.ok()) << result.status();

  std::vector<std::string> done, expected;
  for (const ReconProgress& p : reports) {
    if (p.kind != ReconProgress::Kind::kStageDone) continue;
    ASSERT_TRUE(p.stage.has_value());
    done.push_back(ReconStageName(*p.stage));
    EXPECT_GE(p.seconds, 0);
    EXPECT_EQ(ProgressLine(p).rfind(absl::StrCat(ReconStageName(*p.stage), " done in "), 0), 0u)
        << ProgressLine(p);
  }
  for (const ReconStageInfo& info : ReconStages()) {
    if (info.stage != ReconStage::kLoad) expected.push_back(info.name);
  }
  EXPECT_EQ(done, expected);
  ASSERT_EQ(result->stats.stage_seconds.size(), expected.size());
  EXPECT_EQ(result->stats.optimize_steps, 2);
  EXPECT_EQ(result->stats.optimize_loss.size(), 2u);
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(result->stats.stage_seconds[i].first, expected[i]);
  }
  // A note is its own line.
  ReconProgress note;
  note.detail = "warning: x";
  EXPECT_EQ(ProgressLine(note), "warning: x");
}

}  // namespace
}  // namespace pf
