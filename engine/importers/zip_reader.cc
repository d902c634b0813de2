// ZIP: end-of-central-directory record, central directory, local headers,
// and zlib's raw inflate for method 8.
#include "engine/importers/zip_reader.h"

#include <zlib.h>

#include <algorithm>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {
namespace {

constexpr uint32_t kEndOfCentralDirSignature = 0x06054b50;
constexpr uint32_t kCentralDirSignature = 0x02014b50;
constexpr uint32_t kLocalHeaderSignature = 0x04034b50;
constexpr size_t kEndOfCentralDirSize = 22;
constexpr size_t kCentralDirHeaderSize = 46;
constexpr size_t kLocalHeaderSize = 30;

uint16_t Le16(const std::string& b, size_t at) {
  return static_cast<uint16_t>(static_cast<unsigned char>(b[at]) |
                               (static_cast<unsigned char>(b[at + 1]) << 8));
}

uint32_t Le32(const std::string& b, size_t at) {
  return static_cast<uint32_t>(Le16(b, at)) | (static_cast<uint32_t>(Le16(b, at + 2)) << 16);
}

}  // namespace

absl::StatusOr<ZipReader> ZipReader::Open(const std::string& path) {
  ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(path));
  return FromBytes(std::move(bytes), path);
}

absl::StatusOr<ZipReader> ZipReader::FromBytes(std::string bytes, std::string label) {
  ZipReader zip;
  zip.label_ = std::move(label);
  zip.bytes_ = std::move(bytes);
  const std::string& b = zip.bytes_;
  auto bad = [&](const std::string& what) {
    return absl::DataLossError(absl::StrCat(zip.label_, ": not a readable ZIP archive: ", what));
  };
  if (b.size() < kEndOfCentralDirSize) return bad("too short");
  // The end record sits in the last 22 + 65535 (comment) bytes.
  size_t eocd = std::string::npos;
  const size_t lowest =
      b.size() > kEndOfCentralDirSize + 65535 ? b.size() - kEndOfCentralDirSize - 65535 : 0;
  for (size_t at = b.size() - kEndOfCentralDirSize + 1; at-- > lowest;) {
    if (Le32(b, at) == kEndOfCentralDirSignature) {
      eocd = at;
      break;
    }
  }
  if (eocd == std::string::npos) return bad("no end-of-central-directory record");
  const uint16_t count = Le16(b, eocd + 10);
  const uint32_t dir_size = Le32(b, eocd + 12);
  const uint32_t dir_offset = Le32(b, eocd + 16);
  if (count == 0xFFFF || dir_offset == 0xFFFFFFFFu) return bad("ZIP64 archives are not supported");
  if (static_cast<uint64_t>(dir_offset) + dir_size > eocd) {
    return bad("central directory lies outside the file");
  }
  size_t at = dir_offset;
  for (int i = 0; i < count; ++i) {
    if (at + kCentralDirHeaderSize > eocd || Le32(b, at) != kCentralDirSignature) {
      return bad(absl::StrCat("central directory entry ", i, " is damaged"));
    }
    Entry e;
    const uint16_t flags = Le16(b, at + 8);
    e.method = Le16(b, at + 10);
    e.crc32 = Le32(b, at + 16);
    e.compressed_size = Le32(b, at + 20);
    e.size = Le32(b, at + 24);
    const uint16_t name_len = Le16(b, at + 28);
    const uint16_t extra_len = Le16(b, at + 30);
    const uint16_t comment_len = Le16(b, at + 32);
    e.local_header_offset = Le32(b, at + 42);
    if (at + kCentralDirHeaderSize + name_len > eocd) return bad("entry name past the directory");
    e.name = b.substr(at + kCentralDirHeaderSize, name_len);
    if (flags & 1u) return bad(absl::StrCat(e.name, ": encrypted entries are not supported"));
    if (e.compressed_size == 0xFFFFFFFFu || e.size == 0xFFFFFFFFu) {
      return bad(absl::StrCat(e.name, ": ZIP64 entries are not supported"));
    }
    zip.entries_.push_back(std::move(e));
    at += kCentralDirHeaderSize + name_len + extra_len + comment_len;
  }
  return zip;
}

absl::StatusOr<std::string> ZipReader::Read(const std::string& name) const {
  const auto it = std::find_if(entries_.begin(), entries_.end(),
                               [&](const Entry& e) { return e.name == name; });
  if (it == entries_.end()) {
    std::vector<std::string> names;
    for (const Entry& e : entries_) names.push_back(e.name);
    return absl::NotFoundError(
        absl::StrCat(label_, ": no entry '", name, "' (have ", absl::StrJoin(names, ", "), ")"));
  }
  const Entry& e = *it;
  const std::string where = absl::StrCat(label_, ": entry '", name, "': ");
  const std::string& b = bytes_;
  const uint64_t lh = e.local_header_offset;
  if (lh + kLocalHeaderSize > b.size() || Le32(b, lh) != kLocalHeaderSignature) {
    return absl::DataLossError(absl::StrCat(where, "local header is damaged"));
  }
  const uint64_t data_at = lh + kLocalHeaderSize + Le16(b, lh + 26) + Le16(b, lh + 28);
  if (data_at + e.compressed_size > b.size()) {
    return absl::DataLossError(absl::StrCat(where, "truncated"));
  }
  std::string out;
  if (e.method == 0) {
    out = b.substr(data_at, e.compressed_size);
  } else if (e.method == 8) {
    out.resize(e.size);
    z_stream zs{};
    if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) {
      return absl::InternalError(absl::StrCat(where, "zlib inflateInit2 failed"));
    }
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(b.data() + data_at));
    zs.avail_in = static_cast<uInt>(e.compressed_size);
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    const int rc = inflate(&zs, Z_FINISH);
    const uint64_t produced = zs.total_out;
    inflateEnd(&zs);
    if (rc != Z_STREAM_END || produced != e.size) {
      return absl::DataLossError(absl::StrCat(where, "inflate failed (zlib code ", rc,
                                              ", produced ", produced, " of ", e.size, " bytes)"));
    }
  } else {
    return absl::UnimplementedError(absl::StrCat(where, "compression method ", e.method,
                                                 " is not supported (only stored and deflated)"));
  }
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(out.data()), static_cast<uInt>(out.size())));
  if (crc != e.crc32) return absl::DataLossError(absl::StrCat(where, "CRC-32 does not match"));
  return out;
}

}  // namespace pf
