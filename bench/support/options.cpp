// bench/support/options.hpp, the one file of the benchmarks that compiles CLI11.
#include "options.hpp"

#include <CLI/CLI.hpp>
#include <cstdint>

namespace duolod::bench {

Options::Options(const std::string& description) : app_(std::make_unique<CLI::App>(description)) {}
Options::~Options() = default;

template <class T>
Options& Options::add(const std::string& name, T& value, const std::string& help) {
  last_ = app_->add_option(name, value, help)->capture_default_str();
  return *this;
}

template Options& Options::add(const std::string&, int&, const std::string&);
template Options& Options::add(const std::string&, unsigned&, const std::string&);
template Options& Options::add(const std::string&, int64_t&, const std::string&);
template Options& Options::add(const std::string&, uint64_t&, const std::string&);
template Options& Options::add(const std::string&, float&, const std::string&);
template Options& Options::add(const std::string&, double&, const std::string&);
template Options& Options::add(const std::string&, std::string&, const std::string&);
template Options& Options::add(const std::string&, std::vector<int>&, const std::string&);
template Options& Options::add(const std::string&, std::vector<double>&, const std::string&);
template Options& Options::add(const std::string&, std::vector<std::string>&, const std::string&);

Options& Options::flag(const std::string& name, bool& value, const std::string& help) {
  last_ = app_->add_flag(name, value, help);
  return *this;
}

Options& Options::choices(const std::vector<std::string>& allowed) {
  if (last_) last_->check(CLI::IsMember(allowed));
  return *this;
}

Options& Options::nonNegative() {
  if (last_) last_->check(CLI::NonNegativeNumber);
  return *this;
}

std::optional<int> Options::parse(int argc, char** argv) {
  try {
    app_->parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app_->exit(e);
  }
  return std::nullopt;
}

}  // namespace duolod::bench
