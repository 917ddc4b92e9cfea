// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What an app writes: checked before any work is done (not one of its inputs, in a folder that
// exists and can be written), then written whole or not at all, so that a reader never sees half
// a file and an interrupted run never leaves a stale one under the new name.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace rvwo::apps {

// A path given on the command line, with the option that gave it ("--out").
struct PathArg {
  std::string option;
  std::string path;
};

// Throws std::invalid_argument, one line naming the option and what to do, when an output is one
// of the inputs (the same file by resolved path, symbolic links and hard links included), is a
// folder, or its folder does not exist or cannot be written. Empty paths are skipped.
void checkOutputs(const std::vector<PathArg>& outputs, const std::vector<PathArg>& inputs);

// The temporary file writeWhole writes first: hidden, beside path, with path's extension (image
// writers choose the format by it): "dir/.name.partial.ext".
std::string partialPath(const std::string& path);

// Calls write(partialPath(path)), then renames that file over path. When write throws, the
// partial file is removed and path is left as it was.
void writeWhole(const std::string& path, const std::function<void(const std::string& tmp)>& write);

}  // namespace rvwo::apps
