// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A small ISO 10303-21 (STEP physical file) writer for IFC4: entity ids, argument
/// encoding (strings with `''`, `\\` and `\X2\` escapes, reals that read back bit-exactly), IFC
/// GUIDs from a seed, the header section, and helpers for the geometry and units IFC files need.
///
/// The writer does not know the IFC schema: the caller passes each entity's type and its
/// arguments in schema order. What it guarantees is that the text it writes is well-formed STEP
/// that StepFile::parse() (and any conforming reader) decodes to the same values, and that the
/// same calls give a byte-identical file (no clock, no global state).

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "plumb/core/rng.hpp"
#include "plumb/core/types.hpp"

namespace plumb::bim {

/// @brief One argument of an entity instance, already encoded as STEP text.
///
/// Build values with the named factories; `StepArg::list({...})` nests them.
class StepArg {
 public:
  /// @brief `$`: an unset optional attribute.
  static StepArg null() { return StepArg("$"); }
  /// @brief `*`: an attribute re-declared as derived in a subtype.
  static StepArg derived() { return StepArg("*"); }
  /// @brief `#id`: a reference to an instance. @throws plumb::Error when id is 0.
  static StepArg ref(std::uint32_t id);
  /// @brief An INTEGER, e.g. `3`.
  static StepArg integer(std::int64_t value);
  /// @brief A REAL that reads back to the same double, e.g. `2.5`, `1.E-05`, `0.`.
  /// @throws plumb::Error for NaN or infinity (STEP has no spelling for them).
  static StepArg real(double value);
  /// @brief A STRING from UTF-8 text: `'` doubled, `\` doubled, anything outside printable
  /// ASCII as `\X2\hhhh\X0\` (`\X4\hhhhhhhh\X0\` beyond the basic multilingual plane).
  /// @throws plumb::Error when `utf8` is not valid UTF-8.
  static StepArg string(std::string_view utf8);
  /// @brief An ENUMERATION value `.NAME.`. @throws plumb::Error unless NAME is [A-Za-z0-9_]+.
  static StepArg enumeration(std::string_view name);
  /// @brief A BOOLEAN: `.T.` or `.F.`.
  static StepArg boolean(bool value) { return StepArg(value ? ".T." : ".F."); }
  /// @brief An aggregate `(a,b,...)`.
  static StepArg list(const std::vector<StepArg>& items);
  /// @brief A list of references `(#a,#b,...)`.
  static StepArg refs(const std::vector<std::uint32_t>& ids);
  /// @brief A list of reals `(x,y,...)`.
  static StepArg reals(const std::vector<double>& values);
  /// @brief A typed (select) value, e.g. `IFCLABEL('x')`. @throws plumb::Error on a bad type name.
  static StepArg typed(std::string_view type, const StepArg& value);

  /// @brief The encoded text, e.g. `'it''s'` or `(#1,#2)`.
  const std::string& text() const { return text_; }

 private:
  explicit StepArg(std::string text) : text_(std::move(text)) {}
  std::string text_;
};

/// @brief Encode a double as a STEP REAL (shortest text that reads back to the same value).
/// @throws plumb::Error for NaN or infinity.
std::string step_real(double value);

/// @brief Encode UTF-8 text as a STEP string literal, quotes included. @see StepArg::string
std::string step_string(std::string_view utf8);

/// @brief The 22-character IFC form of a 128-bit GUID (`hi` = the first 64 bits of the UUID).
///
/// IFC's compressed GUID: the 128 bits read as one number, written in base 64 with the alphabet
/// `0-9 A-Z a-z _ $`, most significant digit first; the first digit holds the top 2 bits only, so
/// it is one of `0123`.
std::string ifc_guid(std::uint64_t hi, std::uint64_t lo);

/// @brief Deterministic IFC GUIDs: random version-4 UUIDs drawn from plumb::Rng(seed).
class IfcGuidGenerator {
 public:
  explicit IfcGuidGenerator(std::uint64_t seed) : rng_(seed) {}
  /// @brief The next GUID (22 characters). Same seed -> same sequence.
  std::string next();

 private:
  Rng rng_;
};

/// @brief Settings of IfcWriter: the header section and the GUID seed.
struct IfcWriterSettings {
  std::string schema = "IFC4";                                  ///< FILE_SCHEMA identifier
  std::string description = "ViewDefinition [DesignTransferView]";  ///< FILE_DESCRIPTION text
  std::string file_name = "model.ifc";                          ///< FILE_NAME name (not a path)
  std::string time_stamp = "2026-01-01T00:00:00";  ///< FILE_NAME time stamp (fixed: same input, same bytes)
  std::string author = "plumb";                    ///< FILE_NAME author
  std::string organization = "plumb";              ///< FILE_NAME organization
  std::string preprocessor = "plumb IFC writer";   ///< FILE_NAME preprocessor_version
  std::string originating_system = "plumb";        ///< FILE_NAME originating_system
  std::uint64_t guid_seed = 1;                     ///< seed of the GUID sequence (new_guid())
};

/// @brief Builds an IFC (STEP) file in memory: entities get ids 1, 2, 3... in the order added.
///
/// @code
///   IfcWriter w;
///   const auto p = w.point({0, 0, 0});
///   const auto wcs = w.add("IFCAXIS2PLACEMENT3D", {StepArg::ref(p), StepArg::null(), StepArg::null()});
///   std::string text = w.str();
/// @endcode
/// @note Not thread safe; one writer per thread.
class IfcWriter {
 public:
  explicit IfcWriter(IfcWriterSettings settings = {});

  /// @brief Add an instance `#id=TYPE(args);` and return its id.
  /// @param type entity name, e.g. "IFCWALL" or "IfcWall" (written in upper case).
  /// @throws plumb::Error when the type name is empty or not [A-Za-z0-9_]+.
  std::uint32_t add(std::string_view type, const std::vector<StepArg>& args);

  /// @brief Next GUID of the seeded sequence, as a string argument.
  StepArg new_guid();

  /// @brief IFCCARTESIANPOINT (2 or 3 coordinates); identical points share one instance.
  std::uint32_t point(const std::vector<double>& xyz);
  /// @brief IFCDIRECTION (2 or 3 components); identical directions share one instance.
  std::uint32_t direction(const std::vector<double>& xyz);
  /// @brief IFCAXIS2PLACEMENT3D at `origin` with z axis `axis` and x axis `ref_direction`;
  /// the axes are written as `$` when they are the defaults (+z, +x).
  std::uint32_t axis2_placement_3d(const Vector3d& origin, const Vector3d& axis = Vector3d::UnitZ(),
                                   const Vector3d& ref_direction = Vector3d::UnitX());
  /// @brief IFCAXIS2PLACEMENT2D at `origin` (x axis `ref_direction`, `$` when +x).
  std::uint32_t axis2_placement_2d(const Vector2d& origin, const Vector2d& ref_direction = Vector2d::UnitX());
  /// @brief IFCLOCALPLACEMENT relative to `parent` (0: absolute) by an IFCAXIS2PLACEMENT3D.
  std::uint32_t local_placement(std::uint32_t parent, const Vector3d& origin,
                                const Vector3d& axis = Vector3d::UnitZ(),
                                const Vector3d& ref_direction = Vector3d::UnitX());
  /// @brief IFCUNITASSIGNMENT of SI units: metre, square metre, cubic metre, radian.
  std::uint32_t si_units();

  /// @brief Number of instances added so far (also the last id).
  std::size_t size() const { return entities_.size(); }

  /// @brief The whole file: ISO-10303-21 header, DATA section, end marker.
  std::string str() const;

  /// @brief Write str() to `path`. @throws plumb::Error when the file cannot be written.
  void write(const std::string& path) const;

 private:
  std::uint32_t cached(std::string_view type, const std::vector<double>& xyz);

  IfcWriterSettings settings_;
  IfcGuidGenerator guids_;
  std::vector<std::string> entities_;  ///< `TYPE(args)` per id - 1
  std::map<std::string, std::uint32_t> cache_;  ///< encoded point / direction -> id
};

}  // namespace plumb::bim
