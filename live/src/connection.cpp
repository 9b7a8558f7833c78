// POSIX TCP for the live session: bounded waits (poll) that look at a stop flag every 50 ms.
#include "echoreg/live/connection.hpp"

#include <fmt/format.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

namespace echoreg::live {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kPollSliceMs = 50;

bool stopped(const std::atomic<bool>* stop) {
  return stop != nullptr && stop->load();
}

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

sockaddr_in resolve(const std::string& host, int port) {
  if (port < 0 || port > 65535)
    throw std::runtime_error(fmt::format("port {} is not a TCP port (0-65535)", port));
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int code = ::getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (code != 0 || found == nullptr) {
    throw std::runtime_error(
        fmt::format("host '{}' cannot be resolved: {}", host, ::gai_strerror(code)));
  }
  sockaddr_in address{};
  std::memcpy(&address, found->ai_addr, sizeof(address));
  ::freeaddrinfo(found);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  return address;
}

// One connection attempt that waits at most `waitS` (at least one poll slice) for the peer's
// answer, looking at `stop`: a blocking connect() to a host that does not answer would wait
// for the kernel's SYN timeout (minutes). Leaves the socket blocking again. Sets `error`.
bool connectWithin(int socket, const sockaddr_in& address, double waitS,
                   const std::atomic<bool>* stop, std::string& error) {
  const int flags = ::fcntl(socket, F_GETFL, 0);
  ::fcntl(socket, F_SETFL, flags | O_NONBLOCK);
  bool connected =
      ::connect(socket, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) == 0;
  if (!connected && errno != EINPROGRESS) {
    error = std::strerror(errno);
    return false;
  }
  const Clock::time_point start = Clock::now();
  while (!connected) {
    pollfd descriptor{socket, POLLOUT, 0};
    const int ready = ::poll(&descriptor, 1, kPollSliceMs);
    if (ready > 0) {
      int code = 0;
      socklen_t length = sizeof(code);
      ::getsockopt(socket, SOL_SOCKET, SO_ERROR, &code, &length);
      if (code != 0) {
        error = std::strerror(code);
        return false;
      }
      connected = true;
    } else if (ready < 0 && errno != EINTR) {
      error = std::strerror(errno);
      return false;
    } else if (stopped(stop) || secondsSince(start) >= waitS) {
      error = "no answer";
      return false;
    }
  }
  ::fcntl(socket, F_SETFL, flags);
  return true;
}

void lowLatency(int socket) {
  const int on = 1;
  ::setsockopt(socket, IPPROTO_TCP, TCP_NODELAY, &on, sizeof(on));
}

}  // namespace

Connection::~Connection() {
  if (socket_ >= 0)
    ::close(socket_);
}

Connection& Connection::operator=(Connection&& other) noexcept {
  if (this != &other) {
    if (socket_ >= 0)
      ::close(socket_);
    socket_ = other.socket_;
    other.socket_ = -1;
  }
  return *this;
}

Connection Connection::connect(const std::string& host, int port, double timeoutS,
                               const std::atomic<bool>* stop) {
  const sockaddr_in address = resolve(host, port);
  const Clock::time_point start = Clock::now();
  std::string lastError;
  while (true) {
    if (stopped(stop))
      throw ConnectionClosed("stopped before a connection was made");
    const int socket = ::socket(AF_INET, SOCK_STREAM, 0);
    if (socket < 0)
      throw std::runtime_error(fmt::format("cannot create a socket: {}", std::strerror(errno)));
    // Each attempt waits for an answer at most until the timeout (and at least 0.2 s).
    if (connectWithin(socket, address, std::max(0.2, timeoutS - secondsSince(start)), stop,
                      lastError)) {
      lowLatency(socket);
      return Connection(socket);
    }
    ::close(socket);
    if (secondsSince(start) >= timeoutS) {
      throw std::runtime_error(fmt::format("no OpenIGTLink server at {}:{} within {} s ({})", host,
                                           port, timeoutS, lastError));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void Connection::send(const Packet& packet, double timeoutS, const std::atomic<bool>* stop) {
  std::size_t sent = 0;
  Clock::time_point lastProgress = Clock::now();
  while (sent < packet.size()) {
    // Without waiting while the socket takes bytes; when it is full (the peer does not read),
    // wait for room in slices that look at `stop` and the timeout.
    const ssize_t n =
        ::send(socket_, packet.data() + sent, packet.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      lastProgress = Clock::now();
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      throw ConnectionClosed(
          fmt::format("the peer closed the connection ({})", std::strerror(errno)));
    }
    if (stopped(stop))
      throw ConnectionClosed("stopped while sending");
    if (timeoutS >= 0.0 && secondsSince(lastProgress) >= timeoutS) {
      throw SendTimedOut(fmt::format(
          "the peer read nothing for {} s (its socket is full; {} of {} bytes of a message sent)",
          timeoutS, sent, packet.size()));
    }
    pollfd descriptor{socket_, POLLOUT, 0};
    const int ready = ::poll(&descriptor, 1, kPollSliceMs);
    if (ready < 0 && errno != EINTR)
      throw ConnectionClosed(fmt::format("the connection broke ({})", std::strerror(errno)));
  }
}

bool Connection::read(std::uint8_t* out, std::size_t count, double idleTimeoutS,
                      const std::atomic<bool>* stop) {
  std::size_t got = 0;
  const Clock::time_point start = Clock::now();
  while (got < count) {
    if (stopped(stop))
      return false;
    // What has arrived is taken without waiting (one system call per read while data flows);
    // only when nothing is there, wait for it in slices that look at `stop`.
    const ssize_t n = ::recv(socket_, out + got, count - got, MSG_DONTWAIT);
    if (n > 0) {
      got += static_cast<std::size_t>(n);
      continue;
    }
    if (n == 0) {
      throw ConnectionClosed(got == 0
                                 ? "the peer closed the connection"
                                 : "the peer closed the connection in the middle of a message");
    }
    if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
      throw ConnectionClosed(fmt::format("the connection broke ({})", std::strerror(errno)));
    pollfd descriptor{socket_, POLLIN, 0};
    const int ready = ::poll(&descriptor, 1, kPollSliceMs);
    if (ready < 0 && errno != EINTR)
      throw ConnectionClosed(fmt::format("the connection broke ({})", std::strerror(errno)));
    if (ready <= 0 && got == 0 && secondsSince(start) >= idleTimeoutS)
      return false;
  }
  return true;
}

void Connection::closeGracefully(double timeoutS) {
  if (socket_ < 0)
    return;
  ::shutdown(socket_, SHUT_WR);
  const Clock::time_point start = Clock::now();
  std::uint8_t sink[4096];
  while (secondsSince(start) < timeoutS) {
    pollfd descriptor{socket_, POLLIN, 0};
    if (::poll(&descriptor, 1, kPollSliceMs) <= 0)
      continue;
    const ssize_t n = ::recv(socket_, sink, sizeof(sink), 0);
    if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN))
      break;
  }
  ::close(socket_);
  socket_ = -1;
}

std::string Connection::peer() const {
  sockaddr_in address{};
  socklen_t length = sizeof(address);
  if (::getpeername(socket_, reinterpret_cast<sockaddr*>(&address), &length) != 0)
    return "?";
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &address.sin_addr, text, sizeof(text));
  return fmt::format("{}:{}", text, ntohs(address.sin_port));
}

Listener::Listener(const std::string& host, int port) {
  const sockaddr_in address = resolve(host, port);
  socket_ = ::socket(AF_INET, SOCK_STREAM, 0);
  if (socket_ < 0)
    throw std::runtime_error(fmt::format("cannot create a socket: {}", std::strerror(errno)));
  const int on = 1;
  ::setsockopt(socket_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on));
  if (::bind(socket_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0 ||
      ::listen(socket_, 1) != 0) {
    const std::string problem = std::strerror(errno);
    ::close(socket_);
    socket_ = -1;
    throw std::runtime_error(fmt::format("cannot listen on {}:{}: {}", host, port, problem));
  }
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  ::getsockname(socket_, reinterpret_cast<sockaddr*>(&bound), &length);
  port_ = ntohs(bound.sin_port);
}

Listener::~Listener() {
  if (socket_ >= 0)
    ::close(socket_);
}

std::optional<Connection> Listener::accept(double timeoutS, const std::atomic<bool>* stop) {
  const Clock::time_point start = Clock::now();
  while (!stopped(stop) && secondsSince(start) < timeoutS) {
    pollfd descriptor{socket_, POLLIN, 0};
    if (::poll(&descriptor, 1, kPollSliceMs) <= 0)
      continue;
    const int socket = ::accept(socket_, nullptr, nullptr);
    if (socket >= 0) {
      lowLatency(socket);
      return Connection(socket);
    }
  }
  return std::nullopt;
}

std::optional<MessageReader::Received> MessageReader::next(Connection& connection,
                                                           double idleTimeoutS,
                                                           const std::atomic<bool>* stop) {
  if (!connection.read(header_, kHeaderBytes, idleTimeoutS, stop))
    return std::nullopt;
  const MessageHeader header = decodeHeader(header_);
  if (header.bodyBytes > maxBodyBytes_) {
    throw ProtocolError(fmt::format(
        "{} '{}' announces a body of {} bytes, more than the limit of {} bytes (--max-message-mb): "
        "refused, and the connection closed (the stream cannot be followed past it)",
        header.type, header.deviceName, header.bodyBytes, maxBodyBytes_));
  }
  body_.resize(static_cast<std::size_t>(header.bodyBytes));
  if (!body_.empty() && !connection.read(body_.data(), body_.size(), 1e9, stop))
    return std::nullopt;
  Received received;
  try {
    received.message = decodeBody(header, header_, body_.data());
  } catch (const ProtocolError& e) {
    received.problem = e.what();
  }
  return received;
}

IncomingDiscarder::IncomingDiscarder(Connection& connection)
    : thread_([this, &connection] {
        MessageReader reader(std::size_t{1} << 30);
        try {
          while (!stop_.load())
            reader.next(connection, 0.05, &stop_);
        } catch (const std::exception&) {
          // The peer went away or sent something unreadable: the sending side reports it.
        }
      }) {}

IncomingDiscarder::~IncomingDiscarder() {
  stop();
}

void IncomingDiscarder::stop() {
  stop_ = true;
  if (thread_.joinable())
    thread_.join();
}

}  // namespace echoreg::live
