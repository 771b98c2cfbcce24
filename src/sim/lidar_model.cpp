// SPDX-License-Identifier: BSD-3-Clause
// The LiDAR model itself: its checks, the presets and the JSON file of `plumb simulate --lidar`.
// Apart from the ray casting (lidar.cpp), so that the reader's fuzzer needs no world.
#include "plumb/sim/lidar_model_json.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <nlohmann/json.hpp>

#include "plumb/core/error.hpp"
#include "plumb/sim/lidar.hpp"

namespace plumb::sim {

namespace {

constexpr double kDeg = kPi / 180.0;

std::vector<double> even_rows(int n, double lo_deg, double hi_deg) {
  std::vector<double> el(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) el[static_cast<std::size_t>(i)] = (lo_deg + (hi_deg - lo_deg) * i / (n - 1)) * kDeg;
  return el;
}

}  // namespace

void LidarModel::validate() const {
  PLUMB_CHECK(!elevations_rad.empty(), "LidarModel '" << name << "': elevations_rad is empty");
  PLUMB_CHECK(elevations_rad.size() <= kMaxRows, "LidarModel '" << name << "': " << elevations_rad.size()
                                                             << " rows exceed the 16-bit ring index");
  for (std::size_t r = 0; r < elevations_rad.size(); ++r) {
    PLUMB_CHECK(std::isfinite(elevations_rad[r]) && std::abs(elevations_rad[r]) <= 0.5 * kPi,
                "LidarModel '" << name << "': elevations_rad[" << r << "] = " << elevations_rad[r]
                               << " is not in [-pi/2, pi/2]");
  }
  PLUMB_CHECK(columns >= 1 && columns <= kMaxColumns,
              "LidarModel '" << name << "': columns " << columns << " must be in [1, " << kMaxColumns << "]");
  PLUMB_CHECK(num_rays() <= kMaxRaysPerSweep, "LidarModel '" << name << "': " << num_rays()
                                                             << " rays per sweep (rows x columns) exceed "
                                                             << kMaxRaysPerSweep);
  PLUMB_CHECK(std::isfinite(rate_hz) && rate_hz >= kMinRateHz && rate_hz <= kMaxRateHz,
              "LidarModel '" << name << "': rate_hz " << rate_hz << " must be in [" << kMinRateHz << ", "
                             << kMaxRateHz << "] Hz");
  PLUMB_CHECK(std::isfinite(min_range) && min_range >= 0.0,
              "LidarModel '" << name << "': min_range " << min_range << " must be >= 0");
  PLUMB_CHECK(max_range > min_range && !std::isnan(max_range),
              "LidarModel '" << name << "': max_range " << max_range << " must exceed min_range " << min_range);
  PLUMB_CHECK(std::isfinite(range_sigma) && range_sigma >= 0.0,
              "LidarModel '" << name << "': range_sigma " << range_sigma << " must be >= 0");
  PLUMB_CHECK(dropout >= 0.0 && dropout <= 1.0, "LidarModel '" << name << "': dropout " << dropout << " not in [0, 1]");
  PLUMB_CHECK(std::isfinite(azimuth_offset_rad), "LidarModel '" << name << "': azimuth_offset_rad is not finite");
}

std::vector<std::string> lidar_preset_names() { return {"rfans32", "vlp16", "os1-64"}; }

LidarModel lidar_preset(const std::string& name) {
  LidarModel m;
  m.name = name;
  if (name == "rfans32") {
    m.elevations_rad = even_rows(32, -20.0, 10.0);
    m.columns = 2000;
    m.rate_hz = 10.0;
    m.min_range = 0.3;
    m.max_range = 150.0;
    m.range_sigma = 0.02;
  } else if (name == "vlp16") {
    m.elevations_rad = even_rows(16, -15.0, 15.0);
    m.columns = 1800;
    m.rate_hz = 10.0;
    m.min_range = 0.5;
    m.max_range = 100.0;
    m.range_sigma = 0.03;
  } else if (name == "os1-64") {
    m.elevations_rad = even_rows(64, -16.6, 16.6);
    m.columns = 1024;
    m.rate_hz = 10.0;
    m.min_range = 0.3;
    m.max_range = 120.0;
    m.range_sigma = 0.03;
  } else {
    std::ostringstream known;
    for (const std::string& n : lidar_preset_names()) known << (known.tellp() > 0 ? ", " : "") << n;
    PLUMB_THROW("lidar_preset: unknown LiDAR '" << name << "' (known: " << known.str() << ")");
  }
  return m;
}

LidarModel parse_lidar_model(const std::string& text, const std::string& name) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    PLUMB_THROW(name << ": not valid JSON: " << e.what());
  }
  PLUMB_CHECK(j.is_object(), name << ": the LiDAR model must be a JSON object");
  LidarModel m;
  try {
    if (j.contains("preset")) {
      const std::string preset = j.at("preset").get<std::string>();
      try {
        m = lidar_preset(preset);
      } catch (const Error& e) {
        PLUMB_THROW(name << ": " << e.what());
      }
    }
    m.name = j.value("name", m.name.empty() ? std::string("custom") : m.name);
    const char* const rows_key = j.contains("elevations_deg") ? "elevations_deg" : "elevations_rad";
    if (j.contains(rows_key)) {
      const nlohmann::json& rows = j.at(rows_key);
      // Checked before reading: an array of millions of rows would be copied first otherwise.
      PLUMB_CHECK(rows.is_array() && rows.size() <= LidarModel::kMaxRows,
                  name << ": \"" << rows_key << "\" must be an array of at most " << LidarModel::kMaxRows
                       << " numbers");
      const double scale = rows_key[11] == 'd' ? kDeg : 1.0;  // "elevations_deg"
      m.elevations_rad.clear();
      for (const nlohmann::json& v : rows) m.elevations_rad.push_back(v.get<double>() * scale);
    }
    if (j.contains("columns")) {
      // Read as an integer in range before converting: a fractional, boolean or huge value would be
      // truncated, wrapped or (1e10 -> int) undefined.
      const nlohmann::json& c = j.at("columns");
      PLUMB_CHECK(c.is_number_integer() && c.get<std::int64_t>() >= 1 &&
                      c.get<std::int64_t>() <= LidarModel::kMaxColumns,
                  name << ": \"columns\" must be a whole number in [1, " << LidarModel::kMaxColumns << "], got "
                       << c.dump());
      m.columns = static_cast<int>(c.get<std::int64_t>());
    }
    m.rate_hz = j.value("rate_hz", m.rate_hz);
    m.min_range = j.value("min_range", m.min_range);
    m.max_range = j.value("max_range", m.max_range);
    m.range_sigma = j.value("range_sigma", m.range_sigma);
    m.dropout = j.value("dropout", m.dropout);
  } catch (const nlohmann::json::exception& e) {
    PLUMB_THROW(name << ": bad LiDAR model: " << e.what());
  }
  PLUMB_CHECK(!m.elevations_rad.empty(), name << ": the LiDAR model needs \"elevations_deg\" or \"elevations_rad\"");
  try {
    m.validate();
  } catch (const Error& e) {
    PLUMB_THROW(name << ": " << e.what());
  }
  return m;
}

}  // namespace plumb::sim
