# Sanitizer and fuzzer builds. Included from the top-level CMakeLists before any target, so the
# flags reach the library, the scene generators, the tests and the examples alike (a sanitized
# test linked with an unsanitized library would miss the errors we care about).
#
#   -DCUBE_COLLISION_SANITIZE=address   AddressSanitizer + UndefinedBehaviorSanitizer (+ LeakSanitizer)
#   -DCUBE_COLLISION_SANITIZE=thread    ThreadSanitizer
#   -DCUBE_COLLISION_BUILD_FUZZER=ON    libFuzzer target tests/fuzz (needs clang, e.g. CXX=clang++-14)
#
# Use a separate build directory for each: the flags change the ABI of the sanitizer runtime.

set(CUBE_COLLISION_SANITIZE "" CACHE STRING "Sanitizers for every target: empty, address (address+undefined) or thread")
set_property(CACHE CUBE_COLLISION_SANITIZE PROPERTY STRINGS "" address thread)
option(CUBE_COLLISION_SANITIZE_FCL_FLOAT
  "With CUBE_COLLISION_SANITIZE=address, instrument FCL's float narrow phase too (src/pipeline/callbacks.cpp, cube_fcl_float; slow)" OFF)
option(CUBE_COLLISION_BUILD_FUZZER "Build the libFuzzer target (clang only; implies address+undefined)" OFF)

set(_cube_san_flags "")
if(CUBE_COLLISION_BUILD_FUZZER)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "CUBE_COLLISION_BUILD_FUZZER needs clang (configure with CXX=clang++-14)")
  endif()
  if(CUBE_COLLISION_SANITIZE STREQUAL "thread")
    message(FATAL_ERROR "CUBE_COLLISION_BUILD_FUZZER runs with address+undefined, not thread")
  endif()
  # Coverage instrumentation everywhere; only the fuzz target links libFuzzer's main.
  set(_cube_san_flags -fsanitize=fuzzer-no-link,address,undefined)
elseif(CUBE_COLLISION_SANITIZE STREQUAL "address")
  set(_cube_san_flags -fsanitize=address,undefined)
elseif(CUBE_COLLISION_SANITIZE STREQUAL "thread")
  set(_cube_san_flags -fsanitize=thread)
elseif(NOT CUBE_COLLISION_SANITIZE STREQUAL "")
  message(FATAL_ERROR "CUBE_COLLISION_SANITIZE must be empty, address or thread, not '${CUBE_COLLISION_SANITIZE}'")
endif()

# Debug information of sanitizer builds. Line tables (-g1) give the reports' stack traces their
# files and lines; full -g (variables, for a debugger) makes FCL's float narrow phase, which
# src/pipeline/callbacks.cpp instantiates, much slower to compile (GCC's variable tracking gives up
# on its largest functions after trying, and the assembler then reads a huge file).
set(CUBE_COLLISION_SANITIZE_DEBUG "-g1" CACHE STRING "Debug-information flag of sanitizer builds (-g1 line tables; -g for a debugger)")

if(_cube_san_flags)
  # Any report is a failure: no recovering from undefined behaviour, and frames kept for traces.
  add_compile_options(${_cube_san_flags} -fno-sanitize-recover=all -fno-omit-frame-pointer
                      ${CUBE_COLLISION_SANITIZE_DEBUG})
  add_link_options(${_cube_san_flags} -fno-sanitize-recover=all)
  # Lets the longest randomized tests run fewer sequences, to keep sanitized runs in CI's time.
  add_compile_definitions(CUBE_COLLISION_SANITIZED=1)
endif()
