// The software version: CMake's project version, written into every output
// (EXR attributes, render manifests) and part of every scene cache key.
#ifndef POINTFORWARD_COMMON_VERSION_H_
#define POINTFORWARD_COMMON_VERSION_H_

namespace pf {

// "MAJOR.MINOR.PATCH", e.g. "0.11.0".
const char* SoftwareVersion();

}  // namespace pf

#endif  // POINTFORWARD_COMMON_VERSION_H_
