// A benchmark's command line: CLI11 behind a narrow interface compiled once for all benchmarks.
// CLI11 is header-only, and compiling its header took ~14 s of each benchmark's ~25 s (nine
// benchmarks: ~2 CPU-minutes of every build); here it is compiled in one file.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace duolod::bench {

class Options {
 public:
  explicit Options(const std::string& description);
  ~Options();
  Options(const Options&) = delete;
  Options& operator=(const Options&) = delete;

  // An option ("--name") or a positional argument ("name") that sets `value`; --help shows its
  // current value as the default. Defined for int, unsigned, 64-bit integers, float, double,
  // std::string and vectors of int, double and std::string.
  template <class T>
  Options& add(const std::string& name, T& value, const std::string& help = "");
  // A flag that sets `value` to true; a name "!--no-x" sets it to false.
  Options& flag(const std::string& name, bool& value, const std::string& help = "");
  // Restrictions on the option added last.
  Options& choices(const std::vector<std::string>& allowed);
  Options& nonNegative();

  // Parses the command line. An exit code when the program should end now (0 after --help;
  // CLI11's non-zero code after a parse error, its message printed), else nothing.
  std::optional<int> parse(int argc, char** argv);

 private:
  std::unique_ptr<CLI::App> app_;
  CLI::Option* last_ = nullptr;
};

}  // namespace duolod::bench
