#include "aerovo/mavlink/transport.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo::mavlink {
namespace {

int ParsePort(const std::string& s, const std::string& url) {
  if (s.empty() || s.size() > 5 || s.find_first_not_of("0123456789") != std::string::npos) {
    throw InvalidArgument(fmt::format("--mavlink '{}': the port '{}' is not a number", url, s));
  }
  const int port = std::stoi(s);
  if (port < 1 || port > 65535) {
    throw InvalidArgument(fmt::format("--mavlink '{}': the port must be 1..65535, got {}", url, port));
  }
  return port;
}

speed_t BaudConstant(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 1500000: return B1500000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    case 4000000: return B4000000;
    default: return 0;
  }
}

std::string Errno() { return std::strerror(errno); }

sockaddr_in Resolve(const LinkUrl& url) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(url.host.c_str(), nullptr, &hints, &res);
  if (rc != 0 || res == nullptr) {
    throw InputError(fmt::format("--mavlink '{}': cannot resolve host '{}': {}", url.text,
                                 url.host, gai_strerror(rc)));
  }
  sockaddr_in a{};
  std::memcpy(&a, res->ai_addr, sizeof(a));
  freeaddrinfo(res);
  a.sin_port = htons(static_cast<uint16_t>(url.port));
  return a;
}

class UdpTransport : public Transport {
 public:
  explicit UdpTransport(const LinkUrl& url) : listen_(url.kind == LinkUrl::Kind::kUdpIn) {
    const sockaddr_in addr = Resolve(url);
    fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw InputError(fmt::format("--mavlink '{}': socket: {}", url.text, Errno()));
    if (listen_) {
      const int one = 1;
      setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
      if (bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
        const std::string why = Errno();
        close(fd_);
        throw InputError(fmt::format("--mavlink '{}': cannot listen on {}:{}: {}", url.text,
                                     url.host, url.port, why));
      }
    } else {
      peer_ = addr;
      have_peer_ = true;
    }
  }
  ~UdpTransport() override {
    if (fd_ >= 0) close(fd_);
  }
  bool Send(const uint8_t* data, std::size_t n) override {
    if (!have_peer_) return false;
    const ssize_t s = sendto(fd_, data, n, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&peer_),
                             sizeof(peer_));
    return s == static_cast<ssize_t>(n);
  }
  std::size_t Receive(uint8_t* buffer, std::size_t capacity) override {
    sockaddr_in from{};
    socklen_t len = sizeof(from);
    const ssize_t r = recvfrom(fd_, buffer, capacity, MSG_DONTWAIT,
                               reinterpret_cast<sockaddr*>(&from), &len);
    if (r <= 0) return 0;
    last_sender_ = from;
    if (listen_ && !confirmed_peer_) {  // answer whoever talks to us
      peer_ = from;
      have_peer_ = true;
    }
    return static_cast<std::size_t>(r);
  }
  int fd() const override { return fd_; }
  void RequireConfirmedPeer() override { confirmed_peer_ = true; }
  void KeepLastSender() override {
    if (!listen_ || !confirmed_peer_) return;
    peer_ = last_sender_;
    have_peer_ = true;
  }

 private:
  bool listen_ = false;
  bool confirmed_peer_ = false;  // udpin: the peer changes on KeepLastSender() only
  sockaddr_in last_sender_{};
  int fd_ = -1;
  sockaddr_in peer_{};
  bool have_peer_ = false;
};

class SerialTransport : public Transport {
 public:
  explicit SerialTransport(const LinkUrl& url) {
    fd_ = open(url.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) {
      throw InputError(fmt::format("--mavlink '{}': cannot open {}: {}", url.text, url.device,
                                   Errno()));
    }
    termios t{};
    if (tcgetattr(fd_, &t) != 0) {
      const std::string why = Errno();
      close(fd_);
      throw InputError(fmt::format("--mavlink '{}': {} is not a serial port: {}", url.text,
                                   url.device, why));
    }
    cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    t.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS | CSTOPB | PARENB);
    t.c_cc[VMIN] = 0;
    t.c_cc[VTIME] = 0;
    cfsetispeed(&t, BaudConstant(url.baud));
    cfsetospeed(&t, BaudConstant(url.baud));
    if (tcsetattr(fd_, TCSANOW, &t) != 0) {
      const std::string why = Errno();
      close(fd_);
      throw InputError(fmt::format("--mavlink '{}': cannot set {} to {} baud raw: {}", url.text,
                                   url.device, url.baud, why));
    }
  }
  ~SerialTransport() override {
    if (fd_ >= 0) close(fd_);
  }
  bool Send(const uint8_t* data, std::size_t n) override {
    const ssize_t s = write(fd_, data, n);
    return s == static_cast<ssize_t>(n);
  }
  std::size_t Receive(uint8_t* buffer, std::size_t capacity) override {
    const ssize_t r = read(fd_, buffer, capacity);
    return r > 0 ? static_cast<std::size_t>(r) : 0;
  }
  int fd() const override { return fd_; }

 private:
  int fd_ = -1;
};

}  // namespace

LinkUrl ParseLinkUrl(const std::string& url) {
  LinkUrl u;
  u.text = url;
  const auto colon = url.find(':');
  const std::string scheme = colon == std::string::npos ? url : url.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : url.substr(colon + 1);
  const auto last = rest.rfind(':');
  if (scheme != "udp" && scheme != "udpin" && scheme != "serial") {
    throw InvalidArgument(fmt::format(
        "--mavlink '{}': unknown link, expected udp:HOST:PORT, udpin:HOST:PORT or "
        "serial:DEVICE:BAUD",
        url));
  }
  if (last == std::string::npos || last == 0) {
    throw InvalidArgument(fmt::format("--mavlink '{}': expected {}:{}", url, scheme,
                                      scheme == "serial" ? "DEVICE:BAUD" : "HOST:PORT"));
  }
  const std::string first = rest.substr(0, last), second = rest.substr(last + 1);
  if (scheme == "serial") {
    u.kind = LinkUrl::Kind::kSerial;
    u.device = first;
    if (second.empty() || second.find_first_not_of("0123456789") != std::string::npos ||
        second.size() > 8 || BaudConstant(std::stoi(second)) == 0) {
      throw InvalidArgument(fmt::format(
          "--mavlink '{}': baud rate '{}' not supported (9600, 19200, 38400, 57600, 115200, "
          "230400, 460800, 500000, 921600, 1000000, 1500000, 2000000, 3000000, 4000000)",
          url, second));
    }
    u.baud = std::stoi(second);
    return u;
  }
  u.kind = scheme == "udp" ? LinkUrl::Kind::kUdpOut : LinkUrl::Kind::kUdpIn;
  u.host = first;
  u.port = ParsePort(second, url);
  return u;
}

std::unique_ptr<Transport> OpenTransport(const LinkUrl& url) {
  if (url.kind == LinkUrl::Kind::kSerial) return std::make_unique<SerialTransport>(url);
  return std::make_unique<UdpTransport>(url);
}

}  // namespace aerovo::mavlink
