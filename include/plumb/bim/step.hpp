// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief ISO 10303-21 ("STEP physical file", the `.ifc` text format) reader.
///
/// One pass over a slurped buffer indexes every entity instance `#id=TYPE(...)` by its express id
/// and remembers the byte range of its argument list; arguments are decoded only when asked for.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace plumb::bim {

/// @brief One decoded STEP argument: a small tagged value.
struct StepValue {
  /// @brief What the value holds.
  enum class Kind : std::uint8_t {
    kNull,     ///< `$` (unset optional attribute)
    kDerived,  ///< `*` (attribute derived in a subtype)
    kInteger,  ///< `12`, `-3` -> `integer`
    kReal,     ///< `1.`, `2.5E-3` -> `real`
    kString,   ///< `'text'` -> `text` (escapes decoded to UTF-8)
    kEnum,     ///< `.T.`, `.MILLI.` -> `text` without the dots
    kRef,      ///< `#12` -> `ref`
    kBinary,   ///< `"0A1"` -> `text` (raw hex digits)
    kList,     ///< `(a, b, ...)` -> `items`
    kTyped     ///< `IFCLENGTHMEASURE(1.)` -> `text` = type name, `items` = its arguments
  };
  Kind kind = Kind::kNull;
  std::int64_t integer = 0;
  double real = 0.0;
  std::uint32_t ref = 0;
  std::string text;
  std::vector<StepValue> items;

  bool is_null() const { return kind == Kind::kNull || kind == Kind::kDerived; }
  bool is_ref() const { return kind == Kind::kRef; }
  bool is_list() const { return kind == Kind::kList; }
  bool is_number() const { return kind == Kind::kInteger || kind == Kind::kReal; }
  /// @brief Numeric value of an integer or real (also of a typed value wrapping one); NaN otherwise.
  double number() const;
};

/// @brief Schema named by FILE_SCHEMA in the header.
enum class StepSchema { kUnknown, kIfc2x3, kIfc4, kIfc4x3 };

/// @brief Where one entity instance sits in the buffer.
struct StepEntity {
  std::uint32_t id = 0;          ///< express id (`#id`)
  std::uint32_t type = 0;        ///< index into StepFile::type_names()
  std::uint32_t line = 0;        ///< 1-based line of `#id`
  std::uint32_t args_begin = 0;  ///< byte offset just after the opening `(`
  std::uint32_t args_end = 0;    ///< byte offset of the closing `)`
};

/// @brief A parsed (indexed) STEP file. Arguments are decoded lazily with args().
///
/// @note Thread safety: const member functions may be called concurrently.
class StepFile {
 public:
  /// @brief Index a STEP buffer.
  /// @param buffer the whole file content (moved in and kept).
  /// @param name used in error messages (`name:LINE: message`).
  /// @throws plumb::Error on a malformed file (missing `ISO-10303-21;`, truncated entity,
  ///         unterminated string, duplicate id, no DATA section...).
  static StepFile parse(std::string buffer, std::string name = "<memory>");

  /// @brief Read and index a file from disk. @throws plumb::Error when unreadable or malformed.
  static StepFile read(const std::string& path);

  const std::string& name() const { return name_; }
  StepSchema schema() const { return schema_; }
  /// @brief The raw schema identifier from FILE_SCHEMA, e.g. "IFC4" or "IFC2X3".
  const std::string& schema_name() const { return schema_name_; }

  std::size_t size() const { return entities_.size(); }
  const std::vector<StepEntity>& entities() const { return entities_; }
  /// @brief Distinct upper-case type names; StepEntity::type indexes this table.
  const std::vector<std::string>& type_names() const { return type_names_; }

  /// @brief Index into entities() of `#id`, or -1 when there is no such instance.
  std::int64_t find(std::uint32_t id) const;
  bool contains(std::uint32_t id) const { return find(id) >= 0; }
  /// @brief The instance `#id`. @throws plumb::Error naming the file when it does not exist.
  const StepEntity& entity(std::uint32_t id) const;
  /// @brief Upper-case type name of `#id` (empty string when there is no such instance).
  const std::string& type_of(std::uint32_t id) const;
  /// @brief Index of a type name in type_names(), or -1 when the file has no such type.
  std::int64_t type_index(std::string_view upper_name) const;
  /// @brief All instances of one type (upper case, e.g. "IFCWALL"), in file order.
  std::vector<std::uint32_t> ids_of_type(std::string_view upper_name) const;

  /// @brief Decode the argument list of an instance.
  /// @throws plumb::Error `name:LINE: ...` on malformed arguments.
  std::vector<StepValue> args(const StepEntity& e) const;
  std::vector<StepValue> args(std::uint32_t id) const { return args(entity(id)); }

  /// @brief `name:LINE` of an instance for messages.
  std::string where(std::uint32_t id) const;

 private:
  class Parser;  ///< the indexing pass of parse() (defined in step.cpp)

  std::string name_;
  std::string buffer_;
  StepSchema schema_ = StepSchema::kUnknown;
  std::string schema_name_;
  std::vector<StepEntity> entities_;
  std::vector<std::string> type_names_;
  std::unordered_map<std::string, std::uint32_t> type_lookup_;
  std::vector<std::int32_t> dense_index_;                     ///< id -> entity index when ids are dense
  std::unordered_map<std::uint32_t, std::uint32_t> sparse_index_;  ///< otherwise
};

/// @brief Decode a STEP string body (between the quotes) to UTF-8: `''`, `\\`, `\X\hh`,
/// `\X2\hhhh...\X0\`, `\X4\hhhhhhhh...\X0\`, `\S\c`, `\P?\` (dropped).
/// @return false when an escape is malformed (the output then holds what was decoded so far).
bool decode_step_string(std::string_view raw, std::string& out);

}  // namespace plumb::bim
