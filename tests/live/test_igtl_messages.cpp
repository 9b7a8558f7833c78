// OpenIGTLink messages through Debian's OpenIGTLink 1.11: what echoreg packs unpacks to the same
// values (timestamps to the nanosecond, matrices to float precision, pixels bit for bit), and a
// damaged message is refused with a sentence that names it.
#include "echoreg/live/igtl_messages.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cstring>
#include <random>

namespace echoreg::live {
namespace {

Message roundTrip(const Packet& packet) {
  const MessageHeader header = decodeHeader(packet.data());
  EXPECT_EQ(header.bodyBytes + kHeaderBytes, packet.size());
  return decodeBody(header, packet.data(), packet.data() + kHeaderBytes);
}

TEST(IgtlMessages, TransformKeepsNameTimestampAndMatrixToFloatPrecision) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(-120.25, 33.5, 812.125);
  // Timestamps as PLUS captures write them: up to 9 decimals come back as the same double.
  for (const double t : {0.0, 0.01, 1.23, 12345.678901, 86399.999999999}) {
    const Message message = roundTrip(encodeTransform("ProbeToTracker", m, t));
    EXPECT_EQ(message.kind, MessageKind::Transform);
    EXPECT_EQ(message.header.type, "TRANSFORM");
    EXPECT_EQ(message.header.deviceName, "ProbeToTracker");
    EXPECT_EQ(message.header.timestampS, t);
    EXPECT_LT((message.matrix - m).cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_EQ(message.matrix.row(3), Eigen::RowVector4d(0, 0, 0, 1));
  }
}

TEST(IgtlMessages, ImagesOfEveryElementTypeComeBackBitForBit) {
  std::mt19937 random(3);
  for (const core::ElementType type :
       {core::ElementType::UInt8, core::ElementType::Int8, core::ElementType::Int16,
        core::ElementType::UInt16, core::ElementType::Float32}) {
    const int samples = 1000;
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(samples) * core::elementSize(type));
    for (std::uint8_t& b : pixels)
      b = static_cast<std::uint8_t>(random() & 0x7f);  // finite floats
    const Message message = roundTrip(encodeImage("Image", type, pixels.data(), samples, 1, 2.5));
    EXPECT_EQ(message.kind, MessageKind::Image) << core::elementTypeName(type);
    EXPECT_EQ(message.elementType, type);
    EXPECT_EQ(message.samples, samples);
    EXPECT_EQ(message.rows, 1);
    EXPECT_EQ(message.pixels, pixels) << core::elementTypeName(type);
    EXPECT_EQ(message.header.timestampS, 2.5);
  }
}

TEST(IgtlMessages, StringStatusAndPointsComeBack) {
  const Message text = roundTrip(encodeString("FemurStatus", "RMS 0.412 mm, converged", 1.0));
  EXPECT_EQ(text.kind, MessageKind::String);
  EXPECT_EQ(text.text, "RMS 0.412 mm, converged");
  const Message status = roundTrip(
      encodeStatus("ProbeToTracker", kStatusNotReady, "INVALID", "ProbeToTracker INVALID", 3.0));
  EXPECT_EQ(status.kind, MessageKind::Status);
  EXPECT_EQ(status.statusCode, kStatusNotReady);
  EXPECT_EQ(status.statusName, "INVALID");
  EXPECT_EQ(status.text, "ProbeToTracker INVALID");
  const std::vector<Eigen::Vector3d> points{{1.5, -2.25, 3.0}, {100.0, 200.0, -300.5}};
  const Message cloud = roundTrip(encodePoints("FemurPoints", "Femur", points, 4.0));
  EXPECT_EQ(cloud.kind, MessageKind::Point);
  ASSERT_EQ(cloud.points.size(), 2u);
  EXPECT_LT((cloud.points[1] - points[1]).norm(), 1e-4);
}

TEST(IgtlMessages, UnknownTypesAreOtherNotErrors) {
  Packet packet = encodeString("X", "y", 0.0);
  std::memcpy(packet.data() + 2, "BIND\0\0\0\0\0\0\0\0", 12);
  // The CRC covers only the body, so the renamed message still unpacks as an unknown type.
  EXPECT_EQ(roundTrip(packet).kind, MessageKind::Other);
}

TEST(IgtlMessages, DamagedBodyIsRefusedNamingTheMessage) {
  Packet packet = encodeTransform("ProbeToTracker", Eigen::Matrix4d::Identity(), 1.0);
  packet[kHeaderBytes + 5] ^= 0x40;
  const MessageHeader header = decodeHeader(packet.data());
  try {
    decodeBody(header, packet.data(), packet.data() + kHeaderBytes);
    FAIL() << "a body with a wrong CRC was accepted";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("TRANSFORM 'ProbeToTracker'"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("CRC"), std::string::npos) << e.what();
  }
}

TEST(IgtlMessages, NewerHeaderVersionIsRefused) {
  Packet packet = encodeString("X", "y", 0.0);
  packet[1] = 2;  // version 2: OpenIGTLink 3's extended header
  try {
    decodeHeader(packet.data());
    FAIL() << "a version-2 header was accepted";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("header version 2"), std::string::npos) << e.what();
  }
}

TEST(IgtlMessages, WhatOpenIgtLinkCannotCarryIsRefusedBeforeSending) {
  EXPECT_THROW(encodeTransform("ProbeToTracker", Eigen::Matrix4d::Identity(), -0.5),
               std::invalid_argument);
  EXPECT_THROW(encodeTransform("AVeryLongTransformNameToTracker", Eigen::Matrix4d::Identity(), 0),
               std::invalid_argument);
}

}  // namespace
}  // namespace echoreg::live
