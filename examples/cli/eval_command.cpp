// SPDX-License-Identifier: BSD-3-Clause
// `plumb eval EST REF`: APE, RPE, drift and KITTI segment errors of an estimated trajectory
// against a reference, with evo's conventions (evo_ape / evo_rpe reproduce these numbers).

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "plumb/core/error.hpp"
#include "plumb/eval/align.hpp"
#include "plumb/eval/kitti_segments.hpp"
#include "plumb/eval/metrics.hpp"
#include "plumb/io/trajectory.hpp"

namespace plumb::cli {
namespace {

struct EvalOptions {
  std::string estimate_path;
  std::string reference_path;
  std::string format = "tum";
  std::string align = "se3";
  double rpe_delta = 1.0;
  std::string rpe_unit = "frames";
  std::string rpe_pairs_along = "est";
  bool json = false;
  std::string estimate_times;
  std::string reference_times;
  std::vector<std::size_t> drift_at;
  std::vector<double> drift_at_time;
  double max_time_difference = 0.01;
  double time_offset = 0.0;
  double min_pair_fraction = eval::AssociationSettings{}.min_pair_fraction;
  bool orthonormalize = false;
};

eval::AlignMode parse_align(const std::string& name) {
  if (name == "se3") return eval::AlignMode::kSE3;
  if (name == "sim3") return eval::AlignMode::kSim3;
  return eval::AlignMode::kNone;
}

nlohmann::json stats_json(const eval::ErrorStats& s) {
  return {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median}, {"std", s.std},
          {"min", s.min},   {"max", s.max},   {"sse", s.sse},       {"count", s.count}};
}

void print_stats_row(const char* label, const eval::ErrorStats& s) {
  std::printf("  %-16s %11.6f %11.6f %11.6f %11.6f %11.6f %11.6f %7zu\n", label, s.rmse, s.mean, s.median,
              s.std, s.min, s.max, s.count);
}

/// Everything `plumb eval` reports, computed from the two files.
struct EvalResults {
  Trajectory estimate, reference;       // as read
  eval::AssociationResult associated;  // the associated pose pairs
  eval::AlignMode align = eval::AlignMode::kNone;
  eval::ApeResult ape;
  eval::RpeResult rpe;
  std::vector<eval::DriftSample> drift;  // at the asked poses, then at the end of the path
  eval::KittiSegmentResult segments;
};

/// Reads the estimate and the reference in the chosen format.
void read_trajectories(const EvalOptions& o, EvalResults& r) {
  io::TrajectoryReadSettings read_settings;
  read_settings.orthonormalize = o.orthonormalize;
  if (o.format == "tum") {
    PLUMB_CHECK(o.estimate_times.empty() && o.reference_times.empty(),
                "--est-times / --ref-times only apply to --format kitti (TUM files carry stamps)");
    r.estimate = io::read_tum(o.estimate_path, read_settings);
    r.reference = io::read_tum(o.reference_path, read_settings);
  } else {
    r.estimate = io::read_kitti(o.estimate_path, o.estimate_times, read_settings);
    r.reference = io::read_kitti(o.reference_path, o.reference_times, read_settings);
  }
}

/// Associates the two trajectories and computes the APE, refusing an alignment they do not determine.
void associate_and_align(const EvalOptions& o, EvalResults& r) {
  PLUMB_CHECK(o.rpe_unit != "frames" || o.rpe_delta == std::floor(o.rpe_delta),
              "--rpe-delta: " << o.rpe_delta << " is not a whole number of frames (use --rpe-unit m for metres)");
  // Library messages about the pair of trajectories say "associate: ..." or "umeyama: ...";
  // name the two files in front.
  const std::string inputs = o.estimate_path + " vs " + o.reference_path + ": ";
  eval::AssociationSettings association_settings;
  association_settings.max_time_difference = o.max_time_difference;
  association_settings.time_offset = o.time_offset;
  association_settings.min_pair_fraction = o.min_pair_fraction;
  r.align = parse_align(o.align);
  eval::ApeSettings ape_settings;
  ape_settings.align = r.align;
  try {
    r.associated = eval::associate(r.estimate, r.reference, association_settings);
    r.ape = eval::compute_ape(r.associated.estimate, r.associated.reference, ape_settings);
  } catch (const Error& e) {
    throw Error(inputs + e.what());
  }
  const Trajectory& est = r.associated.estimate;
  const Trajectory& ref = r.associated.reference;
  // A degenerate fit still returns a rotation, but an arbitrary one about the line of the
  // positions: every error after it would be made up.
  if (r.align != eval::AlignMode::kNone && r.ape.status != Status::kOk) {
    PLUMB_THROW(inputs << "--align " << o.align << " is not determined by the " << est.size()
                       << " associated positions ("
                       << (r.ape.status == Status::kDegenerate ? "they lie on a line, so the rotation about it is free"
                                                               : "too few poses")
                       << "); use --align none, or trajectories that turn");
  }
  for (std::size_t index : o.drift_at) {
    PLUMB_CHECK(index < ref.size(), "--drift-at: pose index " << index << " is out of range: " << ref.size()
                                        << " pose pairs were associated (indices 0.." << ref.size() - 1 << ")");
  }
}

/// RPE, drift and KITTI segment errors of the associated pairs (after associate_and_align()).
void compute_errors(const EvalOptions& o, EvalResults& r) {
  const Trajectory& est = r.associated.estimate;
  const Trajectory& ref = r.associated.reference;
  eval::RpeSettings rpe_settings;
  rpe_settings.delta = o.rpe_delta;
  rpe_settings.unit = o.rpe_unit == "m" ? eval::DeltaUnit::kMeters : eval::DeltaUnit::kFrames;
  rpe_settings.align = r.align;
  rpe_settings.pairs_along = o.rpe_pairs_along == "ref" ? eval::PathSource::kReference : eval::PathSource::kEstimate;
  r.rpe = eval::compute_rpe(est, ref, rpe_settings);

  // Drift of the aligned estimate, at the end of the path and where asked.
  const Trajectory aligned =
      eval::apply_similarity(est, r.ape.alignment.T_ref_est, r.ape.alignment.scale);
  std::vector<std::size_t> drift_indices = o.drift_at;
  for (double stamp : o.drift_at_time) {
    PLUMB_CHECK(ref.has_stamps(), "--drift-at-time needs stamps (TUM files or KITTI times files)");
    drift_indices.push_back(eval::nearest_index(ref, stamp));
  }
  drift_indices.push_back(ref.size() - 1);
  r.drift = eval::drift_at(aligned, ref, drift_indices);

  r.segments = eval::compute_kitti_segment_errors(aligned, ref);
}

/// Prints the results as one JSON object.
void print_eval_json(const EvalOptions& o, const EvalResults& r) {
  const Trajectory& est = r.associated.estimate;
  const Trajectory& ref = r.associated.reference;
  const eval::ApeResult& ape = r.ape;
  const eval::RpeResult& rpe = r.rpe;
  const std::vector<eval::DriftSample>& drift = r.drift;
  const eval::DriftSample& drift_end = drift.back();
  const eval::KittiSegmentResult& segments = r.segments;
  nlohmann::json out;
  out["ape"] = stats_json(ape.translation.stats);
  out["ape_rotation_deg"] = stats_json(ape.rotation_deg.stats);
  if (rpe.status == Status::kOk) {
    out["rpe"] = stats_json(rpe.translation.stats);
    out["rpe_rotation_deg"] = stats_json(rpe.rotation_deg.stats);
  } else {
    out["rpe"] = nullptr;
    out["rpe_rotation_deg"] = nullptr;
  }
  out["drift_pct"] = drift_end.drift_pct;
  nlohmann::json drift_json = nlohmann::json::array();
  for (std::size_t k = 0; k + 1 < drift.size(); ++k) {
    const eval::DriftSample& s = drift[k];
    nlohmann::json item = {{"index", s.index}, {"path_length_m", s.path_length}, {"error_m", s.error},
                           {"drift_pct", s.drift_pct}};
    if (ref.has_stamps()) item["stamp"] = ref.stamps[s.index];
    drift_json.push_back(item);
  }
  out["drift"] = drift_json;
  out["path_length_m"] = drift_end.path_length;
  const Eigen::Matrix3d R = ape.alignment.T_ref_est.linear();
  const Eigen::Vector3d t = ape.alignment.T_ref_est.translation();
  out["alignment"] = {{"mode", eval::to_string(r.align)},
                      {"scale", ape.alignment.scale},
                      {"status", to_string(ape.alignment.status)},
                      {"rotation", {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)},
                                    {R(2, 0), R(2, 1), R(2, 2)}}},
                      {"translation", {t.x(), t.y(), t.z()}}};
  out["association"] = {{"num_estimate", r.estimate.size()},
                        {"num_reference", r.reference.size()},
                        {"num_pairs", est.size()},
                        {"by_stamp", r.associated.by_stamp}};
  out["rpe_delta"] = {{"delta", o.rpe_delta}, {"unit", o.rpe_unit}, {"num_pairs", rpe.pairs.size()},
                      {"along", o.rpe_pairs_along}};
  if (segments.status == Status::kOk) {
    out["kitti_segments"] = {{"translation_pct", segments.translation_pct},
                             {"rotation_deg_per_m", segments.rotation_deg_per_m},
                             {"num_segments", segments.segments.size()}};
  } else {
    out["kitti_segments"] = nullptr;
  }
  std::cout << out.dump() << '\n';
}

/// Prints the results as a table, then the drift and the KITTI segment errors.
void print_eval_table(const EvalOptions& o, const EvalResults& r) {
  const eval::ApeResult& ape = r.ape;
  const eval::RpeResult& rpe = r.rpe;
  const std::vector<eval::DriftSample>& drift = r.drift;
  const eval::KittiSegmentResult& segments = r.segments;
  std::printf("estimate : %s (%zu poses)\n", o.estimate_path.c_str(), r.estimate.size());
  std::printf("reference: %s (%zu poses)\n", o.reference_path.c_str(), r.reference.size());
  std::printf("associated %zu pose pairs %s\n", r.associated.estimate.size(),
              r.associated.by_stamp ? "by stamp" : "by index");
  std::printf("alignment: %s, scale %.9g (%s)\n\n", eval::to_string(r.align), ape.alignment.scale,
              to_string(ape.alignment.status));
  std::printf("  %-16s %11s %11s %11s %11s %11s %11s %7s\n", "", "rmse", "mean", "median", "std", "min", "max",
              "count");
  print_stats_row("APE trans [m]", ape.translation.stats);
  print_stats_row("APE rot [deg]", ape.rotation_deg.stats);
  if (rpe.status == Status::kOk) {
    print_stats_row("RPE trans [m]", rpe.translation.stats);
    print_stats_row("RPE rot [deg]", rpe.rotation_deg.stats);
  } else {
    std::printf("  RPE: no pose pair %g %s apart\n", o.rpe_delta, o.rpe_unit.c_str());
  }
  std::printf("  (RPE delta %g %s, consecutive pairs along the %s)\n\n", o.rpe_delta, o.rpe_unit.c_str(),
              o.rpe_pairs_along == "ref" ? "reference" : "estimate");
  // Drift is undefined before the reference has moved (path length 0): say so instead of "nan".
  const auto print_drift = [](const std::string& where, const eval::DriftSample& s) {
    if (std::isfinite(s.drift_pct)) {
      std::printf("drift at %s: %.4f %% (error %.4f m over %.3f m)\n", where.c_str(), s.drift_pct, s.error,
                  s.path_length);
    } else {
      std::printf("drift at %s: undefined, the reference has not moved yet (error %.4f m)\n", where.c_str(),
                  s.error);
    }
  };
  for (std::size_t k = 0; k + 1 < drift.size(); ++k) print_drift("pose " + std::to_string(drift[k].index), drift[k]);
  print_drift("the end", drift.back());
  if (segments.status == Status::kOk) {
    std::printf("KITTI segments (100..800 m): translation %.4f %%, rotation %.6f deg/m (%zu segments)\n",
                segments.translation_pct, segments.rotation_deg_per_m, segments.segments.size());
  }
}

void run_eval(const EvalOptions& o) {
  EvalResults r;
  read_trajectories(o, r);
  associate_and_align(o, r);
  compute_errors(o, r);
  if (o.json) {
    print_eval_json(o, r);
  } else {
    print_eval_table(o, r);
  }
}

}  // namespace

void register_eval_command(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand("eval", "Evaluate a trajectory against a reference: APE, RPE, drift %");
  cmd->footer(
      "Refused with exit code 1 and a message naming the file (and line): stamps that do not strictly\n"
      "increase, a coordinate beyond 1e9 m, fewer than 3 associated pose pairs or fewer than\n"
      "--min-pair-fraction of the shorter trajectory's poses (stamps in different units or clocks),\n"
      "and an --align se3/sim3 that the associated positions do not determine (all on a line).\n"
      "drift_pct is null in --json (\"undefined\" in the table) while the reference has not moved.");
  cmd->add_option("EST", options->estimate_path, "Estimated trajectory file")->required();
  cmd->add_option("REF", options->reference_path, "Reference (ground-truth) trajectory file")->required();
  cmd->add_option("--format", options->format, "File format of both trajectories")
      ->check(CLI::IsMember({"tum", "kitti"}))
      ->capture_default_str();
  cmd->add_option("--align", options->align, "Alignment of the estimate to the reference (Umeyama)")
      ->check(CLI::IsMember({"se3", "sim3", "none"}))
      ->capture_default_str();
  cmd->add_option("--rpe-delta", options->rpe_delta, "RPE step, in --rpe-unit (a whole number for frames)")
      ->check(positive_number())
      ->capture_default_str();
  cmd->add_option("--rpe-unit", options->rpe_unit, "Unit of --rpe-delta: m (path length) or frames")
      ->check(CLI::IsMember({"m", "frames"}))
      ->capture_default_str();
  cmd->add_option("--rpe-pairs-along", options->rpe_pairs_along,
                  "Path that measures metre deltas: est (as evo) or ref")
      ->check(CLI::IsMember({"est", "ref"}))
      ->capture_default_str();
  cmd->add_flag("--json", options->json, "Print exactly one JSON object instead of the table");
  cmd->add_option("--est-times", options->estimate_times, "KITTI times file of the estimate");
  cmd->add_option("--ref-times", options->reference_times, "KITTI times file of the reference");
  cmd->add_option("--drift-at", options->drift_at, "Also report drift % at these pose indices (after association)")
      ->check(non_negative_number());
  cmd->add_option("--drift-at-time", options->drift_at_time, "Also report drift % at the poses nearest these stamps [s]")
      ->check(finite_number());
  cmd->add_option("--max-time-diff", options->max_time_difference, "Largest stamp difference to associate [s]")
      ->check(non_negative_number())
      ->capture_default_str();
  cmd->add_option("--time-offset", options->time_offset, "Offset added to the estimate's stamps [s]")
      ->check(finite_number())
      ->capture_default_str();
  cmd->add_option("--min-pair-fraction", options->min_pair_fraction,
                  "Fewest associated pairs, as a share of the shorter trajectory's poses (0 to 1)")
      ->check(finite_number(0.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--orthonormalize", options->orthonormalize,
                "Project KITTI rotations onto SO(3) (default: keep them as printed, as evo does)");
  cmd->callback([options]() {
    naming_inputs({options->estimate_path, options->reference_path, options->estimate_times, options->reference_times},
                  [&] { run_eval(*options); });
  });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(eval, plumb::cli::register_eval_command);
