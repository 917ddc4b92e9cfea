// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The rawlog reader on any bytes: every record it returns, or one RawlogError, never a crash. And
// the gz check on the same bytes.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "fuzz_input.h"
#include "support/rawlog.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rvwo::fuzz::asFile(data, size, "input.rawlog");
  rvwo::apps::checkRawlogStream(path);
  try {
    rvwo::apps::RawlogReader reader(path);
    for (int k = 0; k < 10000 && reader.next(); ++k) {
    }
  } catch (const std::runtime_error&) {  // RawlogError and the reader's own: what the apps report
  }
  return 0;
}
