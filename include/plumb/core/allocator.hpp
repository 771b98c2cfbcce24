// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A process-wide allocator setting for programs that stream frames through plumb.

namespace plumb {

/// @brief Asks the C library's allocator to keep freed memory for reuse rather than give it back
///        to the system at once. Returns true when the setting was applied (glibc), false where
///        there is no such setting (the call then does nothing).
///
/// A frame's buffers (the file's bytes, the decoded cloud, key points, neighbour lists) are each
/// a few hundred kilobytes to a few megabytes, allocated and freed every frame. glibc serves
/// blocks that large with mmap() and hands them back at free(), or trims the freed top of its
/// heap, so each frame pays a page fault for every 4 KiB it touches again: on a 30 m office run
/// (`plumb run`, one thread) that was about half of the wall time, mostly in the kernel. This
/// raises glibc's mmap threshold to 32 MiB and its trim threshold to 64 MiB (mallopt), so that
/// memory freed by one frame serves the next. Peak memory is unchanged (what is kept is what was
/// in use before); resident memory no longer shrinks after a peak, by up to 64 MiB per arena.
///
/// It changes the allocator of the whole process: the `plumb` command line calls it at start;
/// a program that links the library decides for itself (the same effect without code:
/// `GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=67108864`).
bool keep_freed_memory();

}  // namespace plumb
