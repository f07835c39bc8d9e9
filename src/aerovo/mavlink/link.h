// The link to a flight controller: one transport (transport.h), a receive thread that parses
// what arrives (protocol.h), answers TIMESYNC requests, sends a HEARTBEAT every second and keeps
// the autopilot's recent height and attitude samples (DISTANCE_SENSOR facing down,
// GLOBAL_POSITION_INT.relative_alt, ATTITUDE), each stamped with aerovo's monotonic clock at
// reception; and Send() for the frame loop (never blocks on the network). Thread-safe.
// With a signing key (Options::signing_key; signing.h) every packet sent is signed and only
// packets signed with the key whose timestamps move forward are used; the others are counted
// and dropped before anything reads them, and on udpin only such a packet's sender becomes the
// peer that aerovo's packets go to.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"
#include "aerovo/mavlink/signing.h"
#include "aerovo/mavlink/transport.h"

namespace aerovo::mavlink {

/// CLOCK_MONOTONIC (seconds since the machine booted): the clock of "time since boot".
double MonotonicNowS();
/// CLOCK_REALTIME, seconds since the Unix epoch.
double UnixNowS();

/// Where a height above ground came from.
enum class HeightSourceKind { kDistanceSensor, kRelativeAlt };

/// A height sample of the autopilot.
struct AutopilotHeight {
  double time_s = 0.0;  ///< Reception, MonotonicNowS().
  double height_m = 0.0;
  HeightSourceKind source = HeightSourceKind::kDistanceSensor;
};

/// An attitude sample of the autopilot (ATTITUDE: NED Euler angles).
struct AutopilotAttitude {
  double time_s = 0.0;  ///< Reception, MonotonicNowS().
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
};

/// Counts of a link.
struct LinkStats {
  uint64_t sent = 0;            ///< Packets sent.
  uint64_t send_failed = 0;     ///< Packets not sent (no peer yet on udpin, buffer full).
  uint64_t heartbeats = 0;      ///< HEARTBEATs sent.
  uint64_t timesync_answers = 0;
  uint64_t distance_samples = 0;      ///< Downward DISTANCE_SENSOR readings kept.
  uint64_t relative_alt_samples = 0;  ///< GLOBAL_POSITION_INT readings kept.
  uint64_t attitude_samples = 0;
  uint64_t autopilot_heartbeats = 0;  ///< HEARTBEATs received.
  bool signing = false;               ///< A signing key is set (signing.h).
  uint64_t signed_accepted = 0;       ///< Signing: packets accepted (key and timestamp right).
  uint64_t rejected_unsigned = 0;     ///< Signing: unsigned packets dropped.
  uint64_t rejected_bad_signature = 0;  ///< Signing: signature not made with the key (forged).
  uint64_t rejected_replayed = 0;  ///< Signing: timestamp not after its stream's last (replay).
  uint64_t signing_timestamp_saves = 0;   ///< Signing: the timestamp file written.
  uint64_t signing_timestamp_save_failed = 0;  ///< Signing: the timestamp file not written.
  ParserStats parser;
};

/// Why a link gave no height, from its counts: what arrived that is not read (MAVLink 1
/// packets, bytes of no packet, checksum errors, packets refused by signing) or that nothing
/// did, and when packets were read, that none was a height (a downward DISTANCE_SENSOR or
/// GLOBAL_POSITION_INT). One line, for the log of a run that waited for the autopilot's first
/// height (pipeline/run_setup.cc).
std::string DescribeNoHeight(const LinkStats& stats);

class AutopilotLink {
 public:
  struct Options {
    uint8_t sysid = 1;  ///< Our system id: the vehicle's (the companion belongs to it).
    uint8_t compid = kMavCompIdVisualInertialOdometry;
    double heartbeat_period_s = 1.0;  ///< HEARTBEAT rate 1 Hz (MAVLink heartbeat protocol).
    std::size_t max_samples = 512;    ///< Samples kept per kind (newest; a few s at 50-100 Hz).
    /// MAVLink 2 signing key: sign everything sent, accept only packets signed with it.
    std::optional<SigningKey> signing_key;
    uint8_t link_id = 0;  ///< The link id of our signatures (one link: 0).
    /// Signing: the first timestamp is after this one (a stored timestamp: signing.h
    /// ReadSigningTimestamp).
    uint64_t signing_initial_timestamp = 0;
    /// Signing: the file the local timestamp is written to every signing_timestamp_period_s
    /// and when the link closes (WriteSigningTimestamp); "" = not kept.
    std::string signing_timestamp_file;
    /// Default 10 s (the MAVLink guide asks for at least once a minute).
    double signing_timestamp_period_s = 10.0;
  };
  /// Starts the receive thread on `transport` (not null).
  AutopilotLink(std::unique_ptr<Transport> transport, Options options);
  ~AutopilotLink();
  AutopilotLink(const AutopilotLink&) = delete;
  AutopilotLink& operator=(const AutopilotLink&) = delete;

  /// Sends `m` now (sequence number, our sysid/compid); false when it could not be sent.
  template <class M>
  bool Send(const M& m) {
    std::lock_guard<std::mutex> lock(send_mutex_);
    std::vector<uint8_t> bytes = Encode(m, seq_++, options_.sysid, options_.compid);
    if (signing_) signing_->Sign(&bytes, M::kCrcExtra, UnixNowS());
    return SendLocked(bytes);
  }

  /// The height sample nearest to `time_s` (MonotonicNowS clock) within `tolerance_s`, of the
  /// best source that has one: a downward DISTANCE_SENSOR, else GLOBAL_POSITION_INT's
  /// relative_alt; nullopt when neither has a sample that close.
  std::optional<AutopilotHeight> HeightNear(double time_s, double tolerance_s) const;
  /// The ATTITUDE sample nearest to `time_s` within `tolerance_s`.
  std::optional<AutopilotAttitude> AttitudeNear(double time_s, double tolerance_s) const;
  /// Waits until a height sample has arrived or `timeout_s` has passed; true when there is one.
  bool WaitForHeight(double timeout_s) const;
  /// Signing: writes the local timestamp to Options::signing_timestamp_file now (counted in
  /// LinkStats; nothing without a key or a file). Also done every signing_timestamp_period_s and
  /// by the destructor.
  void SaveSigningTimestamp();
  LinkStats stats() const;

 private:
  void Loop();
  // Signing: whether `packet` may be used (counted when not).
  bool Authentic(const Packet& packet);
  void Handle(const Packet& packet, double now_s);
  bool SendLocked(const std::vector<uint8_t>& bytes);

  std::unique_ptr<Transport> transport_;
  Options options_;
  std::unique_ptr<SigningState> signing_;  // null without a key
  std::mutex send_mutex_;  // transport writes, seq_, send counters
  uint8_t seq_ = 0;
  mutable std::mutex data_mutex_;  // samples and the other counters
  std::deque<AutopilotHeight> distance_, relative_alt_;
  std::deque<AutopilotAttitude> attitude_;
  LinkStats stats_;
  Parser parser_;  // receive thread only
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace aerovo::mavlink
