// libFuzzer target: the TFRecord reader over arbitrary bytes. The reader
// takes a path, so each input is written to one temporary file per process
// and every record is read until the end or the first error.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>

#include "engine/importers/tfrecord_reader.h"
#include "fuzz/fuzz_temp_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const pf::FuzzTempFile file("tfrecord");
  file.Write(data, size);
  absl::StatusOr<std::unique_ptr<pf::TfRecordReader>> reader =
      pf::TfRecordReader::Open(file.path());
  if (!reader.ok()) abort();  // The file was just written: opening must work.
  std::string record;
  // Each successful Next() consumes at least 16 bytes, so this ends.
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&record);
    if (!more.ok() || !*more) break;
  }
  return 0;
}
