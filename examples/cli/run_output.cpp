// SPDX-License-Identifier: BSD-3-Clause
#include "run_output.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "cli_support.hpp"
#include "plumb/app/deviation_files.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/io/svg.hpp"
#include "plumb/io/trajectory.hpp"

namespace plumb::cli {
namespace {

nlohmann::json pose_json(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({T(r, 0), T(r, 1), T(r, 2), T(r, 3)});
  return rows;
}

double percent(double error, double distance) { return distance > 0 ? 100.0 * error / distance : 0.0; }

namespace fs = std::filesystem;

constexpr const char* kStagingPrefix = ".plumb-staging-";

bool starts_with(const std::string& s, const std::string& prefix) { return s.compare(0, prefix.size(), prefix) == 0; }

/// frames/ of a dump: NNNNNN.pcd files only.
bool is_frame_file_name(const std::string& name) {
  if (name.size() != 10 || name.compare(6, 4, ".pcd") != 0) return false;
  return std::all_of(name.begin(), name.begin() + 6, [](char c) { return c >= '0' && c <= '9'; });
}

/// The first entry of `dir` that is not one of `names` (nor the marker nor a staging directory),
/// or, inside a "frames" entry, the first file that is not a frame; empty when there is none.
std::string first_foreign_entry(const fs::path& dir, const std::vector<std::string>& names) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name == OutputDir::marker_name() || starts_with(name, kStagingPrefix)) continue;
    if (std::find(names.begin(), names.end(), name) == names.end()) return name;
    if (name == "frames" && fs::is_directory(it->path())) {
      for (fs::directory_iterator f(it->path(), ec); !ec && f != end; f.increment(ec)) {
        const std::string fname = f->path().filename().string();
        if (!is_frame_file_name(fname)) return "frames/" + fname;
      }
    }
  }
  PLUMB_CHECK(!ec, dir.string() << ": cannot list the directory: " << ec.message());
  return {};
}

std::string marker_command(const fs::path& dir) {
  std::ifstream in(dir / OutputDir::marker_name());
  std::string line;
  if (!in.is_open() || !std::getline(in, line)) return {};
  return line;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

const std::vector<std::string>& frame_dump_names() {
  static const std::vector<std::string> names = {"meta.json", "frames.csv", "frames",       "wheels.csv",   "odom.csv",
                                                 "imu.csv",   "gt.tum",     "gt_dense.tum", "as_built.json"};
  return names;
}

const std::vector<std::string>& run_output_names() {
  static const std::vector<std::string> names = {
      "report.json",    "wheel.tum",       "lidar.tum",      "bim.tum",        "bim_refined.tum",
      "trajectory.svg", "deviations.json", "deviations.csv", "deviations.svg", "deviations.bcf"};
  return names;
}

OutputDir::OutputDir(std::string dir, std::string command, std::vector<std::string> names, bool overwrite,
                     bool replace_own, std::vector<std::string> nested)
    : dir_(std::move(dir)), command_(std::move(command)), names_(std::move(names)), nested_(std::move(nested)) {
  PLUMB_CHECK(!dir_.empty(), "the output directory name is empty");
  const fs::path path(dir_);
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (fs::exists(st)) {
    PLUMB_CHECK(fs::is_directory(st), dir_ << ": exists and is not a directory");
    const bool empty = fs::is_empty(path, ec);
    PLUMB_CHECK(!ec, dir_ << ": cannot list the directory: " << ec.message());
    if (!empty) {
      std::vector<std::string> allowed = names_;
      allowed.insert(allowed.end(), nested_.begin(), nested_.end());
      const std::string foreign = first_foreign_entry(path, allowed);
      const bool own = foreign.empty() && marker_command(path) == "plumb " + command_;
      std::string shown = foreign;
      if (shown.empty()) {  // plumb's names, but no marker of this command: name the first one
        for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
          shown = it->path().filename().string();
          if (shown != marker_name() && !starts_with(shown, kStagingPrefix)) break;
        }
      }
      if (own) {
        PLUMB_CHECK(replace_own || overwrite, dir_ << ": already holds the output of an earlier plumb " << command_
                                                   << "; pass --overwrite to replace it");
      } else if (!overwrite) {
        PLUMB_THROW(dir_ << ": not empty and holds files plumb did not write ("
                         << "'" << shown << "'"
                         << (foreign.empty() ? std::string(" without a ") + marker_name() + " marker of plumb " + command_
                                             : std::string())
                         << "); refusing to write there. Choose an empty or new directory, or pass --overwrite to "
                            "replace plumb's "
                         << command_ << " files in it (" << join(names_) << ")");
      }
    }
  } else {
    fs::create_directories(path, ec);
    PLUMB_CHECK(!ec, dir_ << ": cannot create the output directory: " << ec.message());
    created_ = true;
  }
  staging_ = (path / (kStagingPrefix + std::to_string(::getpid()))).string();
  fs::remove_all(staging_, ec);
  fs::create_directory(staging_, ec);
  if (ec) {
    const std::string message = ec.message();
    if (created_) fs::remove(path, ec);
    PLUMB_THROW(dir_ << ": cannot write into the output directory: " << message);
  }
  // A file in it, too: a directory may accept mkdir but not a file (quota, full disk).
  const std::string probe = staging_ + "/" + marker_name();
  {
    std::ofstream out(probe);
    out << "plumb " << command_ << '\n';
    if (!out.good()) {
      const std::string message = std::strerror(errno);
      fs::remove_all(staging_, ec);
      if (created_) fs::remove(path, ec);
      PLUMB_THROW(dir_ << ": cannot write into the output directory: " << message);
    }
  }
}

OutputDir::~OutputDir() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
  if (created_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
}

void OutputDir::commit() {
  PLUMB_CHECK(!committed_, dir_ << ": OutputDir::commit twice");
  const fs::path out(dir_), staged(staging_);
  std::error_code ec;
  std::vector<std::string> entries = names_;
  entries.push_back(marker_name());  // last: the set is plumb's once everything else is in place
  for (const std::string& name : entries) {
    const fs::path from = staged / name, to = out / name;
    const bool have_new = fs::exists(fs::symlink_status(from, ec));
    const bool have_old = fs::exists(fs::symlink_status(to, ec));
    if (have_new && !fs::is_directory(from) && !(have_old && fs::is_directory(fs::symlink_status(to)))) {
      fs::rename(from, to, ec);  // atomic replacement of a file
      PLUMB_CHECK(!ec, to.string() << ": cannot move the new file into place: " << ec.message());
      continue;
    }
    if (have_old) {
      // A directory cannot be renamed over a non-empty one: move the old one aside, then delete it.
      const fs::path old = out / (std::string(kStagingPrefix) + "old-" + std::to_string(::getpid()) + "-" + name);
      fs::rename(to, old, ec);
      PLUMB_CHECK(!ec, to.string() << ": cannot replace the earlier output: " << ec.message());
      if (have_new) {
        fs::rename(from, to, ec);
        PLUMB_CHECK(!ec, to.string() << ": cannot move the new output into place: " << ec.message());
      }
      fs::remove_all(old, ec);
      PLUMB_CHECK(!ec, old.string() << ": cannot remove the earlier output: " << ec.message());
    } else if (have_new) {
      fs::rename(from, to, ec);
      PLUMB_CHECK(!ec, to.string() << ": cannot move the new output into place: " << ec.message());
    }
  }
  fs::remove_all(staged, ec);
  committed_ = true;
}

nlohmann::json run_report_json(const RunReport& r) {
  nlohmann::json j;
  j["frames"] = r.frames.size();
  j["frames_requested"] = r.frames_requested;
  j["partial"] = r.partial;
  if (r.partial) j["error"] = r.error;
  j["warnings"] = r.warnings;
  j["odometry_clamped_frames"] = r.odometry_clamped_frames;
  j["ground_truth"] = r.has_ground_truth ? "used" : r.ground_truth_note;
  j["localized"] = r.localized;
  j["localization_status"] = to_string(r.localization_status);
  if (r.localized) {
    const BimLocalization& l = r.localization;
    j["localization"] = {{"score", l.score},           {"second_score", l.second_score}, {"ambiguous", l.ambiguous},
                         {"overlap", l.fine.overlap},  {"rmse", l.fine.rmse},            {"see_through", l.see_through},
                         {"storey", l.storey},         {"seconds_search", l.seconds_search},
                         {"seconds_fine", l.seconds_fine}, {"views", l.views},
                         {"distance", r.localization_distance}, {"frames_read", r.localization_frames}};
  }
  j["T_world_base0"] = pose_json(r.T_world_base0);
  j["bim_points"] = r.bim_points;
  j["anchors"] = {{"attempted", r.anchors_attempted}, {"accepted", r.anchors_accepted}, {"rejected", r.anchors_rejected}};
  j["fallbacks"] = r.fallbacks;
  j["seconds_localize"] = r.seconds_localize;
  j["seconds_frames"] = r.seconds_frames;
  if (!r.bim_refined.empty()) j["seconds_refine"] = r.seconds_refine;
  j["frames_per_second"] = r.frames_per_second;
  j["mean_seconds_per_frame"] = {{"front_end", r.mean_seconds_front_end},
                                 {"segment", r.mean_seconds_segment},
                                 {"icp", r.mean_seconds_icp},
                                 {"process", r.mean_seconds_process}};
  j["seconds_per_frame"] = {{"median", r.median_seconds_process},
                            {"max", r.max_seconds_process},
                            {"slowest_frame", r.slowest_frame}};
  j["peak_rss_mib"] = peak_rss_mib();
  if (r.has_ground_truth) {
    j["initial_error"] = {{"xy", r.initial_error_xy}, {"yaw_deg", r.initial_error_yaw_deg}};
    j["path_length"] = r.path_length;
    nlohmann::json table = nlohmann::json::array();
    const bool refined = !r.bim_refined.empty();
    for (const ObservationRow& row : r.table) {
      nlohmann::json t = {{"point", row.name}, {"frame", row.frame}, {"distance", row.distance},
                          {"wheel", {{"error", row.error_wheel}, {"percent", percent(row.error_wheel, row.distance)}}},
                          {"lidar", {{"error", row.error_lidar}, {"percent", percent(row.error_lidar, row.distance)}}},
                          {"bim", {{"error", row.error_bim}, {"percent", percent(row.error_bim, row.distance)}}}};
      if (refined) {
        t["bim_refined"] = {{"error", row.error_refined}, {"percent", percent(row.error_refined, row.distance)}};
      }
      table.push_back(t);
    }
    j["table"] = table;
    j["ape_rmse_xy"] = {{"wheel", r.ape_rmse_wheel}, {"lidar", r.ape_rmse_lidar}, {"bim", r.ape_rmse_bim}};
    j["max_error_xy"] = {{"wheel", r.max_error_wheel}, {"lidar", r.max_error_lidar}, {"bim", r.max_error_bim}};
    if (refined) {
      j["ape_rmse_xy"]["bim_refined"] = r.ape_rmse_refined;
      j["max_error_xy"]["bim_refined"] = r.max_error_refined;
    }
    j["registration_error_xy"] = {
        {"count", r.registrations}, {"rms", r.registration_error_rms}, {"max", r.registration_error_max}};
  }
  return j;
}

nlohmann::json deviations_json(const RunReport& r) {
  nlohmann::json elements = nlohmann::json::array();
  for (const DeviationReportRow& d : r.deviations) {
    elements.push_back({{"global_id", d.global_id},
                        {"type", d.type},
                        {"name", d.name},
                        {"storey", d.storey},
                        {"observations", d.observations},
                        {"normal", {d.normal.x(), d.normal.y(), d.normal.z()}},
                        {"point", {d.point.x(), d.point.y(), d.point.z()}},
                        {"offset_m", d.offset_m},
                        {"sigma_m", d.sigma_m},
                        {"rotation_deg", d.rotation_deg},
                        {"status", deviation_status_name(d.status)}});
  }
  return {{"tolerance_m", r.deviation_tolerance}, {"elements", elements}};
}

namespace {

/// A CSV field: quoted, with quotes doubled, when it holds a separator, a quote or a line break.
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

/// The floor plans are the model cut 1 m above the start pose's base.
double plan_height(const RunReport& r) { return r.T_world_base0.translation().z() + 1.0; }

/// deviations.svg and deviations.bcf. The BCF topics are dated by the recording's start: the first
/// frame's stamp read as Unix time (a simulated dump, stamped from 0, gives 1970-01-01T00:00:00Z).
void write_deviation_views(const RunReport& r, const bim::BimMesh& mesh, const std::string& out_dir,
                           const std::string& title, const std::string& model_name) {
  DeviationSvgSettings svg;
  svg.title = title;
  svg.height = plan_height(r);
  io::SvgPlot plot = deviation_svg(r.deviations, r.deviation_tolerance, mesh, svg);
  plot.add_trajectory(r.bim, "robot path (BIM-corrected)", "#2ca02c", true);
  plot.paths.back().width = 1.0;
  io::write_svg(plot, out_dir + "/deviations.svg");
  DeviationBcfSettings bcf;
  bcf.project_name = fs::path(model_name).filename().string() + " as built";
  const double start = r.bim.has_stamps() ? r.bim.stamps.front() : 0.0;
  bcf.date = bcf_date_time(std::max(0.0, start));
  bcf.origin_offset = mesh.origin_offset;
  io::write_bcf(out_dir + "/deviations.bcf", deviation_bcf(r.deviations, r.deviation_tolerance, bcf));
}

void write_deviations(const RunReport& r, const std::string& out_dir) {
  {
    std::ofstream out(out_dir + "/deviations.json");
    out << deviations_json(r).dump(2) << '\n';
    PLUMB_CHECK(out.good(), out_dir << "/deviations.json: write error");
  }
  std::ofstream out(out_dir + "/deviations.csv");
  out << "global_id,type,name,storey,observations,normal_x,normal_y,normal_z,point_x,point_y,point_z,offset_m,"
         "sigma_m,rotation_deg,status\n";
  char numbers[512];
  for (const DeviationReportRow& d : r.deviations) {
    std::snprintf(numbers, sizeof(numbers), "%zu,%.6f,%.6f,%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.4f", d.observations,
                  d.normal.x(), d.normal.y(), d.normal.z(), d.point.x(), d.point.y(), d.point.z(), d.offset_m,
                  d.sigma_m, d.rotation_deg);
    out << csv_field(d.global_id) << ',' << csv_field(d.type) << ',' << csv_field(d.name) << ','
        << csv_field(d.storey) << ',' << numbers << ',' << deviation_status_name(d.status) << '\n';
  }
  PLUMB_CHECK(out.good(), out_dir << "/deviations.csv: write error");
}

}  // namespace

void check_localized(const RunReport& r, const io::FrameDumpReader& dump, const std::string& model_name) {
  if (r.localization_status != Status::kOk) {
    if (r.ambiguous_localization) {
      const BimLocalization& a = *r.ambiguous_localization;
      const auto place = [](const Eigen::Isometry3d& T) {
        std::ostringstream o;
        const Pose2 p = Pose2::from_isometry(T);
        o << "(" << p.x << ", " << p.y << ", heading " << p.theta * 180.0 / kPi << " deg)";
        return o.str();
      };
      PLUMB_THROW(dump.dir() << ": the start fits two places of " << model_name << " about as well, "
                             << place(a.T_world_base_search) << " and " << place(a.T_world_base_second)
                             << " (scores " << a.score << " and " << a.second_score << ", from " << a.views
                             << " frame(s); " << r.localization_distance
                             << " m driven in all); give --start-hint X Y (the room the robot starts in), a longer "
                                "--start-search-distance, or --gt-start");
    }
    PLUMB_THROW(dump.dir() << ": the first frame could not be localized in " << model_name << " ("
                           << to_string(r.localization_status) << ", score " << r.localization.score << ", overlap "
                           << r.localization.fine.overlap << ", see-through " << r.localization.see_through << ", from "
                           << r.localization.views << " frame(s) over " << r.localization_distance
                           << " m of driving); give --start-hint X Y, --gt-start, or check that the dump was recorded in this building");
  }
}

void write_run_outputs(const RunReport& r, const nlohmann::json& report, const bim::BimMesh& mesh,
                       const io::FrameDumpReader& dump, const std::string& out_dir, const std::string& title,
                       const std::string& model_name) {
  check_localized(r, dump, model_name);
  {
    std::ofstream out(out_dir + "/report.json");
    out << report.dump(2) << '\n';
    PLUMB_CHECK(out.good(), out_dir << "/report.json: write error");
  }
  io::write_tum(r.wheel, out_dir + "/wheel.tum");
  io::write_tum(r.lidar, out_dir + "/lidar.tum");
  io::write_tum(r.bim, out_dir + "/bim.tum");
  if (!r.bim_refined.empty()) io::write_tum(r.bim_refined, out_dir + "/bim_refined.tum");
  if (!r.deviations.empty()) {
    write_deviations(r, out_dir);
    write_deviation_views(r, mesh, out_dir, title, model_name);
  }

  io::SvgPlot plot;
  plot.title = title;
  if (!mesh.storeys.empty()) {
    const bim::FloorPlan fp = bim::slice_floor_plan(mesh, plan_height(r));
    for (std::size_t i = 0; i < fp.segment_start.size(); ++i) plot.floor_plan.push_back({fp.segment_start[i], fp.segment_end[i]});
  }
  if (r.has_ground_truth) plot.add_trajectory(dump.ground_truth(), "ground truth", "#000000", true);
  plot.add_trajectory(r.wheel, "wheel odometry", "#d62728");
  plot.add_trajectory(r.lidar, "LiDAR (no BIM)", "#ff7f0e");
  plot.add_trajectory(r.bim, "BIM-corrected", "#2ca02c");
  if (!r.bim_refined.empty()) plot.add_trajectory(r.bim_refined, "BIM-corrected, second pass", "#1f77b4");
  io::write_svg(plot, out_dir + "/trajectory.svg");
}

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
}

void print_run_summary(const RunReport& r) {
  std::printf("%zu frames, %.1f frames/s; anchors %zu accepted / %zu rejected of %zu attempted; %zu fallbacks\n",
              r.frames.size(), r.frames_per_second, r.anchors_accepted, r.anchors_rejected, r.anchors_attempted,
              r.fallbacks);
  if (r.mean_seconds_process > 0.0) {
    std::printf("per frame: %.1f ms in BimOdometry (front end %.1f, key points %.1f, BIM ICP %.1f) = %.1f frames/s without reading\n",
                r.mean_seconds_process * 1e3, r.mean_seconds_front_end * 1e3, r.mean_seconds_segment * 1e3,
                r.mean_seconds_icp * 1e3, 1.0 / r.mean_seconds_process);
    std::printf("slowest frame: %.1f ms (frame %zu; median %.1f ms)\n", r.max_seconds_process * 1e3, r.slowest_frame,
                r.median_seconds_process * 1e3);
  }
  if (r.localized) {
    std::printf("initial localization: %s in %.2f s (score %.2f, second %.2f, overlap %.2f, rmse %.1f mm)\n",
                to_string(r.localization_status), r.seconds_localize, r.localization.score, r.localization.second_score,
                r.localization.fine.overlap, r.localization.fine.rmse * 1e3);
    if (r.localization.views > 1) {
      std::printf("  from %zu frames over the first %.1f m of driving (the first frame alone fitted several places)\n",
                  r.localization.views, r.localization_distance);
    }
  }
  if (!r.has_ground_truth) return;
  std::printf("initial pose error: %.1f mm, %.3f deg\n", r.initial_error_xy * 1e3, r.initial_error_yaw_deg);
  std::printf("%-6s %10s %18s %18s %18s\n", "point", "path [m]", "wheel", "LiDAR", "BIM-corrected");
  for (const ObservationRow& row : r.table) {
    auto cell = [&](double e) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%.3f m %6.3f %%", e, percent(e, row.distance));
      return std::string(buf);
    };
    std::printf("%-6s %10.2f %18s %18s %18s\n", row.name.c_str(), row.distance, cell(row.error_wheel).c_str(),
                cell(row.error_lidar).c_str(), cell(row.error_bim).c_str());
  }
  std::printf("max error (xy):  wheel %.3f m, LiDAR %.3f m, BIM-corrected %.3f m\n", r.max_error_wheel,
              r.max_error_lidar, r.max_error_bim);
  std::printf("APE rmse (xy):   wheel %.3f m, LiDAR %.3f m, BIM-corrected %.3f m\n", r.ape_rmse_wheel,
              r.ape_rmse_lidar, r.ape_rmse_bim);
  if (!r.bim_refined.empty()) {
    std::printf("second pass over the building as estimated (bim_refined.tum): max error %.3f m, APE rmse %.3f m, "
                "end %.3f m\n", r.max_error_refined, r.ape_rmse_refined, r.table.empty() ? 0.0 : r.table.back().error_refined);
  }
  if (r.registrations > 0) {
    std::printf("BIM registration alone vs truth (xy, %zu frames): rms %.3f m, max %.3f m (the model's as-built deviations)\n",
                r.registrations, r.registration_error_rms, r.registration_error_max);
  }
}

std::function<void(std::size_t, std::size_t)> terminal_progress(const std::string& what) {
  if (isatty(fileno(stderr)) == 0) return {};
  return [what](std::size_t done, std::size_t total) {
    if (done % 10 == 0 || done == total) std::fprintf(stderr, "\r  %s: frame %zu / %zu", what.c_str(), done, total);
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

}  // namespace plumb::cli
