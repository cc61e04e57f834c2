"""Numbers the programming manual fixes, shared by the checks, the compiler and the
reference interpreter (which otherwise share no code)."""

from __future__ import annotations

#: Timers and counters 0..14 exist without declaration (Control I compatible).
BUILTIN_TC = 15
MAX_TC = 1023
#: Timer and counter registers are 12 bits wide.
TC_MAX_VALUE = 4095
MAX_KT_MS = 40950
#: map_counters: counter n (0..14) is flag bytes 96+2n (low) and 97+2n (high nibble).
COUNTER_FLAG_BASE = 96
MAPPED_COUNTERS = 15
#: PARAM leaves the slave's answer in bits 0-3 of this flag byte, success in bit 7.
PARAM_FLAG = 127
#: The image stores a name (a variable's, a source file's) with a length byte, and the
#: number of source files (main and function-block files) in one byte (docs/image-format.md).
MAX_IMAGE_NAME_BYTES = 255
MAX_SOURCE_FILES = 255
