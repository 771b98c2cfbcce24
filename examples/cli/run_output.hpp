// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What `plumb run` and `plumb demo` both do with a RunReport: the output files, the JSON report
// and the error table of Liu et al. 2022, Table 2, on stdout.

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plumb/app/run.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"

namespace plumb::cli {

/// @brief An output directory a command fills with one set of files, checked before the work and
///        replaced as a whole when the work is done.
///
/// Ownership rule: a directory is plumb's own output of a command when it holds the marker file
/// `.plumb-output` (first line "plumb COMMAND") and nothing but that command's file names (and
/// leftover `.plumb-staging-*` directories of an interrupted run). An empty or missing directory
/// is free. Anything else holds files plumb did not write: it is refused unless `overwrite`, and
/// even then only the command's own file names are replaced (other files are left as they are).
/// Files are written into a staging directory inside OUT; commit() renames them into place and
/// removes the command's files the new set does not have (a shorter dump leaves no stale frame).
/// A run that never commits leaves OUT as it was (a directory it had to create is removed again).
class OutputDir {
 public:
  /// @param names the entries the command writes into OUT (files, or directories such as "frames")
  /// @param replace_own whether plumb's own earlier output of this command may be replaced without
  ///        `overwrite` (`run`, `lio`, `demo`: results are reproducible; `simulate`: no)
  /// @throws plumb::Error naming OUT when it cannot be created or written, is not a directory, or
  ///         holds files the rule above does not allow to replace
  /// @param nested entries allowed in OUT that commit() leaves alone (directories another OutputDir fills)
  OutputDir(std::string dir, std::string command, std::vector<std::string> names, bool overwrite, bool replace_own,
            std::vector<std::string> nested = {});
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::string& dir() const { return dir_; }
  /// Where the files are written before commit() (a directory inside dir()).
  const std::string& staging() const { return staging_; }
  /// Move the staged set into dir() (see the class comment). @throws plumb::Error on a file-system error
  void commit();

  /// The name of the marker file.
  static const char* marker_name() { return ".plumb-output"; }

 private:
  std::string dir_, command_, staging_;
  std::vector<std::string> names_, nested_;
  bool created_ = false, committed_ = false;
};

/// The entries `plumb simulate` writes into a frame dump directory (frames/ holds NNNNNN.pcd only).
const std::vector<std::string>& frame_dump_names();
/// The entries `plumb run` writes.
const std::vector<std::string>& run_output_names();

/// @brief deviations.json of a run that estimated the as-built: the tolerance and one object per element.
nlohmann::json deviations_json(const RunReport& r);

/// The report as JSON (frames, localization, anchors, timings; Table 2 and APE with ground truth).
nlohmann::json run_report_json(const RunReport& r);

/// @brief Throws the message for a first frame that could not be localized (nothing is written then).
/// @throws plumb::Error when r.localization_status is not kOk
void check_localized(const RunReport& r, const io::FrameDumpReader& dump, const std::string& model_name);

/// Writes OUT/report.json, OUT/{wheel,lidar,bim}.tum and OUT/trajectory.svg (floor plan of the
/// model at the robot's height, ground truth when present) into `out_dir` (an OutputDir's staging);
/// with deviations (--as-built) also deviations.json, deviations.csv, deviations.svg and
/// deviations.bcf (app/deviation_files.hpp; the BCF dated by the first frame's stamp as Unix time).
/// @throws plumb::Error on a write error, or when the localization failed (nothing written)
void write_run_outputs(const RunReport& r, const nlohmann::json& report, const bim::BimMesh& mesh,
                       const io::FrameDumpReader& dump, const std::string& out_dir, const std::string& title,
                       const std::string& model_name);

/// Prints each of `warnings` as "warning: ..." on stderr.
void print_warnings(const std::vector<std::string>& warnings);

/// Prints the frame counts and, with ground truth, the initial-localization error, Table 2 and APE.
void print_run_summary(const RunReport& r);

/// A progress callback printing "frame i / n" on stderr when it is a terminal; empty otherwise.
std::function<void(std::size_t, std::size_t)> terminal_progress(const std::string& what);

}  // namespace plumb::cli
