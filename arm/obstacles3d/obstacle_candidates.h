// The obstacle candidates of one frame (issue 10: "obstacle candidates are the terrain's outliers"),
// one implementation for `lpstereo obstacles3d`, bench/obstacles3d_eval and the full-chain bench.
//
// Steps: (1) every valid disparity's camera point (arm::triangulate, millimetres) becomes an
// ObstaclePoint in metres, with its vehicle-frame position (CameraToVehicle), its disparity, pixel
// and colour; (2) the vehicle points are condensed into the 2.5D grid and the terrain is fitted
// (arm/terrain: height_grid, fit_terrain); (3) classify_points keeps the points more than
// obstacle_height_m above the fitted surface, with their height above it. When the terrain is
// unknown (too few cells, a wall filling the view ...) there are no candidates and `note` says why.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "dag/plane.h"

namespace lpstereo::arm::obstacles3d {

// An 8-bit, 3-channel interleaved image the size of the disparity map (a cv::Mat CV_8UC3's data,
// say), or none: then every point gets the grey of `grey` (u8 plane) repeated.
struct ColourView {
  const uint8_t* pixels = nullptr;
  size_t row_stride_bytes = 0;
  bool blue_first = true;  // OpenCV's BGR order; false for RGB
};

struct CandidateParameters {
  double obstacle_height_m = 0.2;  // a point this far above the fitted surface is a candidate, (0, 10)
  terrain::TerrainGridSpec grid;   // default: x 0..34 m forward, y -11..11 m, 0.5 m cells
  terrain::TerrainFitParameters fit;
};

struct CandidatePoints {
  std::vector<ObstaclePoint> points;  // the candidates, height_above_ground_m set
  int64_t cloud_points = 0;           // valid disparities triangulated
  int64_t outside_area = 0;           // not covered by the terrain area (no height above ground)
  terrain::TerrainEstimate terrain;   // the fit (terrain.known false: no candidates)
  // The 2.5D grid before the fit's equalisation (empty when the cloud was empty): what
  // terrain::compute_traversability takes beside the fit (terrain.grid is the equalised one).
  terrain::HeightGrid measured_grid;
  std::string note;                   // one line for a status or log
};

// `grey` (u8) and the colour view, when given, are the left image the disparity map belongs to.
// Throws std::invalid_argument when the planes' sizes disagree or obstacle_height_m is out of range.
CandidatePoints extract_obstacle_candidates(const Plane& disparity_q4, int16_t invalid_disparity_q4, const CameraPoints& camera,
                                            const Plane& grey, const ColourView& colour, const CameraToVehicle& to_vehicle,
                                            const CandidateParameters& parameters);

}  // namespace lpstereo::arm::obstacles3d
