// Tests of the progress bar, the progress lines and when ProgressReporter
// prints them.
#include "client/remote/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace pf {
namespace {

namespace v1 = pointforward::v1;

v1::OperationMetadata Rendering(int done, int total) {
  v1::OperationMetadata metadata;
  metadata.set_kind("render");
  metadata.set_state("RUNNING");
  metadata.set_stage("rendering");
  metadata.set_frames_done(done);
  metadata.set_frames_total(total);
  return metadata;
}

// Returns everything written to `file` so far.
std::string Contents(std::FILE* file) {
  std::fflush(file);
  std::rewind(file);
  std::string text;
  for (int c = std::fgetc(file); c != EOF; c = std::fgetc(file))
    text.push_back(static_cast<char>(c));
  return text;
}

TEST(ProgressFraction, PrefersTheFractionThenFrames) {
  v1::OperationMetadata metadata = Rendering(13, 25);
  EXPECT_DOUBLE_EQ(ProgressFraction(metadata), 0.52);
  metadata.set_fraction(0.25);
  EXPECT_DOUBLE_EQ(ProgressFraction(metadata), 0.25);
  metadata.set_fraction(7.0);
  EXPECT_DOUBLE_EQ(ProgressFraction(metadata), 1.0);
  EXPECT_DOUBLE_EQ(ProgressFraction(v1::OperationMetadata()), 0.0);
}

TEST(FormatProgressBar, ShowsBarPercentFramesAndStage) {
  EXPECT_EQ(FormatProgressBar(Rendering(13, 25)), "[#####-----]  52%  13/25 frames  rendering");
  EXPECT_EQ(FormatProgressBar(Rendering(25, 25)), "[##########] 100%  25/25 frames  rendering");
  EXPECT_EQ(FormatProgressBar(Rendering(0, 25), 4), "[----]   0%  0/25 frames  rendering");
}

TEST(FormatProgressBar, LeavesOutFramesOfAReconstruction) {
  v1::OperationMetadata metadata;
  metadata.set_stage("sampling");
  metadata.set_fraction(0.3);
  EXPECT_EQ(FormatProgressBar(metadata), "[###-------]  30%  sampling");
}

TEST(FormatProgressLine, NamesTheJobAndItsState) {
  EXPECT_EQ(FormatProgressLine("renderJobs/X", Rendering(13, 25)),
            "renderJobs/X: RUNNING 13/25 frames (52%) rendering");
  v1::OperationMetadata queued;
  queued.set_state("QUEUED");
  EXPECT_EQ(FormatProgressLine("scenes/s", queued), "scenes/s: QUEUED (0%)");
  EXPECT_EQ(FormatProgressLine("scenes/s", v1::OperationMetadata()), "scenes/s: PENDING (0%)");
}

TEST(ProgressReporter, PrintsPlainLinesOnlyWhenFiguresChange) {
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  ProgressReporter progress(file, /*interactive=*/false);
  progress.Update("renderJobs/X", Rendering(1, 4));
  progress.Update("renderJobs/X", Rendering(1, 4));
  progress.Update("renderJobs/X", Rendering(2, 4));
  progress.Finish();
  EXPECT_EQ(Contents(file),
            "renderJobs/X: RUNNING 1/4 frames (25%) rendering\n"
            "renderJobs/X: RUNNING 2/4 frames (50%) rendering\n");
  std::fclose(file);
}

TEST(ProgressReporter, RedrawsTheBarInPlaceOnATerminal) {
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  ProgressReporter progress(file, /*interactive=*/true);
  v1::OperationMetadata long_stage = Rendering(1, 4);
  long_stage.set_stage("waiting for scene");
  progress.Update("renderJobs/X", long_stage);
  progress.Update("renderJobs/X", Rendering(2, 4));
  progress.Update("renderJobs/X", Rendering(2, 4));
  progress.Finish();
  // The second text is 8 characters shorter: 8 spaces wipe the rest.
  EXPECT_EQ(Contents(file),
            "\r[##--------]  25%  1/4 frames  waiting for scene"
            "\r[#####-----]  50%  2/4 frames  rendering        \n");
  std::fclose(file);
}

}  // namespace
}  // namespace pf
