// Golden bits: for fixed inputs the project generates itself, the output of every kernel and of the
// whole disparity pipeline hashes to the same value on every back end: the scalar level, each
// native ISA level this CPU has (SSE4.2, AVX2, AVX-512 on x86; NEON on aarch64, run under
// qemu-aarch64 by the aarch64 preset) and the counting back end. The hashes are written down here,
// so the x86 host, the simulator and an ARM board are held to the same bits.
//
// A kernel registered without a golden case fails KernelsAllHaveAGoldenCase. When a kernel's
// output changes on purpose, the failure prints the new hash to paste here (say why in the commit).
#include <gtest/gtest.h>

#include <cinttypes>
#include <cstdio>
#include <random>
#include <set>

#include "arm/disparity_engine.h"
#include "arm/scheduler.h"
#include "arm/tasks/road_profile.h"
#include "dag/remap_table.h"
#include "dag/tile_executor.h"
#include "io/synthetic_scene.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

// FNV-1a over the image area, row by row (padding excluded), plus the size.
uint64_t plane_hash(const Plane& plane) {
  uint64_t hash = 0xcbf29ce484222325ull;
  auto mix = [&](uint8_t byte) {
    hash ^= byte;
    hash *= 0x100000001b3ull;
  };
  for (int shift = 0; shift < 32; shift += 8) mix(static_cast<uint8_t>(plane.width() >> shift));
  for (int shift = 0; shift < 32; shift += 8) mix(static_cast<uint8_t>(plane.height() >> shift));
  const size_t row_bytes = static_cast<size_t>(plane.width()) * plane.element_size();
  for (int y = 0; y < plane.height(); ++y) {
    const uint8_t* row = plane.row<uint8_t>(y);
    for (size_t i = 0; i < row_bytes; ++i) mix(row[i]);
  }
  return hash;
}

// Deterministic inputs by format: raw mt19937 words (the engine is specified bit for bit by the
// standard, unlike the distributions), shaped to exercise each kernel.
Plane golden_input(const PortSpec& port, PlaneShape shape, uint32_t seed) {
  if (port.format.type == ElementType::remap_q5) {
    return make_synthetic_rectification_map(shape.width, shape.height, SyntheticRectification{});
  }
  Plane plane(shape.width, shape.height, port.format, 0);
  if (port.name == "road") {
    // A road profile record (arm/tasks/road_profile.h): valid, d(v) = 0.5 v - 10 px (Q16 slope
    // 32768, intercept -655360), horizon row 20 (Q8 5120), and a far segment (a climb) above row 40:
    // d(v) = 0.25 v (Q16 16384, intercept 0), which meets the near line there; the other words zero.
    for (int x = 0; x < shape.width; ++x) plane.at<int32_t>(x, 0) = 0;
    plane.at<int32_t>(arm::kRoadValid, 0) = 1;
    plane.at<int32_t>(arm::kRoadSlopeQ16, 0) = 32768;
    plane.at<int32_t>(arm::kRoadInterceptQ16, 0) = -655360;
    plane.at<int32_t>(arm::kRoadHorizonRowQ8, 0) = 5120;
    plane.at<int32_t>(arm::kRoadFarValid, 0) = 1;
    plane.at<int32_t>(arm::kRoadFarSlopeQ16, 0) = 16384;
    plane.at<int32_t>(arm::kRoadFarInterceptQ16, 0) = 0;
    plane.at<int32_t>(arm::kRoadFarBreakRow, 0) = 40;
    return plane;
  }
  std::mt19937 words(seed);
  if ((port.name == "x" || port.name == "y" || port.name == "z") && port.format.type == ElementType::s32) {
    // Camera-frame points in mm (point_cell_binning's inputs): -70000 .. 69999 (past the kernel's
    // +-65535 range at both ends), every 13th pixel no point (kNoPointMm = INT32_MIN).
    for (int y = 0; y < shape.height; ++y) {
      for (int x = 0; x < shape.width; ++x) {
        const uint32_t word = static_cast<uint32_t>(words());
        plane.at<int32_t>(x, y) = (x + y * shape.width) % 13 == 12 ? INT32_MIN : static_cast<int32_t>(word % 140000u) - 70000;
      }
    }
    return plane;
  }
  if (port.name == "keypoints" && port.format.type == ElementType::s32) {
    // A keypoint list (arm/tasks/keypoint_record.h: valid, x, y, response) over a 97 x 61 image:
    // positions anywhere (some too near the border for a patch), every fifth row invalid.
    for (int y = 0; y < shape.height; ++y) {
      int32_t* record = plane.row<int32_t>(y);
      record[0] = y % 5 == 4 ? 0 : 1;
      for (int x = 1; x < shape.width; ++x) record[x] = static_cast<int32_t>(static_cast<uint32_t>(words()) % (x == 2 ? 61u : 97u));
    }
    return plane;
  }
  for (int y = 0; y < shape.height; ++y) {
    for (int x = 0; x < shape.width; ++x) {
      const uint32_t word = static_cast<uint32_t>(words());
      switch (port.format.type) {
        case ElementType::u8:
          if (port.name == "mask") {  // an obstacle mask: no vote, free, obstacle, and 3 (not a mask value)
            plane.at<uint8_t>(x, y) = static_cast<uint8_t>(word % 4);
            break;
          }
          // A smooth ramp plus noise: structure for census and medians, ties for the comparisons.
          plane.at<uint8_t>(x, y) = static_cast<uint8_t>((x * 3 + y * 2) / 4 + (word & 0x1F));
          break;
        case ElementType::census32:
          plane.at<uint32_t>(x, y) = word & 0x00F0F0F0u & (word >> 3);
          break;
        case ElementType::census64:
          plane.at<uint64_t>(x, y) = (uint64_t{word} << 32 | static_cast<uint32_t>(words())) & 0x3FFFFFFFFFFFFFFFull;
          break;
        case ElementType::u16:
          plane.at<uint16_t>(x, y) = static_cast<uint16_t>(word & 0x0FFF);  // e.g. SGM forward sums, < 4096
          break;
        case ElementType::s16:
          plane.at<int16_t>(x, y) = static_cast<int16_t>(static_cast<int>(word % 1200) - 100);
          break;
        default: {
          uint8_t* element = plane.row<uint8_t>(y) + static_cast<size_t>(x) * plane.element_size();
          for (int byte = 0; byte < plane.element_size(); ++byte) element[byte] = static_cast<uint8_t>(word >> (8 * (byte % 4)));
        }
      }
    }
  }
  return plane;
}

struct GoldenCase {
  std::string kernel;
  nlohmann::json params;
  BorderMode border_mode;
  std::vector<PlaneShape> input_shapes;
  uint64_t hash;  // of output 0, from the scalar reference
};

// 97 x 61: odd, wider than one 512-bit vector of u8 and with a partial last chunk on every level.
const std::vector<GoldenCase>& golden_cases() {
  static const std::vector<GoldenCase> cases = {
      {"census5x5", nlohmann::json::object(), BorderMode::replicate, {{97, 61}}, 0x40ccef81b86a8ea8ull},
      {"census9x7", nlohmann::json::object(), BorderMode::constant, {{97, 61}}, 0x1baf97e699f34578ull},
      {"census9x9_sparse", nlohmann::json::object(), BorderMode::replicate, {{97, 61}}, 0x65e9259a0553b942ull},
      {"census_wta_disparity", {{"min_disparity", -3}, {"num_disparities", 24}, {"max_cost_bits", 5}},
       BorderMode::replicate, {{97, 61}, {97, 61}}, 0x78c485fbf2aecb61ull},
      {"median3x3", nlohmann::json::object(), BorderMode::replicate, {{97, 61}}, 0xfe146256b73fdb16ull},
      {"remap_bilinear", nlohmann::json::object(), BorderMode::constant, {{97, 61}, {97, 61}}, 0xae5d9a5b4982d4f4ull},
      {"downsample2x", nlohmann::json::object(), BorderMode::replicate, {{97, 61}}, 0xf62a5de4e48df7b2ull},
      {"median3x3_s16", {{"invalid_q4", -16}}, BorderMode::replicate, {{97, 61}}, 0x2a44dd156fc0ce16ull},
      {"discontinuity_near_side", {{"invalid_q4", -16}, {"radius_px", 3}, {"jump_q4", 32}}, BorderMode::replicate, {{97, 61}}, 0xe101cc090dec6f5aull},
      // Inputs -100 .. 1099 (Q4, integer parts -7 .. 68): the invalid marker -64 (bin -1), below
      // the bins, 40 bins (a partial 32-lane block) and above them.
      {"v_disparity", {{"min_disparity", -3}, {"num_bins", 40}}, BorderMode::replicate, {{97, 61}}, 0x8d71a94bed7f6205ull},
      // Disparity -100 .. 1099 (Q4; the invalid marker -64) against the road 0.5 v - 10 px (road_q4 from
      // -160 to 320 over the 61 rows): rows above 20 - 8 cast no vote; tolerance 200 Q4 in a 3-row window.
      {"vldh_mask", {{"min_disparity", -3}, {"window_rows", 3}, {"min_count", 2}, {"match_tolerance_q4", 200}, {"rows_above_horizon", 8}},
       BorderMode::replicate, {{97, 61}, {arm::kRoadProfileWords, 1}}, 0x9779b22e15486644ull},
      // Disparity -100 .. 1099 (Q4) across [1.5, 60) px in 40 rows (k = 1.5), masks 0 .. 3 (3: no
      // vote), 5-column cells (the last one 2 columns wide): positive, negative (0) and mixed cells.
      {"advanced_u_disparity", {{"columns_per_cell", 5}, {"grid_rows", 40}, {"min_disparity_px", 1.5}, {"max_disparity_px", 60.0}, {"exponent_k", 1.5}, {"obstacle_weight", 3}, {"free_weight", 2}},
       BorderMode::replicate, {{97, 61}, {97, 61}}, 0x9b6d840661bf2124ull},
      // Inputs -100 .. 1099 (Q4): the invalid marker -64, d <= 0, the range and above it (> 976).
      {"disparity_to_points", {{"baseline_m", 0.12}, {"focal_px", 700.5}, {"u0_px", 48.3}, {"v0_px", 30.7}, {"min_disparity", -3}, {"num_disparities", 64}},
       BorderMode::replicate, {{97, 61}}, 0xb5e2659b9254767full},
      // Random camera points (see golden_input) through a camera 1.65 m up, pitched and rolled
      // (Q14 rotation of a few degrees), into a 60 m x 40 m area of 0.5 m cells around it.
      {"point_cell_binning", {{"rotation_q14", {-286, 858, 16357, -16380, -15, -286, 0, -16362, 858}}, {"translation_mm", {0, 0, 1650}},
                              {"forward_min_mm", -10000}, {"forward_max_mm", 50000}, {"lateral_min_mm", -20000}, {"lateral_max_mm", 20000}, {"cell_mm", 500}},
       BorderMode::replicate, {{97, 61}, {97, 61}, {97, 61}}, 0x57f7d05dd28b032eull},
      {"disparity_fuse_multires", {{"min_far", 0}, {"num_far", 40}, {"min_near", 0}, {"num_near", 40}, {"margin_px", 2}},
       BorderMode::replicate, {{97, 61}, {49, 31}}, 0x1f6bc6b4f586e441ull},
      // SGM: D = 40 spans two 32-lane vectors with a partial one; the backward pass gets forward
      // sums (40 per pixel) small enough to stay inside the proven 16-bit bound.
      {"sgm_4path", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0x4d01500b35a9dddcull},
      {"sgm_4path_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0xbd960f9cc30b333bull},
      {"sgm_8path_forward", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0x82e024665cb4156full},
      {"sgm_8path_forward_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0xd74c844c52218697ull},
      {"sgm_8path_backward", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 61}, {97, 61}, {97 * 40, 61}}, 0x50b280760fb88c40ull},
      {"sgm_8path_backward_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 61}, {97, 61}, {97 * 40, 61}}, 0xeaabfe9d7590a005ull},
      {"sgm_4path_row_pair_sums", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0xb38f88be77d58ffcull},
      {"sgm_4path_column_pair_sums", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0x47423da366d5c9d6ull},
      {"sgm_4path_row_pair_sums_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0x72f715c4fe28c998ull},
      {"sgm_4path_column_pair_sums_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0xc4b1077f5a193c01ull},
      {"sgm_8path_backward_sums", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0x7b4b1d3f9218db9dull},
      {"sgm_8path_backward_sums_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 61}, {97, 61}}, 0xfa203fec69c83cb2ull},
      {"harris_response", {{"window_size", 5}}, BorderMode::replicate, {{97, 61}}, 0xfe0ee533a9eb353full},
      // Raw random words: responses of every sign and size, the default threshold.
      {"harris_nms", {{"radius", 2}}, BorderMode::constant, {{97, 61}}, 0x28b080498a8d55f6ull},
      {"gaussian5x5", nlohmann::json::object(), BorderMode::constant, {{97, 61}}, 0x1cac97398381bbb3ull},
      // 40 keypoints on a 97 x 61 image (see golden_input), sector 3.
      {"brief256", {{"yaw_sector", 3}}, BorderMode::replicate, {{97, 61}, {4, 40}}, 0x82fa07fab96d7ccbull},
      // 40 random query descriptors against 37 random train descriptors (distances about 128 +- 8),
      // random valid words; ratio 0.9 and max_distance 124 (train indices and both distances are held too).
      {"hamming_match", {{"ratio_q8", 230}, {"max_distance", 124}}, BorderMode::replicate, {{8, 40}, {4, 40}, {8, 37}, {4, 37}}, 0xb727f39e80b99c21ull},
      // 40 keypoints (see golden_input) on 97 x 61 census planes, [-3, 21), 3 x 3 window, U = 10.
      {"sparse_disparity", {{"min_disparity", -3}, {"num_disparities", 24}, {"window_radius", 1}, {"uniqueness_percent", 10}},
       BorderMode::replicate, {{97, 61}, {97, 61}, {4, 40}}, 0x661230c272794cedull},
      // Camera formats to luma. u16 inputs are word & 0x0FFF: the low byte (yuyv's luma) random, the
      // high byte (uyvy's) 0 .. 15. The RGB input is 3 x 97 bytes per row of the u8 ramp plus noise.
      {"copy_u8", nlohmann::json::object(), BorderMode::replicate, {{97, 61}}, 0x06e23c25cd43a814ull},
      {"yuv422_to_luma", {{"order", "yuyv"}}, BorderMode::replicate, {{97, 61}}, 0x110dd43507f44bb2ull},
      {"yuv422_to_luma", {{"order", "uyvy"}}, BorderMode::replicate, {{97, 61}}, 0x51af7fcca88cd762ull},
      {"rgb888_to_luma", {{"order", "bgr"}}, BorderMode::replicate, {{3 * 97, 61}}, 0x740a5dc71b3098ffull},
      {"sgm_sums_select", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97 * 40, 61}, {97 * 40, 61}}, 0xe8ebb4cbc8b52d59ull},
      // The banded 8-path schedule over three bands (64, 64 and 22 rows); sgm_8path_bands gets the
      // checkpoints its census inputs give (derived_golden_inputs), its output is 8-path SGM's.
      {"sgm_8path_forward_checkpoints", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 150}, {97, 150}}, 0xfa5f8c8320e95be7ull},
      {"sgm_8path_backward_checkpoints", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 150}, {97, 150}}, 0x37c36b95a8c9c248ull},
      {"sgm_8path_forward_checkpoints_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 150}, {97, 150}}, 0xac6fc0ca7091d199ull},
      {"sgm_8path_backward_checkpoints_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}}, BorderMode::replicate, {{97, 150}, {97, 150}}, 0x6ac27fb8c336f1dcull},
      {"sgm_8path_bands", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 150}, {97, 150}, {3 * 97 * 40, 3}, {3 * 97 * 40, 3}}, 0x7b1fe995576c9186ull},
      {"sgm_8path_bands_census64", {{"min_disparity", -3}, {"num_disparities", 40}, {"p1", 5}, {"p2", 45}, {"uniqueness_percent", 5}, {"subpixel", 1}, {"lr_max_diff", 1}}, BorderMode::replicate, {{97, 150}, {97, 150}, {3 * 97 * 40, 3}, {3 * 97 * 40, 3}}, 0xdf6ab2102ed6fafcull},
  };
  return cases;
}

// Inputs a kernel needs to be consistent with its other inputs: sgm_8path_bands reads the checkpoints
// of its census inputs, so they are the checkpoint kernels' (reference) outputs, not random planes.
void derive_golden_inputs(const GoldenCase& golden, const std::vector<PlaneView>& input_views, std::vector<Plane>& inputs) {
  if (golden.kernel.rfind("sgm_8path_bands", 0) != 0) return;
  const std::string suffix = golden.kernel.size() > std::string("sgm_8path_bands").size() ? "_census64" : "";
  const char* passes[2] = {"sgm_8path_forward_checkpoints", "sgm_8path_backward_checkpoints"};
  nlohmann::json penalties = golden.params;
  for (const char* key : {"uniqueness_percent", "subpixel", "lr_max_diff"}) penalties.erase(key);
  for (int i = 0; i < 2; ++i) {
    const KernelDescriptor& checkpoints = testing::kernel_named(passes[i] + suffix);
    const PreparedKernel prepared = checkpoints.prepare(penalties, {golden.input_shapes[0], golden.input_shapes[1]});
    std::vector<PlaneView> outputs = {inputs.at(2 + i).view()};
    checkpoints.reference({input_views[0], input_views[1]}, outputs, prepared.params.get(), golden.border_mode, 0);
  }
}

// The first pixel where two planes differ, as "x=.. y=..", or "" if equal.
std::string first_difference(const Plane& expected, const Plane& actual) {
  const size_t element = static_cast<size_t>(expected.element_size());
  for (int y = 0; y < expected.height(); ++y) {
    for (int x = 0; x < expected.width(); ++x) {
      if (std::memcmp(expected.row<uint8_t>(y) + x * element, actual.row<uint8_t>(y) + x * element, element) != 0) {
        return "x=" + std::to_string(x) + " y=" + std::to_string(y);
      }
    }
  }
  return "";
}

std::string hex(uint64_t value) {
  char text[32];
  std::snprintf(text, sizeof(text), "0x%016" PRIx64 "ull", value);
  return text;
}

TEST(Golden, EveryKernelGivesItsGoldenBitsOnEveryBackEnd) {
  for (const GoldenCase& golden : golden_cases()) {
    const KernelDescriptor& kernel = testing::kernel_named(golden.kernel);
    std::vector<Plane> inputs;
    std::vector<PlaneView> input_views;
    int input = 0;
    for (const PortSpec& port : kernel.ports) {
      if (port.direction != PortDirection::input) continue;
      inputs.push_back(golden_input(port, golden.input_shapes.at(input), 1000u + static_cast<uint32_t>(input)));
      input_views.push_back(inputs.back().view());
      ++input;
    }
    derive_golden_inputs(golden, input_views, inputs);
    const PreparedKernel prepared = kernel.prepare(golden.params, golden.input_shapes);
    std::vector<BufferFormat> output_formats;
    for (const PortSpec& port : kernel.ports) {
      if (port.direction == PortDirection::output) output_formats.push_back(port.format);
    }
    auto run = [&](const std::function<void(std::vector<PlaneView>&)>& execute) {
      std::vector<Plane> outputs;
      std::vector<PlaneView> views;
      for (size_t o = 0; o < output_formats.size(); ++o) {
        outputs.emplace_back(prepared.output_shapes[o].width, prepared.output_shapes[o].height, output_formats[o]);
        views.push_back(outputs.back().view());
      }
      execute(views);
      return outputs;
    };
    const std::vector<Plane> reference = run([&](std::vector<PlaneView>& views) {
      kernel.reference(input_views, views, prepared.params.get(), golden.border_mode, 0);
    });
    const uint64_t reference_hash = plane_hash(reference[0]);
    EXPECT_EQ(hex(reference_hash), hex(golden.hash)) << golden.kernel << ": the scalar reference's output hash changed";
    auto check_back_end = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      const std::vector<Plane> outputs = run([&](std::vector<PlaneView>& views) {
        VectorNodeBinding binding{&kernel, prepared.params.get(), golden.border_mode, 0, input_views, views,
                                  prepared.input_halos, prepared.input_scales};
        run_vector_node(binding, 40, 16, backend, isa);
      });
      for (size_t o = 0; o < outputs.size(); ++o) {
        EXPECT_EQ(first_difference(reference[o], outputs[o]), "")
            << golden.kernel << " on " << label << ", output " << o << ": first pixel that differs from the reference";
      }
      EXPECT_EQ(hex(plane_hash(outputs[0])), hex(golden.hash)) << golden.kernel << " on " << label;
    };
    for (simd::Isa isa : simd::available_isas()) check_back_end(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
    check_back_end(KernelBackend::counting, simd::Isa::scalar, "counting");
  }
}

TEST(Golden, KernelsAllHaveAGoldenCase) {
  std::set<std::string> covered;
  for (const GoldenCase& golden : golden_cases()) covered.insert(golden.kernel);
  for (const std::string& name : KernelRegistry::instance().names()) {
    if (name.rfind("test_", 0) == 0) continue;  // test-only kernels
    EXPECT_TRUE(covered.count(name)) << "kernel '" << name << "' has no golden case in tests/kernels/golden_test.cpp";
  }
}

// The whole disparity pipeline on the built-in synthetic scene: the engine's defaults (8-path SGM by
// bands, LR check, median, speckle filter) and in the two-pass layout a target profile costs, and the
// chip graphs' matcher alone (4-path SGM, LR 1 px, no post-processing): a layout never changes a bit.
TEST(Golden, DisparityPipelineGivesItsGoldenBitsOnEveryBackEnd) {
  io::SyntheticSceneOptions scene_options;
  scene_options.width = 193;
  scene_options.height = 121;
  const io::SyntheticStereoScene scene = io::make_synthetic_stereo_scene(scene_options);
  struct Pipeline {
    std::string label;
    arm::DisparityParameters parameters;
    arm::EightPathLayout layout = arm::EightPathLayout::bands;
    uint64_t golden;
  };
  std::vector<Pipeline> pipelines(3);
  pipelines[0].label = "engine defaults (8 paths by bands)";
  pipelines[0].golden = 0x10f3737f44ee57beull;
  pipelines[2].label = "engine defaults, 8 paths as sgm_8path_forward + sgm_8path_backward";
  pipelines[2].layout = arm::EightPathLayout::forward_backward;
  pipelines[2].golden = pipelines[0].golden;  // a layout: the same bits
  pipelines[1].label = "4-path SGM alone";
  pipelines[1].parameters.paths = 4;
  pipelines[1].parameters.lr_max_diff = 1;
  pipelines[1].parameters.median = false;
  pipelines[1].parameters.speckle_max_size_px = 0;
  pipelines[1].golden = 0x35f7256dcdd1de53ull;
  for (Pipeline& pipeline : pipelines) {
    pipeline.parameters.num_disparities = 32;
    std::optional<Plane> scalar;
    auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      simd::ActiveIsaScope scope(isa);
      const auto graph = make_verified_graph(arm::DisparityEngine::graph_spec(pipeline.parameters, pipeline.layout),
                                             scene_options.width, scene_options.height, {});
      arm::FrameRunner runner(*graph, 2, backend);
      runner.process({{"left", &scene.left}, {"right", &scene.right}});
      const Plane& disparity = runner.buffer("disparity");
      if (!scalar) scalar = disparity.clone();
      EXPECT_EQ(first_difference(*scalar, disparity), "") << pipeline.label << " on " << label << " vs scalar";
      EXPECT_EQ(hex(plane_hash(disparity)), hex(pipeline.golden)) << pipeline.label << " on " << label;
    };
    check(KernelBackend::native, simd::Isa::scalar, "scalar");
    for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
    check(KernelBackend::counting, simd::Isa::scalar, "counting");
  }
}

}  // namespace
}  // namespace lpstereo
