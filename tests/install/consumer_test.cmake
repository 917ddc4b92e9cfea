# Installs RVWO into a fresh prefix and copies the installed tree elsewhere (nothing in it may
# point at the build, the source tree or its .deps/). From the copy, with LD_LIBRARY_PATH empty:
# every installed app's --help, rvwo-sim (on an installed scenario; --randomise on the installed
# motions) and rvwo-replay on a 2 s sequence. Then configures, builds and runs consumer projects
# against the copy: one made of the README's "Use a component in your own SLAM system" code
# blocks (so the README's example is the one that compiles), and one per component asked for alone
# (kernels alone gets rvwo::kernels and nothing else).
# With -DFROM=deb the tree is the Debian package's (cpack -G DEB), unpacked with dpkg-deb -x.
# Run as: cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... [-DFROM=deb] -P consumer_test.cmake
foreach(v BUILD_DIR SOURCE_DIR WORK_DIR)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "consumer_test: ${v} not set")
  endif()
endforeach()

# Runs a command; fails the test unless it exits 0. Its output is left in `out`.
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer_test: '${ARGN}' failed (${rc}):\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
if(FROM STREQUAL "deb")
  # The Debian package, unpacked: what `apt install ./rvwo_<version>_amd64.deb` puts under /usr.
  run(${CMAKE_CPACK_COMMAND} -G DEB --config "${BUILD_DIR}/CPackConfig.cmake" -B "${WORK_DIR}/deb")
  file(GLOB deb "${WORK_DIR}/deb/rvwo_*.deb")
  run(dpkg-deb -f "${deb}" Depends)
  foreach(needed libopencv libmrpt libc6)  # Ceres is linked statically (libceres-dev has no shared one)
    if(NOT out MATCHES "${needed}")
      message(FATAL_ERROR "consumer_test: ${deb} does not depend on ${needed}: ${out}")
    endif()
  endforeach()
  run(dpkg-deb -x "${deb}" "${WORK_DIR}/unpacked")
  set(prefix "${WORK_DIR}/unpacked/usr")
  foreach(f share/rvwo/patches/orbslam3/README.md share/doc/rvwo/LICENSE share/rvwo/models/deeplabv3_mnv2_voc21.onnx)
    if(NOT EXISTS "${prefix}/${f}")
      message(FATAL_ERROR "consumer_test: ${f} not in ${deb}")
    endif()
  endforeach()
else()
  run(${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK_DIR}/installed")
  file(COPY "${WORK_DIR}/installed/" DESTINATION "${WORK_DIR}/copy")  # symbolic links kept as links
  set(prefix "${WORK_DIR}/copy")
endif()

# The copy's binaries find their libraries relative to themselves, and its CMake files name no
# folder of the build.
file(GLOB apps "${prefix}/bin/*")
if(NOT apps)
  message(FATAL_ERROR "consumer_test: no app installed in bin/")
endif()
foreach(a ${apps})
  file(READ "${a}" magic LIMIT 2 HEX)
  if(magic STREQUAL "2321")  # a script (rvwo-bag): it finds what it needs relative to itself
    continue()
  endif()
  run(readelf -d "${a}")
  string(REGEX MATCH "R(UN)?PATH[^\n]*" runpath "${out}")
  if(ORB_SLAM3_ROOT)  # a build with --backend orbslam3 finds that tree where it was built, absolute
    string(REPLACE "${ORB_SLAM3_ROOT}/" "ORB_SLAM3_ROOT/" runpath "${runpath}")
  endif()
  if(runpath MATCHES "\\[/|:/")
    message(FATAL_ERROR "consumer_test: ${a}: an absolute ${runpath}")
  endif()
endforeach()
file(GLOB_RECURSE cmake_files "${prefix}/*.cmake")
foreach(f ${cmake_files})
  file(READ "${f}" text)
  foreach(dir "${SOURCE_DIR}" "${BUILD_DIR}" "${WORK_DIR}/installed" "${WORK_DIR}/deb")
    string(FIND "${text}" "${dir}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "consumer_test: ${f} names ${dir}")
    endif()
  endforeach()
endforeach()
set(ENV{LD_LIBRARY_PATH} "")
foreach(a ${apps})
  run("${a}" --help)
endforeach()
if(EXISTS "${prefix}/bin/rvwo-sim" AND EXISTS "${prefix}/bin/rvwo-replay")
  set(seq "${WORK_DIR}/sequence")
  run("${prefix}/bin/rvwo-sim" --quiet --scenario "${prefix}/share/rvwo/scenarios/static.yaml" --duration 2 --out "${seq}")
  run("${prefix}/bin/rvwo-replay" --quiet --settings "${seq}/settings.yaml" --rawlog "${seq}/sequence.rawlog"
      --out "${seq}/vw.txt")
  file(STRINGS "${seq}/vw.txt" poses REGEX "^[0-9]")
  list(LENGTH poses n)
  if(n LESS 50)
    message(FATAL_ERROR "consumer_test: the installed rvwo-replay wrote ${n} poses for 2 s at 30 Hz")
  endif()
  # --randomise draws among the installed motions, not the source tree's.
  run("${prefix}/bin/rvwo-sim" --quiet --randomise --seed 2 --lens pinhole --duration 0.3 --out "${WORK_DIR}/drawn")
  file(READ "${WORK_DIR}/drawn/scenario.yaml" drawn)
  file(REAL_PATH "${prefix}/share/rvwo/scenarios/motion" motions)
  string(FIND "${drawn}" "Sequence.MotionFile: \"${motions}/" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "consumer_test: the installed rvwo-sim --randomise took no installed motion:\n${drawn}")
  endif()
endif()
foreach(f include/rvwo/kernels/barron.h include/rvwo/edges/se2_xyz_edge.h lib/cmake/rvwo/rvwoConfig.cmake)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "consumer_test: ${f} not installed")
  endif()
endforeach()

# The README's code blocks: the ```cmake and ```cpp blocks after the marker line.
file(READ "${SOURCE_DIR}/README.md" readme)
string(FIND "${readme}" "<!-- consumer-example -->" at)
if(at EQUAL -1)
  message(FATAL_ERROR "consumer_test: README.md has no <!-- consumer-example --> marker")
endif()
string(SUBSTRING "${readme}" ${at} -1 readme)
foreach(lang cmake cpp)
  string(REGEX MATCH "```${lang}\n(.*)" tail "${readme}")
  string(FIND "${CMAKE_MATCH_1}" "```" end)
  string(SUBSTRING "${CMAKE_MATCH_1}" 0 ${end} block_${lang})
endforeach()
set(app "${WORK_DIR}/readme_example")
file(WRITE "${app}/CMakeLists.txt" "${block_cmake}")
file(WRITE "${app}/main.cpp" "${block_cpp}")
run(${CMAKE_COMMAND} -S "${app}" -B "${app}/build" -G Ninja "-DCMAKE_PREFIX_PATH=${prefix}")
run(${CMAKE_COMMAND} --build "${app}/build")
file(GLOB exe "${app}/build/*")
execute_process(COMMAND "${app}/build/my_slam" RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 0 OR NOT out MATCHES "weight")
  message(FATAL_ERROR "consumer_test: README example ran with ${rc}: ${out}")
endif()
message(STATUS "README example printed: ${out}")

# kernels alone: only rvwo::kernels is defined, no solver is looked for.
set(k "${WORK_DIR}/kernels_only")
file(WRITE "${k}/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)
project(kernels_only CXX)
find_package(rvwo CONFIG REQUIRED COMPONENTS kernels)
if(NOT TARGET rvwo::kernels OR TARGET rvwo::ceres OR TARGET rvwo::g2o OR TARGET rvwo::edges)
  message(FATAL_ERROR \"kernels_only: wrong targets\")
endif()
if(DEFINED Ceres_FOUND OR DEFINED g2o_FOUND)
  message(FATAL_ERROR \"kernels_only: a solver was looked for\")
endif()
add_executable(k main.cpp)
target_link_libraries(k PRIVATE rvwo::kernels)
")
file(WRITE "${k}/main.cpp" "#include <rvwo/kernels/barron.h>
int main() { double rho[3]; rvwo::BarronKernel(-2.0).evaluate(4.0, rho); return rho[1] == 0.25 ? 0 : 1; }
")
run(${CMAKE_COMMAND} -S "${k}" -B "${k}/build" -G Ninja "-DCMAKE_PREFIX_PATH=${prefix}")
run(${CMAKE_COMMAND} --build "${k}/build")
run("${k}/build/k")

# semantics, when built: OpenCV and ONNX Runtime are found through the installed config.
if(EXISTS "${prefix}/lib/cmake/rvwo/rvwo_semantics-targets.cmake")
  set(s "${WORK_DIR}/semantics_only")
  file(WRITE "${s}/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)
project(semantics_only CXX)
find_package(rvwo CONFIG REQUIRED COMPONENTS semantics)
add_executable(s main.cpp)
target_link_libraries(s PRIVATE rvwo::semantics)
")
  file(WRITE "${s}/main.cpp" "#include <rvwo/semantics/label_lookup.h>
int main() {
  rvwo::Segmentation seg;
  seg.labels = cv::Mat(10, 10, CV_32S, cv::Scalar(0));
  seg.labels.at<int>(5, 5) = 15;
  return rvwo::LabelLookup(seg, {15}, 2).labelAt({6.5f, 5.5f}) == 15 ? 0 : 1;
}
")
  run(${CMAKE_COMMAND} -S "${s}" -B "${s}/build" -G Ninja "-DCMAKE_PREFIX_PATH=${prefix}")
  run(${CMAKE_COMMAND} --build "${s}/build")
  run("${s}/build/s")
endif()

# The solver adapters, tracking, settings, the estimator and the ORB-SLAM3 plugin, each asked for
# alone: found with what they need (Ceres before tracking; g2o from the installed tree), built and run.
set(tracking_main "#include <rvwo/tracking/window.h>
int main() {
  const rvwo::PinholeCamera camera(400, 400, 320, 240);
  const rvwo::Se2XyzMonoEdge mono(camera, Eigen::Isometry3d::Identity());
  rvwo::WindowProblem pb;
  pb.keyframes.push_back({Eigen::Vector3d::Zero(), 0.0, true});
  const rvwo::WindowSolution s = rvwo::solveWindow(mono, nullptr, pb, rvwo::WindowOptions());
  return !s.ran && s.x_w_b.size() == 1 ? 0 : 1;
}
")
set(estimator_main "#include <rvwo/estimator/estimator.h>
int main() { return rvwo::estimator::EstimatorOptions().window > 0 ? 0 : 1; }
")
set(ceres_main "#include <rvwo/ceres/barron_loss.h>
int main() { double rho[3]; rvwo::ceres_adapters::BarronLoss(2.0, 1.0).Evaluate(1.0, rho); return rho[0] > 0 ? 0 : 1; }
")
set(g2o_main "#include <rvwo/g2o/barron_kernel.h>
int main() { Eigen::Vector3d rho; rvwo::g2o_adapters::BarronRobustKernel(2.0, 1.0).robustify(1.0, rho); return rho[0] > 0 ? 0 : 1; }
")
set(settings_main "#include <rvwo/settings/settings.h>
int main() { return rvwo::Settings::fromString(\"%YAML:1.0\\nA: 2\\n\", \"s.yaml\").requireNumber(\"A\") == 2 ? 0 : 1; }
")
set(orbslam3_main "#include <rvwo/orbslam3/wheel_input.h>
int main() { rvwo::orbslam3::WheelInput w; return w.active() ? 1 : 0; }
")
foreach(c ceres g2o tracking settings estimator orbslam3)
  if(NOT EXISTS "${prefix}/lib/cmake/rvwo/rvwo_${c}-targets.cmake")
    continue()
  endif()
  set(d "${WORK_DIR}/${c}_only")
  file(WRITE "${d}/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)
project(${c}_only CXX)
find_package(rvwo CONFIG REQUIRED COMPONENTS ${c})
add_executable(app main.cpp)
target_link_libraries(app PRIVATE rvwo::${c})
")
  file(WRITE "${d}/main.cpp" "${${c}_main}")
  run(${CMAKE_COMMAND} -S "${d}" -B "${d}/build" -G Ninja "-DCMAKE_PREFIX_PATH=${prefix}")
  run(${CMAKE_COMMAND} --build "${d}/build")
  run("${d}/build/app")
endforeach()
