// Tests of the ZIP reader and the .npy parser: archives built here (stored
// and deflated entries), bad input, and the real DGP LiDAR .npz.
#include "engine/importers/zip_reader.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <string>

#include "engine/importers/bytes_test_util.h"
#include "engine/importers/npy.h"
#include "tests/test_util.h"

namespace pf {
namespace {

using testing::Le;

// Builds a ZIP of one entry, stored (method 0) or raw-deflated (method 8).
std::string MakeZip(const std::string& name, const std::string& content, int method) {
  std::string data = content;
  if (method == 8) {
    z_stream zs{};
    deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
    data.resize(deflateBound(&zs, content.size()));
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(content.data()));
    zs.avail_in = content.size();
    zs.next_out = reinterpret_cast<Bytef*>(data.data());
    zs.avail_out = data.size();
    deflate(&zs, Z_FINISH);
    data.resize(zs.total_out);
    deflateEnd(&zs);
  }
  const uint32_t crc = crc32(0, reinterpret_cast<const Bytef*>(content.data()), content.size());
  const std::string common = Le(20, 2) + Le(0, 2) + Le(method, 2) + Le(0, 2) + Le(0, 2) +
                             Le(crc, 4) + Le(data.size(), 4) + Le(content.size(), 4) +
                             Le(name.size(), 2) + Le(0, 2);
  const std::string local = Le(0x04034b50, 4) + common + name + data;
  const std::string central = Le(0x02014b50, 4) + Le(20, 2) + common + Le(0, 2) + Le(0, 2) +
                              Le(0, 2) + Le(0, 4) + Le(0, 4) + name;
  const std::string end = Le(0x06054b50, 4) + Le(0, 2) + Le(0, 2) + Le(1, 2) + Le(1, 2) +
                          Le(central.size(), 4) + Le(local.size(), 4) + Le(0, 2);
  return local + central + end;
}

// Builds a version-1 .npy of `values` with dtype `descr` and `shape`.
std::string MakeNpy(const std::string& descr, const std::string& shape,
                    const std::vector<double>& values) {
  std::string header =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + header.size() + 1) % 64 != 0) header.push_back(' ');
  header.push_back('\n');
  std::string out = std::string("\x93NUMPY\x01\x00", 8) + Le(header.size(), 2) + header;
  for (double v : values) {
    if (descr == "<f8") {
      out.append(reinterpret_cast<const char*>(&v), 8);
    } else {
      const float f = static_cast<float>(v);
      out.append(reinterpret_cast<const char*>(&f), 4);
    }
  }
  return out;
}

TEST(ZipReader, ReadsStoredAndDeflatedEntries) {
  std::string text;
  for (int i = 0; i < 200; ++i) text += "row " + std::to_string(i) + " of a compressible text\n";
  for (int method : {0, 8}) {
    auto zip = ZipReader::FromBytes(MakeZip("data.txt", text, method), "test.zip");
    ASSERT_TRUE(zip.ok()) << zip.status();
    ASSERT_EQ(zip->entries().size(), 1u);
    EXPECT_EQ(zip->entries()[0].method, method);
    auto content = zip->Read("data.txt");
    ASSERT_TRUE(content.ok()) << content.status();
    EXPECT_EQ(*content, text);
  }
}

TEST(ZipReader, RejectsMissingEntryAndDamagedData) {
  auto zip = ZipReader::FromBytes(MakeZip("a.npy", "hello hello hello", 0), "x.npz");
  ASSERT_TRUE(zip.ok());
  const auto missing = zip->Read("data.npy");
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(std::string(missing.status().message()).find("have a.npy"), std::string::npos);

  std::string bytes = MakeZip("a.npy", "hello hello hello", 0);
  bytes[30 + 5 + 2] ^= 0x01;  // A content byte: the CRC no longer matches.
  auto damaged = ZipReader::FromBytes(bytes, "y.npz");
  ASSERT_TRUE(damaged.ok());
  EXPECT_EQ(damaged->Read("a.npy").status().code(), absl::StatusCode::kDataLoss);

  EXPECT_EQ(ZipReader::FromBytes("not a zip at all, just text", "z.npz").status().code(),
            absl::StatusCode::kDataLoss);
}

TEST(Npy, ParsesFloat64AndFloat32) {
  auto f8 = ParseNpy(MakeNpy("<f8", "(2, 3)", {1, 2, 3, 4.5, -5, 6}), "a.npy");
  ASSERT_TRUE(f8.ok()) << f8.status();
  EXPECT_EQ(f8->shape, (std::vector<int64_t>{2, 3}));
  EXPECT_EQ(f8->data, (std::vector<double>{1, 2, 3, 4.5, -5, 6}));
  auto f4 = ParseNpy(MakeNpy("<f4", "(3,)", {0.25, -1, 7}), "b.npy");
  ASSERT_TRUE(f4.ok()) << f4.status();
  EXPECT_EQ(f4->shape, (std::vector<int64_t>{3}));
  EXPECT_EQ(f4->data, (std::vector<double>{0.25, -1, 7}));
}

TEST(Npy, RejectsUnsupportedDtypeAndSizeMismatch) {
  const auto ints = ParseNpy(MakeNpy("<i4", "(1,)", {}), "c.npy");
  EXPECT_EQ(ints.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(ints.status().message()).find("'<i4'"), std::string::npos);
  const auto short_data = ParseNpy(MakeNpy("<f8", "(4, 4)", {1, 2}), "d.npy");
  EXPECT_EQ(short_data.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ParseNpy("garbage", "e.npy").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ZipReader, ReadsRealDgpLidarNpz) {
  PF_REQUIRE_DATA(dir, "dgp_test_scene/scene_02");
  auto zip = ZipReader::Open(dir + "/point_cloud/LIDAR/15616458250027900.npz");
  ASSERT_TRUE(zip.ok()) << zip.status();
  ASSERT_EQ(zip->entries().size(), 1u);
  EXPECT_EQ(zip->entries()[0].method, 8);  // numpy.savez_compressed.
  auto npy = zip->Read("data.npy");
  ASSERT_TRUE(npy.ok()) << npy.status();
  auto points = ParseNpy(*npy, "data.npy");
  ASSERT_TRUE(points.ok()) << points.status();
  EXPECT_EQ(points->shape, (std::vector<int64_t>{47230, 4}));
  // Plausible LiDAR returns: within 250 m of the sensor, some near, some far.
  int near = 0, far = 0;
  for (int64_t i = 0; i < points->shape[0]; ++i) {
    const double* p = &points->data[i * 4];
    const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    ASSERT_LT(r, 250.0);
    near += r < 10;
    far += r > 30;
  }
  EXPECT_GT(near, 1000);
  EXPECT_GT(far, 100);
}

}  // namespace
}  // namespace pf
