// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The apps' command line. MRPT's TCLAP returns false from CmdLine::parse both after --help or
// --version and after an error it has printed (upstream TCLAP exits instead): this tells the two
// apart, so that --help exits 0 without running the program and a mistyped option exits 1.
#pragma once

#include <mrpt/3rdparty/tclap/CmdLine.h>

#include <optional>

namespace rvwo::apps {

// std::nullopt: go on with the parsed arguments; otherwise the status main returns at once.
inline std::optional<int> parseCommandLine(TCLAP::CmdLine& cmd, int argc, char** argv) {
  struct Output : TCLAP::StdOutput {
    bool failed = false;
    void failure(TCLAP::CmdLineInterface& c, TCLAP::ArgException& e) override {
      failed = true;
      TCLAP::StdOutput::failure(c, e);
    }
  };
  static Output output;  // (the command line keeps a pointer to it)
  // The command line's own output, made in its constructor, is deleted by its destructor only
  // when no other was set: it goes here (or it leaks, and LeakSanitizer fails every app).
  delete cmd.getOutput();
  cmd.setOutput(&output);
  if (cmd.parse(argc, argv)) return std::nullopt;
  return output.failed ? 1 : 0;
}

}  // namespace rvwo::apps
