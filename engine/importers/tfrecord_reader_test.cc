// Tests of CRC-32C and the TFRecord reader: published CRC vectors, framing of
// records we write ourselves, and the real Waymo sample with a flipped byte
// or cut short.
#include "engine/importers/tfrecord_reader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "common/file_util.h"
#include "engine/importers/bytes_test_util.h"
#include "engine/importers/crc32c.h"
#include "tests/test_util.h"
#include "waymo/frame.pb.h"

namespace pf {
namespace {

using testing::Le;

// Frames `payload` as one TFRecord.
std::string Frame(const std::string& payload) {
  const std::string length = Le(payload.size(), 8);
  return length + Le(MaskCrc32c(Crc32c(length)), 4) + payload + Le(MaskCrc32c(Crc32c(payload)), 4);
}

std::string WriteTemp(const std::string& name, const std::string& bytes) {
  const std::string path = testing::MakeTempDir("tfrecord") + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

TEST(Crc32c, MatchesPublishedVectors) {
  EXPECT_EQ(Crc32c("123456789"), 0xE3069283u);
  EXPECT_EQ(Crc32c(std::string(32, '\0')), 0x8A9136AAu);  // RFC 3720 B.4.
  EXPECT_EQ(Crc32c(std::string(32, '\xFF')), 0x62A8AB43u);
  std::string ascending;
  for (int i = 0; i < 32; ++i) ascending.push_back(static_cast<char>(i));
  EXPECT_EQ(Crc32c(ascending), 0x46DD794Eu);
  EXPECT_EQ(Crc32c(""), 0u);
}

TEST(Crc32c, ExtendEqualsWholeAndMaskIsTfRecords) {
  const std::string text = "The quick brown fox jumps over the lazy dog";
  const uint32_t first = Crc32cExtend(0, text.data(), 10);
  EXPECT_EQ(Crc32cExtend(first, text.data() + 10, text.size() - 10), Crc32c(text));
  EXPECT_EQ(MaskCrc32c(0), 0xa282ead8u);
  const uint32_t crc = 0x12345678u;
  EXPECT_EQ(MaskCrc32c(crc), ((crc >> 15) | (crc << 17)) + 0xa282ead8u);
}

TEST(TfRecordReader, ReadsRecordsInOrderWithOffsets) {
  const std::string path =
      WriteTemp("three.tfrecord", Frame("alpha") + Frame("") + Frame("gamma!"));
  auto reader = TfRecordReader::Open(path);
  ASSERT_TRUE(reader.ok()) << reader.status();
  std::string record;
  ASSERT_TRUE(*(*reader)->Next(&record));
  EXPECT_EQ(record, "alpha");
  EXPECT_EQ((*reader)->offset(), 12u + 5 + 4);
  ASSERT_TRUE(*(*reader)->Next(&record));
  EXPECT_EQ(record, "");
  ASSERT_TRUE(*(*reader)->Next(&record));
  EXPECT_EQ(record, "gamma!");
  EXPECT_EQ((*reader)->record_index(), 3);
  auto more = (*reader)->Next(&record);
  ASSERT_TRUE(more.ok());
  EXPECT_FALSE(*more);
}

TEST(TfRecordReader, ReportsCorruptSecondRecordWithItsOffset) {
  std::string bytes = Frame("first record") + Frame("second record");
  const size_t second = 12 + 12 + 4;
  bytes[second + 12 + 3] ^= 0x01;  // A payload byte of record 1.
  const std::string path = WriteTemp("corrupt.tfrecord", bytes);
  auto reader = TfRecordReader::Open(path);
  ASSERT_TRUE(reader.ok());
  std::string record;
  ASSERT_TRUE(*(*reader)->Next(&record));
  const auto result = (*reader)->Next(&record);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kDataLoss);
  const std::string message(result.status().message());
  EXPECT_NE(message.find("record 1 at byte offset 28"), std::string::npos) << message;
  EXPECT_NE(message.find("corrupt"), std::string::npos) << message;
  EXPECT_NE(message.find("payload"), std::string::npos) << message;
}

TEST(TfRecordReader, ReportsCorruptLengthField) {
  std::string bytes = Frame("payload");
  bytes[0] ^= 0x40;
  auto reader = TfRecordReader::Open(WriteTemp("len.tfrecord", bytes));
  ASSERT_TRUE(reader.ok());
  std::string record;
  const auto result = (*reader)->Next(&record);
  ASSERT_FALSE(result.ok());
  EXPECT_NE(std::string(result.status().message()).find("CRC of the length field"),
            std::string::npos)
      << result.status();
}

TEST(TfRecordReader, MissingFileIsNotFound) {
  const auto reader = TfRecordReader::Open("/nonexistent/segment.tfrecord");
  ASSERT_FALSE(reader.ok());
  EXPECT_EQ(reader.status().code(), absl::StatusCode::kNotFound);
}

class RealSegment : public ::testing::Test {
 protected:
  std::string ReadSample() {
    const auto dir = testing::DataDir("waymo_one_frame");
    if (!dir) return "";
    return *ReadFileToString(*dir + "/pvps_data_one_frame.tfrecord");
  }
};

TEST_F(RealSegment, HoldsOneFrameRecordThatParses) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  auto reader = TfRecordReader::Open(dir + "/pvps_data_one_frame.tfrecord");
  ASSERT_TRUE(reader.ok()) << reader.status();
  std::string record;
  ASSERT_TRUE(*(*reader)->Next(&record));
  pointforward::waymo::Frame frame;
  ASSERT_TRUE(frame.ParseFromString(record));
  EXPECT_EQ(frame.context().name(), "1024360143612057520_3580_000_3600_000");
  EXPECT_EQ(frame.images_size(), 5);
  EXPECT_FALSE(*(*reader)->Next(&record));
}

TEST_F(RealSegment, FlippedByteIsRejectedWithTheRecordOffset) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  std::string bytes = ReadSample();
  ASSERT_GT(bytes.size(), 1000000u);
  bytes[bytes.size() / 2] ^= 0x20;  // Inside record 0's payload.
  auto reader = TfRecordReader::Open(WriteTemp("flipped.tfrecord", bytes));
  ASSERT_TRUE(reader.ok());
  std::string record;
  const auto result = (*reader)->Next(&record);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kDataLoss);
  const std::string message(result.status().message());
  EXPECT_NE(message.find("record 0 at byte offset 0: corrupt"), std::string::npos) << message;
}

TEST_F(RealSegment, TruncatedCopyIsRejectedWithTheRecordOffset) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const std::string bytes = ReadSample();
  auto reader =
      TfRecordReader::Open(WriteTemp("cut.tfrecord", bytes.substr(0, bytes.size() - 100)));
  ASSERT_TRUE(reader.ok());
  std::string record;
  const auto result = (*reader)->Next(&record);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kDataLoss);
  const std::string message(result.status().message());
  EXPECT_NE(message.find("record 0 at byte offset 0: truncated"), std::string::npos) << message;
}

}  // namespace
}  // namespace pf
