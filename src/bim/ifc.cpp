// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/ifc.hpp"

#include <cmath>
#include <unordered_map>

#include "plumb/core/error.hpp"

namespace plumb::bim {

namespace {

double si_prefix(const std::string& p) {
  static const std::unordered_map<std::string, double> kPrefix = {
      {"EXA", 1e18},  {"PETA", 1e15}, {"TERA", 1e12}, {"GIGA", 1e9},   {"MEGA", 1e6},   {"KILO", 1e3},
      {"HECTO", 1e2}, {"DECA", 1e1},  {"DECI", 1e-1}, {"CENTI", 1e-2}, {"MILLI", 1e-3}, {"MICRO", 1e-6},
      {"NANO", 1e-9}, {"PICO", 1e-12}, {"FEMTO", 1e-15}, {"ATTO", 1e-18}};
  auto it = kPrefix.find(p);
  return it == kPrefix.end() ? 1.0 : it->second;
}

struct UnitValue {
  std::string type;  // LENGTHUNIT, PLANEANGLEUNIT...
  double factor = 1.0;
  std::string name;
  bool ok = false;
};

UnitValue unit_of(const StepFile& f, std::uint32_t id, int depth, std::vector<std::string>* warnings) {
  UnitValue u;
  if (depth > 8 || !f.contains(id)) return u;
  const std::string& t = f.type_of(id);
  const auto a = f.args(id);
  if (t == "IFCSIUNIT" && a.size() >= 4) {
    u.type = a[1].text;
    const std::string prefix = a[2].kind == StepValue::Kind::kEnum ? a[2].text : "";
    u.factor = si_prefix(prefix);
    u.name = prefix.empty() ? a[3].text : prefix + " " + a[3].text;
    u.ok = true;
  } else if ((t == "IFCCONVERSIONBASEDUNIT" || t == "IFCCONVERSIONBASEDUNITWITHOFFSET") && a.size() >= 4) {
    u.type = a[1].text;
    u.name = a[2].text;
    if (a[3].is_ref() && f.type_of(a[3].ref) == "IFCMEASUREWITHUNIT") {
      const auto m = f.args(a[3].ref);
      if (m.size() >= 2) {
        const double value = m[0].number();
        double base = 1.0;
        if (m[1].is_ref()) {
          const UnitValue b = unit_of(f, m[1].ref, depth + 1, warnings);
          if (b.ok) base = b.factor;
        }
        if (std::isfinite(value) && value > 0.0) {
          u.factor = value * base;
          u.ok = true;
        }
      }
    }
    if (!u.ok && warnings) warnings->push_back(f.where(id) + ": " + t + " #" + std::to_string(id) + ": unreadable conversion factor");
  }
  return u;
}

}  // namespace

IfcUnits read_ifc_units(const StepFile& step, std::vector<std::string>* warnings) {
  IfcUnits units;
  bool have_length = false;
  for (std::uint32_t ua : step.ids_of_type("IFCUNITASSIGNMENT")) {
    const auto a = step.args(ua);
    if (a.empty() || !a[0].is_list()) continue;
    for (const auto& item : a[0].items) {
      if (!item.is_ref()) continue;
      const UnitValue u = unit_of(step, item.ref, 0, warnings);
      if (!u.ok) continue;
      if (u.type == "LENGTHUNIT") {
        units.length_to_m = u.factor;
        units.length_name = u.name;
        have_length = true;
      } else if (u.type == "PLANEANGLEUNIT") {
        units.angle_to_rad = u.factor;
        units.angle_name = u.name;
      }
    }
  }
  if (!have_length && warnings) warnings->push_back(step.name() + ": no length unit in IfcUnitAssignment, assuming metre");
  return units;
}

namespace {
IfcModel finish_model(StepFile step) {
  PLUMB_CHECK(step.schema() != StepSchema::kUnknown,
              step.name() << ":1: unsupported schema '" << step.schema_name() << "' (expected IFC2X3, IFC4 or IFC4X3)");
  IfcModel m{std::move(step), {}, {}};
  m.units = read_ifc_units(m.step, &m.warnings);
  PLUMB_CHECK(std::isfinite(m.units.length_to_m) && m.units.length_to_m > 1e-12 && m.units.length_to_m < 1e12,
              m.step.name() << ": absurd length unit factor " << m.units.length_to_m);
  return m;
}
}  // namespace

IfcModel read_ifc(const std::string& path) { return finish_model(StepFile::read(path)); }

IfcModel parse_ifc(std::string buffer, const std::string& name) {
  return finish_model(StepFile::parse(std::move(buffer), name));
}

std::string ifc_type_display_name(const std::string& upper) {
  static const char* const kNames[] = {
      "IfcWall", "IfcWallStandardCase", "IfcWallElementedCase", "IfcSlab", "IfcSlabStandardCase",
      "IfcSlabElementedCase", "IfcRoof", "IfcBeam", "IfcBeamStandardCase", "IfcColumn",
      "IfcColumnStandardCase", "IfcDoor", "IfcDoorStandardCase", "IfcWindow", "IfcWindowStandardCase",
      "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight", "IfcRailing", "IfcMember",
      "IfcMemberStandardCase", "IfcPlate", "IfcPlateStandardCase", "IfcCovering", "IfcCurtainWall",
      "IfcFooting", "IfcPile", "IfcBuildingElementProxy", "IfcBuildingElementPart", "IfcChimney",
      "IfcShadingDevice", "IfcFurnishingElement", "IfcFurniture", "IfcSystemFurnitureElement",
      "IfcFlowTerminal", "IfcFlowSegment", "IfcFlowFitting", "IfcSpace", "IfcSite", "IfcBuilding",
      "IfcBuildingStorey", "IfcOpeningElement", "IfcOpeningStandardCase", "IfcElementAssembly",
      "IfcTransportElement", "IfcDiscreteAccessory", "IfcMechanicalFastener", "IfcFastener",
      "IfcVirtualElement", "IfcAnnotation", "IfcProxy", "IfcDistributionElement", "IfcEnergyConversionDevice",
      "IfcFlowController", "IfcFlowMovingDevice", "IfcFlowStorageDevice", "IfcFlowTreatmentDevice",
      "IfcSanitaryTerminal", "IfcLightFixture", "IfcDuctSegment", "IfcPipeSegment", "IfcReinforcingBar",
      "IfcGeographicElement", "IfcCivilElement"};
  for (const char* n : kNames) {
    const std::string s(n);
    if (s.size() != upper.size()) continue;
    bool same = true;
    for (std::size_t i = 0; i < s.size() && same; ++i) {
      char c = s[i];
      if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
      same = c == upper[i];
    }
    if (same) return s;
  }
  std::string out = "Ifc";
  for (std::size_t i = 3; i < upper.size(); ++i) {
    char c = upper[i];
    if (i > 3 && c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    out.push_back(c);
  }
  return out;
}

}  // namespace plumb::bim
