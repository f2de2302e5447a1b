// A disk cache of rendered sequence frames (io/stereo_sequence.h), for the evaluations that render the
// same preset sequences run after run: in bench/obstacles3d_eval the rendering is 60-90 % of a run's
// time (floating seed 3, 300 frames, one thread: 188 s of 215 s), and a rule tried on the moving flag or
// the stixels needs the same sequences again. A frame read back is the rendered frame bit for bit, so a
// run from the cache gives the same figures as one that renders.
//
// The key. Every frame file carries the key of its sequence; a file of another key is not read. The key
// is FNV-1a (64 bit) over the format version, frame 0 as rendered (the grey and colour views, the true
// disparity, the object ids, the pose and the truth of every object: they change with any option of the
// scene, the camera, the ground or the renderer's own code), and the options that move only the later
// frames (camera_speed_mps, yaw_rate_rad_s, fps, the moving objects and their velocities). The caller
// renders frame 0 whatever the cache holds; it is also where the calibration comes from, which is the
// same for every frame and is not stored.
//
// The file (one per frame, `<directory>/<key as 16 hex digits>/<frame as 6 digits>.frame`, written by
// this host for this host: native byte order and struct layout, not an interchange format):
//   "LPSEQFC1"; u64 key; i32 frame;
//   6 images (left, right, left_colour, right_colour, disparity_px, object_ids): i32 rows, i32 cols,
//     i32 OpenCV type, then rows x cols x element bytes, row by row (rows = 0: empty);
//   f64 focal_px; SynthCameraPose; u32 n + n SynthObjectTruth; u32 n + n SequenceObjectTruth; "END1".
// Written to a temporary name in the same folder and renamed into place, so a file under its own name
// is always whole; a file that is not (truncated, another format, another key or frame) is reported as
// damaged, and the caller renders the frame again.
#pragma once

#include <cstdint>
#include <string>

#include "io/calibration.h"
#include "io/stereo_sequence.h"

namespace lpstereo::io {

// FNV-1a (64 bit) over the frame's bits: the six images, focal_px, the pose, every object's truth
// (what the key takes from frame 0; bench/synth_render_bench prints it to show that a change of the
// renderer kept the bits).
uint64_t sequence_frame_digest(const StereoSequenceFrame& frame);

uint64_t sequence_cache_key(const StereoSequenceOptions& options, const StereoSequenceFrame& first_frame);

std::string sequence_frame_cache_path(const std::string& directory, uint64_t key, int frame);

enum class CachedFrame { missing, loaded, damaged };

// missing: no file at `path`; damaged: a file that is not a whole frame `frame` of `key` (why in
// *problem); loaded: `out` holds the frame, its calibration set to `calibration`.
CachedFrame read_cached_sequence_frame(const std::string& path, uint64_t key, int frame, const StereoCalibration& calibration,
                                       StereoSequenceFrame& out, std::string* problem = nullptr);

// Creates the folders on the way. Throws std::runtime_error naming the file when it cannot be written
// (nothing is left under its name then).
void write_cached_sequence_frame(const std::string& path, uint64_t key, int frame, const StereoSequenceFrame& rendered);

}  // namespace lpstereo::io
