// SPDX-License-Identifier: BSD-3-Clause
// The `plumb` command line. Each subcommand lives in its own file `<name>_command.cpp` that
// registers itself with PLUMB_CLI_COMMAND (registry.hpp); it does its work in its CLI11 callback.
//
// Exit codes, one scheme for every subcommand:
//   0    success (also --help, --version);
//   1    the subcommand could not do its work: an input is unusable (plumb::Error; the one stderr
//        line `plumb: error: MESSAGE` names the file and line, or the option), or an output could
//        not be written;
//   3    the job ran to the end and wrote its outputs, but its result failed (cli::JobFailed, see
//        cli_support.hpp): e.g. `register` whose status is not ok, `scan2d` where no scan matched.
//        stdout holds the result as usual, stderr one line `plumb: failed: MESSAGE` with the status;
//   >= 100 usage errors found by CLI11 (unknown option, value failing its check, missing argument),
//        with CLI11's own codes (105 for a value failing its check; the message names the option).
// (2 is left unused: shells and some tools read it as "misuse", which CLI11's codes already cover.)

#include <algorithm>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "plumb/core/allocator.hpp"
#include "plumb/core/error.hpp"
#include "plumb/version.hpp"
#include "cli_support.hpp"
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
  // Every subcommand streams frames whose buffers are freed and made again each frame: keep the
  // freed memory for the next frame instead of faulting it in again (core/allocator.hpp).
  plumb::keep_freed_memory();
  CLI::App app{"plumb: BIM-anchored LiDAR odometry tools", "plumb"};
  app.set_version_flag("--version", std::string("plumb ") + PLUMB_VERSION_STRING,
                       "Print the version and exit");
  app.require_subcommand(1);
  app.footer(
      "Exit codes: 0 ok; 1 unusable input or unwritable output (stderr names it); 3 the job ran and\n"
      "wrote its outputs but its result failed (stderr says why); >= 100 usage errors (CLI11).");

  plumb::cli::register_all_commands(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const plumb::cli::JobFailed& e) {
    std::cerr << "plumb: failed: " << e.what() << '\n';
    return plumb::cli::kExitJobFailed;
  } catch (const plumb::Error& e) {
    std::cerr << "plumb: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "plumb: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
