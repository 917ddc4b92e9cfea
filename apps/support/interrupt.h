// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// SIGINT, SIGTERM and SIGHUP as a request to stop: an app that installs these handlers polls
// interruptSignal() and finishes with what it has. A signal within kRepeatWindow of the first is
// the same request (`timeout` and `kill` on a process group deliver it twice); one after it ends
// the process at once, as the signal's default does.
#pragma once

#include <csignal>
#include <string>

namespace rvwo::apps {

// s: how long after the first signal another one is taken as the same request.
inline constexpr double kRepeatWindow = 1.0;

void installInterruptHandlers();
// 0, or the number of the first signal caught.
int interruptSignal();
// "SIGINT", "SIGTERM", "SIGHUP" (else "signal N").
std::string signalName(int signal);
// The exit status of a process that stopped for the signal: 128 + its number (130, 143, 129).
inline int interruptedStatus(int signal) { return 128 + signal; }

}  // namespace rvwo::apps
