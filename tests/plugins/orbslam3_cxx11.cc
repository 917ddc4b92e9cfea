// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// Built as C++11 (tests/plugins/CMakeLists.txt): the headers ORB-SLAM3's Tracking.h and the patched
// Tracking.cc, LocalMapping.cc and LoopClosing.cc include (essential_graph.h, labels.h, local_map.h, pose.h,
// reacquire.h: their templates, parsed), and pyramid.h, which the patched ORBextractor.cc includes.
#include "rvwo/orbslam3/essential_graph.h"
#include "rvwo/orbslam3/labels.h"
#include "rvwo/orbslam3/local_map.h"
#include "rvwo/orbslam3/pose.h"
#include "rvwo/orbslam3/pyramid.h"
#include "rvwo/orbslam3/reacquire.h"
#include "rvwo/orbslam3/wheel_input.h"

#if __cplusplus != 201103L
#error "this file checks the header under C++11"
#endif

rvwo::orbslam3::WheelReading orbslam3HeaderCompilesAsCxx11() { return rvwo::orbslam3::WheelReading::angles(0, 1, 2); }
