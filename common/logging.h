// Logging setup. Every binary calls InitLogging() once; libraries log through
// spdlog's default logger (stderr). Lines of one job carry its id: use
// JobLogger(job_id) to get a logger whose lines are prefixed with it.
#ifndef POINTFORWARD_COMMON_LOGGING_H_
#define POINTFORWARD_COMMON_LOGGING_H_

#include <spdlog/spdlog.h>

#include <memory>
#include <string_view>

namespace pf {

// Sets the default logger to stderr with `level` ("trace", "debug", "info",
// "warn", "error", "off"); an unknown name means "info". Also honours the
// PF_LOG_LEVEL environment variable when `level` is empty.
void InitLogging(std::string_view level = "");

// Returns a logger that writes to the same sink as the default one, with
// `[job_id]` in every line.
std::shared_ptr<spdlog::logger> JobLogger(std::string_view job_id);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_LOGGING_H_
