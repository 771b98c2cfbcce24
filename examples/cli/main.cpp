// SPDX-License-Identifier: BSD-3-Clause
// The `plumb` command line. Each subcommand lives in its own file `<name>_command.cpp` and is
// registered here with one call; the subcommand does its work in its CLI11 callback.
//
// Exit codes: 0 success; 1 an input could not be used (plumb::Error, message names the file and
// line); CLI11's own codes (>= 100) for usage errors such as an unknown option.

#include <exception>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>

#include "plumb/core/error.hpp"
#include "plumb/version.hpp"

namespace plumb::cli {
// One declaration per subcommand file.
void register_eval_command(CLI::App& app);
void register_calibrate_command(CLI::App& app);
void register_ifc_commands(CLI::App& app);
void register_scan2d_command(CLI::App& app);
}  // namespace plumb::cli

int main(int argc, char** argv) {
  CLI::App app{"plumb: BIM-anchored LiDAR odometry tools", "plumb"};
  app.set_version_flag("--version", std::string("plumb ") + PLUMB_VERSION_STRING,
                       "Print the version and exit");
  app.require_subcommand(1);

  plumb::cli::register_eval_command(app);
  plumb::cli::register_calibrate_command(app);
  plumb::cli::register_ifc_commands(app);
  plumb::cli::register_scan2d_command(app);

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
