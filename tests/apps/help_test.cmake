# `<app> --help` and `--version` must teach and exit 0 without doing the program's work: no error
# line, nothing written; a mistyped option must fail (exit 1) with one line "<app>: error: --x: ...". (MRPT's
# TCLAP returns false from parse() in both cases instead of exiting: an app that ignored it went
# on with empty arguments and failed, and rvwo-demo ran a whole demo.)
#   cmake -DAPP=<executable> -DWORK=<empty scratch folder> -DVERSION=<the project version> -P help_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
foreach(flag --help --version)
  execute_process(COMMAND "${APP}" ${flag} WORKING_DIRECTORY "${WORK}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err TIMEOUT 20)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${APP} ${flag}: exit ${rc}, stderr: ${err}")
  endif()
  if(NOT err STREQUAL "")
    message(FATAL_ERROR "${APP} ${flag}: wrote to stderr: ${err}")
  endif()
  if(flag STREQUAL "--help" AND NOT out MATCHES "USAGE:")
    message(FATAL_ERROR "${APP} --help: no usage in: ${out}")
  endif()
  if(flag STREQUAL "--version" AND NOT out MATCHES "version: ${VERSION}")
    message(FATAL_ERROR "${APP} --version: no version in: ${out}")
  endif()
endforeach()
execute_process(COMMAND "${APP}" --no-such-option WORKING_DIRECTORY "${WORK}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 20)
if(NOT rc EQUAL 1 OR NOT err MATCHES "^[a-z0-9-]+: error: [^\n]*--no-such-option[^\n]*\n$")
  message(FATAL_ERROR "${APP} --no-such-option: exit ${rc}, stderr: ${err}")
endif()
file(GLOB written "${WORK}/*")
if(written)
  message(FATAL_ERROR "${APP} --help, --version or a bad option wrote: ${written}")
endif()
