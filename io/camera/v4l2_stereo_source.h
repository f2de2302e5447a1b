// The V4L2 stereo sources (spec strings v4l2:L,R and v4l2-sbs:D of io/camera/stereo_source.h):
//   - two capture devices, one per view, paired by timestamp (io/camera/timestamp_pairing.h;
//     tolerance SourceOptions::pairing_tolerance_ns, by default half the frame period of the slower
//     device). Each frame is converted to luma as soon as it is dequeued and its buffer given
//     back, so a stalled view never starves the other device of buffers; at most
//     kV4l2PairingQueueFrames frames wait per view.
//   - one device delivering left | right side by side: the device runs at twice the width
//     (SourceOptions::width is the width of one view), and each half is converted from its own
//     first pixel (convert_to_luma on the half's pointer, so no copy of the whole frame).
// Both views must have one size, or SourceError naming both devices and sizes. next(timeout)
// polls the devices together and never waits longer than `timeout`; a device that goes away makes
// every later next() return `disconnected` with the device's message; the destructor stops
// streaming, unmaps and closes (also after a disconnect).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/camera/stereo_source.h"

namespace lpstereo::io {

inline constexpr size_t kV4l2PairingQueueFrames = 4;  // per view: 4 frames of latency at most

// devices: two paths (left, right), or one path with side_by_side. Throws SourceError (one line)
// for a device that cannot be opened or negotiated, and std::invalid_argument, before opening
// anything, for a wrong device count or an option no device can be asked for (an unknown pixel
// format name, a negative or half-given size, a negative rate, fewer than 2 buffers, a tolerance
// below -1).
std::unique_ptr<StereoSource> open_v4l2_stereo_source(const std::vector<std::string>& devices, bool side_by_side,
                                                      const SourceOptions& options);

}  // namespace lpstereo::io
