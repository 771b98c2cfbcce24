// SPDX-License-Identifier: BSD-3-Clause
// The umbrella header compiles on its own and names every public header of the source tree.
#include "plumb/plumb.hpp"
#include "test_data.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace {

TEST(UmbrellaTest, ListsEveryPublicHeader) {
  namespace fs = std::filesystem;
  const fs::path include_dir = fs::path(plumb::test::source_dir()) / "include";
  std::ifstream in(include_dir / "plumb" / "plumb.hpp");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  int num_headers = 0;
  for (const auto& entry : fs::recursive_directory_iterator(include_dir / "plumb")) {
    if (!entry.is_regular_file() || entry.path().extension() != ".hpp") continue;
    const std::string rel = fs::relative(entry.path(), include_dir).generic_string();
    if (rel == "plumb/plumb.hpp" || rel.find("/impl/") != std::string::npos) continue;
    ++num_headers;
    EXPECT_NE(text.str().find("#include \"" + rel + "\""), std::string::npos)
        << rel << " is missing from plumb/plumb.hpp";
  }
  EXPECT_GT(num_headers, 20);
}

TEST(UmbrellaTest, VersionMatchesHeader) { EXPECT_STREQ(plumb::version(), PLUMB_VERSION_STRING); }

}  // namespace
