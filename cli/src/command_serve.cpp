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
  int repeat = 1;  // times the capture is played; 0: until the client closes or SIGINT
};

// --repeat: each pass after the first goes on from where the last ended, one frame interval (the
// capture's mean) after its last frame, as PLUS's saved-data source does when it loops, so the
// client sees one stream whose timestamps keep increasing.
double passPeriodS(const core::Sequence& sequence) {
  const double first = *sequence.frames.front().timestampS;
  const double last = *sequence.frames.back().timestampS;
  const std::size_t n = sequence.frames.size();
  return (last - first) * static_cast<double>(n) / static_cast<double>(n - 1);
}

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

void checkRepeatable(const core::Sequence& sequence, const std::string& path, int repeat) {
  if (repeat == 1)
    return;
  const std::size_t n = sequence.frames.size();
  if (n < 2 || !(*sequence.frames.back().timestampS > *sequence.frames.front().timestampS)) {
    throw core::FileError(path,
                          fmt::format("--repeat {} needs frames spread over time to go on from, "
                                      "and this capture has {} frame(s) over 0 s",
                                      repeat, n));
  }
  for (std::size_t f = 1; f < n; ++f) {
    if (!(*sequence.frames[f].timestampS > *sequence.frames[f - 1].timestampS)) {
      throw core::FileError(path,
                            fmt::format("--repeat {}: frame {}'s timestamp {} does not follow "
                                        "frame {}'s {}, so the passes cannot follow each other",
                                        repeat, f, *sequence.frames[f].timestampS, f - 1,
                                        *sequence.frames[f - 1].timestampS));
    }
  }
  // The last pass must still carry timestamps OpenIGTLink can (under 2^32 s).
  if (repeat > 1) {
    const double lastT = *sequence.frames.back().timestampS +
                         static_cast<double>(repeat - 1) * passPeriodS(sequence);
    if (lastT >= 4294967295.0)
      throw core::FileError(path,
                            fmt::format("--repeat {} would reach timestamp {:.0f} s: OpenIGTLink "
                                        "carries timestamps up to 2^32 s",
                                        repeat, lastT));
  }
}

// "400 of 400 frames", or with --repeat "12000 frames (30 whole passes of the 400-frame capture)".
std::string servedFrames(std::size_t sent, std::size_t captureFrames, int repeat, int passes) {
  if (repeat == 1)
    return fmt::format("{} of {} frames", sent, captureFrames);
  return fmt::format("{} frames ({} whole passes of the {}-frame capture)", sent, passes,
                     captureFrames);
}

int runServe(const ServeOptions& o, const Streams& io) {
  const core::Sequence sequence = core::readSequence(o.capture);
  checkServable(sequence, o.capture, o.imageName);
  checkRepeatable(sequence, o.capture, o.repeat);
  InterruptScope interrupt;
  const std::atomic<bool>* stop = &interruptRequested();
  auto listener = std::make_unique<live::Listener>(o.host, o.port);
  const int port = listener->port();
  io.err << fmt::format("echoreg serve: {}: {} frames{}, waiting for a client on {}:{}\n",
                        o.capture, sequence.frameCount(),
                        o.repeat == 1   ? std::string()
                        : o.repeat == 0 ? std::string(", repeated until the client closes")
                                        : fmt::format(", {} times", o.repeat),
                        o.host, port);
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
  const double period = o.repeat == 1 ? 0.0 : passPeriodS(sequence);
  std::size_t messages = 0, bytes = 0, sent = 0;
  int passes = 0;
  bool clientClosed = false;
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
    for (int pass = 0; (o.repeat == 0 || pass < o.repeat) && !stop->load(); ++pass) {
      const double shift = static_cast<double>(pass) * period;
      for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
        if (stop->load())
          break;
        const core::SequenceFrame& frame = sequence.frames[f];
        const double t = *frame.timestampS + shift;
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
        send(live::encodeString(live::kFrameName, live::frameJson(frame, t), t));
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
      if (!stop->load())
        ++passes;
    }
  } catch (const live::ConnectionClosed& e) {
    // --repeat 0 plays until the client closes: that is its end, not a failure.
    clientClosed = true;
    if (!stop->load() && o.repeat != 0)
      throw std::runtime_error(
          fmt::format("{} after {}: {}", peer,
                      servedFrames(sent, sequence.frameCount(), o.repeat, passes), e.what()));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  // The client reads to the end before the connection goes (it may still be sending).
  discard.stop();
  client->closeGracefully(5.0);
  io.out << fmt::format(
      "{}: served {} ({} messages, {:.1f} MB) to {} in {:.2f} s{}{}\n", o.capture,
      servedFrames(sent, sequence.frameCount(), o.repeat, passes), messages,
      static_cast<double>(bytes) / 1e6, peer, seconds,
      behindS > 0.1 ? fmt::format(", up to {:.2f} s behind the recorded timing (the client read "
                                  "more slowly)",
                                  behindS)
                    : std::string(),
      stop->load()   ? ", interrupted"
      : clientClosed ? ", until the client closed"
                     : "");
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
      "acquisition header, and before each IMAGE a STRING EchoregFrame (exact timestamp, fields).\n"
      "Closes the connection after the last frame (of the last pass, with --repeat). Messages\n"
      "the client sends are read and dropped. Binds 127.0.0.1 unless --host says otherwise.");
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
  cmd->add_option("--repeat", o->repeat,
                  "Times the capture is played, as PLUS's saved-data source loops it: each pass "
                  "goes on one frame interval after the last, its timestamps shifted so that they "
                  "keep increasing (0: until the client closes or SIGINT)")
      ->capture_default_str()
      ->check(wholeNumber(0, 1000000));
  return [o](const Streams& io) { return runServe(*o, io); };
}

}  // namespace echoreg::cli
