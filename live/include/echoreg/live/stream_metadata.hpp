// What a PLUS capture holds beyond its A-lines and poses, carried in echoreg's own STRING
// messages so that `echoreg live` records exactly what `echoreg serve` streamed:
// "EchoregCapture" (once, first: the acquisition settings and the header keys) and
// "EchoregFrame" (before each frame's IMAGE: the frame's timestamp as the capture holds it, which
// OpenIGTLink's 32.32 fixed point carries only to 0.23 ns, and its fields such as ImageStatus).
// Other peers do not send them; the recording then holds what they did send (timestamps to 1 ns).
#pragma once

#include "echoreg/core/sequence.hpp"

#include <string>
#include <utility>
#include <vector>

namespace echoreg::live {

constexpr const char* kCaptureHeaderName = "EchoregCapture";
constexpr const char* kFrameName = "EchoregFrame";

/// The acquisition settings and extra header keys of `sequence` as JSON text.
std::string captureHeaderJson(const core::Sequence& sequence);
/// Sets `layout`'s acquisition and extraHeader from captureHeaderJson's text. Throws
/// std::invalid_argument for text that is not such JSON.
void applyCaptureHeader(const std::string& text, core::Sequence& layout);

/// A frame's exact timestamp and its fields.
struct FrameMetadata {
  double timestampS = 0.0;
  std::vector<std::pair<std::string, std::string>> fields;
};
/// A frame's fields at `timestampS` (its own, or shifted: `serve --repeat`) as JSON text
/// ({"timestamp": 11.120000000000001, "fields": [["ImageStatus","OK"]]}) and back (throws
/// std::invalid_argument for other text).
std::string frameJson(const core::SequenceFrame& frame, double timestampS);
FrameMetadata parseFrameJson(const std::string& text);

}  // namespace echoreg::live
