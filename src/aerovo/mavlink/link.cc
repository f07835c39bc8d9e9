#include "aerovo/mavlink/link.h"

#include <poll.h>
#include <time.h>

#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo::mavlink {
namespace {

double ClockS(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

int64_t ClockNs(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

template <class S>
void PushBounded(std::deque<S>& q, const S& s, std::size_t max) {
  q.push_back(s);
  while (q.size() > max) q.pop_front();
}

template <class S>
std::optional<S> Nearest(const std::deque<S>& q, double time_s, double tolerance_s) {
  std::optional<S> best;
  double best_dt = tolerance_s;
  for (const S& s : q) {
    const double dt = std::abs(s.time_s - time_s);
    if (dt <= best_dt) {
      best = s;
      best_dt = dt;
    }
  }
  return best;
}

}  // namespace

double MonotonicNowS() { return ClockS(CLOCK_MONOTONIC); }
double UnixNowS() { return ClockS(CLOCK_REALTIME); }

AutopilotLink::AutopilotLink(std::unique_ptr<Transport> transport, Options options)
    : transport_(std::move(transport)), options_(options) {
  if (!transport_) throw InvalidArgument("AutopilotLink: the transport is null");
  if (options_.signing_key) {
    signing_ = std::make_unique<SigningState>(*options_.signing_key, options_.link_id,
                                              options_.signing_initial_timestamp);
    transport_->RequireConfirmedPeer();
    stats_.signing = true;
  }
  thread_ = std::thread([this] { Loop(); });
}

AutopilotLink::~AutopilotLink() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  SaveSigningTimestamp();
}

void AutopilotLink::SaveSigningTimestamp() {
  if (!signing_ || options_.signing_timestamp_file.empty()) return;
  bool ok = true;
  try {
    WriteSigningTimestamp(options_.signing_timestamp_file, signing_->local_timestamp());
  } catch (const InputError&) {
    ok = false;
  }
  std::lock_guard<std::mutex> lock(data_mutex_);
  ++(ok ? stats_.signing_timestamp_saves : stats_.signing_timestamp_save_failed);
}

bool AutopilotLink::SendLocked(const std::vector<uint8_t>& bytes) {
  const bool ok = transport_->Send(bytes.data(), bytes.size());
  std::lock_guard<std::mutex> lock(data_mutex_);
  ++(ok ? stats_.sent : stats_.send_failed);
  return ok;
}

void AutopilotLink::Loop() {
  std::vector<uint8_t> buffer(65536);
  double next_heartbeat_s = MonotonicNowS();
  double next_timestamp_save_s = next_heartbeat_s + options_.signing_timestamp_period_s;
  bool heard_peer = false;
  while (!stop_) {
    const double now_s = MonotonicNowS();
    if (now_s >= next_timestamp_save_s) {
      SaveSigningTimestamp();
      next_timestamp_save_s = now_s + options_.signing_timestamp_period_s;
    }
    if (now_s >= next_heartbeat_s) {
      if (Send(Heartbeat{})) {
        std::lock_guard<std::mutex> lock(data_mutex_);
        ++stats_.heartbeats;
      }
      next_heartbeat_s = now_s + options_.heartbeat_period_s;
    }
    pollfd p{transport_->fd(), POLLIN, 0};
    const int wait_ms = static_cast<int>(std::ceil(1000.0 * (next_heartbeat_s - now_s)));
    if (poll(&p, 1, std::max(1, std::min(50, wait_ms))) <= 0) continue;
    while (!stop_) {
      std::size_t n = 0;
      {
        std::lock_guard<std::mutex> lock(send_mutex_);  // udpin: the peer changes on receive
        n = transport_->Receive(buffer.data(), buffer.size());
      }
      if (n == 0) break;
      const double t = MonotonicNowS();
      bool authentic = false;
      parser_.Feed(buffer.data(), n, [&](const Packet& packet) {
        if (!Authentic(packet)) return;
        if (signing_ && !authentic) {
          // Its sender becomes the peer before Handle() answers it (a TIMESYNC).
          std::lock_guard<std::mutex> lock(send_mutex_);
          transport_->KeepLastSender();
        }
        authentic = true;
        Handle(packet, t);
      });
      if (!heard_peer && (authentic || !signing_)) {
        // udpin: the peer is known from its first datagram on (with a key: its first one with
        // a correctly signed packet); announce ourselves at once rather than at the next period
        // (a short run could otherwise end unannounced).
        heard_peer = true;
        next_heartbeat_s = t;
      }
      std::lock_guard<std::mutex> lock(data_mutex_);
      stats_.parser = parser_.stats();
    }
  }
}

bool AutopilotLink::Authentic(const Packet& packet) {
  if (!signing_) return true;
  const SignatureCheck c = signing_->Check(packet, UnixNowS());
  std::lock_guard<std::mutex> lock(data_mutex_);
  switch (c) {
    case SignatureCheck::kAccepted:
      ++stats_.signed_accepted;
      return true;
    case SignatureCheck::kUnsigned:
      ++stats_.rejected_unsigned;
      break;
    case SignatureCheck::kBadSignature:
      ++stats_.rejected_bad_signature;
      break;
    case SignatureCheck::kReplayed:
      ++stats_.rejected_replayed;
      break;
  }
  return false;
}

void AutopilotLink::Handle(const Packet& packet, double now_s) {
  if (const auto ts = Decode<Timesync>(packet)) {
    if (ts->tc1 != 0) return;  // an answer to someone else
    Timesync answer;
    answer.tc1 = ClockNs(CLOCK_MONOTONIC);
    answer.ts1 = ts->ts1;
    answer.target_system = packet.header.sysid;
    answer.target_component = packet.header.compid;
    if (Send(answer)) {
      std::lock_guard<std::mutex> lock(data_mutex_);
      ++stats_.timesync_answers;
    }
    return;
  }
  std::lock_guard<std::mutex> lock(data_mutex_);
  if (const auto d = Decode<DistanceSensor>(packet)) {
    // A downward rangefinder's reading inside its range (cm -> m).
    if (d->orientation != kMavSensorRotationPitch270) return;
    if (d->current_distance < d->min_distance || d->current_distance > d->max_distance) return;
    PushBounded(distance_, AutopilotHeight{now_s, 0.01 * d->current_distance,
                                           HeightSourceKind::kDistanceSensor},
                options_.max_samples);
    ++stats_.distance_samples;
  } else if (const auto g = Decode<GlobalPositionInt>(packet)) {
    PushBounded(relative_alt_, AutopilotHeight{now_s, 0.001 * g->relative_alt,
                                               HeightSourceKind::kRelativeAlt},
                options_.max_samples);
    ++stats_.relative_alt_samples;
  } else if (const auto a = Decode<Attitude>(packet)) {
    if (!std::isfinite(a->roll) || !std::isfinite(a->pitch) || !std::isfinite(a->yaw)) return;
    PushBounded(attitude_, AutopilotAttitude{now_s, a->roll, a->pitch, a->yaw},
                options_.max_samples);
    ++stats_.attitude_samples;
  } else if (packet.header.msgid == Heartbeat::kId) {
    ++stats_.autopilot_heartbeats;
  }
}

std::optional<AutopilotHeight> AutopilotLink::HeightNear(double time_s, double tolerance_s) const {
  std::lock_guard<std::mutex> lock(data_mutex_);
  if (auto d = Nearest(distance_, time_s, tolerance_s)) return d;
  return Nearest(relative_alt_, time_s, tolerance_s);
}

std::optional<AutopilotAttitude> AutopilotLink::AttitudeNear(double time_s,
                                                             double tolerance_s) const {
  std::lock_guard<std::mutex> lock(data_mutex_);
  return Nearest(attitude_, time_s, tolerance_s);
}

bool AutopilotLink::WaitForHeight(double timeout_s) const {
  const double end_s = MonotonicNowS() + timeout_s;
  while (true) {
    {
      std::lock_guard<std::mutex> lock(data_mutex_);
      if (!distance_.empty() || !relative_alt_.empty()) return true;
    }
    if (MonotonicNowS() >= end_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::string DescribeNoHeight(const LinkStats& st) {
  const ParserStats& p = st.parser;
  std::string t;
  const auto add = [&t](const std::string& part) { t += (t.empty() ? "" : "; ") + part; };
  if (p.v1_packets > 0) {
    // ArduPilot's Serial 1 and 2 default to MAVLink 1 on most autopilots (ardupilot.org,
    // "Serial Port Configuration Options": SERIALx_PROTOCOL 1 MAVLink1, 2 MAVLink2).
    add(
        fmt::format("{} MAVLink 1 packets, not read: aerovo reads MAVLink 2 (ArduPilot: "
                    "SERIALn_PROTOCOL = 2, docs/autopilot.md)",
                    p.v1_packets));
  }
  if (p.crc_errors > 0) {
    add(
        fmt::format("{} packets with a wrong checksum (a damaged link, a wrong baud rate or "
                    "another dialect)",
                    p.crc_errors));
  }
  const uint64_t rejected = st.rejected_unsigned + st.rejected_bad_signature + st.rejected_replayed;
  if (rejected > 0) {
    add(fmt::format(
        "{} packets refused by signing ({} unsigned, {} signed with another key, {} "
        "replayed): does the autopilot have the key of --mavlink-key?",
        rejected, st.rejected_unsigned, st.rejected_bad_signature, st.rejected_replayed));
  }
  if (p.packets > 0) {
    add(
        fmt::format("{} packets read ({} heartbeats), none a height: no DISTANCE_SENSOR facing "
                    "down nor GLOBAL_POSITION_INT",
                    p.packets, st.autopilot_heartbeats));
  }
  if (t.empty() && p.bytes_skipped > 0) {
    add(
        fmt::format("{} bytes, no MAVLink packet in them (another protocol, or a wrong baud "
                    "rate?)",
                    p.bytes_skipped));
  }
  return t.empty() ? "nothing received" : t;
}

LinkStats AutopilotLink::stats() const {
  std::lock_guard<std::mutex> lock(data_mutex_);
  return stats_;
}

}  // namespace aerovo::mavlink
