// Safe output files. Every file libpcp writes (meshes, priors, checkpoints) goes through
// write_file_atomically: the bytes go to a temporary file in the target's directory, which is
// flushed, synced and renamed over the target only when complete, so a crash or an error never
// leaves a half-written output. check_output_path lets an app refuse a bad output path before a
// long run starts rather than after it.
#pragma once

#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace pcp {

/// Throws pcp::Error unless `output` can be written: its directory exists and is writable, it is
/// not a directory itself, and it is not the same file as any of `inputs`.
void check_output_path(const std::string& output, const std::vector<std::string>& inputs = {});

/// Writes `path` atomically: `write` fills a binary stream bound to a temporary file in the same
/// directory; on success the file is synced and renamed to `path`. If `write` throws, or any I/O
/// fails, the temporary file is removed, `path` is untouched, and pcp::Error is thrown.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

/// The lower-case extension of `path` including the dot (".ply"), or "" if none.
std::string file_extension(const std::string& path);

}  // namespace pcp
