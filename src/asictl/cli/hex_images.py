"""An Intel HEX file that holds an asictl program image, as ``emu`` and ``disasm`` see it.

``asictl compile`` writes the master's EEPROM contents: a header, the code, the program
map and the source. Only the code is 8051 code, and it runs at its link address (the
image's ``code_base``), not at 0 where the header lies; treating the whole file as code
runs (or lists) the header as instructions. So ``emu`` and ``disasm`` recognise an image
by its magic at address 0 and work on its code where it belongs.
"""

from __future__ import annotations

from intelhex import IntelHex

from asictl.codegen8051.listing import code_summary, image_summary
from asictl.errors import UserError
from asictl.image.eeprom import MAGIC, ImageError, ProgramImage


def program_image(hex_image: IntelHex, name: str) -> ProgramImage | None:
    """The asictl program image the HEX file holds, None if it holds none (plain 8051
    code); a damaged image is a ``UserError`` rather than code to run."""
    if hex_image.minaddr() != 0:
        return None
    head = bytes(hex_image.tobinarray(start=0, size=len(MAGIC)))
    if head != MAGIC:
        return None
    try:
        return ProgramImage.from_bytes(hex_image.tobinstr(start=0, end=hex_image.maxaddr()))
    except ImageError as exc:
        raise UserError(
            f"{name}: starts like an asictl program image ('{MAGIC.decode()}') but is not a "
            f"valid one: {exc}"
        ) from None


def code_hex(image: ProgramImage) -> IntelHex:
    """The image's code alone, at its link address."""
    code = IntelHex()
    code.frombytes(image.code, offset=image.code_base)
    return code


def describe(name: str, image: ProgramImage) -> list[str]:
    """What the image is and its program map, as listing comment lines."""
    return [
        f"; {name}: an asictl program image, identity {image.identity_hex}",
        f"; its code: {code_summary(image)} (the header, program map and source are data)",
        ";",
        *image_summary(image),
    ]
