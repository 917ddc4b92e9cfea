// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// SIGINT, SIGTERM and SIGHUP as a request to stop: an app that installs these handlers polls
// interruptSignal() and finishes with what it has. The first signal only sets the flag; the
// handlers then go back to the default, so that a second one ends the process at once.
#pragma once

#include <csignal>
#include <string>

namespace rvwo::apps {

void installInterruptHandlers();
// 0, or the number of the first signal caught.
int interruptSignal();
// "SIGINT", "SIGTERM", "SIGHUP" (else "signal N").
std::string signalName(int signal);
// The exit status of a process that stopped for the signal: 128 + its number (130, 143, 129).
inline int interruptedStatus(int signal) { return 128 + signal; }

}  // namespace rvwo::apps
