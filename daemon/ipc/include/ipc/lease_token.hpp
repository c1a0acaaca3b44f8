// SPDX-License-Identifier: Apache-2.0
// Where drivebusd's lease tokens come from: the kernel's CSPRNG, 128 bits per token. The lease
// table itself stays pure and takes its tokens from whatever source it is given.
#pragma once

#include "ipc/lease.hpp"

namespace drivebus::ipc {

// getrandom(2). Throws at construction when the kernel has no getrandom (before 3.17), so a
// daemon that could not make secret tokens never starts; a draw that fails later (it cannot
// once the first one worked) ends the process rather than hand out a guessable token.
TokenSource random_tokens();

}  // namespace drivebus::ipc
