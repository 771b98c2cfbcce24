// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Frame dump directories: the exchange format between the simulator, `plumb run` / `lio`
///        and users' own recorded data (LiDAR frames, wheel encoders, wheel odometry, IMU, ground
///        truth). Layout (every file but meta.json and frames.csv optional):
///
/// ```
/// DIR/meta.json        sensor model, extrinsics T_base_lidar / T_base_imu (4x4 row-major),
///                      nominal wheel_radius_left / wheel_radius_right / axle, units
/// DIR/frames.csv       index,stamp,file        (file relative to DIR, e.g. frames/000000.pcd)
/// DIR/frames/NNNNNN.pcd  LiDAR frame: x y z intensity ring time label; time [s] since the stamp
/// DIR/wheels.csv       stamp,left,right        cumulative wheel angles [rad] (io/wheel_encoders.hpp)
/// DIR/odom.csv         stamp,x,y,theta         wheel odometry integrated with the nominal parameters
/// DIR/imu.csv          stamp,wx,wy,wz,ax,ay,az angular rate [rad/s], specific force [m/s^2], IMU frame
/// DIR/gt.tum           true T_world_base at the frame stamps (TUM)
/// DIR/gt_dense.tum     true T_world_base, dense (TUM)
/// DIR/as_built.json    simulated dumps: every BIM element's true as-built displacement
///                      T_design_asbuilt (4x4 row-major, world frame), by global_id
/// ```
/// CSV files start with exactly that header line; `#` lines and blank lines are skipped; fields
/// are separated by commas. Stamps are in seconds and must increase strictly within a file.

#include <cstddef>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/as_built.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/io/pcd.hpp"

namespace plumb::io {

// The readings a dump holds are the library's own (plumb/core/sensor_data.hpp).
using plumb::ImuSample;
using plumb::OdomSample;

/// @brief The LiDAR as described in meta.json (informative; frames carry their own points).
struct DumpLidar {
  std::string name;                    ///< e.g. "rfans32"; empty when unknown
  double rate_hz = 0.0;                ///< revolutions per second, 0 when unknown
  int columns = 0;                     ///< firings per revolution and line, 0 when unknown
  std::vector<double> elevations_rad;  ///< one per ring [rad], may be empty
  double min_range = 0.0;              ///< [m]
  double max_range = 0.0;              ///< [m], 0 when unknown
};

/// @brief Contents of meta.json.
struct FrameDumpMeta {
  DumpLidar lidar;
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();  ///< lidar points into the base frame
  Eigen::Isometry3d T_base_imu = Eigen::Isometry3d::Identity();    ///< IMU frame into the base frame
  double wheel_radius_left = 0.0;   ///< nominal [m]; 0 when the dump has no wheels
  double wheel_radius_right = 0.0;  ///< nominal [m]; 0 when the dump has no wheels
  double axle = 0.0;                ///< nominal wheel separation [m]; 0 when the dump has no wheels
  double imu_rate_hz = 0.0;         ///< 0 when unknown or no IMU
  Vector3d origin_offset = Vector3d::Zero();  ///< BIM/IFC world = dump world + offset [m]
  std::string source;    ///< free text: what produced the dump (e.g. "plumb simulate")
  std::string model;     ///< free text: the building model, when known
  std::string scenario;  ///< free text: e.g. "indoor"
};

/// @brief Settings of FrameDumpWriter.
struct FrameDumpWriteSettings {
  PcdEncoding encoding = PcdEncoding::kBinary;  ///< PCD DATA kind of the frames
  /// Allow writing into a directory that already holds a dump file (meta.json, frames.csv, ...,
  /// frames/NNNNNN.pcd): all of them are removed first (other files are left). False: refused.
  bool overwrite = false;
};

/// @brief Writes a frame dump directory incrementally (frames are streamed, not held in memory).
///
/// Usage: construct (writes meta.json, creates DIR/frames), add_frame() per LiDAR frame, the
/// write_*() functions once each, then close() (also called by the destructor, which swallows errors).
/// @note Not thread safe; one writer per directory.
class FrameDumpWriter {
 public:
  /// @throws plumb::Error if the directory cannot be created or written, or already holds a dump
  ///         and `settings.overwrite` is false.
  FrameDumpWriter(const std::string& dir, const FrameDumpMeta& meta, const FrameDumpWriteSettings& settings = {});
  ~FrameDumpWriter();
  FrameDumpWriter(const FrameDumpWriter&) = delete;
  FrameDumpWriter& operator=(const FrameDumpWriter&) = delete;

  /// @brief Write frames/NNNNNN.pcd and its frames.csv line.
  /// @throws plumb::Error if the stamp does not increase or the cloud is inconsistent.
  void add_frame(double stamp, const PointCloud& cloud_lidar);
  void write_wheels(const std::vector<WheelEncoderReading>& wheels);      ///< wheels.csv
  void write_odometry(const std::vector<OdomSample>& odometry);   ///< odom.csv
  void write_imu(const std::vector<ImuSample>& imu);              ///< imu.csv
  void write_ground_truth(const Trajectory& T_world_base);        ///< gt.tum
  void write_ground_truth_dense(const Trajectory& T_world_base);  ///< gt_dense.tum
  void write_as_built(const std::vector<ElementDeviation>& elements);  ///< as_built.json
  /// @brief Flush and close frames.csv. @throws plumb::Error on a write error.
  void close();

  std::size_t num_frames() const { return num_frames_; }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
  FrameDumpWriteSettings settings_;
  std::FILE* frames_csv_ = nullptr;
  std::size_t num_frames_ = 0;
  double last_stamp_ = 0.0;
};

/// @brief imu.csv read one sample at a time, so that a long run's memory does not grow with the
///        length of its IMU log (run_lio() feeds its estimator from one).
///
/// The rows are checked as parse_frame_dump_imu() checks them; a bad row throws from the next()
/// call that reaches it, naming `path:LINE`.
class ImuCsvReader {
 public:
  /// @throws plumb::Error when `path` is missing, a directory or unreadable.
  explicit ImuCsvReader(const std::string& path);
  ~ImuCsvReader();
  ImuCsvReader(ImuCsvReader&&) noexcept;
  ImuCsvReader& operator=(ImuCsvReader&&) noexcept;

  /// @brief The next sample into `out`; false at the end of the file.
  /// @throws plumb::Error `path:LINE: message` on a missing header, a wrong field count, a field
  ///         that is not a finite number or a stamp that does not increase; `path: empty file` when
  ///         the file ends before its header line; `path: read error`.
  bool next(ImuSample& out);
  const std::string& path() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// @brief Lazy reader of a frame dump: opening reads meta.json and frames.csv only; frames and the
///        other files are read when asked for.
/// @note Every malformed file gives plumb::Error naming the file and the line (meta.json: line and
///       column). const member functions may be called from several threads.
class FrameDumpReader {
 public:
  /// @throws plumb::Error if DIR/meta.json or DIR/frames.csv is missing or malformed.
  explicit FrameDumpReader(const std::string& dir);

  const FrameDumpMeta& meta() const { return meta_; }
  const std::string& dir() const { return dir_; }
  std::size_t num_frames() const { return stamps_.size(); }
  double stamp(std::size_t i) const;              ///< @throws plumb::Error when out of range
  const std::vector<double>& stamps() const { return stamps_; }
  std::string frame_path(std::size_t i) const;    ///< absolute or DIR-relative path of frame i
  /// @brief Read frame i (LiDAR frame, fields as stored). @throws plumb::Error on a bad file.
  PointCloud frame(std::size_t i) const;

  bool has_wheels() const;             ///< wheels.csv exists
  bool has_odometry() const;           ///< odom.csv exists
  bool has_imu() const;                ///< imu.csv exists
  bool has_ground_truth() const;       ///< gt.tum exists
  bool has_ground_truth_dense() const; ///< gt_dense.tum exists
  bool has_as_built() const;           ///< as_built.json exists
  std::vector<WheelEncoderReading> wheels() const;   ///< @throws plumb::Error when absent or malformed
  std::vector<OdomSample> odometry() const;  ///< @throws plumb::Error when absent or malformed
  std::vector<ImuSample> imu() const;        ///< @throws plumb::Error when absent or malformed
  /// @brief imu.csv one sample at a time (see ImuCsvReader). @throws plumb::Error when absent.
  ImuCsvReader imu_reader() const;
  Trajectory ground_truth() const;           ///< @throws plumb::Error when absent or malformed
  Trajectory ground_truth_dense() const;     ///< @throws plumb::Error when absent or malformed
  /// @brief The elements of as_built.json in file order.
  /// @throws plumb::Error naming the file when absent, and file:line:column when malformed.
  std::vector<ElementDeviation> as_built() const;

 private:
  std::string dir_;
  FrameDumpMeta meta_;
  std::vector<double> stamps_;
  std::vector<std::string> files_;
};

/// @brief The rows of frames.csv.
struct FrameDumpIndex {
  std::vector<double> stamps;      ///< [s], strictly increasing
  std::vector<std::string> files;  ///< as written: relative to DIR or absolute
};

/// @brief Parse frames.csv text (`index,stamp,file`; indices 0, 1, 2, ...); `name` is used in messages.
/// @throws plumb::Error `name:LINE: message` on a missing header, a wrong field count, a field that
///         is not a finite number, an index out of sequence, a stamp that does not increase or an
///         empty file name.
FrameDumpIndex parse_frame_dump_frames(const std::string& text, const std::string& name = "frames.csv");
/// @brief Parse odom.csv text (`stamp,x,y,theta`); `name` is used in messages.
/// @throws plumb::Error `name:LINE: message` as parse_frame_dump_frames().
std::vector<OdomSample> parse_frame_dump_odometry(const std::string& text, const std::string& name = "odom.csv");
/// @brief Parse imu.csv text (`stamp,wx,wy,wz,ax,ay,az`); `name` is used in messages.
/// @throws plumb::Error `name:LINE: message` as parse_frame_dump_frames().
std::vector<ImuSample> parse_frame_dump_imu(const std::string& text, const std::string& name = "imu.csv");

/// @brief meta.json text for `meta` (what FrameDumpWriter writes).
std::string frame_dump_meta_json(const FrameDumpMeta& meta);
/// @brief Parse meta.json text; `name` is used in messages.
/// @throws plumb::Error `name:LINE:COL: message` on malformed JSON, a missing required key
///         (T_base_lidar), a value of the wrong kind, a number that is not finite (e.g. 1e999; the
///         message names the key), a transform that is not rigid, or a lidar rate_hz that is neither
///         0 (unknown) nor in [0.1, 1000] Hz.
FrameDumpMeta parse_frame_dump_meta(const std::string& text, const std::string& name = "meta.json");

/// @brief as_built.json text for `elements` (what FrameDumpWriter::write_as_built writes):
///        `{"elements": [{"global_id": ..., "type": ..., "T_design_asbuilt": [16 numbers]}, ...]}`,
///        numbers written so that they read back exactly.
std::string frame_dump_as_built_json(const std::vector<ElementDeviation>& elements);
/// @brief Parse as_built.json text; `name` is used in messages.
/// @throws plumb::Error `name:LINE:COL: message` on malformed JSON, a missing "elements" array or
///         entry key, a value of the wrong kind, a number that is not finite, or a transform that is
///         not rigid.
std::vector<ElementDeviation> parse_frame_dump_as_built(const std::string& text,
                                                        const std::string& name = "as_built.json");

}  // namespace plumb::io
