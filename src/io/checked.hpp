// Checked size arithmetic for the readers (issue 25).
//
// Every count, size and offset a reader derives from file data goes through
// these: a product, a sum or a conversion that does not fit its type is
// reported (false), never wrapped.  A VTU zlib header with nb = 3 and
// bs = 2^63 once gave (nb - 1) * bs + last = 192 in uint64_t arithmetic and a
// 192-byte buffer that zlib was told could take 2^63 bytes.
//
// Usage: `uint64_t total; if (!ck_mul(nb - 1, bs, total) || !ck_add(total,
// last, total)) return error;`.  The builtins are GCC's and Clang's
// (documented in GCC's "Integer Overflow Builtins"); they are exact for
// every integer type, signed or unsigned, including mixed operand types.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace tetopt::detail {

/// out = a * b; false (out unspecified) when the exact product does not fit.
template <class A, class B, class R>
[[nodiscard]] inline bool ck_mul(A a, B b, R& out) {
  static_assert(std::is_integral_v<A> && std::is_integral_v<B> && std::is_integral_v<R>);
  return !__builtin_mul_overflow(a, b, &out);
}

/// out = a + b; false when the exact sum does not fit.
template <class A, class B, class R>
[[nodiscard]] inline bool ck_add(A a, B b, R& out) {
  static_assert(std::is_integral_v<A> && std::is_integral_v<B> && std::is_integral_v<R>);
  return !__builtin_add_overflow(a, b, &out);
}

/// out = a - b; false when the exact difference does not fit (an unsigned
/// a < b included).
template <class A, class B, class R>
[[nodiscard]] inline bool ck_sub(A a, B b, R& out) {
  static_assert(std::is_integral_v<A> && std::is_integral_v<B> && std::is_integral_v<R>);
  return !__builtin_sub_overflow(a, b, &out);
}

/// out = v converted to R; false when v is out of R's range (a negative
/// value into an unsigned type included).
template <class V, class R>
[[nodiscard]] inline bool ck_cast(V v, R& out) {
  static_assert(std::is_integral_v<V> && std::is_integral_v<R>);
  return !__builtin_add_overflow(v, 0, &out);
}

/// Bytes needed for n records of `per` items of `bytes` bytes each, as a
/// size_t; false when it overflows.  The readers size their vectors with it
/// (n * per * bytes) before a resize or reserve.
[[nodiscard]] inline bool ck_bytes(uint64_t n, uint64_t per, uint64_t bytes, size_t& out) {
  uint64_t t;
  return ck_mul(n, per, t) && ck_mul(t, bytes, t) && ck_cast(t, out);
}

}  // namespace tetopt::detail

namespace tetopt::detail {

/// n * per as a size for resize / reserve, saturated at SIZE_MAX when the
/// product (or a negative n) does not fit: the allocation then fails with
/// std::length_error, which read_mesh reports as out of memory (issue 25)
/// instead of allocating a wrapped, too small buffer.  Callers bound n by
/// the bytes left first; this is the second line.
[[nodiscard]] inline size_t ck_size(int64_t n, uint64_t per) {
  size_t out = 0;
  if (n < 0 || !ck_mul(static_cast<uint64_t>(n), per, out)) return SIZE_MAX;
  return out;
}

}  // namespace tetopt::detail
