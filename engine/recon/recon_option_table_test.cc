// Tests of the one table of reconstruction options: every field of the
// message in it once, flags and fields checked alike, defaults filled, and
// the cache key's fields.
#include "engine/recon/recon_option_table.h"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using Kind = ReconOptionSpec::Kind;

const std::vector<std::string>& Models() {
  static const std::vector<std::string> models = BuiltInReconModelNames();
  return models;
}

absl::StatusOr<v1::ReconstructionOptions> FromFlags(const std::vector<std::string>& words) {
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(words, ReconValueFlags(), ReconSwitchFlags());
  if (!cl.ok()) return cl.status();
  return ReconProtoFromFlags(*cl, Models());
}

TEST(ReconOptionTable, EveryFieldOfTheMessageIsInTheTableOnce) {
  std::map<std::string, int> count;
  for (const ReconOptionSpec& spec : ReconOptionTable()) ++count[spec.field];
  const auto* descriptor = v1::ReconstructionOptions::descriptor();
  ASSERT_EQ(count.size(), static_cast<size_t>(descriptor->field_count()));
  for (int i = 0; i < descriptor->field_count(); ++i) {
    EXPECT_EQ(count[descriptor->field(i)->name()], 1) << descriptor->field(i)->name();
  }
}

TEST(ReconOptionTable, FlagsAndFieldsAreRefusedWithTheSameWords) {
  for (const ReconOptionSpec& spec : ReconOptionTable()) {
    if (spec.kind != Kind::kInt && spec.kind != Kind::kReal) continue;
    const double outside = spec.hi + 1;
    const std::string text =
        spec.kind == Kind::kInt ? absl::StrCat(int64_t(outside)) : absl::StrCat(outside);
    const absl::Status flag = FromFlags({absl::StrCat("--", ReconOptionFlag(spec)), text}).status();
    ASSERT_EQ(flag.code(), absl::StatusCode::kInvalidArgument) << ReconOptionFlag(spec);
    ASSERT_EQ(flag.message().rfind(absl::StrCat("--", ReconOptionFlag(spec), ": must be in "), 0),
              0u)
        << flag;

    v1::ReconstructionOptions proto;
    const auto* field = v1::ReconstructionOptions::descriptor()->FindFieldByName(spec.field);
    const auto* reflection = proto.GetReflection();
    if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) {
      reflection->SetDouble(&proto, field, outside);
    } else if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_INT32) {
      reflection->SetInt32(&proto, field, static_cast<int32_t>(outside));
    } else {
      reflection->SetInt64(&proto, field, static_cast<int64_t>(outside));
    }
    const absl::Status normalized = NormalizeReconProto(proto, Models()).status();
    ASSERT_EQ(normalized.code(), absl::StatusCode::kInvalidArgument) << spec.field;
    // The same problem after the name.
    const std::string flag_problem(flag.message().substr(flag.message().find(": ")));
    EXPECT_EQ(normalized.message(), absl::StrCat("options.", spec.field, flag_problem));
  }
}

// A switch that acts on another option's step is refused without it, by
// the client and at the server's intake.
TEST(ReconOptionTable, ASwitchIsRefusedWithoutTheOptionItNeeds) {
  absl::Status flag = FromFlags({"--optimize-poses"}).status();
  EXPECT_EQ(flag.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(flag.message(), "--optimize-poses: needs --optimize-steps too");
  EXPECT_TRUE(FromFlags({"--optimize-poses", "--optimize-steps", "3"}).ok());
  EXPECT_EQ(FromFlags({"--optimize-densify"}).status().message(),
            "--optimize-densify: needs --optimize-steps too");
  v1::ReconstructionOptions proto;
  proto.set_optimize_poses(true);
  absl::Status field = NormalizeReconProto(proto, Models()).status();
  EXPECT_EQ(field.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(field.message(), "options.optimize_poses: needs options.optimize_steps too (above 0)");
  proto.set_optimize_steps(0);
  EXPECT_FALSE(NormalizeReconProto(proto, Models()).ok());
  proto.set_optimize_steps(4);
  EXPECT_TRUE(NormalizeReconProto(proto, Models()).ok());
}

TEST(ReconOptionTable, FlagsFillTheMessage) {
  absl::StatusOr<v1::ReconstructionOptions> proto = FromFlags({"--model",
                                                               "pixel-aligned",
                                                               "--ns",
                                                               "5000",
                                                               "--nd",
                                                               "70",
                                                               "--fusion",
                                                               "average",
                                                               "--lifespan",
                                                               "--refine",
                                                               "3",
                                                               "--splat-sigma",
                                                               "0.5",
                                                               "--low-pass",
                                                               "0.3",
                                                               "--hidden-band",
                                                               "0",
                                                               "--no-facades",
                                                               "--no-stereo",
                                                               "--no-ego-layer",
                                                               "--colour",
                                                               "flat",
                                                               "--completion",
                                                               "ip-basic",
                                                               "--working-space",
                                                               "linear",
                                                               "--optimize-steps",
                                                               "10",
                                                               "--optimize-poses",
                                                               "--optimize-densify",
                                                               "--device",
                                                               "cuda:1"});
  ASSERT_TRUE(proto.ok()) << proto.status();
  EXPECT_EQ(proto->model(), "pixel-aligned");
  EXPECT_EQ(proto->ns(), 5000);
  EXPECT_EQ(proto->nd(), 70);
  EXPECT_EQ(proto->fusion(), "average");
  EXPECT_TRUE(proto->lifespan());
  EXPECT_FALSE(proto->no_lifespan());
  ASSERT_TRUE(proto->has_refine());
  EXPECT_EQ(proto->refine(), 3);
  EXPECT_EQ(proto->splat_sigma(), 0.5);
  EXPECT_EQ(proto->low_pass(), 0.3);
  ASSERT_TRUE(proto->has_hidden_band());
  EXPECT_EQ(proto->hidden_band(), 0);
  EXPECT_TRUE(proto->no_facades());
  EXPECT_TRUE(proto->no_stereo());
  EXPECT_TRUE(proto->no_ego_layer());
  EXPECT_FALSE(proto->no_ground_fill());
  EXPECT_EQ(proto->colour(), "flat");
  EXPECT_EQ(proto->completion(), "ip-basic");
  EXPECT_EQ(proto->working_space(), "linear");
  EXPECT_TRUE(proto->optimize_poses());
  EXPECT_TRUE(proto->optimize_densify());
  EXPECT_EQ(proto->optimize_steps(), 10);
  EXPECT_EQ(proto->device(), "cuda:1");

  // Nothing given: nothing set (the defaults are the engine's).
  proto = FromFlags({});
  ASSERT_TRUE(proto.ok()) << proto.status();
  EXPECT_EQ(proto->ByteSizeLong(), 0u);

  EXPECT_EQ(FromFlags({"--lifespan", "--no-lifespan"}).status().message(),
            "--lifespan: given with --no-lifespan; give one");
  EXPECT_EQ(FromFlags({"--model", "nerf"}).status().message(),
            "--model: unknown model 'nerf' (expected analytic or pixel-aligned)");
  EXPECT_EQ(FromFlags({"--fusion", "max"}).status().message(),
            "--fusion: unknown weighting 'max' (expected softmax, average or no-depth)");
  EXPECT_EQ(FromFlags({"--ns", "0"}).status().message(),
            "--ns: must be in [1, 1000000000] queries per view, got 0");
  EXPECT_EQ(FromFlags({"--device", "gpu0"}).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ReconOptionTable, NormalizingFillsTheKeysDefaultsAndClearsWhatEqualsThem) {
  v1::ReconstructionOptions proto;
  proto.set_no_lifespan(true);
  proto.set_completion("nearest");
  proto.set_working_space("srgb");
  absl::StatusOr<v1::ReconstructionOptions> out = NormalizeReconProto(proto, Models());
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->model(), "analytic");
  EXPECT_EQ(out->fusion(), "softmax");
  EXPECT_EQ(out->device(), "cpu");
  EXPECT_FALSE(out->no_lifespan());
  EXPECT_EQ(out->completion(), "");
  EXPECT_EQ(out->working_space(), "");
  EXPECT_EQ(out->colour(), "");  // The model's default: no fixed value to fill.

  proto.set_lifespan(true);
  EXPECT_EQ(NormalizeReconProto(proto, Models()).status().message(),
            "options.lifespan: set together with options.no_lifespan; set one");
  v1::ReconstructionOptions bad;
  bad.set_ns(-5);
  EXPECT_EQ(NormalizeReconProto(bad, Models()).status().message(),
            "options.ns: must be in [1, 1000000000] queries per view, got -5");
  bad.Clear();
  bad.set_working_space("gamma");
  EXPECT_EQ(NormalizeReconProto(bad, Models()).status().message(),
            "options.working_space: unknown working space 'gamma' (expected srgb or linear)");
}

TEST(ReconOptionTable, TheCacheKeyListsTheDefaultsAlwaysAndTheRestWhenSet) {
  absl::StatusOr<v1::ReconstructionOptions> defaults = NormalizeReconProto({}, Models());
  ASSERT_TRUE(defaults.ok());
  using Fields = std::vector<std::pair<std::string, std::string>>;
  EXPECT_EQ(SceneCacheKeyFields(*defaults), (Fields{{"model", "analytic"},
                                                    {"ns", "0"},
                                                    {"nd", "0"},
                                                    {"fusion", "softmax"},
                                                    {"lifespan", "off"}}));
  v1::ReconstructionOptions tuned = *defaults;
  tuned.set_lifespan(true);
  tuned.set_refine(4);
  tuned.set_splat_sigma(0.5);
  tuned.set_low_pass(0.3);
  tuned.set_hidden_band(0);
  tuned.set_no_ground_fill(true);
  tuned.set_no_facades(true);
  tuned.set_no_stereo(true);
  tuned.set_no_ego_layer(true);
  tuned.set_colour("flat");
  tuned.set_completion("ip-basic");
  tuned.set_working_space("linear");
  tuned.set_optimize_poses(true);
  tuned.set_optimize_densify(true);
  tuned.set_colour_fit_memory(4.5);
  tuned.set_device("cuda:0");  // Not part of the key.
  EXPECT_EQ(SceneCacheKeyFields(tuned), (Fields{{"model", "analytic"},
                                                {"ns", "0"},
                                                {"nd", "0"},
                                                {"fusion", "softmax"},
                                                {"lifespan", "on"},
                                                {"refine", "4"},
                                                {"splat_sigma", absl::StrFormat("%a", 0.5)},
                                                {"low_pass", absl::StrFormat("%a", double(0.3f))},
                                                {"hidden_band", "0"},
                                                {"colour_fit_memory", absl::StrFormat("%a", 4.5)},
                                                {"ground_fill", "off"},
                                                {"facades", "off"},
                                                {"stereo", "off"},
                                                {"colour", "flat"},
                                                {"completion", "ip-basic"},
                                                {"working_space", "linear"},
                                                {"optimize_poses", "on"},
                                                {"optimize_densify", "on"},
                                                {"ego_layer", "off"}}));
}

}  // namespace
}  // namespace pf
