/* Included first in the shared library's build: the ABI's functions are its only exports. */
#pragma GCC visibility push(default)
#include "wl_lockstep.h"
#pragma GCC visibility pop
