// A TCP connection on which OpenIGTLink messages go both ways (POSIX sockets: OpenIGTLink 1.11's
// ServerSocket binds every interface, echoreg binds the address it is given, loopback by default).
// Every wait is bounded and checks a stop flag, so SIGINT or a silent peer never hangs a session.
#pragma once

#include "echoreg/live/igtl_messages.hpp"

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>

namespace echoreg::live {

/// The peer closed the connection, or it broke.
class ConnectionClosed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The peer is connected but took no byte for the send's timeout (its socket stayed full).
class SendTimedOut : public ConnectionClosed {
 public:
  using ConnectionClosed::ConnectionClosed;
};

/// One connected stream. Move-only; closes on destruction.
class Connection {
 public:
  explicit Connection(int socket) : socket_(socket) {}
  ~Connection();
  Connection(Connection&& other) noexcept : socket_(other.socket_) { other.socket_ = -1; }
  Connection& operator=(Connection&& other) noexcept;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// Connects to host:port, retrying until `timeoutS` has passed (a server that is starting);
  /// an attempt waits for a host that does not answer at most until then (at least 0.2 s). Throws
  /// std::runtime_error naming host and port when no connection was made, and ConnectionClosed when
  /// `stop` was set meanwhile.
  static Connection connect(const std::string& host, int port, double timeoutS,
                            const std::atomic<bool>* stop = nullptr);

  /// Sends every byte; throws ConnectionClosed when the peer has gone or when `stop` is set while
  /// the socket is full, and SendTimedOut (a ConnectionClosed) when `timeoutS` (>= 0) passes
  /// without the peer taking a byte (a peer that does not read). A negative timeout waits as long
  /// as the peer is connected.
  void send(const Packet& packet, double timeoutS = -1.0, const std::atomic<bool>* stop = nullptr);

  /// Reads exactly `count` bytes. Returns false when `stop` was set or `idleTimeoutS` passed
  /// before the first byte; throws ConnectionClosed when the peer closes (mid-message included).
  bool read(std::uint8_t* out, std::size_t count, double idleTimeoutS,
            const std::atomic<bool>* stop);

  std::string peer() const;

  /// Ends the connection so that the peer reads everything sent: no more sending (FIN), then
  /// what the peer still sends is read and dropped until it closes or `timeoutS` passes. (Closing
  /// a socket with unread data would reset the connection and lose data still in flight.)
  void closeGracefully(double timeoutS);

 private:
  int socket_ = -1;
};

/// A listening socket on one address.
class Listener {
 public:
  /// Binds host:port (port 0: any free port). Throws std::runtime_error naming the address.
  Listener(const std::string& host, int port);
  ~Listener();
  Listener(const Listener&) = delete;
  Listener& operator=(const Listener&) = delete;

  int port() const { return port_; }
  /// Waits for one connection up to `timeoutS`; nullopt on timeout or when `stop` is set.
  std::optional<Connection> accept(double timeoutS, const std::atomic<bool>* stop = nullptr);

 private:
  int socket_ = -1;
  int port_ = 0;
};

/// Reads whole messages from a connection, refusing bodies above a size limit.
class MessageReader {
 public:
  explicit MessageReader(std::size_t maxBodyBytes) : maxBodyBytes_(maxBodyBytes) {}

  struct Received {
    std::optional<Message> message;  ///< empty when the message was skipped (see `problem`)
    std::string problem;             ///< why a message was skipped ("" when none)
  };
  /// The next message. nullopt when `stop` was set or nothing arrived for `idleTimeoutS`.
  /// A body that does not unpack is read and skipped (Received::problem says why); an oversized
  /// body or a bad header throws ProtocolError (the stream cannot be followed past it), and a
  /// closed connection throws ConnectionClosed.
  std::optional<Received> next(Connection& connection, double idleTimeoutS,
                               const std::atomic<bool>* stop);

 private:
  std::size_t maxBodyBytes_;
  std::uint8_t header_[kHeaderBytes] = {};
  std::vector<std::uint8_t> body_;
};

/// Reads and drops whatever the peer sends, on a thread of its own, so that the peer's sends never
/// fill the socket and block both sides (a server that only streams, as `echoreg serve` and a PLUS
/// server do). Runs until stop() or destruction, or until the peer goes away or sends something
/// that cannot be followed (the sending side reports that).
class IncomingDiscarder {
 public:
  explicit IncomingDiscarder(Connection& connection);
  ~IncomingDiscarder();
  IncomingDiscarder(const IncomingDiscarder&) = delete;
  IncomingDiscarder& operator=(const IncomingDiscarder&) = delete;
  void stop();

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace echoreg::live
