// SPDX-License-Identifier: Apache-2.0
// For check_layers.py's self-test: a library must not use libdrivebus's API.
#pragma once
#include <drivebus/client.hpp>
