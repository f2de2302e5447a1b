#include "dag/zeroed_block.h"

#include <cstdlib>
#include <cstring>
#include <new>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#define LPSTEREO_MAPS_LARGE_BLOCKS 1
#endif

namespace lpstereo {

ZeroedBlock::ZeroedBlock(size_t bytes) {
  if (bytes == 0) bytes = 1;
  bytes_ = bytes;
#if defined(LPSTEREO_MAPS_LARGE_BLOCKS)
  if (bytes >= kHugePageBytes) {
    // Map one huge page more than needed, keep the 2 MiB aligned part, give the rest back.
    const size_t length = zeroed_block_footprint(bytes);
    void* mapped = mmap(nullptr, length + kHugePageBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) throw std::bad_alloc();
    auto* start = static_cast<uint8_t*>(mapped);
    const uintptr_t address = reinterpret_cast<uintptr_t>(start);
    auto* aligned = start + ((kHugePageBytes - address % kHugePageBytes) % kHugePageBytes);
    if (aligned > start) munmap(start, static_cast<size_t>(aligned - start));
    const size_t tail = static_cast<size_t>(start + length + kHugePageBytes - (aligned + length));
    if (tail > 0) munmap(aligned + length, tail);
#if defined(MADV_HUGEPAGE)
    (void)madvise(aligned, length, MADV_HUGEPAGE);  // advice: refused where THP is off, plain pages then
#endif
    data_ = aligned;
    mapped_bytes_ = length;
    return;
  }
#endif
  const size_t allocation = zeroed_block_footprint(bytes);
  data_ = static_cast<uint8_t*>(std::aligned_alloc(64, allocation));
  if (data_ == nullptr) throw std::bad_alloc();
  std::memset(data_, 0, allocation);
}

void ZeroedBlock::release(uint8_t* data, size_t mapped_bytes) {
  if (data == nullptr) return;
#if defined(LPSTEREO_MAPS_LARGE_BLOCKS)
  if (mapped_bytes > 0) {
    munmap(data, mapped_bytes);
    return;
  }
#endif
  (void)mapped_bytes;
  std::free(data);
}

ZeroedBlock::~ZeroedBlock() { release(data_, mapped_bytes_); }

ZeroedBlock::ZeroedBlock(ZeroedBlock&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      bytes_(std::exchange(other.bytes_, 0)),
      mapped_bytes_(std::exchange(other.mapped_bytes_, 0)) {}

ZeroedBlock& ZeroedBlock::operator=(ZeroedBlock&& other) noexcept {
  if (this != &other) {
    release(data_, mapped_bytes_);
    data_ = std::exchange(other.data_, nullptr);
    bytes_ = std::exchange(other.bytes_, 0);
    mapped_bytes_ = std::exchange(other.mapped_bytes_, 0);
  }
  return *this;
}

std::shared_ptr<uint8_t> ZeroedBlock::share() && {
  const size_t mapped = mapped_bytes_;
  uint8_t* data = std::exchange(data_, nullptr);
  bytes_ = 0;
  mapped_bytes_ = 0;
  return std::shared_ptr<uint8_t>(data, [mapped](uint8_t* pointer) { release(pointer, mapped); });
}

}  // namespace lpstereo
