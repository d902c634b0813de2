// .npy: magic, version, header length, a Python-dict header, raw data.
#include "engine/importers/npy.h"

#include <cstring>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace pf {
namespace {

// Returns the text after `'key':` up to the end of its value in the header
// dict (a quoted string, a bool, or a parenthesised tuple).
std::string HeaderValue(const std::string& header, const std::string& key) {
  const std::string needle = "'" + key + "':";
  size_t at = header.find(needle);
  if (at == std::string::npos) return "";
  at += needle.size();
  while (at < header.size() && header[at] == ' ') ++at;
  if (at >= header.size()) return "";
  size_t end;
  if (header[at] == '(') {
    end = header.find(')', at);
    return end == std::string::npos ? "" : header.substr(at + 1, end - at - 1);
  }
  if (header[at] == '\'') {
    end = header.find('\'', at + 1);
    return end == std::string::npos ? "" : header.substr(at + 1, end - at - 1);
  }
  end = header.find_first_of(",}", at);
  return header.substr(at, end == std::string::npos ? std::string::npos : end - at);
}

}  // namespace

absl::StatusOr<NpyArray> ParseNpy(std::string_view bytes, const std::string& label) {
  auto bad = [&](const std::string& what) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": not a supported .npy array: ", what));
  };
  if (bytes.size() < 10 || bytes.substr(0, 6) != std::string_view("\x93NUMPY", 6)) {
    return bad("missing the \\x93NUMPY magic");
  }
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len, header_at;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) |
                 (static_cast<size_t>(static_cast<unsigned char>(bytes[9])) << 8);
    header_at = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) return bad("truncated header");
    header_len = 0;
    for (int i = 3; i >= 0; --i)
      header_len = (header_len << 8) | static_cast<unsigned char>(bytes[8 + i]);
    header_at = 12;
  } else {
    return bad(absl::StrCat("format version ", major, " is not supported"));
  }
  if (header_at + header_len > bytes.size()) return bad("truncated header");
  const std::string header(bytes.substr(header_at, header_len));
  const std::string descr = HeaderValue(header, "descr");
  size_t item_size;
  if (descr == "<f8") {
    item_size = 8;
  } else if (descr == "<f4") {
    item_size = 4;
  } else {
    return bad(absl::StrCat("dtype '", descr, "' (only '<f4' and '<f8' are read)"));
  }
  if (absl::StripAsciiWhitespace(HeaderValue(header, "fortran_order")) != "False") {
    return bad("Fortran-ordered arrays are not supported");
  }
  NpyArray array;
  int64_t count = 1;
  for (absl::string_view dim : absl::StrSplit(HeaderValue(header, "shape"), ',')) {
    dim = absl::StripAsciiWhitespace(dim);
    if (dim.empty()) continue;
    int64_t n;
    if (!absl::SimpleAtoi(dim, &n) || n < 0)
      return bad(absl::StrCat("bad shape entry '", std::string(dim), "'"));
    array.shape.push_back(n);
    count *= n;
  }
  const std::string_view payload = bytes.substr(header_at + header_len);
  if (payload.size() != static_cast<size_t>(count) * item_size) {
    return bad(absl::StrCat("shape needs ", count * item_size, " data bytes, the file has ",
                            payload.size()));
  }
  array.data.resize(count);
  for (int64_t i = 0; i < count; ++i) {
    if (item_size == 8) {
      std::memcpy(&array.data[i], payload.data() + i * 8, 8);
    } else {
      float f;
      std::memcpy(&f, payload.data() + i * 4, 4);
      array.data[i] = f;
    }
  }
  return array;
}

}  // namespace pf
