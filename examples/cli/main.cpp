// SPDX-License-Identifier: BSD-3-Clause
// The `plumb` command line. Each subcommand lives in its own file `<name>_command.cpp` that
// registers itself with PLUMB_CLI_COMMAND (registry.hpp); it does its work in its CLI11 callback.
//
// Exit codes: 0 success; 1 an input could not be used (plumb::Error, message names the file and
// line); CLI11's own codes (>= 100) for usage errors such as an unknown option.

#include <algorithm>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "plumb/core/error.hpp"
#include "plumb/version.hpp"
#include "registry.hpp"

namespace plumb::cli {

namespace {
struct Entry {
  std::string name;
  RegisterFn fn;
};
// Function-local static: safe to use from other files' static initializers.
std::vector<Entry>& registry() {
  static std::vector<Entry> entries;
  return entries;
}
}  // namespace

int add_command(const char* name, RegisterFn fn) {
  registry().push_back({name, fn});
  return 0;
}

void register_all_commands(CLI::App& app) {
  auto entries = registry();
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.name < b.name; });
  for (const Entry& e : entries) e.fn(app);
}

}  // namespace plumb::cli

int main(int argc, char** argv) {
  CLI::App app{"plumb: BIM-anchored LiDAR odometry tools", "plumb"};
  app.set_version_flag("--version", std::string("plumb ") + PLUMB_VERSION_STRING,
                       "Print the version and exit");
  app.require_subcommand(1);

  plumb::cli::register_all_commands(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const plumb::Error& e) {
    std::cerr << "plumb: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "plumb: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
