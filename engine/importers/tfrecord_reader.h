// Streaming reader of TFRecord files (the container of Waymo Open Dataset
// segments). Each record is framed as
//   uint64 length | uint32 masked CRC-32C of the 8 length bytes |
//   length bytes of payload | uint32 masked CRC-32C of the payload,
// all little-endian. Both CRCs are verified; a record is read only when asked
// for, so a segment of any size needs memory for one record at a time.
//
//   ASSIGN_OR_RETURN(auto reader, TfRecordReader::Open(path));
//   std::string record;
//   while (true) {
//     ASSIGN_OR_RETURN(bool more, reader->Next(&record));
//     if (!more) break;
//     ...
//   }
#ifndef POINTFORWARD_ENGINE_IMPORTERS_TFRECORD_READER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_TFRECORD_READER_H_

#include <cstdint>
#include <fstream>
#include <memory>
#include <string>

#include "absl/status/statusor.h"

namespace pf {

class TfRecordReader {
 public:
  // Opens `path`; NOT_FOUND when it cannot be opened.
  static absl::StatusOr<std::unique_ptr<TfRecordReader>> Open(const std::string& path);

  // Reads the next record's payload into `*record`. Returns false at a clean
  // end of file. DATA_LOSS, naming the file, the record index and its byte
  // offset, when the file ends inside a record ("truncated") or a CRC does not
  // match ("corrupt"); after an error the reader stays at the bad record.
  absl::StatusOr<bool> Next(std::string* record);

  // Index and byte offset of the record that Next() reads next.
  int64_t record_index() const { return index_; }
  uint64_t offset() const { return offset_; }

 private:
  TfRecordReader(std::string path, uint64_t file_size);

  std::string path_;
  std::ifstream in_;
  uint64_t file_size_ = 0;
  uint64_t offset_ = 0;
  int64_t index_ = 0;
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_TFRECORD_READER_H_
