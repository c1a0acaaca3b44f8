# SPDX-License-Identifier: Apache-2.0
# Warning flags shared by every drivebus target.
add_library(drivebus_warnings INTERFACE)
target_compile_options(drivebus_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion
  -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual
  -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
if(DRIVEBUS_WERROR)
  target_compile_options(drivebus_warnings INTERFACE -Werror)
endif()
