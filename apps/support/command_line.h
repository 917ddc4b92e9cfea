// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The apps' command line. MRPT's TCLAP returns false from CmdLine::parse both after --help or
// --version and after an error it has printed (upstream TCLAP exits instead): this tells the two
// apart, so that --help exits 0 without running the program and a mistyped option exits 1, with
// one error line naming the option (TCLAP's own message is six lines and a usage block).
#pragma once

#include <mrpt/3rdparty/tclap/CmdLine.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

namespace rvwo::apps {

// std::nullopt: go on with the parsed arguments; otherwise the status main returns at once.
inline std::optional<int> parseCommandLine(TCLAP::CmdLine& cmd, int argc, char** argv) {
  struct Output : TCLAP::StdOutput {
    bool failed = false;
    void failure(TCLAP::CmdLineInterface& c, TCLAP::ArgException& e) override {
      failed = true;
      // argId() is "Argument: (--x)" for a known option, "Argument: --x" for an unknown one, " "
      // or "undefined" for none.
      const std::string program = std::filesystem::path(c.getProgramName()).filename().string();
      std::string id = e.argId(), what = e.error();
      if (id.rfind("Argument: ", 0) == 0) {
        id = id.substr(10);
        if (id.size() > 2 && id.front() == '(' && id.back() == ')') id = id.substr(1, id.size() - 2);
        id += ": ";
      } else {
        id.clear();
      }
      if (what == "Couldn't find match for argument") what = "no such option";
      if (what.rfind("One or more required arguments missing", 0) == 0) {
        what = "missing";
        for (TCLAP::Arg* a : c.getArgList()) {
          if (a->isRequired() && !a->isSet()) what += " --" + a->getName();
        }
      }
      std::fprintf(stderr, "%s: error: %s%s (--help lists the options)\n", program.c_str(), id.c_str(), what.c_str());
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

// An app's main: runs body (which returns the exit status) and turns what it throws into one
// line on stderr, "<program>: error: <what>", and exit status 1.
template <typename Body>
int runApp(const char* program, Body&& body) {
  try {
    return body();
  } catch (const TCLAP::ArgException& e) {
    std::fprintf(stderr, "%s: %s (%s)\n", program, e.error().c_str(), e.argId().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
  }
  return 1;
}

}  // namespace rvwo::apps
