// SPDX-License-Identifier: BSD-3-Clause
// The BIM cloud a LiDAR is registered to: the demo office's structure, without what a LiDAR does not see.
#include "plumb/bim/bim_cloud.hpp"

#include <algorithm>
#include <cctype>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "test_data.hpp"

namespace {

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  return s;
}

TEST(BimCloudTest, SamplesTheStructureWithoutDoorsWindowsSpacesOrFurniture) {
  // With the spaces meshed, so that leaving them out is the cloud's doing.
  const plumb::bim::BimMesh mesh =
      plumb::bim::build_mesh(plumb::bim::read_ifc(plumb::test::source_dir() + "/examples/data/demo_office.ifc"),
                             plumb::bim::mesh_settings_with_spaces());
  const plumb::PointCloud cloud = plumb::bim::sample_bim_cloud(mesh, 0.2);
  ASSERT_GT(cloud.size(), 1000u);
  ASSERT_TRUE(cloud.has_normals());
  ASSERT_EQ(cloud.labels.size(), cloud.size());
  const std::set<std::string> invisible = {"IFCDOOR", "IFCWINDOW", "IFCSPACE", "IFCOPENINGELEMENT",
                                           "IFCFURNISHINGELEMENT", "IFCFURNITURE"};
  std::set<std::string> sampled;
  for (const auto label : cloud.labels) sampled.insert(upper(mesh.elements.at(static_cast<std::size_t>(label)).type));
  for (const std::string& type : sampled) EXPECT_EQ(invisible.count(type), 0u) << type;
  EXPECT_TRUE(sampled.count("IFCWALL") || sampled.count("IFCWALLSTANDARDCASE"));
  EXPECT_TRUE(sampled.count("IFCSLAB"));
  // The model has what the cloud leaves out.
  std::set<std::string> modelled;
  for (const plumb::bim::BimElement& e : mesh.elements) {
    if (e.num_triangles > 0) modelled.insert(upper(e.type));
  }
  EXPECT_TRUE(modelled.count("IFCDOOR") && modelled.count("IFCWINDOW") && modelled.count("IFCSPACE"));
  // The same as sampling the visible types by hand, point for point.
  plumb::bim::SurfaceSampleSettings visible;
  visible.spacing = 0.2;
  for (const plumb::bim::BimElement& e : mesh.elements) {
    if (e.num_triangles > 0 && !invisible.count(upper(e.type))) visible.filter.types.push_back(e.type);
  }
  const plumb::PointCloud by_hand = plumb::bim::sample_surface(mesh, visible);
  ASSERT_EQ(by_hand.size(), cloud.size());
  EXPECT_EQ(by_hand.points, cloud.points);
  EXPECT_THROW(plumb::bim::sample_bim_cloud(mesh, 0.0), plumb::Error);
}

}  // namespace
