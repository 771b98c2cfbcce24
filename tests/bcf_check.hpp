// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Checking a BCF archive with outside tools, for the tests of every writer of one: Python's
/// zipfile extracts it and xmllint validates each XML file against buildingSMART's BCF 2.1 schema
/// of its kind (PLUMB_DATA_DIR/bcf/2.1).

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "test_data.hpp"

namespace plumb::test {

/// @brief Path of a program on PATH, empty when there is none.
inline std::string program_path(const std::string& name) {
  const RunResult r = run_program("/bin/sh", "-c 'command -v " + name + "'");
  if (r.exit_code != 0) return {};
  std::string path = r.out;
  while (!path.empty() && (path.back() == '\n' || path.back() == '\r')) path.pop_back();
  return path;
}

/// @brief The directory of the BCF 2.1 schemas.
inline std::string bcf_schema_dir() { return test::data_dir() + "/bcf/2.1"; }

/// @brief Why the archives cannot be checked here (python3, xmllint or the schemas missing), empty
/// when they can: the caller skips with it.
inline std::string bcf_check_unavailable() {
  if (program_path("python3").empty()) return "python3 not found";
  if (program_path("xmllint").empty()) return "xmllint not found";
  if (!file_exists(bcf_schema_dir() + "/markup.xsd")) return "BCF schemas not found in " + bcf_schema_dir();
  return {};
}

/// @brief Extract the archive at `bcf_path` into `dir` (Python's zipfile, which checks the CRCs).
inline void extract_bcf(const std::string& bcf_path, const std::string& dir) {
  const RunResult x = run_program(program_path("python3"),
                                  "-c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' '" +
                                      bcf_path + "' '" + dir + "'");
  ASSERT_EQ(x.exit_code, 0) << bcf_path << ": " << x.err;
}

/// @brief Validate every file under `dir` (an extracted archive) against the schema of its kind
/// (bcf.version, project.bcfp, */markup.bcf, */viewpoint.bcfv), a failure per invalid or unknown
/// file. @return the number of files validated
inline std::size_t expect_valid_bcf_files(const std::string& dir) {
  const std::string xmllint = program_path("xmllint");
  std::size_t validated = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string name = e.path().filename().string();
    const std::string xsd = name == "bcf.version"      ? "version.xsd"
                            : name == "project.bcfp"   ? "project.xsd"
                            : name == "markup.bcf"     ? "markup.xsd"
                            : name == "viewpoint.bcfv" ? "visinfo.xsd"
                                                       : "";
    if (xsd.empty()) {
      ADD_FAILURE() << "unexpected file " << e.path();
      continue;
    }
    const RunResult v =
        run_program(xmllint, "--noout --schema '" + bcf_schema_dir() + "/" + xsd + "' '" + e.path().string() + "'");
    EXPECT_EQ(v.exit_code, 0) << e.path() << ": " << v.err;
    ++validated;
  }
  return validated;
}

}  // namespace plumb::test
