// Tests of the checks on output file names sent by the server.
#include "client/remote/output_files.h"

#include <gtest/gtest.h>

namespace pf {
namespace {

namespace v1 = pointforward::v1;

v1::OutputFile File(const std::string& name) {
  v1::OutputFile file;
  file.set_name(name);
  file.mutable_digest()->set_sha256(std::string(64, 'a'));
  return file;
}

TEST(CheckOutputName, AcceptsPlainNames) {
  EXPECT_TRUE(CheckOutputName("front_100.exr").ok());
  EXPECT_TRUE(CheckOutputName("manifest.json").ok());
  EXPECT_TRUE(CheckOutputName("a..b.png").ok());
}

TEST(CheckOutputName, RefusesNamesThatLeaveTheDirectory) {
  for (const std::string name : {"../x", "/etc/x", "a/b", "..", ".", "", "a\\b"}) {
    const absl::Status status = CheckOutputName(name);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << "'" << name << "'";
  }
  EXPECT_FALSE(CheckOutputName(std::string("a\0b", 3)).ok());
  EXPECT_NE(std::string(CheckOutputName("../x").message()).find("'../x'"), std::string::npos);
}

TEST(CheckOutputFiles, NamesTheBadFileOfTheJob) {
  v1::RenderJob job;
  job.set_name("renderJobs/r1");
  *job.add_files() = File("a.exr");
  *job.add_files() = File("../b.exr");
  const absl::Status status = CheckOutputFiles(job);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(status.message()).find("renderJobs/r1 files[1]: "), std::string::npos)
      << status;
}

TEST(CheckOutputFiles, RefusesDuplicatesAndMissingDigests) {
  v1::RenderJob job;
  *job.add_files() = File("a.exr");
  *job.add_files() = File("a.exr");
  EXPECT_NE(std::string(CheckOutputFiles(job).message()).find("appears twice"), std::string::npos);

  v1::RenderJob no_digest;
  no_digest.add_files()->set_name("a.exr");
  EXPECT_NE(std::string(CheckOutputFiles(no_digest).message()).find("files[0].digest"),
            std::string::npos);

  v1::RenderJob good;
  *good.add_files() = File("a.exr");
  *good.add_files() = File("a.png");
  EXPECT_TRUE(CheckOutputFiles(good).ok());
}

}  // namespace
}  // namespace pf
