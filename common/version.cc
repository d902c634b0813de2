#include "common/version.h"

namespace pf {

const char* SoftwareVersion() { return PF_SOFTWARE_VERSION; }

}  // namespace pf
