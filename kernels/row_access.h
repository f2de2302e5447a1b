// Row loads and stores with a clipped right end, shared by the tile bodies.
//
// A tile body walks a row in chunks of one vector. The last chunk of a row may run past the bytes
// the body may touch (the tile's width plus its right halo on input, the tile's width on output:
// the rest of the row belongs to the next tile or is padding), so it uses the partial forms of the
// contract (kernels/simd/emulated.h), which read or write only the lanes inside. Either form is one
// load or one store op, so a body's op count does not depend on where a row ends.
//
// These are templates over the back end B, so each ISA level's unit instantiates its own copy (no
// standard-library calls inside: see kernels/simd/native.h for why code must not merge across levels).
#pragma once

namespace lpstereo::kernels {

// The vector at row[column .. column + lanes), reading no element at or past row[readable_end];
// lanes from readable_end on are 0. One load op. Requires column <= readable_end.
template <class B, class Lane>
auto load_clipped(const Lane* row, int column, int readable_end) {
  constexpr int kLanes = B::kBytes / static_cast<int>(sizeof(Lane));
  const int readable = readable_end - column;
  return readable >= kLanes ? B::load(row + column) : B::load_partial(row + column, readable > 0 ? readable : 0);
}

// Stores `value` at row[column ..), writing no element at or past row[writable_end]. One store op.
template <class B, class Lane, class Vector>
void store_clipped(Lane* row, int column, int writable_end, const Vector& value) {
  constexpr int kLanes = B::kBytes / static_cast<int>(sizeof(Lane));
  const int writable = writable_end - column;
  if (writable >= kLanes) {
    B::store(row + column, value);
  } else {
    B::store_partial(row + column, value, writable > 0 ? writable : 0);
  }
}

}  // namespace lpstereo::kernels
