// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/ifc_writer.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

#include "plumb/core/error.hpp"

namespace plumb::bim {

namespace {

constexpr char kHex[] = "0123456789ABCDEF";

bool is_name_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

bool is_name(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (!is_name_char(c)) return false;
  }
  return true;
}

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) {
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  }
  return out;
}

/// Next code point of a UTF-8 string at `i` (advanced past it); false on malformed input
/// (truncated sequence, stray continuation byte, overlong form, surrogate, > U+10FFFF).
bool next_code_point(std::string_view s, std::size_t& i, std::uint32_t& cp) {
  const auto b0 = static_cast<unsigned char>(s[i]);
  int extra = 0;
  std::uint32_t min = 0;
  if (b0 < 0x80) {
    cp = b0;
  } else if ((b0 & 0xE0) == 0xC0) {
    cp = b0 & 0x1F;
    extra = 1;
    min = 0x80;
  } else if ((b0 & 0xF0) == 0xE0) {
    cp = b0 & 0x0F;
    extra = 2;
    min = 0x800;
  } else if ((b0 & 0xF8) == 0xF0) {
    cp = b0 & 0x07;
    extra = 3;
    min = 0x10000;
  } else {
    return false;
  }
  if (i + static_cast<std::size_t>(extra) >= s.size() && extra > 0) return false;  // truncated
  for (int k = 1; k <= extra; ++k) {
    const auto b = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
    if ((b & 0xC0) != 0x80) return false;
    cp = (cp << 6) | (b & 0x3F);
  }
  if (extra > 0 && cp < min) return false;
  if (cp > 0x10FFFF || (cp >= 0xD800 && cp < 0xE000)) return false;
  i += static_cast<std::size_t>(extra) + 1;
  return true;
}

void append_hex(std::string& out, std::uint32_t value, int digits) {
  for (int k = digits - 1; k >= 0; --k) out.push_back(kHex[(value >> (4 * k)) & 0xF]);
}

}  // namespace

// ---- encoding ------------------------------------------------------------------------------------

std::string step_real(double value) {
  PLUMB_CHECK(std::isfinite(value), "step_real: " << value << " has no STEP spelling (NaN or infinity)");
  if (value == 0.0) return "0.";  // also -0
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), value);
  PLUMB_CHECK(res.ec == std::errc(), "step_real: cannot format " << value);
  const std::string s(buf, res.ptr);
  const std::size_t e = s.find('e');
  std::string mantissa = s.substr(0, e);
  if (mantissa.find('.') == std::string::npos) mantissa.push_back('.');
  if (e == std::string::npos) return mantissa;
  std::string exponent = s.substr(e + 1);
  if (!exponent.empty() && exponent[0] == '+') exponent.erase(0, 1);
  return mantissa + "E" + exponent;
}

std::string step_string(std::string_view utf8) {
  std::string out = "'";
  out.reserve(utf8.size() + 2);
  std::size_t i = 0;
  int run = 0;  // 0: plain text, 2: inside \X2\, 4: inside \X4\ .
  auto close_run = [&]() {
    if (run != 0) out += "\\X0\\";
    run = 0;
  };
  while (i < utf8.size()) {
    std::uint32_t cp = 0;
    const std::size_t at = i;
    PLUMB_CHECK(next_code_point(utf8, i, cp), "step_string: invalid UTF-8 at byte " << at << " of the text");
    if (cp >= 0x20 && cp <= 0x7E) {
      close_run();
      out.push_back(static_cast<char>(cp));
      if (cp == '\'' || cp == '\\') out.push_back(static_cast<char>(cp));
      continue;
    }
    const int width = cp > 0xFFFF ? 4 : 2;
    if (run != width) {
      close_run();
      out += width == 2 ? "\\X2\\" : "\\X4\\";
      run = width;
    }
    append_hex(out, cp, 2 * width);
  }
  close_run();
  out.push_back('\'');
  return out;
}

StepArg StepArg::ref(std::uint32_t id) {
  PLUMB_CHECK(id != 0, "StepArg::ref: #0 is not a valid instance id");
  return StepArg("#" + std::to_string(id));
}

StepArg StepArg::integer(std::int64_t value) { return StepArg(std::to_string(value)); }

StepArg StepArg::real(double value) { return StepArg(step_real(value)); }

StepArg StepArg::string(std::string_view utf8) { return StepArg(step_string(utf8)); }

StepArg StepArg::enumeration(std::string_view name) {
  PLUMB_CHECK(is_name(name), "StepArg::enumeration: '" << name << "' is not a valid enumeration name");
  return StepArg("." + upper(name) + ".");
}

StepArg StepArg::list(const std::vector<StepArg>& items) {
  std::string s = "(";
  for (std::size_t k = 0; k < items.size(); ++k) {
    if (k > 0) s.push_back(',');
    s += items[k].text_;
  }
  s.push_back(')');
  return StepArg(std::move(s));
}

StepArg StepArg::refs(const std::vector<std::uint32_t>& ids) {
  std::vector<StepArg> items;
  items.reserve(ids.size());
  for (std::uint32_t id : ids) items.push_back(ref(id));
  return list(items);
}

StepArg StepArg::reals(const std::vector<double>& values) {
  std::vector<StepArg> items;
  items.reserve(values.size());
  for (double v : values) items.push_back(real(v));
  return list(items);
}

StepArg StepArg::typed(std::string_view type, const StepArg& value) {
  PLUMB_CHECK(is_name(type), "StepArg::typed: '" << type << "' is not a valid type name");
  return StepArg(upper(type) + "(" + value.text_ + ")");
}

// ---- GUIDs ---------------------------------------------------------------------------------------

std::string ifc_guid(std::uint64_t hi, std::uint64_t lo) {
  static constexpr char kDigits[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$";
  std::string out(22, '0');
  for (int k = 0; k < 22; ++k) {
    const int shift = 6 * (21 - k);  // bit position of the digit's least significant bit
    std::uint64_t bits;
    if (shift >= 64) {
      bits = hi >> (shift - 64);
    } else if (shift == 0) {
      bits = lo;
    } else {
      bits = (lo >> shift) | (hi << (64 - shift));
    }
    out[static_cast<std::size_t>(k)] = kDigits[bits & 63U];
  }
  return out;
}

std::string IfcGuidGenerator::next() {
  std::uint64_t hi = rng_.engine()();
  std::uint64_t lo = rng_.engine()();
  hi = (hi & ~std::uint64_t{0xF000}) | std::uint64_t{0x4000};        // version 4
  lo = (lo & ~(std::uint64_t{3} << 62)) | (std::uint64_t{1} << 63);  // variant 10
  return ifc_guid(hi, lo);
}

// ---- writer --------------------------------------------------------------------------------------

IfcWriter::IfcWriter(IfcWriterSettings settings) : settings_(std::move(settings)), guids_(settings_.guid_seed) {
  PLUMB_CHECK(is_name(settings_.schema), "IfcWriter: schema '" << settings_.schema << "' is not a valid identifier");
}

std::uint32_t IfcWriter::add(std::string_view type, const std::vector<StepArg>& args) {
  PLUMB_CHECK(is_name(type), "IfcWriter::add: '" << type << "' is not a valid entity type name");
  std::string s = upper(type);
  s.push_back('(');
  for (std::size_t k = 0; k < args.size(); ++k) {
    if (k > 0) s.push_back(',');
    s += args[k].text();
  }
  s.push_back(')');
  entities_.push_back(std::move(s));
  return static_cast<std::uint32_t>(entities_.size());
}

StepArg IfcWriter::new_guid() { return StepArg::string(guids_.next()); }

std::uint32_t IfcWriter::cached(std::string_view type, const std::vector<double>& xyz) {
  PLUMB_CHECK(xyz.size() == 2 || xyz.size() == 3,
              "IfcWriter: " << type << " needs 2 or 3 coordinates, got " << xyz.size());
  const StepArg coords = StepArg::reals(xyz);
  const std::string key = std::string(type) + coords.text();
  auto it = cache_.find(key);
  if (it != cache_.end()) return it->second;
  const std::uint32_t id = add(type, {coords});
  cache_.emplace(key, id);
  return id;
}

std::uint32_t IfcWriter::point(const std::vector<double>& xyz) { return cached("IFCCARTESIANPOINT", xyz); }

std::uint32_t IfcWriter::direction(const std::vector<double>& xyz) {
  double n_sq = 0.0;
  for (double v : xyz) n_sq += v * v;
  PLUMB_CHECK(n_sq > 0.0 && std::isfinite(n_sq), "IfcWriter::direction: zero or non-finite direction");
  return cached("IFCDIRECTION", xyz);
}

std::uint32_t IfcWriter::axis2_placement_3d(const Vector3d& origin, const Vector3d& axis,
                                            const Vector3d& ref_direction) {
  PLUMB_CHECK(axis.cross(ref_direction).norm() > 1e-9 * axis.norm() * ref_direction.norm(),
              "IfcWriter::axis2_placement_3d: axis and ref_direction are parallel or zero");
  const std::uint32_t p = point({origin.x(), origin.y(), origin.z()});
  const StepArg z = axis == Vector3d::UnitZ() ? StepArg::null()
                                              : StepArg::ref(direction({axis.x(), axis.y(), axis.z()}));
  const StepArg x = ref_direction == Vector3d::UnitX()
                        ? StepArg::null()
                        : StepArg::ref(direction({ref_direction.x(), ref_direction.y(), ref_direction.z()}));
  return add("IFCAXIS2PLACEMENT3D", {StepArg::ref(p), z, x});
}

std::uint32_t IfcWriter::axis2_placement_2d(const Vector2d& origin, const Vector2d& ref_direction) {
  const std::uint32_t p = point({origin.x(), origin.y()});
  const StepArg x = ref_direction == Vector2d::UnitX()
                        ? StepArg::null()
                        : StepArg::ref(direction({ref_direction.x(), ref_direction.y()}));
  return add("IFCAXIS2PLACEMENT2D", {StepArg::ref(p), x});
}

std::uint32_t IfcWriter::local_placement(std::uint32_t parent, const Vector3d& origin, const Vector3d& axis,
                                         const Vector3d& ref_direction) {
  const std::uint32_t rel = axis2_placement_3d(origin, axis, ref_direction);
  return add("IFCLOCALPLACEMENT", {parent == 0 ? StepArg::null() : StepArg::ref(parent), StepArg::ref(rel)});
}

std::uint32_t IfcWriter::si_units() {
  auto unit = [&](const char* type, const char* name) {
    return add("IFCSIUNIT", {StepArg::derived(), StepArg::enumeration(type), StepArg::null(), StepArg::enumeration(name)});
  };
  const std::uint32_t length = unit("LENGTHUNIT", "METRE");
  const std::uint32_t area = unit("AREAUNIT", "SQUARE_METRE");
  const std::uint32_t volume = unit("VOLUMEUNIT", "CUBIC_METRE");
  const std::uint32_t angle = unit("PLANEANGLEUNIT", "RADIAN");
  return add("IFCUNITASSIGNMENT", {StepArg::refs({length, area, volume, angle})});
}

std::string IfcWriter::str() const {
  std::string out;
  std::size_t total = 512;
  for (const auto& e : entities_) total += e.size() + 16;
  out.reserve(total);
  out += "ISO-10303-21;\nHEADER;\n";
  out += "FILE_DESCRIPTION((" + step_string(settings_.description) + "),'2;1');\n";
  out += "FILE_NAME(" + step_string(settings_.file_name) + "," + step_string(settings_.time_stamp) + ",(" +
         step_string(settings_.author) + "),(" + step_string(settings_.organization) + ")," +
         step_string(settings_.preprocessor) + "," + step_string(settings_.originating_system) + ",'');\n";
  out += "FILE_SCHEMA(('" + upper(settings_.schema) + "'));\nENDSEC;\nDATA;\n";
  for (std::size_t k = 0; k < entities_.size(); ++k) {
    out.push_back('#');
    out += std::to_string(k + 1);
    out.push_back('=');
    out += entities_[k];
    out += ";\n";
  }
  out += "ENDSEC;\nEND-ISO-10303-21;\n";
  return out;
}

void IfcWriter::write(const std::string& path) const {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  PLUMB_CHECK(out.good(), path << ": cannot open for writing");
  const std::string text = str();
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write failed");
}

}  // namespace plumb::bim
