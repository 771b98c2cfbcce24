// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private helper of the io writers of XML (SVG plots, BCF archives). Not installed; not part
///        of the API.

#include <string>
#include <string_view>

namespace plumb::io::detail {

/// `text` with & < > and " written as entities: safe in XML text and in attribute values quoted
/// with ", as the writers quote them.
inline std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace plumb::io::detail
