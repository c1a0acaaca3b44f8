// SPDX-License-Identifier: Apache-2.0
// For check_layers.py's self-test: the master must not know the shared-memory layout.
#include "drivebus/shm.hpp"
