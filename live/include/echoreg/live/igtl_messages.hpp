// OpenIGTLink messages as echoreg sends and reads them, packed and unpacked by Debian's
// OpenIGTLink 1.11 (protocol 2, version-1 headers: what PLUS answers until a client sends a newer
// header). Timestamps are seconds, carried as OpenIGTLink's 32.32 fixed point and rounded to the
// nanosecond on reading, so a capture's timestamps (written with up to 9 decimals) read back as
// the same numbers. docs/live.md lists the messages by name.
#pragma once

#include "echoreg/core/sequence.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::live {

/// A message that breaks the protocol: a bad header, a body that fails its CRC or does not
/// unpack, an announced body larger than allowed. The text names the message type and device.
class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bytes of an OpenIGTLink header.
constexpr std::size_t kHeaderBytes = 58;

/// What a header says.
struct MessageHeader {
  int version = 0;
  std::string type;        ///< "TRANSFORM", "IMAGE", "STRING", "STATUS", "POINT", ...
  std::string deviceName;  ///< e.g. "ProbeToTracker"
  double timestampS = 0.0;
  std::uint64_t bodyBytes = 0;
};

/// Reads a header of kHeaderBytes bytes. Throws ProtocolError for a header version other than 1
/// (an OpenIGTLink 3 extended header, which 1.11 cannot unpack) or an empty type.
MessageHeader decodeHeader(const std::uint8_t* header);

enum class MessageKind { Transform, Image, String, Status, Point, Other };

/// One received message, decoded. Only the fields of its kind are filled.
struct Message {
  MessageKind kind = MessageKind::Other;
  MessageHeader header;
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();  ///< Transform: p_To = matrix * p_From
  /// Image: the element type, samples per row, rows, and the pixels in host byte order.
  core::ElementType elementType = core::ElementType::None;
  int samples = 0;
  int rows = 0;
  std::vector<std::uint8_t> pixels;
  std::string text;  ///< String: the text; Status: the status string
  int statusCode = 0;
  std::string statusName;  ///< Status: the error name (echoreg: the pose's status word)
  std::vector<Eigen::Vector3d> points;  ///< Point: the positions
};

/// Unpacks a body of header.bodyBytes bytes after its header (the CRC checked). Types other than
/// TRANSFORM, IMAGE, STRING, STATUS and POINT come back as MessageKind::Other. Throws
/// ProtocolError naming the type and device for a CRC mismatch, a body that does not unpack, or an
/// IMAGE that is not one 2D slice of a scalar type echoreg reads (int8, uint8, int16, uint16,
/// float32).
Message decodeBody(const MessageHeader& header, const std::uint8_t* headerBytes,
                   const std::uint8_t* body);

/// A packed message (header and body), ready to send.
using Packet = std::vector<std::uint8_t>;

/// TRANSFORM `name` (e.g. "ProbeToTracker"). Throws std::invalid_argument for a negative or
/// non-finite timestamp (OpenIGTLink carries unsigned seconds) or a name over 20 characters.
Packet encodeTransform(const std::string& name, const Eigen::Matrix4d& matrix, double timestampS);
/// IMAGE `name` of `rows` rows of `samples` elements (an A-line: 1 row), as PLUS streams it.
Packet encodeImage(const std::string& name, core::ElementType type, const std::uint8_t* pixels,
                   int samples, int rows, double timestampS);
/// STRING `name` (UTF-8 / US-ASCII text).
Packet encodeString(const std::string& name, const std::string& text, double timestampS);
/// STATUS `name` with an OpenIGTLink status code, an error name (at most 20 characters) and text.
Packet encodeStatus(const std::string& name, int code, const std::string& errorName,
                    const std::string& text, double timestampS);
/// POINT `name`: points of one group, named `<prefix><index>`.
Packet encodePoints(const std::string& name, const std::string& group,
                    const std::vector<Eigen::Vector3d>& points, double timestampS);

/// OpenIGTLink status codes echoreg uses (igtl::StatusMessage's values).
constexpr int kStatusOk = 1;
constexpr int kStatusNotReady = 13;

}  // namespace echoreg::live
