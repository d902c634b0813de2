// A per-process temporary file for fuzz targets whose code under test reads
// a path: each input overwrites it; it is removed when the process exits
// normally.
#ifndef POINTFORWARD_FUZZ_FUZZ_TEMP_FILE_H_
#define POINTFORWARD_FUZZ_FUZZ_TEMP_FILE_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace pf {

class FuzzTempFile {
 public:
  // Creates "$TMPDIR/pf_fuzz_<pid>.<suffix>" (TMPDIR defaults to /tmp).
  explicit FuzzTempFile(const std::string& suffix) {
    const char* tmp = std::getenv("TMPDIR");
    path_ = std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/pf_fuzz_" +
            std::to_string(getpid()) + "." + suffix;
  }
  ~FuzzTempFile() { std::remove(path_.c_str()); }

  const std::string& path() const { return path_; }

  // Replaces the file's content with `size` bytes at `data`; aborts when the
  // file cannot be written (a harness failure, not a finding).
  void Write(const uint8_t* data, size_t size) const {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    if (f == nullptr) std::abort();
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    if (std::fclose(f) != 0) std::abort();
  }

 private:
  std::string path_;
};

}  // namespace pf

#endif  // POINTFORWARD_FUZZ_FUZZ_TEMP_FILE_H_
