// SPDX-License-Identifier: BSD-3-Clause
#include "detail_decompress.hpp"

#include <algorithm>
#include <limits>
#include <memory>

#include <bzlib.h>
#include <lz4frame.h>
#include <zstd.h>

#include "plumb/core/error.hpp"

namespace plumb::io::detail {
namespace {

struct Lz4Context {
  LZ4F_dctx* ctx = nullptr;
  Lz4Context() {
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) ctx = nullptr;
  }
  ~Lz4Context() { LZ4F_freeDecompressionContext(ctx); }
  Lz4Context(const Lz4Context&) = delete;
  Lz4Context& operator=(const Lz4Context&) = delete;
};

// One byte more than `size` shows an overlong chunk.
std::size_t limit_of(std::uint64_t size) {
  return static_cast<std::size_t>(std::min<std::uint64_t>(size, std::numeric_limits<std::size_t>::max() - 1)) + 1;
}

// Grow `out` (a buffer being filled, `used` bytes so far) towards `limit` bytes; false when full.
bool grow(std::vector<std::uint8_t>& out, std::size_t used, std::size_t limit) {
  if (used < out.size()) return true;
  if (out.size() >= limit) return false;
  out.resize(std::min(limit, std::max<std::size_t>(out.size() * 2, 1 << 16)));
  return true;
}

void finish(std::vector<std::uint8_t>& out, std::size_t used, std::uint64_t size, const std::string& at) {
  PLUMB_CHECK(used == size, at << ": chunk decompresses to " << used << " bytes, its header says " << size);
  out.resize(used);
}

}  // namespace

void decompress_bz2(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                    const std::string& at) {
  out.clear();
  const std::size_t limit = limit_of(size);
  std::size_t used = 0;
  PLUMB_CHECK(n <= std::numeric_limits<unsigned>::max(), at << ": bz2 chunk of " << n << " bytes is too large");
  bz_stream s{};
  PLUMB_CHECK(BZ2_bzDecompressInit(&s, 0, 0) == BZ_OK, at << ": cannot start bz2 decompression");
  std::unique_ptr<bz_stream, int (*)(bz_stream*)> end(&s, BZ2_bzDecompressEnd);
  s.next_in = const_cast<char*>(reinterpret_cast<const char*>(in));
  s.avail_in = static_cast<unsigned>(n);
  int rc = BZ_OK;
  while (rc != BZ_STREAM_END) {
    PLUMB_CHECK(grow(out, used, limit), at << ": bz2 chunk decompresses to more than its size " << size);
    s.next_out = reinterpret_cast<char*>(out.data() + used);
    s.avail_out = static_cast<unsigned>(std::min<std::size_t>(out.size() - used, std::numeric_limits<unsigned>::max()));
    const unsigned before_in = s.avail_in, before_out = s.avail_out;
    rc = BZ2_bzDecompress(&s);
    PLUMB_CHECK(rc == BZ_OK || rc == BZ_STREAM_END, at << ": corrupt bz2 chunk (bzlib error " << rc << ')');
    const std::size_t produced = before_out - s.avail_out;
    used += produced;
    PLUMB_CHECK(rc == BZ_STREAM_END || produced > 0 || s.avail_in < before_in, at << ": bz2 chunk data cut off");
  }
  finish(out, used, size, at);
}

void decompress_lz4_frame(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                          const std::string& at) {
  out.clear();
  const std::size_t limit = limit_of(size);
  std::size_t used = 0;
  Lz4Context c;
  PLUMB_CHECK(c.ctx != nullptr, at << ": cannot start lz4 decompression");
  std::size_t pos = 0, hint = 1;
  while (pos < n) {
    PLUMB_CHECK(grow(out, used, limit), at << ": lz4 chunk decompresses to more than its size " << size);
    std::size_t dst = out.size() - used, src = n - pos;
    hint = LZ4F_decompress(c.ctx, out.data() + used, &dst, in + pos, &src, nullptr);
    PLUMB_CHECK(!LZ4F_isError(hint), at << ": corrupt lz4 chunk (" << LZ4F_getErrorName(hint) << ')');
    PLUMB_CHECK(dst > 0 || src > 0, at << ": lz4 chunk makes no progress");
    pos += src;
    used += dst;
  }
  PLUMB_CHECK(hint == 0, at << ": lz4 chunk data cut off");
  finish(out, used, size, at);
}

void decompress_zstd(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                     const std::string& at) {
  out.clear();
  const std::size_t limit = limit_of(size);
  std::size_t used = 0;
  std::unique_ptr<ZSTD_DStream, std::size_t (*)(ZSTD_DStream*)> s(ZSTD_createDStream(), ZSTD_freeDStream);
  PLUMB_CHECK(s != nullptr && !ZSTD_isError(ZSTD_initDStream(s.get())), at << ": cannot start zstd decompression");
  ZSTD_inBuffer src{in, n, 0};
  std::size_t hint = 1;
  while (src.pos < src.size || hint != 0) {
    PLUMB_CHECK(grow(out, used, limit), at << ": zstd chunk decompresses to more than its size " << size);
    ZSTD_outBuffer dst{out.data() + used, out.size() - used, 0};
    const std::size_t before_in = src.pos;
    hint = ZSTD_decompressStream(s.get(), &dst, &src);
    PLUMB_CHECK(!ZSTD_isError(hint), at << ": corrupt zstd chunk (" << ZSTD_getErrorName(hint) << ')');
    used += dst.pos;
    if (hint == 0 && src.pos == src.size) break;
    PLUMB_CHECK(dst.pos > 0 || src.pos > before_in, at << ": zstd chunk data cut off");
  }
  finish(out, used, size, at);
}

}  // namespace plumb::io::detail
