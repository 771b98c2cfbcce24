// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What `plumb run` and `plumb demo` both do with a RunReport: the output files, the JSON report
// and the error table of Liu et al. 2022, Table 2, on stdout.

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/run.hpp"

namespace plumb::cli {

/// The report as JSON (frames, localization, anchors, timings; Table 2 and APE with ground truth).
nlohmann::json run_report_json(const RunReport& r);

/// Writes OUT/report.json; when the first frame was localized, also OUT/{wheel,lidar,bim}.tum and
/// OUT/trajectory.svg (floor plan of the model at the robot's height, ground truth when present).
/// @throws plumb::Error on a write error, or (after report.json) when the localization failed
void write_run_outputs(const RunReport& r, const nlohmann::json& report, const bim::BimMesh& mesh,
                       const io::FrameDumpReader& dump, const std::string& out_dir, const std::string& title,
                       const std::string& model_name);

/// Prints the frame counts and, with ground truth, the initial-localization error, Table 2 and APE.
void print_run_summary(const RunReport& r);

/// A progress callback printing "frame i / n" on stderr when it is a terminal; empty otherwise.
std::function<void(std::size_t, std::size_t)> terminal_progress(const std::string& what);

}  // namespace plumb::cli
