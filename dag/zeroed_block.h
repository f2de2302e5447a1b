// Zeroed, 64-byte aligned memory for the large buffers of a frame: graph planes, row state, tile
// scratch. A block of 2 MiB or more is mapped on its own (mmap: the kernel hands it out zeroed, so
// it is not zeroed twice), aligned to 2 MiB and advised as transparent huge pages (madvise
// MADV_HUGEPAGE, which Linux honours in its "madvise" THP mode, Debian's default, and in "always"):
// its first touch then faults 2 MiB at a time instead of 4 KiB, 512 times fewer faults. A one-shot
// run touches every buffer once, so page faults and zeroing were most of its time (an 8-path
// `lpstereo disparity` at 1282x1110 x 256 spent 0.5 s of 1.1 s in the kernel). Where the system
// gives no huge pages (THP "never"), the advice is ignored and the block is plain zeroed pages:
// same contents, same bits. Smaller blocks come from the heap (aligned_alloc + memset).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace lpstereo {

inline constexpr size_t kHugePageBytes = size_t{2} << 20;

// The memory a block of `bytes` takes (rounded up to 64 bytes, or to whole huge pages from
// kHugePageBytes on): what the engines' working-set figures count.
inline constexpr size_t zeroed_block_footprint(size_t bytes) {
  const size_t unit = bytes >= kHugePageBytes ? kHugePageBytes : 64;
  return (bytes + unit - 1) / unit * unit;
}

class ZeroedBlock {
 public:
  ZeroedBlock() = default;
  // `bytes` zeroed bytes (at least 1). Throws std::bad_alloc.
  explicit ZeroedBlock(size_t bytes);
  ~ZeroedBlock();
  ZeroedBlock(ZeroedBlock&& other) noexcept;
  ZeroedBlock& operator=(ZeroedBlock&& other) noexcept;
  ZeroedBlock(const ZeroedBlock&) = delete;
  ZeroedBlock& operator=(const ZeroedBlock&) = delete;

  uint8_t* get() const { return data_; }
  size_t size() const { return bytes_; }
  // Hands the memory to a shared owner (Plane's storage), which releases it the same way.
  std::shared_ptr<uint8_t> share() &&;

 private:
  static void release(uint8_t* data, size_t mapped_bytes);
  uint8_t* data_ = nullptr;
  size_t bytes_ = 0;
  size_t mapped_bytes_ = 0;  // 0: from the heap (free); else the mapping's length (munmap)
};

// A block that grows on demand and keeps its memory (tile scratch): contents unspecified (zero
// after a growth).
class GrowingBlock {
 public:
  uint8_t* data() const { return block_.get(); }
  size_t size() const { return block_.size(); }
  // Makes the block at least `bytes` large (no-op when it is).
  void reserve(size_t bytes) {
    if (bytes > block_.size()) block_ = ZeroedBlock(bytes);
  }

 private:
  ZeroedBlock block_;
};

}  // namespace lpstereo
