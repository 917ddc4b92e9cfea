# The Debian package: `cpack -G DEB` in a build folder makes rvwo_<version>_amd64.deb for Debian 12,
# installed under /usr: the apps on the PATH, the libraries, headers and CMake package, ONNX Runtime
# and g2o under lib/rvwo/, the ORB-SLAM3 patch set and the scenarios under share/rvwo/. Depends:
# the Debian runtime libraries its binaries load (dpkg-shlibdeps); Recommends: the -dev packages a
# consumer of the CMake package compiles against.
set(CPACK_PACKAGE_NAME rvwo)
set(CPACK_PACKAGE_VENDOR "the RVWO authors")
set(CPACK_PACKAGE_CONTACT "the RVWO authors")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGE_DESCRIPTION "Drop-in components that make ORB-SLAM3-style visual SLAM robust on wheeled robots in
dynamic scenes (SE(2) edges, wheel preintegration, adaptive robust kernels, segmentation), with
Ceres and g2o adapters, an estimator, and MRPT rawlog apps (rvwo-replay, rvwo-sim, rvwo-eval,
rvwo-convert, rvwo-segment).")
set(CPACK_RESOURCE_FILE_LICENSE "${PROJECT_SOURCE_DIR}/LICENSE")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # rvwo_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# rvwo-bag's Python packages (lib/rvwo/python) are CPython 3.11 wheels: they carry their own libraries.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS "${CPACK_PACKAGING_INSTALL_PREFIX}/${RVWO_PRIVATE_LIBDIR}/onnxruntime/lib"
  "${CPACK_PACKAGING_INSTALL_PREFIX}/${RVWO_PRIVATE_LIBDIR}/python/numpy.libs")
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3 (>= 3.11), python3 (<< 3.12)")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "libeigen3-dev, libceres-dev, libopencv-dev, libmrpt-dev, nlohmann-json3-dev")
set(CPACK_STRIP_FILES ON)
include(CPack)
