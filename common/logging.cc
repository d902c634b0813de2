// Logging setup on spdlog.
#include "common/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <cstdlib>
#include <string>

namespace pf {

void InitLogging(std::string_view level) {
  std::string name(level);
  if (name.empty()) {
    const char* env = std::getenv("PF_LOG_LEVEL");
    name = env != nullptr ? env : "info";
  }
  auto logger = spdlog::stderr_color_mt("pf");
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  spdlog::set_default_logger(logger);
  spdlog::level::level_enum parsed = spdlog::level::from_str(name);
  // from_str maps unknown names to "off"; only accept "off" when asked for.
  if (parsed == spdlog::level::off && name != "off") parsed = spdlog::level::info;
  spdlog::set_level(parsed);
}

std::shared_ptr<spdlog::logger> JobLogger(std::string_view job_id) {
  // A sink of its own: a pattern set on a logger is set on its sinks, and
  // sharing the default logger's sink would change that logger's lines too.
  auto base = spdlog::default_logger();
  auto logger = std::make_shared<spdlog::logger>(
      std::string(job_id), std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [%n] %v");
  logger->set_level(base->level());
  return logger;
}

}  // namespace pf
