// `echoreg serve`: a PLUS capture streamed over OpenIGTLink as a PLUS server streams it, so a
// user can rehearse with 3D Slicer and `echoreg live` has a peer (docs/live.md).
#include "commands.hpp"
#include "interrupt.hpp"
#include "validators.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/live/connection.hpp"
#include "echoreg/live/igtl_messages.hpp"
#include "echoreg/live/stream_metadata.hpp"

#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <ostream>
#include <string>
#include <thread>

namespace echoreg::cli {

namespace {

struct ServeOptions {
  std::string capture;
  std::string host = "127.0.0.1";
  int port = 18944;
  std::string rate = "recorded";
  double waitS = 60.0;
  std::string imageName = "Image";
};

// Frames must carry what OpenIGTLink can: timestamps from 0 to 2^32 s, names of 1 to 20 characters.
void checkServable(const core::Sequence& sequence, const std::string& path,
                   const std::string& imageName) {
  if (sequence.frames.empty())
    throw core::FileError(path, "holds no frames to serve");
  if (sequence.hasPixels() && sequence.frameSize[1] != 1) {
    throw core::FileError(path,
                          fmt::format("frames of {} rows: echoreg serves A-lines (frames of N x 1)",
                                      sequence.frameSize[1]));
  }
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const std::optional<double>& t = sequence.frames[f].timestampS;
    if (!t || !(*t >= 0.0) || *t >= 4294967295.0) {
      throw core::FileError(path,
                            fmt::format("frame {} has {}: OpenIGTLink carries timestamps from 0 to "
                                        "2^32 s",
                                        f, t ? fmt::format("timestamp {}", *t) : "no timestamp"));
    }
  }
  for (const std::string& name : sequence.transformNames()) {
    if (name.size() > 20) {
      throw core::FileError(path,
                            fmt::format("transform {} has a name of {} characters: OpenIGTLink "
                                        "device names have at most 20",
                                        name, name.size()));
    }
  }
  if (imageName.empty() || imageName.size() > 20)
    throw std::invalid_argument("--image-name must have 1 to 20 characters");
}

int runServe(const ServeOptions& o, const Streams& io) {
  const core::Sequence sequence = core::readSequence(o.capture);
  checkServable(sequence, o.capture, o.imageName);
  InterruptScope interrupt;
  const std::atomic<bool>* stop = &interruptRequested();
  auto listener = std::make_unique<live::Listener>(o.host, o.port);
  const int port = listener->port();
  io.err << fmt::format("echoreg serve: {}: {} frames, waiting for a client on {}:{}\n", o.capture,
                        sequence.frameCount(), o.host, port);
  std::optional<live::Connection> client = listener->accept(o.waitS, stop);
  // One client only: a second one (e.g. live reconnecting) is refused at once rather than left
  // waiting in the listening socket's queue.
  listener.reset();
  if (!client) {
    if (stop->load()) {
      io.err << "echoreg serve: interrupted before a client connected\n";
      return 1;
    }
    throw std::runtime_error(
        fmt::format("no client connected to {}:{} within --wait {} s", o.host, port, o.waitS));
  }
  const std::string peer = client->peer();
  io.err << fmt::format("echoreg serve: streaming to {}\n", peer);

  // What the client sends back (echoreg live's points and registration, Slicer's messages) is
  // read and dropped, so that its sends never fill the socket and block both sides.
  live::IncomingDiscarder discard(*client);

  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const double firstTimestamp = *sequence.frames.front().timestampS;
  const std::size_t frameBytes =
      sequence.samplesPerFrame() * core::elementSize(sequence.elementType);
  std::size_t messages = 0, bytes = 0, sent = 0;
  double behindS = 0.0;  // --rate recorded: how late the slowest frame went out
  bool warnedBehind = false;
  const auto send = [&](const live::Packet& packet) {
    client->send(packet, -1.0, stop);  // a slow reader is waited for (SIGINT ends it)
    ++messages;
    bytes += packet.size();
  };
  try {
    send(live::encodeString(live::kCaptureHeaderName, live::captureHeaderJson(sequence),
                            firstTimestamp));
    for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
      if (stop->load())
        break;
      const core::SequenceFrame& frame = sequence.frames[f];
      const double t = *frame.timestampS;
      if (o.rate == "recorded") {
        const auto due = start + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(t - firstTimestamp));
        while (Clock::now() < due && !stop->load())
          std::this_thread::sleep_for(
              std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(50)));
      }
      for (const auto& [name, transform] : frame.transforms) {
        // PLUS sends only valid transforms; the status of an invalid one goes as a STATUS of the
        // same name, so the recording keeps it.
        if (transform.valid()) {
          send(live::encodeTransform(name, transform.matrix, t));
        } else {
          send(live::encodeStatus(name, live::kStatusNotReady, transform.status,
                                  name + " " + transform.status, t));
        }
      }
      send(live::encodeString(live::kFrameName, live::frameJson(frame), t));
      if (sequence.hasPixels()) {
        send(live::encodeImage(o.imageName, sequence.elementType,
                               sequence.pixels.data() + f * frameBytes, sequence.frameSize[0],
                               sequence.frameSize[1], t));
      }
      ++sent;
      if (o.rate == "recorded") {
        const double late =
            std::chrono::duration<double>(Clock::now() - start).count() - (t - firstTimestamp);
        behindS = std::max(behindS, late);
        if (late > 1.0 && !warnedBehind) {
          warnedBehind = true;
          io.err << fmt::format(
              "echoreg serve: the client reads more slowly than the recording's rate: frame {} "
              "went out {:.1f} s late; nothing is dropped, the stream waits for it\n",
              f, late);
        }
      }
    }
  } catch (const live::ConnectionClosed& e) {
    if (!stop->load())
      throw std::runtime_error(
          fmt::format("{} after {} of {} frames: {}", peer, sent, sequence.frameCount(), e.what()));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  // The client reads to the end before the connection goes (it may still be sending).
  discard.stop();
  client->closeGracefully(5.0);
  io.out << fmt::format(
      "{}: served {} of {} frames ({} messages, {:.1f} MB) to {} in {:.2f} s{}{}\n", o.capture,
      sent, sequence.frameCount(), messages, static_cast<double>(bytes) / 1e6, peer, seconds,
      behindS > 0.1 ? fmt::format(", up to {:.2f} s behind the recorded timing (the client read "
                                  "more slowly)",
                                  behindS)
                    : std::string(),
      stop->load() ? ", interrupted" : "");
  return 0;
}

}  // namespace

CommandAction addServeCommand(CLI::App& app) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "serve",
      "Stream a PLUS capture over OpenIGTLink as a PLUS server does (docs/live.md): waits for one\n"
      "client, then sends per frame one TRANSFORM per valid transform (named after it, e.g.\n"
      "ProbeToTracker; an invalid one as a STATUS of that name), and one IMAGE of the A-line\n"
      "(1 x N), each with the frame's timestamp; first a STRING EchoregCapture with the capture's\n"
      "acquisition header, and before each IMAGE a STRING EchoregFrame (exact timestamp, fields). "
      "Closes the connection after the last frame. Messages the client sends\n"
      "are read and dropped. Binds 127.0.0.1 unless --host says otherwise.");
  cmd->add_option("capture", o->capture, "PLUS capture (.mha, .mhd, .nrrd)")->required();
  cmd->add_option("--port", o->port, "TCP port (0: any free port, printed on stderr)")
      ->capture_default_str()
      ->check(wholeNumber(0, 65535));
  cmd->add_option("--host", o->host,
                  "Address to listen on (0.0.0.0 for every interface: the network can then reach "
                  "it)")
      ->capture_default_str();
  cmd->add_option("--rate", o->rate,
                  "recorded: frames at their timestamps; max: as fast as the "
                  "client reads")
      ->check(CLI::IsMember({"recorded", "max"}))
      ->capture_default_str();
  cmd->add_option("--wait", o->waitS, "Seconds to wait for a client")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--image-name", o->imageName, "Device name of the IMAGE messages")
      ->capture_default_str();
  return [o](const Streams& io) { return runServe(*o, io); };
}

}  // namespace echoreg::cli
