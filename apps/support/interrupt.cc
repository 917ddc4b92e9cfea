// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "support/interrupt.h"

#include <time.h>

#include <cstdint>

namespace rvwo::apps {

namespace {

volatile std::sig_atomic_t caught = 0;
std::int64_t first_ns = 0;  // CLOCK_MONOTONIC at the first signal; written before `caught`

std::int64_t monotonicNs() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);  // async-signal-safe (POSIX)
  return std::int64_t{now.tv_sec} * 1000000000 + now.tv_nsec;
}

extern "C" void onInterrupt(int signal) {
  const std::int64_t now = monotonicNs();
  if (caught == 0) {
    first_ns = now;
    caught = signal;
    return;
  }
  if (now - first_ns < static_cast<std::int64_t>(kRepeatWindow * 1e9)) return;  // the same request
  std::signal(signal, SIG_DFL);
  std::raise(signal);
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
