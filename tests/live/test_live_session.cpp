// `echoreg serve` and `echoreg live` on loopback, in this process: everything served is
// recorded; a peer that breaks the protocol, a pose stream that stops, a server that closes and
// SIGINT each end or mark the session with a clear message and never hang (every wait in the
// commands is bounded; the peers here stop by themselves). The registration itself against
// `register` is tests/study/test_live.cpp (it needs the simulated study).
#include "aline_generator.hpp"
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/live/connection.hpp"
#include "echoreg/live/igtl_messages.hpp"
#include "echoreg/live/stream_metadata.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <thread>

namespace echoreg::live {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::runEchoreg;

int freePort() {
  Listener listener("127.0.0.1", 0);
  return listener.port();
}

// The demo sweep with a bone marker on every frame and a field (as PLUS writes ImageStatus).
core::Sequence sweep(int frames) {
  test::DemoSweepOptions options;
  options.frames = frames;
  core::Sequence s = test::makeDemoSweep(options);
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    core::TrackedTransform femur;
    femur.matrix.topRightCorner<3, 1>() =
        Eigen::Vector3d(5.0, -3.0, 20.0 + 0.01 * static_cast<double>(f));
    s.frames[f].transforms["FemurToTracker"] = femur;
    s.frames[f].fields = {{"ImageStatus", "OK"}};
  }
  s.extraHeader.push_back({"UltrasoundImageOrientation", "MF"});
  return s;
}

class LiveSession : public ::testing::Test {
 protected:
  void SetUp() override {
    // A closed cube as the bone model, BeamToProbe and an initial FemurToCT: enough for live to
    // run; these sweeps are not of the cube, so their final registration is not the point here.
    std::ofstream cube(dir_.file("cube.obj"));
    const double h = 50.0;
    for (int i = 0; i < 8; ++i)
      cube << "v " << ((i & 1) ? h : -h) << " " << ((i & 2) ? h : -h) << " " << ((i & 4) ? h : -h)
           << "\n";
    cube << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    cube.close();
    core::TransformFile calibration{"Beam", "Probe", Eigen::Matrix4d::Identity(), {}};
    core::writeTransformFile(dir_.file("BeamToProbe.json"), calibration, false);
    core::TransformFile initial{"Femur", "CT", Eigen::Matrix4d::Identity(), {}};
    core::writeTransformFile(dir_.file("initial.json"), initial, false);
  }

  std::vector<std::string> liveArgs(int port, const std::vector<std::string>& more = {}) const {
    std::vector<std::string> a{"live",
                               "--connect",
                               "127.0.0.1:" + std::to_string(port),
                               "--record",
                               dir_.file("rec.igs.mha"),
                               "--model",
                               dir_.file("cube.obj"),
                               "--calibration",
                               dir_.file("BeamToProbe.json"),
                               "--initial",
                               dir_.file("initial.json"),
                               "--out",
                               dir_.file("FemurToCT.json"),
                               "--session-json",
                               dir_.file("session.json"),
                               "--idle-timeout",
                               "5",
                               "--connect-timeout",
                               "10",
                               "--adapt-frames",
                               "20"};
    a.insert(a.end(), more.begin(), more.end());
    return a;
  }

  nlohmann::json session() const {
    std::ifstream in(dir_.file("session.json"));
    return nlohmann::json::parse(in);
  }

  // A hand-made server: sends what `feed` sends to the first client, then closes.
  std::future<void> fakeServer(int port, std::function<void(Connection&)> feed) {
    auto listener = std::make_shared<Listener>("127.0.0.1", port);
    return std::async(std::launch::async, [listener, feed] {
      std::optional<Connection> client = listener->accept(10.0);
      if (client) {
        feed(*client);
        client->closeGracefully(5.0);
      }
    });
  }

  test::TempDir dir_;
};

void sendFrame(Connection& c, const core::Sequence& s, std::size_t f, bool withProbe = true) {
  const core::SequenceFrame& frame = s.frames[f];
  const double t = *frame.timestampS;
  for (const auto& [name, transform] : frame.transforms) {
    if (name == "ProbeToTracker" && !withProbe)
      continue;
    if (transform.valid())
      c.send(encodeTransform(name, transform.matrix, t));
  }
  const std::size_t bytes = s.samplesPerFrame() * core::elementSize(s.elementType);
  c.send(encodeImage("Image", s.elementType, s.pixels.data() + f * bytes, s.frameSize[0], 1, t));
}

TEST_F(LiveSession, RecordsEverythingServedAndEndsWhenTheServerCloses) {
  const core::Sequence served = sweep(400);
  core::writeSequence(served, dir_.file("served.igs.mha"));
  const int port = freePort();
  auto serve = std::async(std::launch::async, [&] {
    return runEchoreg({"serve", dir_.file("served.igs.mha"), "--port", std::to_string(port),
                       "--rate", "max", "--wait", "10"});
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  const CommandResult server = serve.get();
  ASSERT_EQ(server.exitCode, 0) << server.err;
  EXPECT_NE(server.out.find("served 400 of 400 frames"), std::string::npos) << server.out;
  // The sweep is not of the cube: the final registration may fail, the session must not.
  ASSERT_TRUE(fs::exists(dir_.file("rec.igs.mha"))) << live.err;
  EXPECT_FALSE(fs::exists(dir_.file("rec.igs.partial.mhd")));
  EXPECT_FALSE(fs::exists(dir_.file("rec.igs.partial.raw")));
  const nlohmann::json s = session();
  EXPECT_EQ(s.at("frames"), 400);
  EXPECT_EQ(s.at("recorded_frames"), 400);
  EXPECT_NE(s.at("ended_by").get<std::string>().find("the server closed the connection"),
            std::string::npos);
  // Frames 300-319 of the sweep have an INVALID probe, served as STATUS and refused by the pose.
  EXPECT_EQ(s.at("verdicts").at("invalid-pose"), 20);
  EXPECT_EQ(s.at("sampling_frequency_source"), "header");
  EXPECT_EQ(live.err.find("assumed"), std::string::npos) << live.err;
  EXPECT_NE(s.at("refusal_examples")
                .at("invalid-pose")
                .get<std::string>()
                .find("ProbeToTracker is INVALID"),
            std::string::npos);

  // The recording reads back as the served capture: pixels and timestamps exactly, statuses and
  // fields as served, the header's keys, and the poses to OpenIGTLink's float precision.
  const core::Sequence recorded = core::readSequence(dir_.file("rec.igs.mha"));
  ASSERT_EQ(recorded.frames.size(), served.frames.size());
  EXPECT_EQ(recorded.elementType, served.elementType);
  EXPECT_EQ(recorded.frameSize, served.frameSize);
  EXPECT_EQ(recorded.pixels, served.pixels);
  EXPECT_EQ(recorded.acquisition.samplingFrequencyHz, served.acquisition.samplingFrequencyHz);
  EXPECT_EQ(recorded.acquisition.speedOfSoundMps, served.acquisition.speedOfSoundMps);
  EXPECT_EQ(recorded.extraHeader, served.extraHeader);
  for (std::size_t f = 0; f < served.frames.size(); ++f) {
    const core::SequenceFrame& a = served.frames[f];
    const core::SequenceFrame& b = recorded.frames[f];
    ASSERT_EQ(a.timestampS, b.timestampS) << "frame " << f;
    EXPECT_EQ(a.fields, b.fields) << "frame " << f;
    ASSERT_EQ(a.transforms.size(), b.transforms.size()) << "frame " << f;
    for (const auto& [name, transform] : a.transforms) {
      const core::TrackedTransform& got = b.transforms.at(name);
      EXPECT_EQ(got.status, transform.status) << "frame " << f << " " << name;
      if (transform.valid()) {
        EXPECT_LT((got.matrix - transform.matrix).cwiseAbs().maxCoeff(), 1e-4)
            << "frame " << f << " " << name;
      }
    }
  }
}

TEST_F(LiveSession, ReconnectsWhenTheServerComesBackAndGivesUpWhenItDoesNot) {
  // The second stream is the sweep 100 s later, as a restarted PLUS server's clock goes on.
  const core::Sequence first = sweep(150);
  core::Sequence second = sweep(150);
  for (core::SequenceFrame& frame : second.frames)
    *frame.timestampS += 100.0;
  core::writeSequence(first, dir_.file("first.igs.mha"));
  core::writeSequence(second, dir_.file("second.igs.mha"));
  const int port = freePort();
  const auto serve = [&](const std::string& capture) {
    return runEchoreg({"serve", dir_.file(capture), "--port", std::to_string(port), "--rate", "max",
                       "--wait", "10"});
  };
  auto live = std::async(std::launch::async, [&] {
    return runEchoreg(liveArgs(port, {"--reconnect", "3"}));
  });
  const CommandResult server1 = serve("first.igs.mha");
  ASSERT_EQ(server1.exitCode, 0) << server1.err;
  std::this_thread::sleep_for(std::chrono::milliseconds(700));  // live retries meanwhile
  const CommandResult server2 = serve("second.igs.mha");
  ASSERT_EQ(server2.exitCode, 0) << server2.err;
  const CommandResult result = live.get();

  // Back once; then the server stays away: exit 1, with the recording of both streams written.
  EXPECT_EQ(result.exitCode, 1) << result.err;
  const std::string address = "127.0.0.1:" + std::to_string(port);
  EXPECT_NE(result.err.find("reconnecting to " + address + " for up to 3 s"), std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("reconnected to 127.0.0.1"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("did not come back within --reconnect 3 s; the recording holds the "
                            "300 frames received"),
            std::string::npos)
      << result.err;
  const nlohmann::json s = session();
  EXPECT_EQ(s.at("frames"), 300);
  EXPECT_EQ(s.at("recorded_frames"), 300);
  EXPECT_EQ(s.at("reconnections"), 1);
  EXPECT_GE(s.at("disconnected_seconds").get<double>(), 3.0);
  const core::Sequence recorded = core::readSequence(dir_.file("rec.igs.mha"));
  ASSERT_EQ(recorded.frames.size(), 300U);
  std::vector<std::uint8_t> both = first.pixels;
  both.insert(both.end(), second.pixels.begin(), second.pixels.end());
  EXPECT_EQ(recorded.pixels, both);
  for (std::size_t f = 0; f < 150; ++f) {
    ASSERT_EQ(recorded.frames[f].timestampS, first.frames[f].timestampS) << f;
    ASSERT_EQ(recorded.frames[150 + f].timestampS, second.frames[f].timestampS) << f;
  }
}

TEST_F(LiveSession, ListeningLiveTakesAClientThatComesBackIntoTheSameRecording) {
  const core::Sequence s = sweep(60);
  const int port = freePort();
  std::vector<std::string> args = liveArgs(port, {"--reconnect", "2"});
  args[1] = "--listen";  // "--connect", "127.0.0.1:PORT" -> "--listen", "PORT"
  args[2] = std::to_string(port);
  auto live = std::async(std::launch::async, [&] { return runEchoreg(args); });
  for (std::size_t part = 0; part < 2; ++part) {
    Connection client = Connection::connect("127.0.0.1", port, 10.0);
    if (part == 0)
      client.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = part * 30; f < part * 30 + 30; ++f)
      sendFrame(client, s, f);
    client.closeGracefully(5.0);
  }
  const CommandResult result = live.get();
  EXPECT_EQ(result.exitCode, 1) << result.err;
  EXPECT_NE(result.err.find("waiting for a server to connect to 127.0.0.1:" + std::to_string(port) +
                            " for up to 2 s"),
            std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("did not come back within --reconnect 2 s"), std::string::npos)
      << result.err;
  const nlohmann::json j = session();
  EXPECT_EQ(j.at("reconnections"), 1);
  EXPECT_EQ(j.at("recorded_frames"), 60);
  const core::Sequence recorded = core::readSequence(dir_.file("rec.igs.mha"));
  ASSERT_EQ(recorded.frames.size(), 60U);
  EXPECT_EQ(recorded.pixels, s.pixels);
}

TEST(SlowConsumer, ASendToAPeerThatDoesNotReadGivesUpAfterItsTimeoutOrOnStop) {
  Listener listener("127.0.0.1", 0);
  Connection sender = Connection::connect("127.0.0.1", listener.port(), 5.0);
  std::optional<Connection> receiver = listener.accept(5.0);  // never reads
  ASSERT_TRUE(receiver);
  const Packet megabyte(std::size_t{1} << 20, 0x5a);
  const auto start = std::chrono::steady_clock::now();
  std::size_t sent = 0;
  std::string problem;
  try {
    for (; sent < 256; ++sent)  // far more than loopback's socket buffers hold
      sender.send(megabyte, 0.3);
  } catch (const ConnectionClosed& e) {
    problem = e.what();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(sent, 256U);
  EXPECT_NE(problem.find("the peer read nothing for 0.3 s"), std::string::npos) << problem;
  EXPECT_LT(seconds, 10.0);
  // Without a timeout the send waits for the reader, and a stop flag ends the wait.
  std::atomic<bool> stop{false};
  auto stopper = std::async(std::launch::async, [&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    stop = true;
  });
  EXPECT_THROW(sender.send(megabyte, -1.0, &stop), ConnectionClosed);
  stopper.get();
}

// A server that only streams reads and drops what its client sends (serve's IncomingDiscarder),
// so that the client's sends never block: 64 MB of images, far more than loopback's buffers hold,
// all go through with a 2 s send timeout. (serve's own loop had its stop flag the wrong way round
// and read nothing.)
TEST(SlowConsumer, TheDiscarderReadsWhatAStreamingServersClientSends) {
  Listener listener("127.0.0.1", 0);
  Connection client = Connection::connect("127.0.0.1", listener.port(), 5.0);
  std::optional<Connection> server = listener.accept(5.0);
  ASSERT_TRUE(server);
  const std::vector<std::uint8_t> pixels(std::size_t{1} << 20, 7);
  const Packet image = encodeImage("Image", core::ElementType::UInt8, pixels.data(),
                                   static_cast<int>(pixels.size()), 1, 1.0);
  std::size_t sent = 0;
  {
    IncomingDiscarder discard(*server);
    for (; sent < 64; ++sent)
      client.send(image, 2.0);
    discard.stop();
  }
  EXPECT_EQ(sent, 64U);
}

TEST_F(LiveSession, ServeWaitsForAClientThatStallsAndDropsNothing) {
  // 6000 A-lines of 4096 bytes at 3000 a second (24 MB in 2 s, more than loopback buffers
  // hold); the client reads nothing for 3 s, then everything.
  test::DemoSweepOptions options;
  options.frames = 600;
  options.frameRateHz = 3000.0;
  const core::Sequence once = test::makeDemoSweep(options);
  core::Sequence fast = once;
  for (int copy = 1; copy < 10; ++copy) {
    for (core::SequenceFrame frame : once.frames) {
      *frame.timestampS += 0.2 * copy;
      fast.frames.push_back(std::move(frame));
    }
    fast.pixels.insert(fast.pixels.end(), once.pixels.begin(), once.pixels.end());
  }
  core::writeSequence(fast, dir_.file("fast.igs.mha"));
  const int port = freePort();
  auto serve = std::async(std::launch::async, [&] {
    return runEchoreg({"serve", dir_.file("fast.igs.mha"), "--port", std::to_string(port), "--rate",
                       "recorded", "--wait", "10"});
  });
  std::vector<double> timestamps;
  {
    Connection client = Connection::connect("127.0.0.1", port, 10.0);
    std::this_thread::sleep_for(std::chrono::seconds(3));
    MessageReader reader(std::size_t{1} << 26);
    try {
      while (auto received = reader.next(client, 5.0, nullptr)) {
        if (received->message && received->message->kind == MessageKind::Image)
          timestamps.push_back(received->message->header.timestampS);
      }
    } catch (const ConnectionClosed&) {
      // serve closes after the last frame; closing here ends its graceful close
    }
  }
  const CommandResult server = serve.get();
  ASSERT_EQ(server.exitCode, 0) << server.err;
  EXPECT_NE(server.out.find("served 6000 of 6000 frames"), std::string::npos) << server.out;
  EXPECT_NE(server.out.find("s behind the recorded timing (the client read more slowly)"),
            std::string::npos)
      << server.out;
  EXPECT_NE(server.err.find("the client reads more slowly than the recording's rate"),
            std::string::npos)
      << server.err;
  ASSERT_EQ(timestamps.size(), 6000U);
  EXPECT_TRUE(std::is_sorted(timestamps.begin(), timestamps.end()));
}

// Reads every IMAGE's timestamp and pixels until the server closes.
std::vector<std::pair<double, std::vector<std::uint8_t>>> readImages(Connection& client) {
  std::vector<std::pair<double, std::vector<std::uint8_t>>> images;
  MessageReader reader(std::size_t{1} << 26);
  try {
    while (auto received = reader.next(client, 5.0, nullptr)) {
      if (received->message && received->message->kind == MessageKind::Image)
        images.emplace_back(received->message->header.timestampS,
                            std::move(received->message->pixels));
    }
  } catch (const ConnectionClosed&) {
    // serve closes after the last frame
  }
  return images;
}

TEST_F(LiveSession, ServeRepeatsTheCaptureWithTimestampsGoingOnAsPlusLoopsIt) {
  // 100 frames at 100 Hz (0.99 s from first to last): each pass goes on one mean frame interval
  // (0.01 s) after the last one, so pass k is the capture shifted by k * 1 s.
  const core::Sequence served = sweep(100);
  core::writeSequence(served, dir_.file("served.igs.mha"));
  const double first = *served.frames.front().timestampS;
  const double period = (*served.frames.back().timestampS - first) * 100.0 / 99.0;
  int port = freePort();
  auto serve = std::async(std::launch::async, [&] {
    return runEchoreg({"serve", dir_.file("served.igs.mha"), "--port", std::to_string(port),
                       "--rate", "max", "--wait", "10", "--repeat", "3"});
  });
  std::vector<std::pair<double, std::vector<std::uint8_t>>> images;
  {
    Connection client = Connection::connect("127.0.0.1", port, 10.0);
    images = readImages(client);
  }
  CommandResult server = serve.get();
  ASSERT_EQ(server.exitCode, 0) << server.err;
  EXPECT_NE(server.out.find("served 300 frames (3 whole passes of the 100-frame capture)"),
            std::string::npos)
      << server.out;
  ASSERT_EQ(images.size(), 300U);
  const std::size_t bytes = served.samplesPerFrame() * core::elementSize(served.elementType);
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::size_t f = i % 100, pass = i / 100;
    // OpenIGTLink's timestamps are 32.32 fixed point: 2^-32 s, well under a microsecond.
    EXPECT_NEAR(images[i].first, *served.frames[f].timestampS + static_cast<double>(pass) * period,
                1e-6)
        << "image " << i;
    const auto frame = served.pixels.begin() + static_cast<std::ptrdiff_t>(f * bytes);
    EXPECT_TRUE(std::equal(frame, frame + static_cast<std::ptrdiff_t>(bytes),
                           images[i].second.begin(), images[i].second.end()))
        << "image " << i;
    if (i > 0) {
      EXPECT_GT(images[i].first, images[i - 1].first) << "image " << i;
    }
  }

  // --repeat 0: until the client closes, which is serve's normal end.
  port = freePort();
  serve = std::async(std::launch::async, [&] {
    return runEchoreg({"serve", dir_.file("served.igs.mha"), "--port", std::to_string(port),
                       "--rate", "max", "--wait", "10", "--repeat", "0"});
  });
  {
    Connection client = Connection::connect("127.0.0.1", port, 10.0);
    MessageReader reader(std::size_t{1} << 26);
    int read = 0;
    while (read < 1000) {
      auto received = reader.next(client, 5.0, nullptr);
      ASSERT_TRUE(received.has_value());
      if (received->message && received->message->kind == MessageKind::Image)
        ++read;
    }
  }
  server = serve.get();
  ASSERT_EQ(server.exitCode, 0) << server.err;
  EXPECT_NE(server.out.find("until the client closed"), std::string::npos) << server.out;
  EXPECT_NE(server.out.find("-frame capture)"), std::string::npos) << server.out;

  // A capture that cannot go on from itself is refused before anything is served.
  core::writeSequence(sweep(1), dir_.file("one.igs.mha"));
  CommandResult r = runEchoreg(
      {"serve", dir_.file("one.igs.mha"), "--port", "0", "--wait", "0.2", "--repeat", "2"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("one.igs.mha: --repeat 2 needs frames spread over time"), std::string::npos)
      << r.err;
  core::Sequence backwards = sweep(5);
  backwards.frames[3].timestampS = *backwards.frames[1].timestampS;
  core::writeSequence(backwards, dir_.file("backwards.igs.mha"));
  r = runEchoreg(
      {"serve", dir_.file("backwards.igs.mha"), "--port", "0", "--wait", "0.2", "--repeat", "0"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("backwards.igs.mha: --repeat 0: frame 3's timestamp"), std::string::npos)
      << r.err;
  r = runEchoreg({"serve", dir_.file("one.igs.mha"), "--port", "0", "--repeat", "-1"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
}

// A server that sends A-lines and poses but no capture header (a PLUS server does not): the
// sampling frequency is --sampling-frequency's, recorded in the capture; without it the preset's
// 50 MHz is assumed and said, since every depth scales with it.
TEST_F(LiveSession, ASamplingFrequencyTheStreamDoesNotGiveIsTakenFromTheOptionOrSaidToBeAssumed) {
  const core::Sequence s = sweep(30);
  const auto runWithoutHeader = [&](const std::vector<std::string>& more) {
    const int port = freePort();
    auto server = fakeServer(port, [&](Connection& c) {
      for (std::size_t f = 0; f < 30; ++f)
        sendFrame(c, s, f);
    });
    const CommandResult live = runEchoreg(liveArgs(port, more));
    server.get();
    return live;
  };
  const CommandResult assumed = runWithoutHeader({});
  EXPECT_NE(assumed.err.find("echoreg live: warning: the stream gives no sampling frequency (no "
                             "capture header from the server) and none was given: assumed 50 "
                             "MHz; every depth scales with it (--sampling-frequency)"),
            std::string::npos)
      << assumed.err;
  EXPECT_EQ(session().at("sampling_frequency_source"), "assumed");
  EXPECT_EQ(session().at("recorded_frames"), 30);

  const CommandResult given = runWithoutHeader({"--sampling-frequency", "40e6"});
  EXPECT_EQ(given.err.find("assumed"), std::string::npos) << given.err;
  EXPECT_EQ(session().at("sampling_frequency_source"), "given");
  EXPECT_EQ(core::readSequence(dir_.file("rec.igs.mha")).acquisition.samplingFrequencyHz, 40e6);
}

TEST_F(LiveSession, AnOversizedMessageEndsTheSessionWithAClearMessageAndKeepsTheRecording) {
  const core::Sequence s = sweep(30);
  const int port = freePort();
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 30; ++f)
      sendFrame(c, s, f);
    Packet huge = encodeString("Huge", "x", 11.0);
    for (int i = 0; i < 8; ++i)  // body size: 2^32 bytes
      huge[42 + static_cast<std::size_t>(i)] = i == 3 ? 1 : 0;
    c.send(huge);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  server.get();
  EXPECT_EQ(live.exitCode, 1);
  EXPECT_NE(live.err.find("STRING 'Huge' announces a body of 4294967296 bytes, more than the "
                          "limit of 67108864 bytes"),
            std::string::npos)
      << live.err;
  EXPECT_EQ(core::readSequence(dir_.file("rec.igs.mha")).frames.size(), 30u);
}

TEST_F(LiveSession, ADamagedMessageIsSkippedAndTheSessionGoesOn) {
  const core::Sequence s = sweep(40);
  const int port = freePort();
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 40; ++f) {
      if (f == 10) {
        Packet broken = encodeTransform("ProbeToTracker", Eigen::Matrix4d::Identity(), 10.095);
        broken[kHeaderBytes + 3] ^= 0x10;
        c.send(broken);
      }
      sendFrame(c, s, f);
    }
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  server.get();
  EXPECT_NE(live.err.find("1 message(s) skipped: TRANSFORM 'ProbeToTracker': the body does not "
                          "unpack (CRC mismatch"),
            std::string::npos)
      << live.err;
  EXPECT_EQ(session().at("recorded_frames"), 40);
}

TEST_F(LiveSession, APoseStreamThatStopsIsRefusedAsStaleWithTheReason) {
  const core::Sequence s = sweep(200);
  const int port = freePort();
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 200; ++f)
      sendFrame(c, s, f, f < 100);
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  server.get();
  const nlohmann::json result = session();
  EXPECT_NEAR(result.at("verdicts").at("stale-pose").get<int>(), 90, 1);
  EXPECT_NE(live.err.find("frame(s) refused as stale-pose, e.g. frame 1"), std::string::npos)
      << live.err;
  EXPECT_NE(live.err.find("stale pose: the newest ProbeToTracker is 0.1"), std::string::npos)
      << live.err;
  // Every frame is recorded, the ones without a probe pose too.
  EXPECT_EQ(result.at("recorded_frames"), 200);
}

// The end of a session registers the points detected while the A-lines came and does not read
// the recording back (that held the whole capture and every step's output in memory: 11.2 GB
// for 150 s at 3000 A-lines/s). A pose that is not rigid shows it: live records it as received
// and refuses its frame, while reading the recording as `register --capture` refuses the whole
// capture, so a session that read it back would end without a result.
TEST_F(LiveSession, TheResultComesFromTheLivePointsNotFromReadingTheRecordingBack) {
  const core::Sequence s = sweep(300);
  const int port = freePort();
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 300; ++f) {
      if (f == 150) {  // a scaled probe pose: recorded, refused for pairing
        Eigen::Matrix4d scaled = s.frames[f].transforms.at("ProbeToTracker").matrix;
        scaled.topLeftCorner<3, 3>() *= 1.05;
        c.send(encodeTransform("ProbeToTracker", scaled, *s.frames[f].timestampS));
        c.send(encodeTransform("FemurToTracker", s.frames[f].transforms.at("FemurToTracker").matrix,
                               *s.frames[f].timestampS));
        const std::size_t bytes = s.samplesPerFrame() * core::elementSize(s.elementType);
        c.send(encodeImage("Image", s.elementType, s.pixels.data() + f * bytes, s.frameSize[0], 1,
                           *s.frames[f].timestampS));
        continue;
      }
      sendFrame(c, s, f);
    }
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  server.get();
  const nlohmann::json session = this->session();
  ASSERT_EQ(session.at("recorded_frames"), 300) << live.err;
  EXPECT_EQ(session.at("verdicts").at("invalid-pose"), 1);
  // The recording holds the pose as received, which register refuses.
  const CommandResult offline =
      runEchoreg({"register", "--capture", dir_.file("rec.igs.mha"), "--calibration",
                  dir_.file("BeamToProbe.json"), "--model", dir_.file("cube.obj"), "--initial",
                  dir_.file("initial.json"), "--out", dir_.file("offline.json")});
  EXPECT_EQ(offline.exitCode, 1);
  EXPECT_NE(offline.err.find("frame 150: its ProbeToTrackerTransform is not a rigid pose"),
            std::string::npos)
      << offline.err;

  // live's result: register's file, from its own points. The cube is not what the sweep is of, so
  // it does not converge (exit 1); it is written either way.
  ASSERT_TRUE(fs::exists(dir_.file("FemurToCT.json"))) << live.err;
  // The session's end speaks as live, not as register (whose solver and files it uses): the
  // points start 210 mm from the cube, so the fit is refused, and said so.
  EXPECT_EQ(live.exitCode, 1);
  EXPECT_NE(live.err.find("echoreg live: " + dir_.file("FemurToCT.json") + ": not converged"),
            std::string::npos)
      << live.err;
  EXPECT_EQ(live.err.find("echoreg register"), std::string::npos) << live.err;
  EXPECT_EQ(live.err.find("its ProbeToTrackerTransform is not a rigid pose"), std::string::npos)
      << live.err;
  const core::TransformFile result =
      core::readTransformFile(dir_.file("FemurToCT.json"), "Femur", "CT");
  const int accepted = session.at("accepted").get<int>();
  ASSERT_GE(accepted, 3);
  EXPECT_EQ(result.extra.at("ultrasound_points"), accepted);
  EXPECT_EQ(result.extra.at("points").size(), static_cast<std::size_t>(accepted));
  const nlohmann::json& source = result.extra.at("sources").at(0);
  EXPECT_EQ(source.at("capture"), dir_.file("rec.igs.mha"));
  EXPECT_EQ(source.at("detected"), "live");
  EXPECT_EQ(source.at("frames"), 300);
  EXPECT_EQ(source.at("accepted"), accepted);
  EXPECT_EQ(source.at("rejected_by_reason").at("invalid-pose"), 1);
}

// A sweep whose first second is unrepresentative (the probe put down tilted 35 degrees: 100
// A-lines without bone, then 200 over bone that casts its shadow): the first 20 A-lines measure
// the per-record shadow rule, a later measurement the shadow required, as register measures on
// the whole recording. live says so, judges the frames so far again, and its result is register's
// on the recording (the same points; the cube model is not what the sweep is of, so neither fit
// converges, and both are written).
TEST_F(LiveSession, AShadowRuleMeasuredAgainIsSaidAndTheResultIsRegisters) {
  core::Sequence s = sweep(300);
  test::SpecimenSetOptions lineOptions;
  for (std::size_t f = 0; f < 100; ++f) {
    lineOptions.seed = 9000 + f;
    const test::LabelledALine line = test::makeSpecimenALine(8.0, 9.0, 35.0, lineOptions);
    std::copy(line.samples.begin(), line.samples.end(),
              s.pixels.begin() + static_cast<std::ptrdiff_t>(f * s.samplesPerFrame()));
  }
  core::writeSequence(s, dir_.file("served.igs.mha"));
  const int port = freePort();
  auto serve = std::async(std::launch::async, [&] {
    return runEchoreg({"serve", dir_.file("served.igs.mha"), "--port", std::to_string(port),
                       "--rate", "max", "--wait", "10"});
  });
  const CommandResult live = runEchoreg(liveArgs(port));
  ASSERT_EQ(serve.get().exitCode, 0);
  EXPECT_NE(live.err.find("echoreg live: measured on the first 20 A-line(s)"), std::string::npos)
      << live.err;
  EXPECT_NE(live.err.find("shadow rule auto"), std::string::npos) << live.err;
  EXPECT_NE(live.err.find("echoreg live: the shadow rule is now required (was auto)"),
            std::string::npos)
      << live.err;
  const nlohmann::json session = this->session();
  const nlohmann::json& detection = session.at("detection");
  EXPECT_EQ(detection.at("shadow_rule"), "required");
  EXPECT_EQ(detection.at("shadow_rule_switches"), 1);
  const nlohmann::json& measurements = detection.at("shadow_rule_measurements");
  ASSERT_GE(measurements.size(), 3u);
  EXPECT_EQ(measurements.front().at("frames"), 20);
  EXPECT_EQ(measurements.front().at("rule"), "auto");
  EXPECT_EQ(measurements.back().at("frames"), 300);
  EXPECT_EQ(measurements.back().at("rule"), "required");

  const CommandResult offline =
      runEchoreg({"register", "--capture", dir_.file("rec.igs.mha"), "--calibration",
                  dir_.file("BeamToProbe.json"), "--model", dir_.file("cube.obj"), "--initial",
                  dir_.file("initial.json"), "--out", dir_.file("offline.json")});
  ASSERT_TRUE(fs::exists(dir_.file("offline.json"))) << offline.err;
  ASSERT_TRUE(fs::exists(dir_.file("FemurToCT.json"))) << live.err;
  const core::TransformFile byRegister =
      core::readTransformFile(dir_.file("offline.json"), "Femur", "CT");
  const core::TransformFile byLive =
      core::readTransformFile(dir_.file("FemurToCT.json"), "Femur", "CT");
  const int accepted = byRegister.extra.at("sources").at(0).at("accepted").get<int>();
  EXPECT_GT(accepted, 30);
  EXPECT_EQ(session.at("accepted"), accepted);
  EXPECT_EQ(byLive.extra.at("ultrasound_points"), accepted);
  EXPECT_LT((byLive.matrix - byRegister.matrix).cwiseAbs().maxCoeff(), 1e-6);
}

// A results' receiver that takes a fixed number of messages per connection and then drops it
// (OpenIGTLink's ReceiveServer example takes 100), twice: live connects to it again and goes on
// sending, so the session's final update arrives, on the third connection. (Before, live sent
// nothing more after the first drop, and whether the receiver ever saw a FemurToCT depended on how
// many updates happened to come before the drop.)
TEST_F(LiveSession, AResultsReceiverThatClosesIsConnectedToAgainAndGetsTheFinalUpdate) {
  const core::Sequence s = sweep(300);
  const int port = freePort();
  const int resultsPort = freePort();
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 300; ++f)
      sendFrame(c, s, f);
  });
  constexpr int kPerConnection = 10;
  std::atomic<bool> done{false};
  auto receiver = std::async(std::launch::async, [&] {
    Listener listener("127.0.0.1", resultsPort);
    std::vector<std::vector<Message>> connections;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
      std::optional<Connection> c = listener.accept(0.2, &done);
      if (!c) {
        if (done.load())
          break;
        continue;
      }
      connections.emplace_back();
      MessageReader reader(std::size_t{1} << 24);
      try {
        const std::size_t limit = connections.size() <= 2 ? kPerConnection : SIZE_MAX;
        while (connections.back().size() < limit) {
          std::optional<MessageReader::Received> got = reader.next(*c, 5.0, nullptr);
          if (!got)
            break;
          if (got->message)
            connections.back().push_back(*got->message);
        }
      } catch (const ConnectionClosed&) {
      }
    }
    return connections;
  });
  const CommandResult live = runEchoreg(liveArgs(
      port, {"--send-to", "127.0.0.1:" + std::to_string(resultsPort), "--min-points", "5"}));
  server.get();
  // What live sent last has been read once the receiver's last connection is quiet.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  done = true;
  const std::vector<std::vector<Message>> connections = receiver.get();
  const nlohmann::json session = this->session();
  ASSERT_GE(session.at("accepted").get<int>(), 3 * kPerConnection) << live.err;
  ASSERT_EQ(connections.size(), 3U) << live.err;
  EXPECT_EQ(session.at("results_reconnections"), 2);
  EXPECT_NE(live.err.find("live connects to it again (at most once a second)"), std::string::npos)
      << live.err;
  EXPECT_NE(live.err.find("connected again to the results' receiver"), std::string::npos)
      << live.err;
  // The first two connections were filled; the last one ends with the final update: the status
  // of the fit on every point and the cloud of all of them.
  EXPECT_EQ(connections[0].size(), static_cast<std::size_t>(kPerConnection));
  EXPECT_EQ(connections[1].size(), static_cast<std::size_t>(kPerConnection));
  const std::vector<Message>& last = connections.back();
  ASSERT_GE(last.size(), 2U);
  const Message& status = last[last.size() - 2];
  const Message& cloud = last.back();
  EXPECT_EQ(status.header.deviceName, "FemurStatus");
  EXPECT_NE(status.text.find(fmt::format("{} points", session.at("accepted").get<int>())),
            std::string::npos)
      << status.text;
  EXPECT_EQ(cloud.header.deviceName, "FemurPoints");
  EXPECT_EQ(cloud.points.size(), session.at("accepted").get<std::size_t>());
}

TEST_F(LiveSession, SigintEndsTheSessionCleanly) {
  const core::Sequence s = sweep(50);
  const int port = freePort();
  std::promise<void> sent;
  std::atomic<bool> release{false};
  auto server = fakeServer(port, [&](Connection& c) {
    c.send(encodeString(kCaptureHeaderName, captureHeaderJson(s), 10.0));
    for (std::size_t f = 0; f < 50; ++f)
      sendFrame(c, s, f);
    sent.set_value();
    // Then silent, connection open, until the test is done (at most 10 s).
    for (int i = 0; i < 200 && !release.load(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
  });
  // A harmless handler while live is not running, so that the signal never ends the test program.
  const auto previous = std::signal(SIGINT, [](int) {});
  auto live = std::async(std::launch::async, [&] { return runEchoreg(liveArgs(port)); });
  sent.get_future().wait();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  std::raise(SIGINT);
  const CommandResult result = live.get();
  release = true;
  server.get();
  std::signal(SIGINT, previous);
  EXPECT_EQ(session().at("ended_by"), "interrupted (SIGINT)") << result.err;
  EXPECT_EQ(session().at("recorded_frames"), 50);
}

TEST_F(LiveSession, UsageAndPeerProblemsAreNamed) {
  CommandResult r =
      runEchoreg({"live", "--record", dir_.file("r.igs.mha"), "--model", dir_.file("cube.obj"),
                  "--calibration", dir_.file("BeamToProbe.json"), "--initial",
                  dir_.file("initial.json"), "--out", dir_.file("o.json")});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("give --connect HOST:PORT or --listen PORT"), std::string::npos) << r.err;
  std::vector<std::string> a = liveArgs(freePort());
  a[2] = "127.0.0.1";  // no port
  r = runEchoreg(a);
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--connect must be HOST:PORT"), std::string::npos) << r.err;
  a = liveArgs(freePort());
  *(std::find(a.begin(), a.end(), "--connect-timeout") + 1) = "0.3";
  r = runEchoreg(a);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("no OpenIGTLink server at 127.0.0.1:"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_.file("rec.igs.mha")));

  core::Sequence negative = sweep(3);
  negative.frames[1].timestampS = -1.0;
  core::writeSequence(negative, dir_.file("negative.igs.mha"));
  r = runEchoreg({"serve", dir_.file("negative.igs.mha"), "--port", "0", "--wait", "0.2"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("negative.igs.mha: frame 1 has timestamp -1"), std::string::npos) << r.err;
  core::writeSequence(sweep(3), dir_.file("three.igs.mha"));
  r = runEchoreg({"serve", dir_.file("three.igs.mha"), "--port", "0", "--wait", "0.2"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("no client connected to 127.0.0.1:"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace echoreg::live
