# SPDX-License-Identifier: Apache-2.0
# DRIVEBUS_SANITIZE: ASan + UBSan on everything built in this tree.
if(DRIVEBUS_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# DRIVEBUS_TSAN: ThreadSanitizer on everything built in this tree (it cannot be combined with
# ASan). Libraries from the system (iceoryx, fmt, tomlplusplus) are not instrumented: races
# inside them go unseen, and tests/tsan.supp silences what their uninstrumented
# synchronisation makes TSan report in ours.
if(DRIVEBUS_TSAN)
  if(DRIVEBUS_SANITIZE)
    message(FATAL_ERROR "DRIVEBUS_TSAN and DRIVEBUS_SANITIZE cannot be combined: use two build trees")
  endif()
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

# DRIVEBUS_FUZZ: coverage instrumentation for libFuzzer on the code under test.
if(DRIVEBUS_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "DRIVEBUS_FUZZ needs clang (libFuzzer); configure with "
                        "-DCMAKE_CXX_COMPILER=clang++-19")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
