// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Chunk decompression shared by the ROS 1 bag and the MCAP readers: bz2, lz4 (the LZ4 frame
// format) and zstd. Each fills `out` with exactly `size` bytes or throws plumb::Error prefixed by
// `at` ("FILE: offset N"). The output grows with what the data really holds, so a corrupt `size`
// costs no memory.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace plumb::io::detail {

void decompress_bz2(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                    const std::string& at);
void decompress_lz4_frame(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                          const std::string& at);
void decompress_zstd(const std::uint8_t* in, std::size_t n, std::uint64_t size, std::vector<std::uint8_t>& out,
                     const std::string& at);

}  // namespace plumb::io::detail
