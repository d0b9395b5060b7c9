// Process-wide log sink. The library reports through it; the CLI decides where text goes.
#include <cstdio>
#include <mutex>

#include "duolod/core.hpp"

namespace duolod::core {
namespace {

std::mutex g_log_mutex;
LogLevel g_minimum = LogLevel::kInfo;
LogSink g_sink = [](LogLevel level, std::string_view message) {
  static const char* kNames[] = {"debug", "info", "warning", "error"};
  std::fprintf(stderr, "duolod %s: %.*s\n", kNames[static_cast<int>(level)],
               static_cast<int>(message.size()), message.data());
};

}  // namespace

void setLogSink(LogSink sink) {
  std::lock_guard lock(g_log_mutex);
  g_sink = std::move(sink);
}

void setLogLevel(LogLevel minimum) {
  std::lock_guard lock(g_log_mutex);
  g_minimum = minimum;
}

void log(LogLevel level, std::string_view message) {
  std::lock_guard lock(g_log_mutex);
  if (level < g_minimum || !g_sink) return;
  g_sink(level, message);
}

}  // namespace duolod::core
