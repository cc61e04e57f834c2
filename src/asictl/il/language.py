"""Numbers the programming manual fixes, shared by the checks, the compiler and the
reference interpreter (which otherwise share no code)."""

from __future__ import annotations

# The master's own numbers, which the language follows (one definition, in platform).
from asictl.platform.master import COUNTER_FLAG_BASE as COUNTER_FLAG_BASE
from asictl.platform.master import MAPPED_COUNTERS as MAPPED_COUNTERS
from asictl.platform.master import MAX_TC as MAX_TC

#: Timers and counters 0..14 exist without declaration (Control I compatible).
BUILTIN_TC = 15
#: Timer and counter registers are 12 bits wide.
TC_MAX_VALUE = 4095
MAX_KT_MS = 40950
#: PARAM leaves the slave's answer in bits 0-3 of this flag byte, success in bit 7.
PARAM_FLAG = 127
#: The image stores a name (a variable's, a source file's) with a length byte, and the
#: number of source files (main and function-block files) in one byte (docs/image-format.md).
MAX_IMAGE_NAME_BYTES = 255
MAX_SOURCE_FILES = 255
