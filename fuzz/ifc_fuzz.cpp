// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the STEP/IFC reader and the IFC mesher: any input must either parse or
// throw plumb::Error; a parsed model must mesh without crashing (problems become warnings).
// Seeds: fuzz/seeds/ifc/*.ifc.

#include <cstddef>
#include <cstdint>
#include <string>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 20)) return 0;
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const plumb::bim::IfcModel model = plumb::bim::parse_ifc(std::move(text), "fuzz.ifc");
    for (const auto& e : model.step.entities()) {
      try {
        (void)model.step.args(e);
      } catch (const plumb::Error&) {
      }
    }
    plumb::bim::BimMeshSettings settings;
    settings.circle_segments = 8;
    (void)plumb::bim::build_mesh(model, settings);
  } catch (const plumb::Error&) {
  }
  return 0;
}
