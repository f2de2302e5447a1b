// A vector kernel as a descriptor (after OpenVX / TIOVX): its ports, neighbourhood, output block,
// scratch, parameters, and its implementations (one tile function per native ISA level, one for the
// counting back end, and a whole-image scalar reference used by the tests).
//
// A kernel is pure compute over tiles. The executor (arm/scheduler, host_sim) cuts the output into
// tiles, gives each window input its tile plus the declared halo (pixels outside the image already
// filled per the node's border mode), runs the tile function, and writes the output tile back. The
// kernel never sees the image border for window inputs; for whole-access inputs (the remap source)
// it sees the full plane and applies the border mode itself.
//
// Adding a kernel = one file in kernels/ that defines the tile body once (template over the back
// end), the reference, the descriptor, and registers it with LPSTEREO_REGISTER_KERNEL.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>  // the full header only where parameters are read (kernel.cpp), not in per-ISA units

#include "dag/format.h"
#include "kernels/simd/isa.h"

namespace lpstereo {

// A 2-D view of elements. Plain data: kernel bodies compiled per ISA level use it without calling
// any out-of-line or inline member code (see kernels/simd/native.h for why).
struct PlaneView {
  uint8_t* origin = nullptr;     // element (0, 0); halo pixels sit at negative offsets and past width
  ptrdiff_t stride_bytes = 0;    // bytes from one row to the next
  int32_t width = 0;             // elements per row, halo not included
  int32_t height = 0;            // rows, halo not included
};

template <class Element>
inline Element* plane_row(const PlaneView& plane, int y) {
  return reinterpret_cast<Element*>(plane.origin + static_cast<ptrdiff_t>(y) * plane.stride_bytes);
}

enum class BorderMode : uint8_t {
  replicate,  // outside pixels take the value of the nearest edge pixel
  constant,   // outside pixels take border_value
};

std::string_view border_mode_name(BorderMode mode);

// For scalar references: u8 pixel (x, y) of `plane`, or for (x, y) outside it what the border mode
// gives (replicate: the nearest edge pixel; constant: the low byte of border_value, as the tile
// executor fills a u8 halo). Out of line on purpose: references run in the baseline unit only.
uint8_t reference_pixel_u8(const PlaneView& plane, int x, int y, BorderMode border_mode, uint32_t border_value);

struct Halo {
  int left = 0, right = 0, top = 0, bottom = 0;
  bool operator==(const Halo&) const = default;
};

inline constexpr int kMaxKernelPorts = 8;

// Everything a tile function gets. Plain data for the same reason as PlaneView.
struct TileArgs {
  PlaneView inputs[kMaxKernelPorts];   // window inputs: the tile with halo around it; whole inputs: full plane
  int input_count = 0;
  PlaneView outputs[kMaxKernelPorts];  // the output tile
  int output_count = 0;
  const void* params = nullptr;        // the kernel's prepared parameter struct
  uint8_t* scratch = nullptr;          // scratch_bytes() of tile-local memory (SRAM on the chip)
  size_t scratch_bytes = 0;
  int32_t tile_x = 0, tile_y = 0;      // output tile origin in the full output plane
  int32_t image_width = 0, image_height = 0;  // full output plane size
  BorderMode border_mode = BorderMode::replicate;
  uint32_t border_value = 0;
  uint8_t* state = nullptr;            // row-state kernels: state_bytes() kept across the tiles of a frame
  size_t state_bytes = 0;
};

using TileFunction = void (*)(const TileArgs& args);

// Whole-image scalar reference: inputs and outputs are full planes (no halo); applies the border
// mode itself. Written for clarity, not speed; the tests compare every back end with it.
using ReferenceFunction = std::function<void(const std::vector<PlaneView>& inputs,
                                             const std::vector<PlaneView>& outputs, const void* params,
                                             BorderMode border_mode, uint32_t border_value)>;

enum class PortDirection : uint8_t { input, output };

enum class PortAccess : uint8_t {
  window,  // tile + halo, delivered by DMA per tile
  whole,   // random access to the whole plane (remap source); DMA'd by the bounding box the kernel reports
};

struct PortSpec {
  std::string name;
  PortDirection direction = PortDirection::input;
  BufferFormat format;
  PortAccess access = PortAccess::window;
};

struct PlaneShape {
  int width = 0;
  int height = 0;
  bool operator==(const PlaneShape&) const = default;
};

// A parameter, a port shape or a combination the kernel refuses. The message names the parameter
// or port, the expected and the actual value; the graph layer adds the node name and the phase.
class KernelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What prepare() returns: the kernel's own parameter struct and its output shapes.
// How a window input's coordinates relate to the output's, on both axes:
// input = output x numerator / denominator (2/1: the input is twice the output, a 2x downsampling
// kernel; 1/2: a 2x upsampling kernel). The input tile starts at floor(tile_x x n / d).
struct InputScale {
  int numerator = 1;
  int denominator = 1;
  bool operator==(const InputScale&) const = default;
};

// Rectangle in the full plane, [x0, x1) x [y0, y1).
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// The input rectangle (input coordinates, halo included, not clipped to the plane) that the output
// tile [tile_x, tile_x + tile_width) x [tile_y, tile_y + tile_height) reads.
PixelRect window_input_rect(const Halo& halo, const InputScale& scale, int tile_x, int tile_y, int tile_width,
                            int tile_height);

struct PreparedKernel {
  std::shared_ptr<const void> params;
  std::vector<PlaneShape> output_shapes;  // one per output port, in port order
  // Per input port (in input order), when the neighbourhood depends on the parameters (the right
  // view of a disparity search needs max_disparity - 1 columns to its left). Empty = every window
  // input uses the descriptor's halo.
  std::vector<Halo> input_halos;
  // Per input port, for kernels whose inputs are not the output's size (pyramids). Empty = 1/1.
  std::vector<InputScale> input_scales;
};

struct KernelDescriptor {
  std::string name;     // the name graph files use: "census5x5"
  std::string summary;  // one line for `lpstereo kernels` and the docs
  std::vector<PortSpec> ports;  // inputs first, then outputs
  Halo halo;                    // neighbourhood each window input needs around the output tile
  int block_width = 1;          // output tile widths are multiples of this (except at the right edge)
  int block_height = 1;
  std::vector<BorderMode> border_modes;  // the border modes the kernel supports (window inputs or its own)

  // Phase 2 and 5: validates the parameters and input shapes; returns the prepared parameters and
  // output shapes. Throws KernelError. Reads no frame data.
  std::function<PreparedKernel(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes)> prepare;

  // Tile-local scratch for an output tile of this size; defaults to none.
  std::function<size_t(int tile_width, int tile_height, const void* params)> scratch_bytes;

  // Row-state kernels (SGM path costs carried from one row to the next): the bytes of state that
  // persist across the tiles of one frame, zeroed before its first tile. Such a kernel gets
  // full-width tiles, top to bottom, on one worker. Unset = no state, tiles independent.
  std::function<size_t(int image_width, int image_height, const void* params)> state_bytes;
  // Row-state kernels only: the tiles come bottom to top (the backward pass of 8-path SGM); the
  // kernel walks the rows of each tile bottom to top itself.
  bool rows_bottom_up = false;
  // Tiles span whole output rows (the kernel works along each row, e.g. SGM's left-right check
  // collects the right view's minima over the row) but carry nothing from one tile to the next,
  // so they may run in parallel. Row-state kernels get full-width tiles anyway.
  bool full_width_tiles = false;

  // For whole-access inputs: the source rectangle an output tile reads (clipped to the plane), so
  // the simulator charges DMA for it. Defaults to the whole plane.
  std::function<PixelRect(int input_index, const PixelRect& output_tile, const PlaneShape& input_shape,
                          const void* params)>
      source_rect;

  TileFunction native[simd::kIsaCount] = {};  // per ISA level; scalar always set
  TileFunction counting = nullptr;            // the counting back end (same bits, tallies ops)
  ReferenceFunction reference;

  int input_count() const;
  int output_count() const;
  // The native tile function for the active ISA level (falls back to lower levels).
  TileFunction native_for(simd::Isa isa) const;
};

// All kernels linked into the program, by name.
class KernelRegistry {
 public:
  static KernelRegistry& instance();
  void add(KernelDescriptor descriptor);
  // Null if no such kernel.
  const KernelDescriptor* find(const std::string& name) const;
  std::vector<std::string> names() const;

 private:
  std::vector<std::unique_ptr<KernelDescriptor>> kernels_;
};

// Parameter helpers for prepare(): each throws KernelError naming the parameter, the expected range
// and the actual value.
int param_int(const nlohmann::json& params, const char* name, int default_value, int min_value, int max_value);
double param_double(const nlohmann::json& params, const char* name, double default_value, double min_value,
                    double max_value);
// Throws if `params` holds a key not in `known` (a typo must not silently fall back to a default).
void check_param_names(const nlohmann::json& params, const std::vector<std::string>& known);

namespace detail {
struct KernelRegistrar {
  explicit KernelRegistrar(KernelDescriptor (*make)()) { KernelRegistry::instance().add(make()); }
};
}  // namespace detail

}  // namespace lpstereo

// Registers the descriptor returned by `make_function` (a function returning KernelDescriptor).
// Use once per kernel, in the kernel's own file, in the baseline (LPSTEREO_ISA_TU == 0) build only.
#define LPSTEREO_REGISTER_KERNEL(identifier, make_function) \
  static const ::lpstereo::detail::KernelRegistrar lpstereo_kernel_registrar_##identifier(make_function)

// Declares and defines the per-ISA entry point `name_<isa>` for this translation unit, running the
// tile body template `body<Native>`. The baseline unit's entry is name_scalar.
#define LPSTEREO_CONCAT_INNER(a, b) a##_##b
#define LPSTEREO_CONCAT(a, b) LPSTEREO_CONCAT_INNER(a, b)
#define LPSTEREO_NATIVE_ENTRY(name, body)                                                        \
  namespace lpstereo::kernels {                                                                  \
  void LPSTEREO_CONCAT(name, LPSTEREO_ISA_SUFFIX)(const ::lpstereo::TileArgs& args) {           \
    body<::lpstereo::simd::Native>(args);                                                        \
  }                                                                                              \
  }

// Declares every per-ISA entry point of `name` and fills descriptor.native[] with those built.
#define LPSTEREO_DECLARE_NATIVE_ENTRIES(name)                                                    \
  namespace lpstereo::kernels {                                                                  \
  void name##_scalar(const ::lpstereo::TileArgs&);                                               \
  void name##_sse42(const ::lpstereo::TileArgs&);                                                \
  void name##_avx2(const ::lpstereo::TileArgs&);                                                 \
  void name##_avx512(const ::lpstereo::TileArgs&);                                               \
  void name##_avx512_icl(const ::lpstereo::TileArgs&);                                           \
  void name##_neon(const ::lpstereo::TileArgs&);                                                 \
  }

#if defined(LPSTEREO_HAVE_ISA_SSE42)
#define LPSTEREO_NATIVE_SSE42(name) descriptor.native[int(::lpstereo::simd::Isa::sse42)] = ::lpstereo::kernels::name##_sse42;
#else
#define LPSTEREO_NATIVE_SSE42(name)
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX2)
#define LPSTEREO_NATIVE_AVX2(name) descriptor.native[int(::lpstereo::simd::Isa::avx2)] = ::lpstereo::kernels::name##_avx2;
#else
#define LPSTEREO_NATIVE_AVX2(name)
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX512)
#define LPSTEREO_NATIVE_AVX512(name) descriptor.native[int(::lpstereo::simd::Isa::avx512)] = ::lpstereo::kernels::name##_avx512;
#else
#define LPSTEREO_NATIVE_AVX512(name)
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX512_ICL)
#define LPSTEREO_NATIVE_AVX512_ICL(name) descriptor.native[int(::lpstereo::simd::Isa::avx512_icl)] = ::lpstereo::kernels::name##_avx512_icl;
#else
#define LPSTEREO_NATIVE_AVX512_ICL(name)
#endif
#if defined(LPSTEREO_HAVE_ISA_NEON)
#define LPSTEREO_NATIVE_NEON(name) descriptor.native[int(::lpstereo::simd::Isa::neon)] = ::lpstereo::kernels::name##_neon;
#else
#define LPSTEREO_NATIVE_NEON(name)
#endif

// Inside a function building `descriptor`: sets native[] for every level this build compiled.
#define LPSTEREO_FILL_NATIVE_TABLE(name)                                            \
  descriptor.native[int(::lpstereo::simd::Isa::scalar)] = ::lpstereo::kernels::name##_scalar; \
  LPSTEREO_NATIVE_SSE42(name) LPSTEREO_NATIVE_AVX2(name) LPSTEREO_NATIVE_AVX512(name) LPSTEREO_NATIVE_AVX512_ICL(name) \
  LPSTEREO_NATIVE_NEON(name)
