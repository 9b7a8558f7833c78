// OpenIGTLink messages through Debian's OpenIGTLink 1.11 (igtl::*Message pack and unpack them).
#include "echoreg/live/igtl_messages.hpp"

#include <fmt/format.h>
#include <igtlImageMessage.h>
#include <igtlMessageHeader.h>
#include <igtlPointMessage.h>
#include <igtlStatusMessage.h>
#include <igtlStringMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_util.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace echoreg::live {

namespace {

constexpr double kFractionScale = 4294967296.0;  // 2^32: OpenIGTLink's fraction of a second

// Seconds as OpenIGTLink's (seconds, 2^-32 fraction); refuses what it cannot carry.
void splitTimestamp(double timestampS, unsigned int& seconds, unsigned int& fraction) {
  if (!std::isfinite(timestampS) || timestampS < 0.0 || timestampS >= 4294967295.0) {
    throw std::invalid_argument(
        fmt::format("timestamp {} s cannot be sent: OpenIGTLink carries 0 to 2^32 s", timestampS));
  }
  double whole = std::floor(timestampS);
  double part = std::round((timestampS - whole) * kFractionScale);
  if (part >= kFractionScale) {
    whole += 1.0;
    part = 0.0;
  }
  seconds = static_cast<unsigned int>(whole);
  fraction = static_cast<unsigned int>(part);
}

// Rounded to the nanosecond: a timestamp written with up to 9 decimals reads back as written.
double joinTimestamp(std::uint32_t seconds, std::uint32_t fraction) {
  const double nanoseconds = std::round(static_cast<double>(fraction) / kFractionScale * 1e9);
  return static_cast<double>(seconds) + nanoseconds / 1e9;
}

void requireName(const std::string& name) {
  if (name.empty() || name.size() > IGTL_HEADER_NAME_SIZE) {
    throw std::invalid_argument(fmt::format(
        "device name '{}' cannot be sent: OpenIGTLink names have 1 to 20 characters", name));
  }
}

template <typename MessagePointer>
Packet pack(MessagePointer& message, const std::string& name, double timestampS) {
  requireName(name);
  unsigned int seconds = 0, fraction = 0;
  splitTimestamp(timestampS, seconds, fraction);
  message->SetDeviceName(name.c_str());
  message->SetTimeStamp(seconds, fraction);
  message->Pack();
  const auto* bytes = static_cast<const std::uint8_t*>(message->GetPackPointer());
  return Packet(bytes, bytes + message->GetPackSize());
}

int igtlScalarType(core::ElementType type) {
  switch (type) {
    case core::ElementType::Int8:
      return igtl::ImageMessage::TYPE_INT8;
    case core::ElementType::UInt8:
      return igtl::ImageMessage::TYPE_UINT8;
    case core::ElementType::Int16:
      return igtl::ImageMessage::TYPE_INT16;
    case core::ElementType::UInt16:
      return igtl::ImageMessage::TYPE_UINT16;
    case core::ElementType::Float32:
      return igtl::ImageMessage::TYPE_FLOAT32;
    case core::ElementType::None:
      break;
  }
  throw std::invalid_argument("an IMAGE needs pixels (the capture is tracker-only)");
}

core::ElementType elementTypeOf(int scalarType) {
  switch (scalarType) {
    case igtl::ImageMessage::TYPE_INT8:
      return core::ElementType::Int8;
    case igtl::ImageMessage::TYPE_UINT8:
      return core::ElementType::UInt8;
    case igtl::ImageMessage::TYPE_INT16:
      return core::ElementType::Int16;
    case igtl::ImageMessage::TYPE_UINT16:
      return core::ElementType::UInt16;
    case igtl::ImageMessage::TYPE_FLOAT32:
      return core::ElementType::Float32;
    default:
      return core::ElementType::None;
  }
}

bool hostIsBigEndian() {
  const std::uint16_t probe = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 0;
}

// Unpacks `message` from the received bytes; throws ProtocolError when the CRC or body is bad.
template <typename MessagePointer>
void unpack(MessagePointer& message, const MessageHeader& header, const std::uint8_t* headerBytes,
            const std::uint8_t* body) {
  igtl::MessageHeader::Pointer igtlHeader = igtl::MessageHeader::New();
  igtlHeader->InitPack();
  std::memcpy(igtlHeader->GetPackPointer(), headerBytes, kHeaderBytes);
  igtlHeader->Unpack();
  message->SetMessageHeader(igtlHeader);
  message->AllocatePack();
  std::memcpy(message->GetPackBodyPointer(), body, static_cast<std::size_t>(header.bodyBytes));
  const int status = message->Unpack(1);
  if ((status & igtl::MessageHeader::UNPACK_BODY) == 0) {
    throw ProtocolError(
        fmt::format("{} '{}': the body does not unpack (CRC mismatch or a body "
                    "too short for its type); message skipped",
                    header.type, header.deviceName));
  }
}

}  // namespace

MessageHeader decodeHeader(const std::uint8_t* bytes) {
  igtl_header raw;
  std::memcpy(&raw, bytes, kHeaderBytes);
  igtl_header_convert_byte_order(&raw);
  MessageHeader header;
  header.version = raw.version;
  header.type.assign(raw.name, strnlen(raw.name, IGTL_HEADER_TYPE_SIZE));
  header.deviceName.assign(raw.device_name, strnlen(raw.device_name, IGTL_HEADER_NAME_SIZE));
  header.timestampS = joinTimestamp(static_cast<std::uint32_t>(raw.timestamp >> 32),
                                    static_cast<std::uint32_t>(raw.timestamp & 0xffffffffU));
  header.bodyBytes = raw.body_size;
  if (header.version != IGTL_HEADER_VERSION) {
    throw ProtocolError(fmt::format(
        "a message with header version {} (expected {}: OpenIGTLink 1.x/2 headers; an OpenIGTLink "
        "3 extended header is not read){}",
        header.version, IGTL_HEADER_VERSION,
        header.type.empty() ? std::string() : " of type " + header.type));
  }
  if (header.type.empty())
    throw ProtocolError("a message header without a type");
  return header;
}

Message decodeBody(const MessageHeader& header, const std::uint8_t* headerBytes,
                   const std::uint8_t* body) {
  Message message;
  message.header = header;
  if (header.type == "TRANSFORM") {
    igtl::TransformMessage::Pointer transform = igtl::TransformMessage::New();
    unpack(transform, header, headerBytes, body);
    igtl::Matrix4x4 m;
    transform->GetMatrix(m);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c)
        message.matrix(r, c) = static_cast<double>(m[r][c]);
    }
    message.kind = MessageKind::Transform;
  } else if (header.type == "IMAGE") {
    igtl::ImageMessage::Pointer image = igtl::ImageMessage::New();
    unpack(image, header, headerBytes, body);
    int size[3], subSize[3], offset[3];
    image->GetDimensions(size);
    image->GetSubVolume(subSize, offset);
    message.elementType = elementTypeOf(image->GetScalarType());
    if (message.elementType == core::ElementType::None || image->GetNumComponents() != 1) {
      throw ProtocolError(fmt::format(
          "IMAGE '{}': scalar type {} with {} component(s) is not read (echoreg reads one "
          "component of int8, uint8, int16, uint16 or float32); message skipped",
          header.deviceName, image->GetScalarType(), image->GetNumComponents()));
    }
    if (size[2] != 1 || subSize[0] != size[0] || subSize[1] != size[1] || subSize[2] != 1 ||
        size[0] < 1 || size[1] < 1) {
      throw ProtocolError(fmt::format(
          "IMAGE '{}': {}x{}x{} (sub-volume {}x{}x{}) is not one whole 2D frame; message skipped",
          header.deviceName, size[0], size[1], size[2], subSize[0], subSize[1], subSize[2]));
    }
    message.samples = size[0];
    message.rows = size[1];
    const std::size_t bytes = static_cast<std::size_t>(size[0]) *
                              static_cast<std::size_t>(size[1]) *
                              core::elementSize(message.elementType);
    const auto* pixels = static_cast<const std::uint8_t*>(image->GetScalarPointer());
    message.pixels.assign(pixels, pixels + bytes);
    const bool bigEndian = image->GetEndian() == igtl::ImageMessage::ENDIAN_BIG;
    const std::size_t width = core::elementSize(message.elementType);
    if (bigEndian != hostIsBigEndian() && width > 1) {
      for (std::size_t i = 0; i + width <= message.pixels.size(); i += width)
        std::reverse(message.pixels.begin() + static_cast<std::ptrdiff_t>(i),
                     message.pixels.begin() + static_cast<std::ptrdiff_t>(i + width));
    }
    message.kind = MessageKind::Image;
  } else if (header.type == "STRING") {
    igtl::StringMessage::Pointer text = igtl::StringMessage::New();
    unpack(text, header, headerBytes, body);
    message.text = text->GetString();
    message.kind = MessageKind::String;
  } else if (header.type == "STATUS") {
    igtl::StatusMessage::Pointer status = igtl::StatusMessage::New();
    unpack(status, header, headerBytes, body);
    message.statusCode = status->GetCode();
    message.statusName = status->GetErrorName();
    message.text = status->GetStatusString();
    message.kind = MessageKind::Status;
  } else if (header.type == "POINT") {
    igtl::PointMessage::Pointer points = igtl::PointMessage::New();
    unpack(points, header, headerBytes, body);
    for (int i = 0; i < points->GetNumberOfPointElement(); ++i) {
      igtl::PointElement::Pointer element;
      points->GetPointElement(i, element);
      float p[3];
      element->GetPosition(p);
      message.points.emplace_back(p[0], p[1], p[2]);
    }
    message.kind = MessageKind::Point;
  }
  return message;
}

Packet encodeTransform(const std::string& name, const Eigen::Matrix4d& matrix, double timestampS) {
  igtl::TransformMessage::Pointer message = igtl::TransformMessage::New();
  igtl::Matrix4x4 m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      m[r][c] = static_cast<float>(matrix(r, c));
  }
  message->SetMatrix(m);
  return pack(message, name, timestampS);
}

Packet encodeImage(const std::string& name, core::ElementType type, const std::uint8_t* pixels,
                   int samples, int rows, double timestampS) {
  igtl::ImageMessage::Pointer message = igtl::ImageMessage::New();
  message->SetDimensions(samples, rows, 1);
  message->SetSpacing(1.0f, 1.0f, 1.0f);
  message->SetScalarType(igtlScalarType(type));
  message->SetEndian(hostIsBigEndian() ? igtl::ImageMessage::ENDIAN_BIG
                                       : igtl::ImageMessage::ENDIAN_LITTLE);
  message->AllocateScalars();
  std::memcpy(
      message->GetScalarPointer(), pixels,
      static_cast<std::size_t>(samples) * static_cast<std::size_t>(rows) * core::elementSize(type));
  return pack(message, name, timestampS);
}

Packet encodeString(const std::string& name, const std::string& text, double timestampS) {
  igtl::StringMessage::Pointer message = igtl::StringMessage::New();
  if (text.size() > 65535)
    throw std::invalid_argument("a STRING message holds at most 65535 bytes");
  message->SetString(text.c_str());
  return pack(message, name, timestampS);
}

Packet encodeStatus(const std::string& name, int code, const std::string& errorName,
                    const std::string& text, double timestampS) {
  igtl::StatusMessage::Pointer message = igtl::StatusMessage::New();
  message->SetCode(code);
  message->SetSubCode(0);
  message->SetErrorName(errorName.substr(0, 20).c_str());
  message->SetStatusString(text.c_str());
  return pack(message, name, timestampS);
}

Packet encodePoints(const std::string& name, const std::string& group,
                    const std::vector<Eigen::Vector3d>& points, double timestampS) {
  igtl::PointMessage::Pointer message = igtl::PointMessage::New();
  for (std::size_t i = 0; i < points.size(); ++i) {
    igtl::PointElement::Pointer element = igtl::PointElement::New();
    element->SetName(fmt::format("{}-{}", group, i + 1).c_str());
    element->SetGroupName(group.c_str());
    element->SetRGBA(255, 200, 0, 255);
    element->SetPosition(static_cast<float>(points[i].x()), static_cast<float>(points[i].y()),
                         static_cast<float>(points[i].z()));
    element->SetRadius(1.0f);
    message->AddPointElement(element);
  }
  return pack(message, name, timestampS);
}

}  // namespace echoreg::live
