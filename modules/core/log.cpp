module;
#include <cstdlib>
#include <string>
#include <string_view>
#include <spdlog/spdlog.h>
#include <spdlog/sinks/stdout_color_sinks.h>
module weft.core;

namespace weft::log {
namespace {
spdlog::logger& logger() {
  static std::shared_ptr<spdlog::logger> instance = [] {
    auto l = spdlog::stderr_color_mt("weft");
    l->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
    const char* level = std::getenv("WEFT_LOG");
    l->set_level(level ? spdlog::level::from_str(level) : spdlog::level::info);
    return l;
  }();
  return *instance;
}
}  // namespace

void info(std::string_view m) { logger().info("{}", m); }
void warn(std::string_view m) { logger().warn("{}", m); }
void error(std::string_view m) { logger().error("{}", m); }
void debug(std::string_view m) { logger().debug("{}", m); }
void set_level(std::string_view level) { logger().set_level(spdlog::level::from_str(std::string(level))); }
}  // namespace weft::log
