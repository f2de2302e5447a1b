// The heap policy of a process that runs frames: what one frame frees stays in the process for the
// next, instead of going back to the kernel and being faulted in again.
//
// A frame loop allocates and frees the same large blocks every frame: arm::triangulate's three
// s32 planes (1.2 MB each at 640x480), the terrain's grids and point lists, the candidates' bands.
// glibc's malloc maps a block of 128 KiB or more on its own and unmaps it when freed (the mmap
// threshold; each such free raises it to that block's size, up to 32 MiB), and it gives the top of
// a heap back to the kernel once more than the trim threshold lies free there (128 KiB, raised to
// twice the mmap threshold with it): a frame's 3.7 MB of planes is more. So each frame faults the
// same pages in again, one fault per 4 KiB page, each page zeroed by the kernel. On the 2-core
// KVM guest of 2026-12-06 a fault cost about 10 us: allocating the three planes took 8.7-14.6 ms
// (median of 50) against 0.04 ms with this policy, and obstacles3d_chain_bench's frame took 41.9
// -> 25.1 ms wall (process CPU 54.4 -> 36.6 ms; triangulate 7.7 -> 0.8 ms, the terrain stage 17.9
// -> 8.0 ms; docs/obstacles3d.md, "Speed: the full chain").
//
// keep_freed_heap_memory() sets glibc's mmap threshold to 32 MiB (the largest mallopt takes; it
// also stops the threshold's dynamic adjustment) and turns trimming off. Blocks under 32 MiB then
// come from the heaps (the main one and the threads' arenas) and stay there once freed, ready for
// the next frame. The price is that the process keeps its peak heap for its life, which is what a
// process that runs the same frame over and over wants (real-time Linux guides set the same, with
// mlockall). Blocks of 32 MiB and more, the SGM volumes, are still mapped on their own: their owner,
// arm::DisparityEngine, keeps them for its life.
//
// It is a process-wide setting, so the program decides it, not the library: the lpstereo command
// and the benchmarks call it first thing in main(). Call it before the threads start.
#pragma once

namespace lpstereo::arm {

// Returns true when the C library's malloc took both settings. False where the allocator is not
// glibc's (another C library; a sanitizer's allocator, which replaces malloc and answers mallopt
// with a refusal): the allocator keeps its own policy then.
bool keep_freed_heap_memory();

}  // namespace lpstereo::arm
