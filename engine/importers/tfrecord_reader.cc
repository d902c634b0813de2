// TFRecord framing: read, check both CRCs, report where it went wrong.
#include "engine/importers/tfrecord_reader.h"

#include <filesystem>
#include <system_error>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "engine/importers/crc32c.h"

namespace pf {
namespace {

uint64_t DecodeLe64(const unsigned char* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

uint32_t DecodeLe32(const unsigned char* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

}  // namespace

TfRecordReader::TfRecordReader(std::string path, uint64_t file_size)
    : path_(std::move(path)), in_(path_, std::ios::binary), file_size_(file_size) {}

absl::StatusOr<std::unique_ptr<TfRecordReader>> TfRecordReader::Open(const std::string& path) {
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return absl::NotFoundError(absl::StrCat(path, ": cannot open (", ec.message(), ")"));
  std::unique_ptr<TfRecordReader> reader(new TfRecordReader(path, size));
  if (!reader->in_) return absl::NotFoundError(absl::StrCat(path, ": cannot open for reading"));
  return reader;
}

absl::StatusOr<bool> TfRecordReader::Next(std::string* record) {
  if (offset_ == file_size_) return false;
  const std::string where =
      absl::StrCat(path_, ": record ", index_, " at byte offset ", offset_, ": ");
  constexpr uint64_t kHeaderSize = 12, kFooterSize = 4;
  if (file_size_ - offset_ < kHeaderSize) {
    return absl::DataLossError(absl::StrCat(where, "truncated: ", file_size_ - offset_,
                                            " bytes left, a record header needs 12"));
  }
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset_));
  unsigned char header[kHeaderSize];
  if (!in_.read(reinterpret_cast<char*>(header), kHeaderSize)) {
    return absl::DataLossError(absl::StrCat(where, "read error in the record header"));
  }
  const uint64_t length = DecodeLe64(header);
  const uint32_t length_crc = DecodeLe32(header + 8);
  if (MaskCrc32c(Crc32cExtend(0, header, 8)) != length_crc) {
    return absl::DataLossError(
        absl::StrCat(where, "corrupt: CRC of the length field does not match"));
  }
  const uint64_t available = file_size_ - offset_ - kHeaderSize;
  if (length > available || available - length < kFooterSize) {
    return absl::DataLossError(absl::StrCat(where, "truncated: the record declares ", length,
                                            " payload bytes + 4 CRC bytes, the file has ",
                                            available, " left"));
  }
  record->resize(length);
  unsigned char footer[kFooterSize];
  if (!in_.read(record->data(), static_cast<std::streamsize>(length)) ||
      !in_.read(reinterpret_cast<char*>(footer), kFooterSize)) {
    return absl::DataLossError(absl::StrCat(where, "read error in the payload"));
  }
  if (MaskCrc32c(Crc32cExtend(0, record->data(), record->size())) != DecodeLe32(footer)) {
    return absl::DataLossError(
        absl::StrCat(where, "corrupt: CRC of the ", length, "-byte payload does not match"));
  }
  offset_ += kHeaderSize + length + kFooterSize;
  ++index_;
  return true;
}

}  // namespace pf
