// Output directory and atomic file writes (SPEC 10: checkpoints are written atomically).
#pragma once
#include <string>

namespace biodem::output {

/// Creates `dir` (with parents) and proves it writable by creating and removing a probe file.
/// Throws biodem::Error "<label> <dir>: <what failed>: <reason>" (label defaults to "--out").
void prepare_output_dir(const std::string& dir, const std::string& label = "--out");

/// Writes `content` to `path + ".tmp"`, flushes and fsyncs it, then renames it over `path`, so
/// that a reader (or a run killed mid-write) sees either the old file or the complete new one.
/// Throws biodem::Error naming the path.
void write_file_atomic(const std::string& path, const std::string& content);

}  // namespace biodem::output
