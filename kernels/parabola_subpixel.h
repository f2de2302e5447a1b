// The parabola sub-pixel step of the disparity matchers (the SGM kernels, kernels/sgm_core.h, and
// sparse_disparity), one definition so the two give the same offsets for the same costs.
//
// With b the winning disparity and C its cost, a = C(b - 1) - C(b) > 0 (ties go to the smallest d,
// so the left neighbour is strictly higher) and c = C(b + 1) - C(b) >= 0, the vertex of the parabola
// through the three costs lies (a - c) / (2 (a + c)) px from b. In Q4, rounded half up:
//   q = (16 |a - c| + a + c) / (2 (a + c)),  offset = -q when c > a, else +q.
// |a - c| <= a + c gives 0 <= q <= 8 (|offset| <= 0.5 px), so q has 4 bits and comes from a 4-step
// restoring division (compare, subtract, select, add; the contract has no divide op). u32 lanes:
// the numerator is at most 17 (a + c); callers keep a + c below 2^27 (SGM: < 2^17; sparse_disparity:
// < 2^17 as well, its sentinels are 0xFFFF), so nothing wraps.
// Ops (every back end): arith 13, logic 8, shift 4, compare 5.
#pragma once

namespace lpstereo::kernels {

// bit_values[k] = 1 << k in every lane; zero = 0 in every lane (the caller's broadcasts).
template <class B>
[[gnu::always_inline]] inline typename B::VU32 parabola_offset_q4(const typename B::VU32& a, const typename B::VU32& c,
                                                                   const typename B::VU32 (&bit_values)[4],
                                                                   const typename B::VU32& zero) {
  using VU32 = typename B::VU32;
  const VU32 difference = B::sub(B::max(a, c), B::min(a, c));
  const VU32 negative = B::cmpgt(c, a);
  const VU32 denominator = B::add(a, c);
  VU32 numerator = B::add(B::template shl<4>(difference), denominator);
  const VU32 divisor = B::add(denominator, denominator);
  const VU32 t3 = B::template shl<3>(divisor);
  const VU32 below3 = B::cmplt(numerator, t3);
  numerator = B::select(below3, numerator, B::sub(numerator, t3));
  VU32 quotient = B::bit_andnot(below3, bit_values[3]);
  const VU32 t2 = B::template shl<2>(divisor);
  const VU32 below2 = B::cmplt(numerator, t2);
  numerator = B::select(below2, numerator, B::sub(numerator, t2));
  quotient = B::add(quotient, B::bit_andnot(below2, bit_values[2]));
  const VU32 t1 = B::template shl<1>(divisor);
  const VU32 below1 = B::cmplt(numerator, t1);
  numerator = B::select(below1, numerator, B::sub(numerator, t1));
  quotient = B::add(quotient, B::bit_andnot(below1, bit_values[1]));
  const VU32 below0 = B::cmplt(numerator, divisor);
  quotient = B::add(quotient, B::bit_andnot(below0, bit_values[0]));
  return B::select(negative, B::sub(zero, quotient), quotient);
}

}  // namespace lpstereo::kernels
