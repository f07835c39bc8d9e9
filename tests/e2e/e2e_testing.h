// Helpers shared by the end-to-end tests: a fresh scratch folder, running the built `aerovo`,
// the grey terrain of the tests that fly over generated ground, and reading back the files a
// run wrote (whole text, JSON, line count, frames.csv as rows).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/camera/pinhole.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::e2e {

// Scratch folders and whole files: core/testing.h (shared with the modules' tests).
using ::aerovo::testing::FreshTempDir;
using ::aerovo::testing::ReadText;
using ::aerovo::testing::UnusedTempPath;

#ifdef AEROVO_CLI_PATH
/// Runs the built `aerovo` with `args` (a shell command line), its stdout and stderr to `log`;
/// returns std::system's status (0 = exit 0).
inline int RunCli(const std::string& args, const std::filesystem::path& log = "/dev/null") {
  const std::string cmd =
      std::string(AEROVO_CLI_PATH) + " " + args + " > " + log.string() + " 2>&1";
  return std::system(cmd.c_str());
}

/// RunCli with the output discarded: true when `aerovo` exited with 0.
inline bool Cli(const std::string& args) { return RunCli(args) == 0; }
#endif

/// Grey procedural terrain of size_px x size_px at metres_per_px (sim::GenerateTerrain, seed).
inline cv::Mat GreyTerrain(double metres_per_px, unsigned seed, int size_px = 1600) {
  sim::TerrainOptions t;
  t.width_px = size_px;
  t.height_px = size_px;
  t.metres_per_px = metres_per_px;
  t.seed = seed;
  cv::Mat grey;
  cv::cvtColor(sim::GenerateTerrain(t), grey, cv::COLOR_BGR2GRAY);
  return grey;
}

/// The nadir frame of width x height pixels cut from `ground` (metres_per_px per pixel) at
/// (x_m east, y_m north) metres from the ground image's centre, turned by heading_rad
/// (counter-clockwise seen from above), seen by a sensor with `scale` times the pixels per side:
/// ground pixel = centre + (x, -y) / metres_per_px + R(-heading) (p - c) / scale, c the frame's
/// centre. Bilinear, the ground reflected at its borders.
inline cv::Mat RenderNadir(const cv::Mat& ground, double metres_per_px, double x_m, double y_m,
                           double heading_rad, int width, int height, int scale = 1) {
  const double c = std::cos(-heading_rad) / scale, s = std::sin(-heading_rad) / scale;
  const double cx = 0.5 * (width * scale - 1), cy = 0.5 * (height * scale - 1);
  const double gx = 0.5 * (ground.cols - 1) + x_m / metres_per_px;
  const double gy = 0.5 * (ground.rows - 1) - y_m / metres_per_px;
  const cv::Matx23d ground_from_frame(c, -s, gx - (c * cx - s * cy), s, c, gy - (s * cx + c * cy));
  cv::Mat frame;
  cv::warpAffine(ground, frame, ground_from_frame, cv::Size(width * scale, height * scale),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  return frame;
}

/// The file parsed as JSON; null when it cannot be opened (a run that wrote no summary: the
/// test's assertions on the fields then fail), nlohmann::json::parse_error when malformed.
inline nlohmann::json ReadJson(const std::filesystem::path& p) {
  std::ifstream in(p);
  nlohmann::json j;
  if (in) in >> j;
  return j;
}

/// The camera of a simulated flight (`aerovo simulate`'s sim.json "camera" in `sim_dir`):
/// pinhole or fisheye lens, its focal length, principal point and distortion.
inline CameraIntrinsics SimCamera(const std::filesystem::path& sim_dir) {
  const nlohmann::json cam = ReadJson(sim_dir / "sim.json")["camera"];
  CameraIntrinsics k;
  k.width_px = cam["width_px"];
  k.height_px = cam["height_px"];
  k.fx_px = k.fy_px = cam["focal_px"].get<double>();
  k.cx_px = cam["cx_px"];
  k.cy_px = cam["cy_px"];
  k.model = cam["model"] == "fisheye" ? LensModel::kFisheye : LensModel::kPinhole;
  k.distortion = cam["distortion"].get<std::vector<double>>();
  return k;
}

/// Number of lines of the file (0 when it cannot be read).
inline int CountLines(const std::filesystem::path& p) {
  std::ifstream in(p);
  int n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

/// The rows of a CSV file of aerovo's (frames.csv, map_fixes.csv, ...) as column name -> cell:
/// no quoting (aerovo's cells hold no comma); a cell missing at the end of a row (a trailing
/// empty one) is "". Empty when the file is missing or has only its header.
inline std::vector<std::map<std::string, std::string>> ReadCsvRows(
    const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::map<std::string, std::string>> rows;
  std::string line;
  if (!std::getline(in, line)) return rows;
  std::vector<std::string> header;
  std::stringstream hs(line);
  for (std::string f; std::getline(hs, f, ',');) header.push_back(f);
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::stringstream ls(line);
    std::string f;
    for (const std::string& column : header) {
      if (!std::getline(ls, f, ',')) f.clear();
      row[column] = f;
    }
    rows.push_back(row);
  }
  return rows;
}

/// A run folder's frames.csv (ReadCsvRows).
inline std::vector<std::map<std::string, std::string>> ReadFramesCsv(
    const std::filesystem::path& run_dir) {
  return ReadCsvRows(run_dir / "frames.csv");
}

// A live source delivering `source`'s frames at `fps` whether or not they are taken (a camera
// or stream): frame k at k / fps s after the first Next(), as Frame::time_s and index k.
class PacedLiveSource : public FrameSource {
 public:
  PacedLiveSource(std::unique_ptr<FrameSource> source, double fps)
      : source_(std::move(source)), period_s_(1.0 / fps) {}
  bool Next(Frame& frame) override {
    if (count_ == 0) start_ = std::chrono::steady_clock::now();
    std::this_thread::sleep_until(start_ + std::chrono::duration<double>(period_s_ * count_));
    if (!source_->Next(frame)) return false;
    frame.time_s = period_s_ * count_;
    frame.index = count_++;
    return true;
  }
  std::string Describe() const override { return "paced live source"; }
  bool IsLive() const override { return true; }

 private:
  std::unique_ptr<FrameSource> source_;
  double period_s_;
  std::chrono::steady_clock::time_point start_;
  int count_ = 0;
};

// A loopback UDP socket playing the autopilot: every ODOMETRY received (aerovo's own parser:
// the independent decoders are tests/mavlink's node-mavlink scripts).
class OdometryListener {
 public:
  OdometryListener() : fd_(::socket(AF_INET, SOCK_DGRAM, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t n = sizeof a;
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&a), n) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &n) != 0) {
      port_ = -1;
    } else {
      port_ = ntohs(a.sin_port);
    }
  }
  ~OdometryListener() {
    if (fd_ >= 0) ::close(fd_);
  }
  int port() const { return port_; }
  // The ODOMETRY messages received so far (the run has ended: nothing waits).
  std::vector<mavlink::Odometry> Odometries() {
    std::vector<mavlink::Odometry> out;
    mavlink::Parser parser;
    uint8_t buf[2048];
    for (ssize_t n; (n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT)) > 0;) {
      parser.Feed(buf, static_cast<std::size_t>(n), [&](const mavlink::Packet& p) {
        if (const auto o = mavlink::Decode<mavlink::Odometry>(p)) out.push_back(*o);
      });
    }
    return out;
  }
  std::vector<int> ResetCounters() {
    std::vector<int> out;
    for (const mavlink::Odometry& o : Odometries()) out.push_back(o.reset_counter);
    return out;
  }

 private:
  int fd_;
  int port_ = -1;
};

}  // namespace aerovo::e2e
