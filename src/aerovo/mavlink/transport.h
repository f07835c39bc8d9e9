// The byte links a MAVLink stream runs on, named by a URL:
//   udp:HOST:PORT     send to HOST:PORT (a ground station, mavlink-router, a flight controller's
//                     UDP port); replies sent back to aerovo's port are read too;
//   udpin:HOST:PORT   listen on HOST:PORT (0.0.0.0 for every interface); packets are sent to
//                     whoever sent the last datagram (nothing is sent before one arrives; with
//                     a signing key: the last datagram with a correctly signed packet);
//   serial:DEVICE:BAUD  a serial port (termios raw 8N1, no flow control), e.g.
//                     serial:/dev/ttyAMA0:921600 for a flight controller's TELEM port.
// Every transport is non-blocking: Send never waits (a full buffer drops the packet, counted),
// Receive returns what is there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace aerovo::mavlink {

/// A parsed link URL.
struct LinkUrl {
  enum class Kind { kUdpOut, kUdpIn, kSerial };
  Kind kind = Kind::kUdpOut;
  std::string host;    ///< udp/udpin: IPv4 address or host name.
  int port = 0;        ///< udp/udpin: 1 .. 65535.
  std::string device;  ///< serial: the device path.
  int baud = 0;        ///< serial: a standard rate (9600 .. 4000000).
  std::string text;    ///< The URL as given.
  /// udpin and serial: the flight controller talks on the link (height, attitude in).
  bool reads_autopilot() const { return kind != Kind::kUdpOut; }
};

/// Parses `url`; InvalidArgument naming it and saying what is wrong (unknown scheme, missing or
/// bad port, baud rate not supported).
LinkUrl ParseLinkUrl(const std::string& url);

/// A non-blocking byte link.
class Transport {
 public:
  virtual ~Transport() = default;
  /// Sends one packet (a datagram for UDP); false when it could not be sent now (no peer yet
  /// for udpin, buffer full, error).
  virtual bool Send(const uint8_t* data, std::size_t n) = 0;
  /// Reads what has arrived, at most `capacity` bytes (one datagram for UDP); 0 when nothing.
  virtual std::size_t Receive(uint8_t* buffer, std::size_t capacity) = 0;
  /// The file descriptor to poll() for reading.
  virtual int fd() const = 0;
  /// udpin: from now on the peer is no longer whoever sent the last datagram but the sender of
  /// the last datagram confirmed with KeepLastSender() (a link with a signing key confirms a
  /// datagram that held a correctly signed packet, so that no one without the key can redirect
  /// what aerovo sends). Nothing for the other transports.
  virtual void RequireConfirmedPeer() {}
  /// udpin after RequireConfirmedPeer(): the sender of the last datagram Receive() returned
  /// becomes the peer.
  virtual void KeepLastSender() {}
};

/// Opens `url`: InputError naming the URL and the system's reason when it cannot be opened
/// (host not resolved, port in use, no such device, ...).
std::unique_ptr<Transport> OpenTransport(const LinkUrl& url);

}  // namespace aerovo::mavlink
