// Tests of the server's checks of ReconstructionOptions and of the scene
// cache key they enter.
#include "server/clip_intake.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/hash.h"
#include "common/version.h"
#include "pointforward/v1/resources.pb.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

TEST(NormalizeOptions, FillsDefaultsAndRefusesTuningOutOfRangeNamingTheField) {
  absl::StatusOr<v1::ReconstructionOptions> out = NormalizeOptions({});
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->model(), "analytic");
  EXPECT_EQ(out->fusion(), "softmax");
  EXPECT_FALSE(out->has_refine());  // Unset stays unset: the worker's default.

  v1::ReconstructionOptions options;
  options.set_refine(0);
  options.set_splat_sigma(4);
  options.set_low_pass(0);
  options.set_hidden_band(256);
  out = NormalizeOptions(options);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_TRUE(out->has_refine());
  EXPECT_EQ(out->refine(), 0);

  struct Bad {
    void (*set)(v1::ReconstructionOptions*);
    const char* message;
  };
  const Bad bad[] = {
      {[](v1::ReconstructionOptions* o) { o->set_refine(-1); },
       "options.refine: must be in [0, 64] iterations, got -1"},
      {[](v1::ReconstructionOptions* o) { o->set_splat_sigma(0.01); },
       "options.splat_sigma: must be in (0.05, 4], got 0.01"},
      {[](v1::ReconstructionOptions* o) { o->set_low_pass(4.5); },
       "options.low_pass: must be in [0, 4] pixels^2, got 4.5"},
      {[](v1::ReconstructionOptions* o) { o->set_hidden_band(300); },
       "options.hidden_band: must be in [0, 256] pixels, got 300"},
      {[](v1::ReconstructionOptions* o) { o->set_colour("sh"); },
       "options.colour: unknown colour model 'sh' (expected gradients or flat)"},
  };
  for (const Bad& b : bad) {
    v1::ReconstructionOptions o;
    b.set(&o);
    const absl::Status status = NormalizeOptions(o).status();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << b.message;
    EXPECT_EQ(status.message(), b.message);
  }
}

TEST(SceneCacheKey, TuningValuesThatAreSetMakeAnotherScene) {
  v1::UploadedClip clip;
  clip.mutable_manifest()->set_sha256("abc");
  const v1::ReconstructionOptions defaults = *NormalizeOptions({});
  const std::string key = SceneCacheKey(clip, defaults);
  EXPECT_EQ(key.size(), 64u);
  v1::ReconstructionOptions same = defaults;
  same.set_no_ground_fill(false);  // The default, written out.
  EXPECT_EQ(SceneCacheKey(clip, same), key);

  v1::ReconstructionOptions low_pass = defaults;
  low_pass.set_low_pass(0.3);
  v1::ReconstructionOptions near = defaults;
  near.set_low_pass(0.31);
  // The worker keeps the low-pass as a float: what rounds to the same float
  // is the same scene.
  v1::ReconstructionOptions same_float = defaults;
  same_float.set_low_pass(0.3 + 1e-12);
  EXPECT_EQ(SceneCacheKey(clip, same_float), SceneCacheKey(clip, low_pass));
  v1::ReconstructionOptions facades = defaults;
  facades.set_no_facades(true);
  v1::ReconstructionOptions refine = defaults;
  refine.set_refine(4);
  v1::ReconstructionOptions band = defaults;
  band.set_hidden_band(4);  // Same number, another field.
  v1::ReconstructionOptions flat = defaults;
  flat.set_colour("flat");
  v1::ReconstructionOptions gradients = defaults;
  gradients.set_colour("gradients");  // The analytic default, but asked for: another key.
  const std::set<std::string> keys = {key,
                                      SceneCacheKey(clip, low_pass),
                                      SceneCacheKey(clip, near),
                                      SceneCacheKey(clip, facades),
                                      SceneCacheKey(clip, refine),
                                      SceneCacheKey(clip, band),
                                      SceneCacheKey(clip, flat),
                                      SceneCacheKey(clip, gradients)};
  EXPECT_EQ(keys.size(), 8u);
}

// The key is SHA-256 over "name=<length>:<value>\n" lines in a fixed order:
// scenes cached by an earlier server keep their keys.
TEST(SceneCacheKey, IsTheHashOfItsFieldsInTheirOrder) {
  v1::UploadedClip clip;
  clip.mutable_manifest()->set_sha256("abc");
  v1::Digest image;
  image.set_sha256("def");
  (*clip.mutable_files())["images/b.png"] = image;
  image.set_sha256("0123");
  (*clip.mutable_files())["images/a.png"] = image;
  v1::ReconstructionOptions options;
  options.set_refine(4);
  options.set_no_facades(true);
  options.set_device("cpu");
  const std::string version = SoftwareVersion();
  Sha256 hash;
  hash.Update(absl::StrCat("engine=", version.size(), ":", version, "\n",
                           "manifest=3:abc\n"
                           "file images/a.png=4:0123\n"
                           "file images/b.png=3:def\n"
                           "model=8:analytic\n"
                           "ns=1:0\n"
                           "nd=1:0\n"
                           "fusion=7:softmax\n"
                           "lifespan=3:off\n"
                           "refine=1:4\n"
                           "facades=3:off\n"));
  EXPECT_EQ(SceneCacheKey(clip, *NormalizeOptions(options)), hash.FinishHex());
}

// Lifespans are off unless asked for; an earlier client's no_lifespan asks
// for the default and gets the default's scene; both at once is refused.
TEST(SceneCacheKey, LifespanOnIsAnotherSceneAndNoLifespanIsTheDefault) {
  v1::UploadedClip clip;
  clip.mutable_manifest()->set_sha256("abc");
  const std::string key = SceneCacheKey(clip, *NormalizeOptions({}));
  v1::ReconstructionOptions off;
  off.set_no_lifespan(true);
  absl::StatusOr<v1::ReconstructionOptions> normalized = NormalizeOptions(off);
  ASSERT_TRUE(normalized.ok()) << normalized.status();
  EXPECT_FALSE(normalized->no_lifespan());
  EXPECT_EQ(SceneCacheKey(clip, *normalized), key);
  v1::ReconstructionOptions on;
  on.set_lifespan(true);
  normalized = NormalizeOptions(on);
  ASSERT_TRUE(normalized.ok()) << normalized.status();
  EXPECT_NE(SceneCacheKey(clip, *normalized), key);
  on.set_no_lifespan(true);
  const absl::Status both = NormalizeOptions(on).status();
  EXPECT_EQ(both.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(both.message().find("options.lifespan"), std::string::npos) << both;
}

}  // namespace
}  // namespace pf
