// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Self-registration of `plumb` subcommands: a subcommand file ends with
//   PLUMB_CLI_COMMAND(name, register_function);
// and main.cpp adds every registered subcommand, in name order, without knowing the files.

#include <CLI/CLI.hpp>

namespace plumb::cli {

/// Adds a subcommand (or several) to the app.
using RegisterFn = void (*)(CLI::App&);

/// Records `fn` under `name`; called from a static initializer in each subcommand file.
/// @return a dummy value so the call can initialise a namespace-scope constant
int add_command(const char* name, RegisterFn fn);

/// Calls every recorded function on `app`, in name order.
void register_all_commands(CLI::App& app);

}  // namespace plumb::cli

#define PLUMB_CLI_COMMAND(name, fn) \
  [[maybe_unused]] static const int plumb_cli_registered_##name = ::plumb::cli::add_command(#name, fn)
