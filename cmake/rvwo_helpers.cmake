# Helpers shared by every RVWO folder.

# rvwo_optional_dependency(<option var> <package>): resolves AUTO/ON/OFF to ON or OFF.
macro(rvwo_optional_dependency option package)
  if(NOT ${option} STREQUAL "OFF")
    if(${option} STREQUAL "ON")
      find_package(${package} REQUIRED)
    else()
      find_package(${package} QUIET)
    endif()
    if(${package}_FOUND)
      set(${option} ON)
    else()
      message(STATUS "rvwo: ${package} not found, ${option} is OFF")
      set(${option} OFF)
    endif()
  endif()
endmacro()

# Warnings for the project's own code (not for dependencies' headers, which come in as SYSTEM).
function(rvwo_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
endfunction()

# rvwo_add_component(<name> SOURCES ... [PUBLIC_LINK ...] [PRIVATE_LINK ...])
# A library rvwo_<name>, alias rvwo::<name>, headers in <folder>/include/rvwo/..., installed with
# an export set of its own, so that find_package(rvwo COMPONENTS <name>) loads only it.
function(rvwo_add_component name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_LINK;PRIVATE_LINK" ${ARGN})
  set(target rvwo_${name})
  if(ARG_SOURCES)
    add_library(${target} ${ARG_SOURCES})
    target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LINK} PRIVATE ${ARG_PRIVATE_LINK})
    target_include_directories(${target} PUBLIC
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    rvwo_warnings(${target})
  else()
    add_library(${target} INTERFACE)
    target_link_libraries(${target} INTERFACE ${ARG_PUBLIC_LINK})
    target_include_directories(${target} INTERFACE
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  endif()
  target_compile_features(${target} INTERFACE cxx_std_17)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME rvwo_${name})
  add_library(rvwo::${name} ALIAS ${target})
  install(TARGETS ${target} EXPORT rvwo_${name}-targets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(EXPORT rvwo_${name}-targets NAMESPACE rvwo:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/rvwo)
  set(RVWO_COMPONENTS ${RVWO_COMPONENTS} ${name} PARENT_SCOPE)
endfunction()
