// SPDX-License-Identifier: Apache-2.0
// For check_layers.py's self-test: what the simulator may include.
#include "drivebus/profile.hpp"
