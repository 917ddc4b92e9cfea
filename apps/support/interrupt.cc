// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "support/interrupt.h"

namespace rvwo::apps {

namespace {

volatile std::sig_atomic_t caught = 0;

extern "C" void onInterrupt(int signal) {
  if (caught == 0) caught = signal;
  std::signal(signal, SIG_DFL);
}

}  // namespace

void installInterruptHandlers() {
  for (int s : {SIGINT, SIGTERM, SIGHUP}) std::signal(s, onInterrupt);
}

int interruptSignal() { return caught; }

std::string signalName(int signal) {
  switch (signal) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "signal " + std::to_string(signal);
  }
}

}  // namespace rvwo::apps
